"""Drawing helpers and input normalisation of :mod:`replay.record`.

- Geometry: the vehicle attitude as a map-frame quaternion (:func:`quaternion_map`), poses,
  colours, terrain colours by height, terrain mesh decimation (:func:`decimate_mesh`) and the
  triangle mesh of a superellipsoid threat (:func:`superellipsoid_mesh`).
- JSON: plain JSON data from numpy values (:func:`jsonable`; NaN and infinities become ``null``)
  and compact encoding.
- Input validation: threat and detection dicts (their shapes are described in the
  :mod:`replay.record` docstring) are checked and normalised to plain types
  (:func:`normalize_threat`, :func:`normalize_detection`); unknown keys are refused and errors are
  :class:`terrain.errors.InputError`.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
from foxglove_schemas_protobuf.Vector3_pb2 import Vector3

from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]

# significant digits of the numbers in /vehicle/state: 1e-5 m at 10,000 km; formatting 17 (exact
# round trip) costs twice as much, and this message is written 288,000 times in an 8-hour mission
DIGITS = 12
THREAT_KINDS = ("sphere", "cylinder", "ellipsoid")
THREAT_KEYS = ("id", "kind", "center", "radius", "axes", "exponents", "top", "bottom")
DETECTION_KEYS = ("id", "position", "range", "kind", "moving")

# ---------------------------------------------------------------------------------------------
# geometry helpers

_S = math.sqrt(0.5)


def quaternion_map(phi: float, theta: float, psi: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) attitude of the FLU body in the ENU map frame from 3-2-1 Euler angles: the same
    rotation as :func:`replay.frames.quaternion_map_from_euler`, in plain floats (about 10x faster,
    it runs for every state sample).  q = q(NED->ENU) * q(FRD body->NED) * q(FLU->FRD)."""
    cr, sr = math.cos(0.5 * phi), math.sin(0.5 * phi)
    cp, sp = math.cos(0.5 * theta), math.sin(0.5 * theta)
    cy, sy = math.cos(0.5 * psi), math.sin(0.5 * psi)
    w0 = cr * cp * cy + sr * sp * sy
    x0 = sr * cp * cy - cr * sp * sy
    y0 = cr * sp * cy + sr * cp * sy
    z0 = cr * cp * sy - sr * sp * cy
    return (_S * (x0 + y0), _S * (x0 - y0), _S * (w0 - z0), _S * (w0 + z0))


@functools.cache
def _line_head(rgba: tuple[float, float, float, float]) -> bytes:
    """A track line strip without its points (they are appended as wire bytes)."""
    return bytes(
        LinePrimitive(
            type=LinePrimitive.LINE_STRIP,
            pose=_pose(),
            thickness=3.0,
            scale_invariant=True,
            color=_color(*rgba),
        ).SerializeToString()
    )


def _pose(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> Pose:
    """A pose at (x, y, z) with the identity orientation (never the all-zero quaternion)."""
    return Pose(position=Vector3(x=x, y=y, z=z), orientation=Quaternion(w=1.0))


def _color(r: float, g: float, b: float, a: float = 1.0) -> Color:
    return Color(r=r, g=g, b=b, a=a)


def _height_colors(z: FloatArray) -> FloatArray:
    """(n, 4) RGBA: green lowlands, brown hills, grey-white tops (min..max of z)."""
    span = float(np.ptp(z)) if z.size else 0.0
    h = (z - float(np.min(z))) / span if span > 0 else np.zeros_like(z)
    stops = [0.0, 0.35, 0.7, 1.0]
    rgb = [
        (0.22, 0.45, 0.20),
        (0.55, 0.55, 0.30),
        (0.50, 0.38, 0.25),
        (0.92, 0.92, 0.92),
    ]
    out = np.ones((z.size, 4))
    for c in range(3):
        out[:, c] = np.interp(h, stops, [s[c] for s in rgb])
    return out


def decimate_mesh(
    vertices: FloatArray, faces: npt.NDArray[np.int64], max_triangles: int
) -> tuple[FloatArray, npt.NDArray[np.int64]]:
    """Vertex clustering on a horizontal grid until at most ``max_triangles`` remain (for terrain
    meshes, which are height fields): each cell's vertices merge at their mean, degenerate and
    repeated triangles go.  Returns the mesh unchanged when it is small enough."""
    if len(faces) <= max_triangles:
        return vertices, faces
    lo = vertices[:, :2].min(axis=0)
    span = np.maximum(np.ptp(vertices[:, :2], axis=0), 1e-9)
    cell = math.sqrt(float(span[0] * span[1]) / (max_triangles / 2.0))
    while True:
        ij = np.floor((vertices[:, :2] - lo) / cell).astype(np.int64)
        key = ij[:, 0] * (int(ij[:, 1].max()) + 1) + ij[:, 1]
        _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
        inverse = inverse.reshape(-1)
        merged = np.stack(
            [np.bincount(inverse, weights=vertices[:, k]) / counts for k in range(3)], axis=1
        )
        f = inverse[faces]
        keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
        f = f[keep]
        _, first = np.unique(np.sort(f, axis=1), axis=0, return_index=True)
        f = f[np.sort(first)]
        if len(f) <= max_triangles:
            used, remap = np.unique(f, return_inverse=True)
            return merged[used], remap.reshape(f.shape).astype(np.int64)
        cell *= 1.25


def superellipsoid_mesh(
    axes: Sequence[float], exponents: Sequence[float], n_lon: int = 32, n_lat: int = 16
) -> tuple[FloatArray, npt.NDArray[np.int64]]:
    """Surface of ``|x/a|^(2p) + |y/b|^(2q) + |z/c|^(2r) = 1`` (centred at 0) as a triangle mesh:
    each direction of a UV sphere scaled to the surface (bisection on the radius, vectorised)."""
    lon = np.linspace(0.0, 2 * np.pi, n_lon, endpoint=False)
    lat = np.linspace(-np.pi / 2, np.pi / 2, n_lat + 1)[1:-1]
    la, lo = np.meshgrid(lat, lon, indexing="ij")
    dirs = np.stack([np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)], -1)
    dirs = np.concatenate([dirs.reshape(-1, 3), [[0, 0, -1.0], [0, 0, 1.0]]])
    a = np.asarray(axes, dtype=np.float64)
    e = 2.0 * np.asarray(exponents, dtype=np.float64)
    lo_r = np.zeros(len(dirs))
    hi_r = np.full(len(dirs), float(np.linalg.norm(a)))  # the box corner bounds the body
    for _ in range(50):
        mid = 0.5 * (lo_r + hi_r)
        gamma = np.sum(np.abs(mid[:, None] * dirs / a) ** e, axis=1)
        inside = gamma <= 1.0
        lo_r = np.where(inside, mid, lo_r)
        hi_r = np.where(inside, hi_r, mid)
    points = dirs * lo_r[:, None]
    rows, cols = len(lat), n_lon
    faces: list[tuple[int, int, int]] = []
    for i in range(rows - 1):
        for j in range(cols):
            a0, a1 = i * cols + j, i * cols + (j + 1) % cols
            b0, b1 = a0 + cols, a1 + cols
            faces += [(a0, a1, b1), (a0, b1, b0)]
    south, north = rows * cols, rows * cols + 1
    for j in range(cols):
        faces.append((south, (j + 1) % cols, j))
        top = (rows - 1) * cols
        faces.append((north, top + j, top + (j + 1) % cols))
    return points, np.asarray(faces, dtype=np.int64)


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


def _dumps(value: Any) -> bytes:
    return _JSON.encode(value).encode()


def _num(x: float) -> str:
    return f"{x:.{DIGITS}g}" if math.isfinite(x) else "null"


# ---------------------------------------------------------------------------------------------
# input validation


def _finite(value: Any, what: str) -> float:
    try:
        f = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected a number, found {value!r}") from None
    if not math.isfinite(f):
        raise InputError(f"{what}: expected a finite number, found {value!r}")
    return f


def _vector(value: Any, n: int | tuple[int, ...], what: str) -> list[float]:
    sizes = (n,) if isinstance(n, int) else n
    try:
        items = list(value)
    except TypeError:
        raise InputError(f"{what}: expected {sizes[0]} numbers, found {value!r}") from None
    if len(items) not in sizes:
        raise InputError(
            f"{what}: expected {' or '.join(map(str, sizes))} numbers, found {len(items)}"
        )
    return [_finite(v, what) for v in items]


def _keys(item: Any, allowed: Sequence[str], what: str) -> Mapping[str, Any]:
    if not isinstance(item, Mapping):
        raise InputError(f"{what}: expected a mapping, found {type(item).__name__}")
    unknown = sorted(set(map(str, item)) - set(allowed))
    if unknown:
        raise InputError(f"{what}: unknown key(s) {unknown}; allowed: {', '.join(allowed)}")
    if "id" not in item:
        raise InputError(f"{what}: missing 'id'")
    return item


def normalize_threat(item: Any, index: int = 0) -> dict[str, Any]:
    """A threat dict (module docstring) checked and with plain floats; raises InputError."""
    item = _keys(item, THREAT_KEYS, f"threats[{index}]")
    ident = str(item["id"])
    what = f"threat {ident!r}"
    kind = item.get("kind")
    if kind not in THREAT_KINDS:
        raise InputError(f"{what} kind: expected one of {', '.join(THREAT_KINDS)}, found {kind!r}")
    out: dict[str, Any] = {"id": ident, "kind": kind}
    if "center" not in item:
        raise InputError(f"{what}: missing 'center'")
    if kind == "sphere":
        first = next(iter(item["center"]), None) if isinstance(item["center"], Iterable) else None
        if isinstance(first, Iterable) and not isinstance(first, str):  # a hill: several spheres
            centers = [_vector(c, 3, f"{what} center") for c in item["center"]]
            radii = item.get("radius")
            rs = [radii] * len(centers) if not isinstance(radii, Iterable) else list(radii)
            if len(rs) != len(centers):
                raise InputError(f"{what} radius: expected one or {len(centers)} radii")
            out["center"] = centers
            out["radius"] = [_positive(r, f"{what} radius") for r in rs]
        else:
            out["center"] = _vector(item["center"], 3, f"{what} center")
            out["radius"] = _positive(item.get("radius"), f"{what} radius")
    elif kind == "cylinder":
        out["center"] = _vector(item["center"], (2, 3), f"{what} center")
        out["radius"] = _positive(item.get("radius"), f"{what} radius")
        for key in ("bottom", "top"):
            value = item.get(key)
            out[key] = None if value is None else _finite(value, f"{what} {key}")
        if out["bottom"] is not None and out["top"] is not None and out["top"] <= out["bottom"]:
            raise InputError(f"{what}: top {out['top']} must be above bottom {out['bottom']}")
    else:
        out["center"] = _vector(item["center"], 3, f"{what} center")
        out["axes"] = [
            _positive(a, f"{what} axes") for a in _vector(item.get("axes"), 3, f"{what} axes")
        ]
        exps = item.get("exponents")
        out["exponents"] = (
            [1.0, 1.0, 1.0]
            if exps is None
            else [_positive(e, f"{what} exponents") for e in _vector(exps, 3, f"{what} exponents")]
        )
    for key in ("top", "bottom"):
        if kind != "cylinder" and item.get(key) is not None:
            out[key] = _finite(item[key], f"{what} {key}")
    return out


def _positive(value: Any, what: str) -> float:
    f = _finite(value, what)
    if f <= 0:
        raise InputError(f"{what}: expected a number > 0, found {value!r}")
    return f


def normalize_detection(item: Any, index: int = 0) -> dict[str, Any]:
    """A detection dict (module docstring) checked and with plain types; raises InputError."""
    item = _keys(item, DETECTION_KEYS, f"detections[{index}]")
    what = f"detections[{index}]"
    if "position" not in item:
        raise InputError(f"{what}: missing 'position'")
    kind = item.get("kind", "threat")
    if kind not in ("threat", "terrain"):
        raise InputError(f"{what} kind: expected 'threat' or 'terrain', found {kind!r}")
    out: dict[str, Any] = {
        "id": str(item["id"]),
        "position": _vector(item["position"], 3, f"{what} position"),
        "kind": kind,
        "moving": bool(item.get("moving", False)),
    }
    if item.get("range") is not None:
        out["range"] = _finite(item["range"], f"{what} range")
    return out
