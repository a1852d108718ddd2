"""What each message of a recorded run contains: the schemas of the channels and the checks of the
caller's threat and detection dicts (the content side of :mod:`replay.record.recorder`).

- ``PROTOBUF_CLASSES``: the protobuf class of each protobuf schema (names in
  :mod:`replay.record.topics`): the Foxglove ones, and ``terrapath.VehicleState`` (:data:`VehicleState`,
  its descriptor built here: the vehicle state's keys in order, ``STATE_KEYS``, documented in
  ``STATE_DOCS``, and the extras); ``JSON_SCHEMAS``: the JSON Schema of each JSON ``terrapath.*``
  schema (the vehicle state's of recording format 1 is kept: ``STATE_JSON_SCHEMA``).
- Threat and detection dicts (their shapes are described in the :mod:`replay.record.recorder` docstring)
  are checked and normalised to plain types (:func:`normalize_threat`,
  :func:`normalize_detection`); unknown keys are refused and errors are
  :class:`terrain.errors.InputError`.  :func:`check_finite`, :func:`check_vector` and
  :func:`check_positive` are the number checks they and the recorder share.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.LocationFix_pb2 import LocationFix
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.timestamp_pb2 import Timestamp

from replay.flight.log import GUIDANCE_COLUMNS
from replay.record import topics as T
from terrain.errors import InputError

THREAT_KINDS = ("sphere", "cylinder", "ellipsoid", "prism")
THREAT_KEYS = ("id", "kind", "center", "radius", "axes", "exponents", "footprint", "top", "bottom")
DETECTION_KEYS = ("id", "position", "range", "kind", "moving")

# ---------------------------------------------------------------------------------------------
# Foxglove protobuf schemas of the channels (schema data: replay.record.writer.descriptor_set)

PROTOBUF_CLASSES: dict[str, Any] = {
    T.FRAME_TRANSFORM: FrameTransform,
    T.POSE_IN_FRAME: PoseInFrame,
    T.LOCATION_FIX: LocationFix,
    T.SCENE_UPDATE: SceneUpdate,
    T.LOG_SCHEMA: Log,
}

# ---------------------------------------------------------------------------------------------
# JSON schemas of the terrapath channels

_NUM = {"type": ["number", "null"]}
_VEC3 = {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}


def _object(props: Mapping[str, Any], title: str, required: Sequence[str] = ()) -> dict[str, Any]:
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": title,
        "type": "object",
        "properties": dict(props),
        "required": list(required),
    }


STATE_DOCS = {
    "pn": "north, map metres (NED origin = map CRS origin)",
    "pe": "east, map metres",
    "pd": "down, metres (-altitude AMSL)",
    "alt": "altitude, metres AMSL (= -pd)",
    "u": "body x velocity, m/s",
    "v": "body y velocity, m/s",
    "w": "body z velocity, m/s",
    "phi": "roll, rad",
    "theta": "pitch, rad",
    "psi": "yaw (heading), rad clockwise from north",
    "p": "roll rate, rad/s",
    "q": "pitch rate, rad/s",
    "r": "yaw rate, rad/s",
    "airspeed": "speed through the air |(u, v, w) - wind in body axes|, m/s (extras wind_n, "
    "wind_e, wind_d: the air's velocity NED, m/s, when the run has wind)",
    "alpha": "angle of attack atan2(w_air, u_air), rad",
    "beta": "sideslip asin(v_air / airspeed), rad",
    "delta_e": "elevator, rad",
    "delta_a": "aileron, rad",
    "delta_r": "rudder, rad",
    "delta_t": "throttle, 0..1",
}
STATE_KEYS = tuple(STATE_DOCS)
STATE_DOUBLES = ("pn", "pe", "pd", "alt")  # map coordinates: doubles; the other keys float32
# the extras the simulation writes (replay.sim): float32 fields of VehicleState.extras; any
# other name goes to extras.other (name, double value)
STATE_EXTRAS = (
    *GUIDANCE_COLUMNS,  # field numbers follow this order: new extras go at the end
    "next_index",
    "wind_n",
    "wind_e",
    "wind_d",
    "energy_used",
    "energy_left",
)
STATE_TIMESTAMP_FIELD = 1
STATE_FIELD_NUMBERS = {k: i + 2 for i, k in enumerate(STATE_KEYS)}  # 2..21
STATE_EXTRAS_FIELD = 22
EXTRAS_FIELD_NUMBERS = {k: i + 1 for i, k in enumerate(STATE_EXTRAS)}  # 1..15
EXTRAS_OTHER_FIELD = 16
_D = descriptor_pb2.FieldDescriptorProto


def _state_file() -> descriptor_pb2.FileDescriptorProto:
    """terrapath/VehicleState.proto (proto2: every field optional with presence, so that an
    absent extra reads as absent, not 0)::

        message VehicleState {
          google.protobuf.Timestamp timestamp = 1;
          double pn = 2; double pe = 3; double pd = 4; double alt = 5;
          float u = 6; ... float delta_t = 21;      // STATE_KEYS in order
          Extras extras = 22;
          message Extras {
            float course_cmd = 1; ... float energy_left = 15;   // STATE_EXTRAS in order
            repeated Extra other = 16;              // any other name
            message Extra { string name = 1; double value = 2; }
          }
        }
    """
    f = descriptor_pb2.FileDescriptorProto(
        name="terrapath/VehicleState.proto",
        package="terrapath",
        syntax="proto2",
        dependency=[Timestamp.DESCRIPTOR.file.name],
    )
    opt = _D.LABEL_OPTIONAL
    msg = f.message_type.add(name="VehicleState")
    msg.field.add(
        name="timestamp",
        number=STATE_TIMESTAMP_FIELD,
        label=opt,
        type=_D.TYPE_MESSAGE,
        type_name=".google.protobuf.Timestamp",
    )
    for key, number in STATE_FIELD_NUMBERS.items():
        kind = _D.TYPE_DOUBLE if key in STATE_DOUBLES else _D.TYPE_FLOAT
        msg.field.add(name=key, number=number, label=opt, type=kind)
    msg.field.add(
        name="extras",
        number=STATE_EXTRAS_FIELD,
        label=opt,
        type=_D.TYPE_MESSAGE,
        type_name=".terrapath.VehicleState.Extras",
    )
    extras = msg.nested_type.add(name="Extras")
    for key, number in EXTRAS_FIELD_NUMBERS.items():
        extras.field.add(name=key, number=number, label=opt, type=_D.TYPE_FLOAT)
    extras.field.add(
        name="other",
        number=EXTRAS_OTHER_FIELD,
        label=_D.LABEL_REPEATED,
        type=_D.TYPE_MESSAGE,
        type_name=".terrapath.VehicleState.Extras.Extra",
    )
    extra = extras.nested_type.add(name="Extra")
    extra.field.add(name="name", number=1, label=opt, type=_D.TYPE_STRING)
    extra.field.add(name="value", number=2, label=opt, type=_D.TYPE_DOUBLE)
    return f


def _state_class() -> Any:
    pool = descriptor_pool.Default()
    try:
        desc = pool.FindMessageTypeByName(T.STATE_SCHEMA)
    except KeyError:
        pool.Add(_state_file())
        desc = pool.FindMessageTypeByName(T.STATE_SCHEMA)
    return message_factory.GetMessageClass(desc)


VehicleState: Any = _state_class()  # the protobuf class of /vehicle/state (recording format 2)
SEPARATION_DOCS = {
    "nearest_m": "separation from the surface of the nearest active threat, m (absent: none)",
    "zone_m": "separation from the nearest danger zone of the mission, m (absent: none)",
    "margin_m": "the run's success margin, m (a separation below it is a violation)",
}
# /vehicle/state of recording format 1 (JSON), which the reader still reads
STATE_JSON_SCHEMA: dict[str, Any] = _object(
    {
        **{k: {**_NUM, "description": d} for k, d in STATE_DOCS.items()},
        "extras": {
            "type": "object",
            "additionalProperties": _NUM,
            "description": "caller's values: commanded course/altitude, cross-track error, leg...",
        },
    },
    T.STATE_SCHEMA,
    STATE_KEYS,
)
PROTOBUF_CLASSES[T.STATE_SCHEMA] = VehicleState
JSON_SCHEMAS: dict[str, dict[str, Any]] = {
    T.WAYPOINT_LIST_SCHEMA: _object(
        {
            "waypoints": {"type": "array", "items": _VEC3, "description": "map metres"},
            "active_index": {"type": "integer"},
            "reason": {"type": "string"},
        },
        T.WAYPOINT_LIST_SCHEMA,
        ("waypoints", "active_index", "reason"),
    ),
    T.THREAT_LIST_SCHEMA: _object(
        {
            "threats": {"type": "array", "items": {"type": "object"}},
            "appeared": {"type": "array", "items": {"type": "string"}},
            "changed": {"type": "array", "items": {"type": "string"}},
            "removed": {"type": "array", "items": {"type": "string"}},
        },
        T.THREAT_LIST_SCHEMA,
        ("threats", "appeared", "changed", "removed"),
    ),
    T.DETECTION_LIST_SCHEMA: _object(
        {"detections": {"type": "array", "items": {"type": "object"}}},
        T.DETECTION_LIST_SCHEMA,
        ("detections",),
    ),
    T.DECISION_SCHEMA: _object(
        {"algorithm": {"type": "string"}, "compute_s": {"type": "number"}},
        T.DECISION_SCHEMA,
        ("algorithm", "compute_s"),
    ),
    T.METRICS_SCHEMA: _object({}, T.METRICS_SCHEMA),
    T.SEPARATION_SCHEMA: _object(
        {k: {**_NUM, "description": d} for k, d in SEPARATION_DOCS.items()}
        | {
            "nearest": {"type": "string", "description": "id of the nearest active threat"},
            "zone": {"type": "string", "description": "id of the nearest danger zone"},
            "threats": {
                "type": "object",
                "additionalProperties": _NUM,
                "description": "the nearest active threats (at most 4): id -> separation, m",
            },
        },
        T.SEPARATION_SCHEMA,
        ("margin_m", "threats"),
    ),
}


# ---------------------------------------------------------------------------------------------
# input validation


def check_finite(value: Any, what: str) -> float:
    """``value`` as a finite float; ``what`` names it in the InputError."""
    try:
        f = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected a number, found {value!r}") from None
    if not math.isfinite(f):
        raise InputError(f"{what}: expected a finite number, found {value!r}")
    return f


def check_vector(value: Any, n: int | tuple[int, ...], what: str) -> list[float]:
    """``value`` as ``n`` (or one of the sizes ``n``) finite floats."""
    sizes = (n,) if isinstance(n, int) else n
    try:
        items = list(value)
    except TypeError:
        raise InputError(f"{what}: expected {sizes[0]} numbers, found {value!r}") from None
    if len(items) not in sizes:
        raise InputError(
            f"{what}: expected {' or '.join(map(str, sizes))} numbers, found {len(items)}"
        )
    return [check_finite(v, what) for v in items]


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
    """A threat dict (:mod:`replay.record.recorder` docstring) checked and with plain floats; raises InputError."""
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
            centers = [check_vector(c, 3, f"{what} center") for c in item["center"]]
            radii = item.get("radius")
            rs = [radii] * len(centers) if not isinstance(radii, Iterable) else list(radii)
            if len(rs) != len(centers):
                raise InputError(f"{what} radius: expected one or {len(centers)} radii")
            out["center"] = centers
            out["radius"] = [check_positive(r, f"{what} radius") for r in rs]
        else:
            out["center"] = check_vector(item["center"], 3, f"{what} center")
            out["radius"] = check_positive(item.get("radius"), f"{what} radius")
    elif kind in ("cylinder", "prism"):
        out["center"] = check_vector(item["center"], (2, 3), f"{what} center")
        if kind == "cylinder":
            out["radius"] = check_positive(item.get("radius"), f"{what} radius")
        else:
            ring = item.get("footprint")
            if not isinstance(ring, Sequence) or isinstance(ring, str) or len(ring) < 3:
                raise InputError(
                    f"{what} footprint: expected at least 3 [x, y], found {ring!r:.60}"
                )
            out["footprint"] = [check_vector(v, 2, f"{what} footprint") for v in ring]
        for key in ("bottom", "top"):
            value = item.get(key)
            out[key] = None if value is None else check_finite(value, f"{what} {key}")
        if kind == "prism" and out["top"] is None:
            raise InputError(f"{what}: missing 'top'")
        if out["bottom"] is not None and out["top"] is not None and out["top"] <= out["bottom"]:
            raise InputError(f"{what}: top {out['top']} must be above bottom {out['bottom']}")
    else:
        out["center"] = check_vector(item["center"], 3, f"{what} center")
        out["axes"] = [
            check_positive(a, f"{what} axes")
            for a in check_vector(item.get("axes"), 3, f"{what} axes")
        ]
        exps = item.get("exponents")
        out["exponents"] = (
            [1.0, 1.0, 1.0]
            if exps is None
            else [
                check_positive(e, f"{what} exponents")
                for e in check_vector(exps, 3, f"{what} exponents")
            ]
        )
    for key in ("top", "bottom"):
        if kind not in ("cylinder", "prism") and item.get(key) is not None:
            out[key] = check_finite(item[key], f"{what} {key}")
    return out


def check_positive(value: Any, what: str) -> float:
    """``value`` as a finite float > 0."""
    f = check_finite(value, what)
    if f <= 0:
        raise InputError(f"{what}: expected a number > 0, found {value!r}")
    return f


def normalize_detection(item: Any, index: int = 0) -> dict[str, Any]:
    """A detection dict (:mod:`replay.record.recorder` docstring) checked and with plain types; raises InputError."""
    item = _keys(item, DETECTION_KEYS, f"detections[{index}]")
    what = f"detections[{index}]"
    if "position" not in item:
        raise InputError(f"{what}: missing 'position'")
    kind = item.get("kind", "threat")
    if kind not in ("threat", "terrain"):
        raise InputError(f"{what} kind: expected 'threat' or 'terrain', found {kind!r}")
    out: dict[str, Any] = {
        "id": str(item["id"]),
        "position": check_vector(item["position"], 3, f"{what} position"),
        "kind": kind,
        "moving": bool(item.get("moving", False)),
    }
    if item.get("range") is not None:
        out["range"] = check_finite(item["range"], f"{what} range")
    return out
