"""How the content of a message becomes bytes, fast: the encoders of :mod:`replay.record.recorder`.

What a message says is decided by :mod:`replay.record.recorder`; here it is encoded, with the bytes the
general encoders (protobuf's ``SerializeToString``, ``json``) would give, by hand where a message is
large or frequent (the vehicle's samples, many at once: :mod:`replay.record.samples`):

- **protobuf wire format** for large arrays (terrain, track, detection markers), written with numpy
  and struct (:func:`ld`, :func:`doubles_messages`, :func:`packed_fixed32`, :func:`sphere_field`);
  the field numbers used (``TRI_POINTS``, ``UPDATE_ENTITIES``...) are read from, and checked
  against, the installed foxglove schemas at import;
- **JSON**: plain JSON data from numpy values (:func:`jsonable`; NaN and infinities become
  ``null``), compact encoding (:func:`dumps`), numbers to ``DIGITS`` significant digits;
- a **radar scan**, its marker scene update and its detection list, a scan that repeats the last
  one from the last one's pieces, the encoded pieces of repeated detections kept
  (:class:`ScanEncoder`; bounded memos).
"""

from __future__ import annotations

import functools
import json
import math
import struct
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.Point3_pb2 import Point3
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from foxglove_schemas_protobuf.SpherePrimitive_pb2 import SpherePrimitive
from foxglove_schemas_protobuf.TriangleListPrimitive_pb2 import TriangleListPrimitive
from foxglove_schemas_protobuf.Vector3_pb2 import Vector3

from replay.record.wire import tag, varint

FloatArray = npt.NDArray[np.float64]

MEMO_SIZE = 50_000  # encoded detections kept (a few MB), cleared when full

# ---------------------------------------------------------------------------------------------
# protobuf wire format for large arrays (fields checked against the schema descriptors below)

_WIRE_DOUBLE = 1
_WIRE_LEN = 2
_FIXED32 = 7  # FieldDescriptor.TYPE_FIXED32


def ld(field: int, payload: bytes) -> bytes:
    """A length-delimited field (embedded message, string, packed array)."""
    return tag(field, _WIRE_LEN) + varint(len(payload)) + payload


def doubles_messages(field: int, values: FloatArray) -> bytes:
    """``repeated M field`` where M has only double fields 1..k (Point3, Color): one embedded
    message per row of ``values`` (n, k), every field written (also zeros, which is valid)."""
    n, k = values.shape
    out = np.empty((n, 2 + 9 * k), dtype=np.uint8)
    out[:] = _row_template(field, k)
    raw = np.ascontiguousarray(values, dtype="<f8").view(np.uint8).reshape(n, k, 8)
    for j in range(k):
        out[:, 3 + 9 * j : 11 + 9 * j] = raw[:, j]
    return out.tobytes()


@functools.cache
def _row_template(field: int, k: int) -> npt.NDArray[np.uint8]:
    """The bytes of one embedded message of ``doubles_messages`` with all doubles zero."""
    key = tag(field, _WIRE_LEN)
    if len(key) != 1 or k > 15:
        raise ValueError("only fields 1..15 with up to 15 doubles are supported")
    row = [key[0], 9 * k]
    for j in range(k):
        row += [(j + 1) << 3 | _WIRE_DOUBLE] + [0] * 8
    return np.array(row, dtype=np.uint8)


@functools.cache
def _entity_tail(frame_id: str, ident: str) -> bytes:
    return SceneEntity(frame_id=frame_id, id=ident).SerializeToString()


def entity_head(ns: int, frame_id: str, ident: str) -> bytes:
    """``SceneEntity(timestamp=ns, frame_id=frame_id, id=ident).SerializeToString()`` (ns >= 0
    integer nanoseconds), without building the message (it is written once a second for the
    track and for each radar scan)."""
    sec, nsec = divmod(ns, 1_000_000_000)
    stamp = (b"\x08" + varint(sec) if sec else b"") + (b"\x10" + varint(nsec) if nsec else b"")
    return b"\x0a" + varint(len(stamp)) + stamp + _entity_tail(frame_id, ident)


def packed_fixed32(field: int, values: npt.NDArray[Any]) -> bytes:
    return ld(field, np.ascontiguousarray(values, dtype="<u4").tobytes())


_DOUBLE = struct.Struct("<d")
_NO_BITS = bytes(8)


def _vector3(x: float, y: float, z: float) -> bytes:
    """A Vector3 / Point3 message as protobuf writes it: the doubles x (1), y (2), z (3), each
    left out when its bits are all zero (proto3 default; -0.0 is written)."""
    out = b""
    for key, v in ((b"\x09", x), (b"\x11", y), (b"\x19", z)):
        raw = _DOUBLE.pack(v)
        if raw != _NO_BITS:
            out += key + raw
    return out


def sphere_field(field: int, x: float, y: float, z: float, tail: bytes) -> bytes:
    """One ``SpherePrimitive field``: ``pose {position: (x, y, z), orientation: identity}``
    followed by ``tail``, the sphere's encoded ``size`` and ``color`` fields (the bytes of
    SerializeToString; the tests compare them)."""
    position = _vector3(x, y, z)
    pose = bytes((_POSE_POSITION_TAG, len(position))) + position + _IDENTITY
    sphere = bytes((_SPHERE_POSE_TAG, len(pose))) + pose + tail
    return ld(field, sphere)


def _around_position(tail: bytes) -> tuple[bytes, bytes]:
    """The bytes of ``sphere_field(ENTITY_SPHERES, x, y, z, tail)`` before and after its
    position message when x, y and z are all written (27 bytes: three keys and doubles)."""
    whole = sphere_field(ENTITY_SPHERES, 1.0, 1.0, 1.0, tail)
    end = _IDENTITY + tail
    head = whole[: len(whole) - 27 - len(end)]
    if head + _vector3(1.0, 1.0, 1.0) + end != whole:  # pragma: no cover - a schema change
        raise ValueError("unexpected layout of a detection marker")
    return head, end


_POSITION_KEYS = np.frombuffer(b"\x09\x11\x19", dtype=np.uint8)  # Vector3 x, y, z (doubles)
# a detection's JSON after its position's numbers (%r each; a second %r for the range), by
# kind of return: 2 terrain + moving
_ROW_TAILS = tuple(
    f'%r,%r,%r],"kind":"{kind}","moving":{moving},"range":%%r}}'
    for kind in ("threat", "terrain")
    for moving in ("false", "true")
)


def _check_wire_layout() -> None:
    """The hand-encoded fields must be what the installed schemas say (fails at import if not)."""

    def number(msg: Any, name: str, ftype: int | None = None) -> int:
        f = msg.DESCRIPTOR.fields_by_name[name]
        if ftype is not None and f.type != ftype:
            raise ImportError(f"unexpected type for {msg.DESCRIPTOR.full_name}.{name}")
        return int(f.number)

    expected: dict[tuple[Any, str], int] = {
        (Point3, "x"): 1,
        (Point3, "y"): 2,
        (Point3, "z"): 3,
        (Color, "r"): 1,
        (Color, "g"): 2,
        (Color, "b"): 3,
        (Color, "a"): 4,
    }
    for (msg, name), num in expected.items():
        if number(msg, name, 1) != num:  # TYPE_DOUBLE
            raise ImportError(f"unexpected field number for {msg.DESCRIPTOR.full_name}.{name}")
    number(TriangleListPrimitive, "indices", _FIXED32)
    for msg in (Vector3, Point3):
        for j, name in enumerate("xyz"):
            if number(msg, name, 1) != j + 1:
                raise ImportError(f"unexpected field number for {msg.DESCRIPTOR.full_name}.{name}")
    if (number(SceneEntity, "timestamp"), number(SceneEntity, "frame_id")) != (1, 2):
        raise ImportError("unexpected field numbers for foxglove.SceneEntity")
    if (number(Pose, "position"), number(Pose, "orientation")) != (1, 2) or number(
        SpherePrimitive, "pose"
    ) >= min(number(SpherePrimitive, "size"), number(SpherePrimitive, "color")):
        raise ImportError("unexpected field numbers for foxglove.Pose or SpherePrimitive")


_check_wire_layout()
TRI_POINTS = TriangleListPrimitive.DESCRIPTOR.fields_by_name["points"].number
TRI_COLORS = TriangleListPrimitive.DESCRIPTOR.fields_by_name["colors"].number
TRI_INDICES = TriangleListPrimitive.DESCRIPTOR.fields_by_name["indices"].number
LINE_POINTS = LinePrimitive.DESCRIPTOR.fields_by_name["points"].number
ENTITY_LINES = SceneEntity.DESCRIPTOR.fields_by_name["lines"].number
ENTITY_TRIANGLES = SceneEntity.DESCRIPTOR.fields_by_name["triangles"].number
UPDATE_ENTITIES = SceneUpdate.DESCRIPTOR.fields_by_name["entities"].number
ENTITY_SPHERES = SceneEntity.DESCRIPTOR.fields_by_name["spheres"].number
_SPHERE_POSE = SpherePrimitive.DESCRIPTOR.fields_by_name["pose"].number
_POSE_POSITION = Pose.DESCRIPTOR.fields_by_name["position"].number
_SPHERE_POSE_TAG = tag(_SPHERE_POSE, _WIRE_LEN)[0]  # one byte each (fields 1..15), and so are
_POSE_POSITION_TAG = tag(_POSE_POSITION, _WIRE_LEN)[0]  # the lengths: a pose is < 128 bytes
_IDENTITY = Pose(orientation=Quaternion(w=1.0)).SerializeToString()  # the orientation field


# ---------------------------------------------------------------------------------------------
# JSON


def jsonable(value: Any) -> Any:
    """Plain JSON data from numbers, numpy scalars and arrays, tuples, mappings; NaN and infinities
    become ``null`` (JSON has no such numbers)."""
    if isinstance(value, str | bool) or value is None:
        return value
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        f = float(value)
        return f if math.isfinite(f) else None
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, Iterable):
        return [jsonable(v) for v in value]
    raise TypeError(f"{type(value).__name__} is not JSON data")


_JSON = json.JSONEncoder(separators=(",", ":"), allow_nan=False)  # json.dumps with these settings


def dumps(value: Any) -> bytes:
    """Compact JSON bytes (NaN and infinities refused: pass :func:`jsonable` data)."""
    return _JSON.encode(value).encode()


# ---------------------------------------------------------------------------------------------
# a radar scan


def bounded(memo: dict[Any, Any]) -> dict[Any, Any]:
    """``memo``, emptied first when it holds more than ``MEMO_SIZE`` entries."""
    if len(memo) > MEMO_SIZE:  # a noisy radar never repeats a point: keep it bounded
        memo.clear()
    return memo


class ScanEncoder:
    """The two messages of one radar scan.  A radar sees a static threat at the same point scan
    after scan: a scan given as arrays (:meth:`arrays`) whose ids, positions and flags are the
    last one's is encoded from the last one's pieces (the detection list with a new range for
    each detection), and its markers are not written again (Foxglove shows a scene entity
    without a lifetime until it is replaced); other scans are written whole, the text of each
    detection's JSON around its numbers kept per id (bounded, :func:`bounded`).  ``map_origin`` is
    subtracted from the marker positions; ``tails`` are the encoded size and colour fields of a
    terrain, a moving and a stationary threat's marker."""

    def __init__(self, map_origin: Sequence[float], tails: Sequence[bytes]) -> None:
        self._origin = (float(map_origin[0]), float(map_origin[1]), float(map_origin[2]))
        self._tails = tuple(tails)
        self._sphere_memo: dict[tuple[Any, ...], bytes] = {}  # detection marker bytes
        self._row_memo: dict[tuple[str, int], str] = {}  # a detection's JSON, %r for numbers
        # the sphere bytes before and after the position message of each kind of return,
        # 2 terrain + moving (threat, moving threat, terrain, "moving" terrain)
        self._around = [_around_position(self.tail(k > 1, k & 1 > 0)) for k in range(4)]
        self._spheres: bytes | None = None  # the spheres of the markers last written
        self._key: tuple[Any, ...] | None = None  # the last scan given as arrays
        self._listing = ""  # its detection list, a %r in place of each range

    def tail(self, terrain: bool, moving: bool) -> bytes:
        """Size and colour fields of a detection marker (brown terrain, orange moving, red)."""
        return self._tails[0 if terrain else 1 if moving else 2]

    def markers(self, positions: list[list[float]], tails: list[bytes]) -> bytes | None:
        """The spheres of a scan's scene update: one at each position (map CRS metres) followed
        by its ``tail`` (the sphere's encoded size and colour fields); None when they are the
        spheres last returned (the markers shown already).  Forgets the last array scan (the
        caller writes this scan's list)."""
        ox, oy, oz = self._origin
        memo = bounded(self._sphere_memo)
        spheres = []
        for (x, y, z), tail in zip(positions, tails, strict=True):
            # (0.0 and -0.0 are equal keys with different bits: not kept)
            key = (x, y, z, tail) if x and y and z else None
            sphere = memo.get(key)
            if sphere is None:
                sphere = sphere_field(ENTITY_SPHERES, x - ox, y - oy, z - oz, tail)
                if key is not None:
                    memo[key] = sphere
            spheres.append(sphere)
        self._key = None
        return self._shown(b"".join(spheres))

    def arrays(
        self,
        ids: Sequence[str],
        positions: FloatArray,
        terrain: npt.NDArray[np.bool_],
        moving: npt.NDArray[np.bool_],
        ranges: list[float],
    ) -> tuple[bytes | None, bytes]:
        """(the spheres of the scan's markers, None when they are those shown already; the
        detection list ``dumps({"detections": [...]})``): checked arrays (N,) and (N, 3) and
        ``ranges`` (N floats), all finite.  JSON writes a float as its ``repr``: the list is
        written directly (the tests compare it with the recorder's ``write_detections``); a scan
        with the ids, positions (their bits) and flags of the last one costs a comparison and a
        formatting of the ranges.  Terrain returns move with the aircraft: the markers' position
        fields are written for the whole scan at once (:meth:`_spheres`) and the list by one
        ``%`` formatting of its positions (:meth:`_listing_of`)."""
        key = (
            ids if type(ids) is tuple else tuple(ids),
            positions.tobytes(),
            terrain.tobytes(),
            moving.tobytes(),
        )
        spheres = None
        if key != self._key:
            kinds = (2 * terrain.astype(np.int64) + moving).tolist()
            spheres = self._shown(self._spheres_of(positions, kinds))
            self._listing = self._listing_of(key[0], positions, kinds)
            self._key = key
        return spheres, (self._listing % tuple(ranges)).encode()

    def same_positions(self, positions: FloatArray) -> bool:
        """Whether ``positions`` are (bit for bit) those of the last scan given as arrays."""
        return self._key is not None and positions.tobytes() == self._key[1]

    def _shown(self, body: bytes) -> bytes | None:
        """``body``, the spheres to show, or None when they are those shown already."""
        if body == self._spheres:
            return None
        self._spheres = body
        return body

    def _spheres_of(self, positions: FloatArray, kinds: list[int]) -> bytes:
        """``b"".join(sphere_field(...))`` of :meth:`markers` for positions (N, 3) of returns of
        each kind (``2 terrain + moving``: :meth:`tail`'s colours): the position messages (x, y, z
        doubles and their keys) of every row written by numpy, each row's sphere its kind's
        bytes around them; a row with a +0.0 offset (protobuf leaves that double out) by
        :func:`sphere_field`."""
        rel = np.ascontiguousarray(positions - np.array(self._origin), dtype="<f8")
        n = len(rel)
        msg = np.empty((n, 3, 9), dtype=np.uint8)
        msg[:, :, 0] = _POSITION_KEYS
        msg[:, :, 1:] = rel.view(np.uint8).reshape(n, 3, 8)
        flat = msg.tobytes()
        full = (rel.view("<u8") != 0).all(axis=1).tolist()
        around = self._around
        parts = []
        for i, (k, whole) in enumerate(zip(kinds, full, strict=True)):
            if whole:
                head, end = around[k]
                parts.append(head + flat[27 * i : 27 * i + 27] + end)
            else:
                x, y, z = rel[i].tolist()
                parts.append(sphere_field(ENTITY_SPHERES, x, y, z, self.tail(k > 1, k & 1 > 0)))
        return b"".join(parts)

    def _listing_of(self, ids: Sequence[str], positions: FloatArray, kinds: list[int]) -> str:
        """The detection list with a ``%r`` in place of each range: a ``%r`` in the text of
        each detection (kept per id and kind) for each coordinate, filled in one formatting
        (``%`` in ids written ``%%%%``: the list is formatted twice)."""
        memo = bounded(self._row_memo)
        rows = []
        for ident, k in zip(ids, kinds, strict=True):
            row = memo.get((ident, k))
            if row is None:
                head = f'{{"id":{dumps(str(ident)).decode()},"position":['.replace("%", "%%%%")
                row = head + _ROW_TAILS[k]
                memo[(ident, k)] = row
            rows.append(row)
        return ('{"detections":[' + ",".join(rows) + "]}") % tuple(positions.ravel().tolist())
