"""Missions from the tools people fly with (issue 35): QGroundControl ``.plan``, MAVLink
``QGC WPL 110`` (``.waypoints``, as Mission Planner, ArduPilot and pymavlink write it),
terrapath's own GeoJSON and a GeoJSON or KML path, read into a :class:`ForeignMission` (the
file's items in lon/lat and their altitude frames, nothing resolved), then made a terrapath
:class:`~planner.mission.Mission` on a map by :func:`to_mission`.

Reading (:func:`read_foreign`) needs no map. Every error is one line naming the file and the
item (``'m.plan', field 'mission.items[3]': ...``; a WPL line by its number and sequence).

- ``.plan`` (QGroundControl's JSON, ``fileType: "Plan"``): the mission items as the vehicle
  receives them -- ``command``, ``frame`` and the seven ``params`` (latitude, longitude and
  altitude are params 5-7; a null param is NaN, "unchanged"); QGroundControl's own
  ``AltitudeMode`` / ``Altitude`` / ``AMSLAltAboveTerrain`` are its editor's state, not what
  the vehicle flies, so they are not used -- except that an item in QGroundControl's
  "calculated above terrain" mode (``AltitudeMode`` 3) with no AMSL altitude computed is
  refused: its param 7 is not an AMSL altitude yet (the CFIT of QGC #10596). Survey and
  corridor-scan items are read through the simple items QGroundControl saves inside them
  (``TransectStyleComplexItem.Items``); other complex items are refused by number.
  ``plannedHomePosition`` is home ([lat, lon, alt AMSL]); the geofence's exclusion polygons and
  circles become danger zones from the ground up (a geofence is 2D); inclusion fences are kept
  in :attr:`ForeignMission.keep_in` and the mission's ``plan.imported.keep_in`` (map metres),
  and outside their union (as PX4 reads several) is a danger zone, ``outside-geofence``
  (:func:`terrain.zones.outside_of`): the plan, ``terrapath check``, the replay's judge and the
  avoiders keep inside the fences; a return to launch goes to the closest of home and the
  rally points.
- WPL: a header ``QGC WPL 110``, then one item per line: sequence, current, frame, command,
  params 1-4, latitude, longitude, altitude, autocontinue (tabs or spaces). Item 0 is home, in
  MAV_FRAME_GLOBAL (AMSL), as Mission Planner and ArduPilot write it.
- GeoJSON: terrapath's own export (the LineString's positions are the waypoints, metres AMSL;
  its Polygon features are the danger zones) or any FeatureCollection / Feature / geometry with
  one LineString of [lon, lat, alt]; altitudes are AMSL unless the feature's properties say
  ``altitudeMode: relativeToGround`` (then above the terrain, as in KML).
- KML: the first ``LineString``'s ``coordinates`` (lon,lat,alt) and its ``altitudeMode``:
  ``absolute`` (AMSL) or ``relativeToGround`` (above the terrain); ``clampToGround`` (KML's
  default) has no flight altitude and is refused.

Altitude frames (MAV_FRAME): 0 and 5 (GLOBAL): metres AMSL; 3 and 6 (GLOBAL_RELATIVE_ALT):
above home, whose altitude is the file's (``plannedHomePosition``, WPL item 0) or, where the
file gives none, the DEM's ground under home; 10 and 11 (GLOBAL_TERRAIN_ALT): above the DEM's
ground -- the waypoint is placed at that height above the ground under it, and the leg into it
is flown and checked at that height above the ground all along (the autopilot follows terrain
between items), kept as :attr:`~planner.mission.Mission.terrain_heights`. Frame 2 (MISSION) is
for commands without a position. Any other frame is refused by item.

Commands flown (MAV_CMD): 16 WAYPOINT; 22 TAKEOFF (a fixed wing's climb-out is its take-off
mode's: the mission starts at the take-off item, above home when the item has no position);
21 LAND (the touchdown, 1 m above the measured ground at the point whatever the item's altitude,
as the autopilots land; the last leg flown as a landing's final approach, no terrain floor, held
to the glide by the preflight; the items after it are never flown); 20 RETURN_TO_LAUNCH (home at
the altitude of the item before it, as ArduPlane's ``RTL_ALTITUDE`` -1 and PX4 over its return
altitude -- or the rally point closer than home, as both return by default; the mission ends
there); 31 LOITER_TO_ALT, 18 LOITER_TURNS and 19 LOITER_TIME: a
circle of the item's radius (0: the vehicle's turn radius; negative: counter-clockwise),
entered where the path from the previous waypoint meets it tangentially -- a waypoint is placed
there and a :class:`~planner.spiral.Spiral` flown at it (loiter-to-altitude: the turns the
vehicle needs for the altitude change at its turn climb gradient; loiter turns: the count,
rounded up to whole turns; loiter time: the turns the time takes at the cruise speed, rounded
up); 177 DO_JUMP (the items from the target to the jump repeated the count given, unrolled
into waypoints; an endless jump is refused). The commands that do not move the aircraft
(camera, gimbal, servo, relay, region of interest, conditions, land-start marker) are skipped
and listed in :attr:`Resolved.skipped`; any other command is refused with its item number.
DO_CHANGE_SPEED (178): from the waypoint before it on, the speed of param 2 (m/s; -1 or 0: no
change); a ground speed is flown as that true airspeed (noted), a climb or descent speed
(types 2, 3: a multicopter's) is skipped and listed.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from terrain.docfile import parse_json
from terrain.errors import DataFileError, InputError, where
from terrain.grid import HeightGrid

FloatArray = npt.NDArray[np.float64]

# MAV_CMD
WAYPOINT, LOITER_UNLIM, LOITER_TURNS, LOITER_TIME, RTL, LAND, TAKEOFF = 16, 17, 18, 19, 20, 21, 22
LOITER_TO_ALT = 31
DO_JUMP = 177
DO_CHANGE_SPEED = 178
DO_LAND_START = 189
LOITERS = (LOITER_TURNS, LOITER_TIME, LOITER_TO_ALT)
NAV_FLOWN = (WAYPOINT, TAKEOFF, LAND, RTL, *LOITERS)
SPEED_TYPES = {0: "airspeed", 1: "groundspeed", 2: "climb speed", 3: "descent speed"}
# commands that change nothing of the path flown: skipped, and listed
PASSIVE = {
    80: "ROI",
    112: "CONDITION_DELAY",
    114: "CONDITION_DISTANCE",
    115: "CONDITION_YAW",
    181: "DO_SET_RELAY",
    182: "DO_REPEAT_RELAY",
    183: "DO_SET_SERVO",
    184: "DO_REPEAT_SERVO",
    189: "DO_LAND_START",
    195: "DO_SET_ROI_LOCATION",
    196: "DO_SET_ROI_WPNEXT_OFFSET",
    197: "DO_SET_ROI_NONE",
    201: "DO_SET_ROI",
    202: "DO_DIGICAM_CONFIGURE",
    203: "DO_DIGICAM_CONTROL",
    204: "DO_MOUNT_CONFIGURE",
    205: "DO_MOUNT_CONTROL",
    206: "DO_SET_CAM_TRIGG_DIST",
    211: "DO_GRIPPER",
    214: "DO_SET_CAM_TRIGG_INTERVAL",
    530: "SET_CAMERA_MODE",
    531: "SET_CAMERA_ZOOM",
    532: "SET_CAMERA_FOCUS",
    1000: "DO_GIMBAL_MANAGER_PITCHYAW",
    1001: "DO_GIMBAL_MANAGER_CONFIGURE",
    2000: "IMAGE_START_CAPTURE",
    2001: "IMAGE_STOP_CAPTURE",
    2003: "DO_TRIGGER_CONTROL",
    2500: "VIDEO_START_CAPTURE",
    2501: "VIDEO_STOP_CAPTURE",
}
# known commands terrapath does not fly, with the reason given
REFUSED = {
    LOITER_UNLIM: "an unlimited loiter never ends: the mission would not go on",
    30: "CONTINUE_AND_CHANGE_ALT is not flown",
    82: "spline waypoints are not flown (give plain waypoints)",
    84: "VTOL take-off is not flown",
    85: "VTOL landing is not flown",
    92: "GUIDED_ENABLE hands the aircraft to another controller",
    93: "NAV_DELAY is not flown",
    94: "PAYLOAD_PLACE is not flown",
    176: "DO_SET_MODE changes the flight mode",
    179: "DO_SET_HOME moves home (relative altitudes would change mid-mission)",
    3000: "VTOL transition is not flown",
}
NAMES = {
    WAYPOINT: "WAYPOINT",
    LOITER_UNLIM: "LOITER_UNLIM",
    LOITER_TURNS: "LOITER_TURNS",
    LOITER_TIME: "LOITER_TIME",
    RTL: "RETURN_TO_LAUNCH",
    LAND: "LAND",
    TAKEOFF: "TAKEOFF",
    LOITER_TO_ALT: "LOITER_TO_ALT",
    DO_JUMP: "DO_JUMP",
    DO_CHANGE_SPEED: "DO_CHANGE_SPEED",
    **PASSIVE,
}
# MAV_FRAME
AMSL_FRAMES = (0, 5)
RELATIVE_FRAMES = (3, 6)
TERRAIN_FRAMES = (10, 11)
MISSION_FRAME = 2
FRAMES = (*AMSL_FRAMES, *RELATIVE_FRAMES, *TERRAIN_FRAMES, MISSION_FRAME)
MULTIROTOR_TYPES = (2, 3, 4, 13, 14, 15)  # MAV_TYPE quadrotor, coaxial, helicopter, hexa, octo, tri
MULTIROTOR_LOITER_RADIUS = 10.0  # m: a multirotor's loiter of radius 0 (it has no turn radius)
MAX_UNROLLED = 20_000  # waypoints a DO_JUMP may unroll to before the file is refused
QGC_CALC_ABOVE_TERRAIN = 3  # QGroundControl AltitudeMode: AMSL altitudes computed from terrain
FORMAT_NAMES = {
    "qgc-plan": "QGroundControl .plan",
    "wpl": "MAVLink WPL",
    "geojson": "GeoJSON",
    "kml": "KML",
}


@dataclass(frozen=True)
class Item:
    """One mission item as the vehicle receives it: ``params`` are params 1-7 (5-7 latitude,
    longitude, altitude; NaN where the file left them empty); ``field`` names it in messages;
    ``jump_id`` is what a DO_JUMP names it by (a ``.plan``'s ``doJumpId``, a WPL sequence)."""

    field: str
    command: int
    frame: int
    params: tuple[float, float, float, float, float, float, float]
    jump_id: int

    @property
    def lat(self) -> float:
        return self.params[4]

    @property
    def lon(self) -> float:
        return self.params[5]

    @property
    def alt(self) -> float:
        return self.params[6]

    @property
    def name(self) -> str:
        return NAMES.get(self.command, f"command {self.command}")


@dataclass(frozen=True)
class ForeignMission:
    """A mission file of another tool, read but not resolved: ``home`` (lat, lon, altitude m
    AMSL or NaN) or None; the ``items`` in file order; ``fences``: exclusion geofences as
    danger-zone records (lon/lat) with the field each came from; ``keep_in``: inclusion fences
    (fields); ``rally``: rally points (lat, lon, alt)."""

    source: str
    format: str  # "qgc-plan" | "wpl" | "geojson" | "kml"
    items: tuple[Item, ...]
    home: tuple[float, float, float] | None = None
    fences: tuple[tuple[str, dict[str, Any]], ...] = ()
    keep_in: tuple[tuple[str, dict[str, Any]], ...] = ()
    rally: tuple[tuple[float, float, float], ...] = ()
    vehicle_type: str | None = None  # "fixed-wing" | "multirotor" | None (the file does not say)
    cruise_speed: float | None = None  # the file's planning speed (not a command)
    terrapath: bool = False  # written by terrapath

    def fail(self, fld: str, msg: str) -> InputError:
        """A one-line error naming the file and the item (a WPL item by its line)."""
        if fld.startswith("line "):
            return InputError(f"{where(self.source)}{fld}: {msg}")
        return InputError(f"{where(self.source, fld or None)}{msg}")


def is_foreign(path: str | Path) -> bool:
    """Whether ``path`` is a mission of another tool (by its suffix, or a WPL header)."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix in (".plan", ".waypoints", ".wpl", ".kml", ".geojson"):
        return True
    if suffix in (".txt", ".mission", ".json") and p.is_file():
        try:
            with p.open("rb") as f:
                head = f.read(64).lstrip()
        except OSError:
            return False
        return head.startswith(b"QGC WPL") or (suffix == ".json" and head.startswith(b"{"))
    return False


def _text(path: Path) -> str:
    from terrain.docfile import read_text

    return read_text(path, "a mission", encoding="utf-8-sig")


def read_foreign(path: str | Path) -> ForeignMission:
    """Read a ``.plan``, WPL, GeoJSON or KML mission (module docstring)."""
    p = Path(path)
    text = _text(p)
    head = text.lstrip()[:64]
    if head.startswith("QGC WPL"):
        return _read_wpl(p, text)
    if p.suffix.lower() == ".kml" or head.startswith("<"):
        return _read_kml(p, text)
    if p.suffix.lower() in (".waypoints", ".wpl", ".txt", ".mission"):
        raise DataFileError(
            f"{where(p)}expected a MAVLink mission starting 'QGC WPL 110', found "
            f"{(text.strip().splitlines() or [''])[0][:40]!r}"
        )
    data = parse_json(text, p)
    if isinstance(data, dict) and data.get("fileType") == "Plan":
        return _read_plan(p, data)
    if isinstance(data, dict) and isinstance(data.get("type"), str):
        return _read_geojson(p, data)
    raise DataFileError(
        f"{where(p)}expected a QGroundControl plan (fileType 'Plan') or a GeoJSON path, "
        f"found {'a JSON ' + type(data).__name__ if not isinstance(data, dict) else 'neither'}"
    )


# -- QGroundControl .plan -------------------------------------------------------------------------


def _number(value: Any, src: Path, fld: str, *, null_nan: bool = True) -> float:
    if value is None and null_nan:
        return math.nan
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"{where(src, fld)}expected a number, found {value!r}")
    v = float(value)
    if math.isinf(v):
        raise InputError(f"{where(src, fld)}expected a finite number, found {value!r}")
    return v


def _integer(value: Any, src: Path, fld: str) -> int:
    v = _number(value, src, fld, null_nan=False)
    if v != int(v):
        raise InputError(f"{where(src, fld)}expected a whole number, found {value!r}")
    return int(v)


def _plan_item(raw: Any, src: Path, fld: str, jump_id: int) -> Item:
    if not isinstance(raw, dict):
        raise InputError(f"{where(src, fld)}expected a mission item (a mapping), found {raw!r}")
    for key in ("command", "frame", "params"):
        if key not in raw:
            raise InputError(f"{where(src, fld)}missing '{key}'")
    command = _integer(raw["command"], src, f"{fld}.command")
    frame = _integer(raw["frame"], src, f"{fld}.frame")
    params = raw["params"]
    if not isinstance(params, list) or len(params) != 7:
        raise InputError(f"{where(src, fld + '.params')}expected 7 params, found {params!r}")
    values = [_number(v, src, f"{fld}.params[{i}]") for i, v in enumerate(params)]
    coordinate = raw.get("coordinate")  # QGroundControl's first item format
    if isinstance(coordinate, list) and len(coordinate) == 3 and math.isnan(values[4]):
        values[4:7] = [_number(v, src, f"{fld}.coordinate[{i}]") for i, v in enumerate(coordinate)]
    if raw.get("AltitudeMode") == QGC_CALC_ABOVE_TERRAIN and raw.get("AMSLAltAboveTerrain") is None:
        raise InputError(
            f"{where(src, fld)}altitude 'calculated above terrain' with no AMSL altitude "
            "computed yet (AMSLAltAboveTerrain is null): its altitude is not AMSL; open the plan "
            "in QGroundControl with terrain data loaded, or use the terrain frame"
        )
    jid = raw.get("doJumpId", jump_id)
    return Item(
        fld,
        command,
        frame,
        tuple(values),  # type: ignore[arg-type]
        _integer(jid, src, f"{fld}.doJumpId") if jid is not None else jump_id,
    )


def _read_plan(src: Path, data: dict[str, Any]) -> ForeignMission:
    mission = data.get("mission")
    if not isinstance(mission, dict):
        raise DataFileError(f"{where(src, 'mission')}expected a mapping with 'items'")
    raw_items = mission.get("items")
    if not isinstance(raw_items, list):
        raise DataFileError(f"{where(src, 'mission.items')}expected a list of mission items")
    items: list[Item] = []
    for i, raw in enumerate(raw_items):
        fld = f"mission.items[{i}]"
        if isinstance(raw, dict) and raw.get("type") == "ComplexItem":
            inner = (raw.get("TransectStyleComplexItem") or {}).get("Items")
            kind = raw.get("complexItemType", "?")
            if not isinstance(inner, list):
                raise InputError(
                    f"{where(src, fld)}complex item {kind!r} is not flown (only survey and "
                    "corridor scans, through the items QGroundControl saves in them)"
                )
            for j, sub in enumerate(inner):
                sfld = f"{fld}.TransectStyleComplexItem.Items[{j}]"
                items.append(_plan_item(sub, src, sfld, len(items) + 1))
            continue
        if isinstance(raw, dict) and raw.get("type", "SimpleItem") != "SimpleItem":
            raise InputError(f"{where(src, fld + '.type')}unknown item type {raw.get('type')!r}")
        items.append(_plan_item(raw, src, fld, len(items) + 1))
    home = mission.get("plannedHomePosition")
    home_t: tuple[float, float, float] | None = None
    if home is not None:
        if not isinstance(home, list) or len(home) != 3:
            raise InputError(
                f"{where(src, 'mission.plannedHomePosition')}expected [lat, lon, alt], "
                f"found {home!r}"
            )
        h = [_number(v, src, f"mission.plannedHomePosition[{k}]") for k, v in enumerate(home)]
        if not (math.isnan(h[0]) or math.isnan(h[1]) or (h[0] == 0 and h[1] == 0)):
            home_t = (h[0], h[1], h[2])
    vtype = mission.get("vehicleType")
    vehicle_type = None
    if isinstance(vtype, int | float) and not isinstance(vtype, bool):
        vehicle_type = "multirotor" if int(vtype) in MULTIROTOR_TYPES else "fixed-wing"
        if int(vtype) not in (1, *MULTIROTOR_TYPES):
            vehicle_type = "fixed-wing" if int(vtype) in (19, 20, 21, 22, 23, 24, 25) else None
    speed = mission.get("cruiseSpeed")
    if vehicle_type == "multirotor":
        speed = mission.get("hoverSpeed", speed)
    cruise = (
        float(speed)
        if isinstance(speed, int | float) and not isinstance(speed, bool) and speed > 0
        else None
    )
    fences, keep_in = _plan_fences(src, data.get("geoFence"))
    rally: list[tuple[float, float, float]] = []
    rp = data.get("rallyPoints")
    if isinstance(rp, dict) and isinstance(rp.get("points"), list):
        for k, pt in enumerate(rp["points"]):
            fld = f"rallyPoints.points[{k}]"
            if not isinstance(pt, list) or len(pt) != 3:
                raise InputError(f"{where(src, fld)}expected [lat, lon, alt], found {pt!r}")
            la, lo, al = (_number(v, src, f"{fld}[{j}]") for j, v in enumerate(pt))
            rally.append((la, lo, al))
    return ForeignMission(
        str(src),
        "qgc-plan",
        tuple(items),
        home_t,
        fences,
        keep_in,
        tuple(rally),
        vehicle_type,
        cruise,
        terrapath=data.get("groundStation") == "terrapath",
    )


def _plan_fences(
    src: Path, fence: Any
) -> tuple[tuple[tuple[str, dict[str, Any]], ...], tuple[tuple[str, dict[str, Any]], ...]]:
    """(exclusion fences, inclusion fences), each polygon or circle a zone record (lon/lat)
    with the field it came from."""
    if fence is None:
        return (), ()
    if not isinstance(fence, dict):
        raise InputError(f"{where(src, 'geoFence')}expected a mapping, found {fence!r}")
    out: list[tuple[str, dict[str, Any]]] = []
    keep_in: list[tuple[str, dict[str, Any]]] = []
    for k, poly in enumerate(fence.get("polygons") or []):
        fld = f"geoFence.polygons[{k}]"
        if not isinstance(poly, dict) or not isinstance(poly.get("polygon"), list):
            raise InputError(f"{where(src, fld)}expected a mapping with a 'polygon' list")
        ring = []
        for j, v in enumerate(poly["polygon"]):
            if not isinstance(v, list) or len(v) != 2:
                raise InputError(f"{where(src, f'{fld}.polygon[{j}]')}expected [lat, lon]")
            la, lo = (_number(c, src, f"{fld}.polygon[{j}]", null_nan=False) for c in v)
            ring.append([lo, la])
        inclusion = bool(poly.get("inclusion", True))
        name = f"{'keep-in' if inclusion else 'geofence'}-polygon-{k}"
        (keep_in if inclusion else out).append((fld, {"vertices_lonlat": ring, "id": name}))
    for k, circ in enumerate(fence.get("circles") or []):
        fld = f"geoFence.circles[{k}]"
        c = circ.get("circle") if isinstance(circ, dict) else None
        if not isinstance(c, dict) or not isinstance(c.get("center"), list):
            raise InputError(f"{where(src, fld)}expected a mapping with circle.center and radius")
        if len(c["center"]) != 2:
            raise InputError(f"{where(src, fld + '.circle.center')}expected [lat, lon]")
        la, lo = (_number(v, src, f"{fld}.circle.center", null_nan=False) for v in c["center"])
        r = _number(c.get("radius"), src, f"{fld}.circle.radius", null_nan=False)
        if r <= 0:
            raise InputError(f"{where(src, fld + '.circle.radius')}expected metres > 0, found {r}")
        inclusion = bool(circ.get("inclusion", True))
        name = f"{'keep-in' if inclusion else 'geofence'}-circle-{k}"
        rec = {"lon": lo, "lat": la, "radius": r, "id": name}
        (keep_in if inclusion else out).append((fld, rec))
    return tuple(out), tuple(keep_in)


# -- MAVLink WPL ----------------------------------------------------------------------------------


def _read_wpl(src: Path, text: str) -> ForeignMission:
    lines = text.splitlines()
    header = lines[0].split()
    if header[:2] != ["QGC", "WPL"] or len(header) < 3 or header[2] != "110":
        raise DataFileError(
            f"{where(src)}line 1: expected the header 'QGC WPL 110', found {lines[0].strip()!r}"
        )
    items: list[Item] = []
    home: tuple[float, float, float] | None = None
    for n, line in enumerate(lines[1:], start=2):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        cols = line.split()
        fld = f"line {n}"
        if len(cols) != 12:
            raise InputError(
                f"{where(src)}{fld}: expected 12 columns (seq, current, frame, command, "
                f"param 1-4, lat, lon, alt, autocontinue), found {len(cols)}"
            )
        try:
            seq, _cur, frame, command = (int(c) for c in cols[:4])
        except ValueError:
            raise InputError(
                f"{where(src)}{fld}: sequence, current, frame and command must be whole "
                f"numbers, found {' '.join(cols[:4])!r}"
            ) from None
        try:
            values = tuple(float(c) for c in cols[4:11])
        except ValueError:
            raise InputError(f"{where(src)}{fld} (item {seq}): params must be numbers") from None
        label = f"{fld} (item {seq})"
        if not all(math.isfinite(v) or math.isnan(v) for v in values):
            raise InputError(f"{where(src)}{label}: params must be finite numbers")
        if seq == 0 and not items and home is None:
            # home: AMSL, as Mission Planner and ArduPilot write it; 0, 0 is "not set"
            if not (values[4] == 0 and values[5] == 0):
                home = (values[4], values[5], values[6])
            continue
        items.append(Item(label, command, frame, values, seq))  # type: ignore[arg-type]
    return ForeignMission(str(src), "wpl", tuple(items), home)


# -- GeoJSON and KML paths ------------------------------------------------------------------------


def _path_items(src: Path, coords: Any, fld: str, frame: int, what: str) -> tuple[Item, ...]:
    if not isinstance(coords, list) or len(coords) < 2:
        raise InputError(f"{where(src, fld)}expected at least two positions, found {coords!r}")
    items = []
    for i, c in enumerate(coords):
        if not isinstance(c, list | tuple) or len(c) != 3:
            raise InputError(
                f"{where(src, f'{fld}[{i}]')}expected [lon, lat, altitude] ({what}), found {c!r}"
            )
        lo, la, al = (_number(v, src, f"{fld}[{i}]", null_nan=False) for v in c)
        if not (-180 <= lo <= 180 and -90 <= la <= 90):
            raise InputError(f"{where(src, f'{fld}[{i}]')}lon/lat out of range: {lo}, {la}")
        items.append(Item(f"{fld}[{i}]", WAYPOINT, frame, (0, 0, 0, 0, la, lo, al), i + 1))
    return tuple(items)


def _read_geojson(src: Path, data: dict[str, Any]) -> ForeignMission:
    features: list[tuple[str, Any]]
    if data.get("type") == "FeatureCollection":
        feats = data.get("features")
        if not isinstance(feats, list):
            raise DataFileError(f"{where(src, 'features')}expected a list")
        features = [(f"features[{i}]", f) for i, f in enumerate(feats)]
    elif data.get("type") == "Feature":
        features = [("", data)]
    else:
        features = [("", {"type": "Feature", "geometry": data, "properties": {}})]
    line: tuple[str, dict[str, Any], dict[str, Any]] | None = None
    zones: list[tuple[str, dict[str, Any]]] = []
    for fld, f in features:
        geom = f.get("geometry") if isinstance(f, dict) else None
        if not isinstance(geom, dict):
            continue
        props = f.get("properties") or {}
        gtype = geom.get("type")
        if gtype == "LineString" and line is None:
            line = (fld, geom, props if isinstance(props, dict) else {})
        elif gtype in ("Polygon", "MultiPolygon") or (
            gtype == "Point" and isinstance(props, dict) and "diameter" in props
        ):
            zones.append((fld, f))
    if line is None:
        raise DataFileError(
            f"{where(src)}expected a GeoJSON path: a LineString of [lon, lat, altitude], found none"
        )
    fld, geom, props = line
    mode = str(props.get("altitudeMode", props.get("altitude_mode", "absolute")))
    frame = _altitude_mode(src, f"{fld}.properties.altitudeMode".lstrip("."), mode)
    gfld = f"{fld}.geometry.coordinates".lstrip(".")
    items = _path_items(src, geom.get("coordinates"), gfld, frame, "metres AMSL")
    fences = tuple(zones)
    return ForeignMission(
        str(src),
        "geojson",
        items,
        None,
        fences,
        terrapath=str(props.get("altitude", "")) == "metres AMSL",
    )


def _altitude_mode(src: Path, fld: str, mode: str) -> int:
    if mode in ("absolute", "amsl"):
        return AMSL_FRAMES[0]
    if mode in ("relativeToGround", "agl", "terrain"):
        return TERRAIN_FRAMES[0]
    if mode in ("clampToGround", "clampToSeaFloor", "relativeToSeaFloor"):
        raise InputError(
            f"{where(src, fld)}altitude mode {mode!r} puts the path on the ground: a mission "
            "needs 'absolute' (AMSL) or 'relativeToGround' altitudes"
        )
    raise InputError(
        f"{where(src, fld)}expected altitude mode 'absolute' or 'relativeToGround', found {mode!r}"
    )


def _read_kml(src: Path, text: str) -> ForeignMission:
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise DataFileError(f"{where(src)}not valid KML (XML): {exc}") from None
    line = next((e for e in root.iter() if e.tag.split("}")[-1] == "LineString"), None)
    if line is None:
        raise DataFileError(f"{where(src)}expected a KML path: a LineString, found none")
    coords_el = next((e for e in line if e.tag.split("}")[-1] == "coordinates"), None)
    mode_el = next((e for e in line if e.tag.split("}")[-1] == "altitudeMode"), None)
    mode = (mode_el.text or "").strip() if mode_el is not None else "clampToGround"
    frame = _altitude_mode(src, "LineString.altitudeMode", mode)
    raw = (coords_el.text or "") if coords_el is not None else ""
    coords: list[list[float] | str] = []
    for tok in raw.split():
        parts = tok.split(",")
        try:
            coords.append([float(v) for v in parts])
        except ValueError:
            coords.append(tok)
    items = _path_items(src, coords, "LineString.coordinates", frame, "lon,lat,alt")
    return ForeignMission(str(src), "kml", items)


# -- on a map ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Resolved:
    """A foreign mission placed on a map: the waypoints (W, 3) map metres AMSL, the spirals,
    the terrain heights of terrain-frame legs, the danger zones' records, home, and what was
    skipped (item field, command name) and noted for the user."""

    waypoints: FloatArray
    spirals: tuple[Any, ...]
    terrain_heights: dict[int, float]
    speeds: dict[int, float]
    zones: tuple[Any, ...]
    home: tuple[float, float, float]  # map x, y, m AMSL
    landing: bool
    skipped: tuple[str, ...]
    notes: tuple[str, ...]
    items: dict[int, str] = field(default_factory=dict)  # waypoint index -> the item it came from


def unroll(fm: ForeignMission) -> list[Item]:
    """The items in the order they are flown, DO_JUMPs unrolled (a jump to item T with repeat
    count n flies the items from T to the jump n more times; the count is the jump's own, reset
    only by reading the file again, as ArduPilot and PX4 do)."""
    by_id = {it.jump_id: k for k, it in enumerate(fm.items)}
    left: dict[int, int] = {}
    out: list[Item] = []
    k = 0
    while k < len(fm.items):
        it = fm.items[k]
        if it.command != DO_JUMP:
            out.append(it)
            if len(out) > MAX_UNROLLED:
                raise fm.fail(it.field, f"DO_JUMPs unroll to more than {MAX_UNROLLED} items")
            k += 1
            continue
        target, repeat = it.params[0], it.params[1]
        if math.isnan(target) or int(target) not in by_id:
            raise fm.fail(it.field, f"DO_JUMP to item {target:g}, which is not in the mission")
        if math.isnan(repeat) or repeat < 0:
            raise fm.fail(it.field, "DO_JUMP repeats forever (count -1): the mission never ends")
        remaining = left.setdefault(k, int(repeat))
        if remaining > 0:
            left[k] = remaining - 1
            k = by_id[int(target)]
        else:
            k += 1
    return out


def _tangent_point(
    prev: FloatArray, centre: FloatArray, radius: float, clockwise: bool, heading: FloatArray
) -> FloatArray:
    """Where a path from ``prev`` meets the circle (``centre``, ``radius``) tangentially, flying
    round it ``clockwise`` (seen from above) or not; from inside the circle, the point on it
    reached on ``heading``'s side."""
    d = centre - prev
    dist = float(np.hypot(*d))
    side = -1.0 if clockwise else 1.0  # + counter-clockwise: the centre to the left
    if dist > radius * (1 + 1e-9):
        alpha = math.asin(radius / dist)
        u = d / dist
        rot = -side * alpha  # clockwise: turn the line of sight left, the centre on the right
        q = np.array(
            [
                u[0] * math.cos(rot) - u[1] * math.sin(rot),
                u[0] * math.sin(rot) + u[1] * math.cos(rot),
            ]
        )
    else:
        q = d / dist if dist > 1e-9 else heading
    left = np.array([-q[1], q[0]])
    return np.asarray(centre - side * radius * left, dtype=np.float64)


def to_mission_parts(
    fm: ForeignMission,
    grid: HeightGrid,
    *,
    speed: float,
    turn_radius: float,
    turn_climb_gradient: float,
) -> Resolved:
    """Place ``fm`` on ``grid``: lon/lat to map metres, every altitude frame to AMSL (module
    docstring), loiters to spirals; ``turn_radius`` is the loiter radius where an item gives 0
    (and the fillets'), ``turn_climb_gradient`` the climb (descent) per metre flown in a spiral
    a loiter-to-altitude is given turns for, ``speed`` turns a loiter's time into turns."""
    from planner.spiral import MAX_TURNS, Spiral

    if not grid.is_georeferenced:
        raise fm.fail("", "a mission in lon/lat needs a georeferenced DEM (this one has no CRS)")
    items = unroll(fm)
    skipped: list[str] = []
    notes: list[str] = []
    ground_cache: dict[tuple[float, float], float] = {}

    def to_map(lat: float, lon: float, fld: str) -> FloatArray:
        x, y = grid.from_lonlat(np.array([lon]), np.array([lat]))
        p = np.array([float(x[0]), float(y[0])])
        if not bool(grid.contains(p[0], p[1])):
            raise fm.fail(fld, f"lat {lat:.6f}, lon {lon:.6f} lies outside the DEM")
        return p

    def ground(p: FloatArray, fld: str) -> float:
        key = (float(p[0]), float(p[1]))
        if key not in ground_cache:
            h = float(np.asarray(grid.height_at(p[0], p[1])).reshape(-1)[0])
            if not math.isfinite(h):
                raise fm.fail(fld, "no measured terrain under this point for its altitude")
            ground_cache[key] = h
        return ground_cache[key]

    # home: the file's, else the first positioned item's (GeoJSON / KML paths start there)
    home_xy: FloatArray | None = None
    home_alt = math.nan
    if fm.home is not None:
        home_xy = to_map(fm.home[0], fm.home[1], "home")
        home_alt = fm.home[2]
    needs_home = any(it.frame in RELATIVE_FRAMES for it in items)
    if home_xy is None:
        first = next((it for it in items if _positioned(it)), None)
        if needs_home or first is None:
            raise fm.fail(
                "",
                "relative altitudes need home, and the file gives none "
                "(plannedHomePosition / WPL item 0 unset)",
            )
        home_xy = to_map(first.lat, first.lon, first.field)
    if not math.isfinite(home_alt) or (fm.format == "wpl" and home_alt == 0 and needs_home):
        home_alt = ground(home_xy, "home")
        notes.append(f"home altitude from the DEM: {home_alt:.1f} m AMSL")

    def altitude(it: Item, p: FloatArray, prev_z: float | None) -> tuple[float, float | None]:
        a = it.alt
        if math.isnan(a):
            if prev_z is None:
                raise fm.fail(it.field, "no altitude given (param 7) and none before it")
            return prev_z, None
        if it.frame in AMSL_FRAMES:
            return a, None
        if it.frame in RELATIVE_FRAMES:
            return home_alt + a, None
        if it.frame in TERRAIN_FRAMES:
            return ground(p, it.field) + a, a
        raise fm.fail(
            it.field,
            f"frame {it.frame} is not a frame terrapath flies (expected 0/5 AMSL, 3/6 relative "
            "to home, 10/11 above terrain)",
        )

    rally_xy = [
        to_map(la, lo, f"rallyPoints.points[{k}]") for k, (la, lo, _) in enumerate(fm.rally)
    ]
    pts: list[list[float]] = []
    agl: dict[int, float] = {}
    speeds: dict[int, float] = {}
    source_of: dict[int, str] = {}
    spirals: list[Any] = []
    attach: list[tuple[int, tuple[float, float]]] = []  # loiter-to-alt spirals, their centres
    landing = False
    ended = False
    for it in items:
        if ended:
            if it.command in NAV_FLOWN:
                notes.append(f"{it.field} ({it.name}) comes after the mission's end: not flown")
            continue
        if it.frame not in FRAMES:
            raise fm.fail(
                it.field,
                f"frame {it.frame} is not a MAVLink frame terrapath reads (expected 0/5 AMSL, "
                "3/6 relative to home, 10/11 above terrain, 2 for commands without a position)",
            )
        if it.command in PASSIVE:
            skipped.append(f"{it.field} ({it.name})")
            continue
        if it.command in REFUSED:
            raise fm.fail(it.field, f"{it.name}: {REFUSED[it.command]}")
        if it.command == DO_CHANGE_SPEED:
            kind = int(it.params[0]) if math.isfinite(it.params[0]) else 0
            v = it.params[1]
            if kind in (2, 3) or not (math.isfinite(v) and v > 0):
                what = SPEED_TYPES.get(kind, f"speed type {kind}") if v > 0 else "no change"
                skipped.append(f"{it.field} ({it.name}: {what})")
                continue
            if kind == 1:
                notes.append(f"{it.field}: a ground speed of {v:g} m/s flown as that airspeed")
            speeds[max(len(pts) - 1, 0)] = float(v)
            continue
        if it.command not in NAV_FLOWN:
            raise fm.fail(it.field, f"unknown command {it.command}: not a command terrapath flies")
        prev = np.array(pts[-1][:2]) if pts else home_xy
        prev_z = pts[-1][2] if pts else None
        if it.command == RTL:
            # the closest of home and the rally points, as ArduPilot and PX4 return by default
            safe = [home_xy, *rally_xy]
            k_safe = int(np.argmin([float(np.hypot(*(q - prev))) for q in safe]))
            back = safe[k_safe]
            pts.append([float(back[0]), float(back[1]), prev_z if prev_z is not None else home_alt])
            source_of[len(pts) - 1] = it.field
            to = "launch" if k_safe == 0 else f"rally point {k_safe - 1} (closer than home)"
            notes.append(
                f"{it.field}: returns to {to} at {pts[-1][2]:.0f} m AMSL; the mission ends there"
            )
            ended = True
            continue
        has_pos = _positioned(it)
        if it.command == TAKEOFF and not has_pos:
            p = home_xy.copy() if not pts else prev.copy()
        elif not has_pos:
            p = prev.copy()
        else:
            p = to_map(it.lat, it.lon, it.field)
        z, h_agl = altitude(it, p, prev_z)
        if it.command in LOITERS:
            r_raw = it.params[1] if it.command == LOITER_TO_ALT else it.params[2]
            r_raw = 0.0 if math.isnan(r_raw) else r_raw
            radius = abs(r_raw) or turn_radius
            if radius <= 0:
                raise fm.fail(it.field, "a loiter needs a radius (param) or a vehicle that turns")
            clockwise = r_raw >= 0
            heading = (p - prev) / max(float(np.hypot(*(p - prev))), 1e-9)
            t = _tangent_point(prev, p, radius, clockwise, heading)
            if it.command == LOITER_TO_ALT:
                entry = prev_z if prev_z is not None else z
                climb = abs(z - entry)
                per_turn = 2 * math.pi * radius * max(turn_climb_gradient, 1e-9)
                turns = max(1, math.ceil(climb / per_turn - 1e-9))
            elif it.command == LOITER_TURNS:
                entry = z
                turns = (
                    max(1, math.ceil(abs(it.params[0]) - 1e-9))
                    if math.isfinite(it.params[0])
                    else 1
                )
            else:
                entry = z
                secs = it.params[0] if math.isfinite(it.params[0]) else 0.0
                turns = max(1, math.ceil(secs * speed / (2 * math.pi * radius) - 1e-9))
            if turns > MAX_TURNS:
                raise fm.fail(it.field, f"{it.name} needs {turns} turns (more than {MAX_TURNS})")
            pts.append([float(t[0]), float(t[1]), float(z)])
            k = len(pts) - 1
            source_of[k] = it.field
            if h_agl is not None:
                agl[k] = h_agl
            spirals.append(Spiral(k, float(entry), int(turns), float(radius), clockwise))
            if it.command == LOITER_TO_ALT and k >= 1:
                attach.append((len(spirals) - 1, (float(p[0]), float(p[1]))))
            continue
        if it.command == LAND:
            # the autopilots land at the point whatever the item's altitude (ArduPlane, PX4):
            # touchdown 1 m above the measured ground there, as terrapath's own landings
            safety = grid.safety()
            g = float(np.asarray(safety.height_at(p[0], p[1])).reshape(-1)[0])
            if not math.isfinite(g):
                raise fm.fail(it.field, "no measured terrain under the landing point")
            z, h_agl = g + 1.0, None
            landing, ended = True, True
        pts.append([float(p[0]), float(p[1]), float(z)])
        k = len(pts) - 1
        source_of[k] = it.field
        if h_agl is not None:
            agl[k] = h_agl
    for j, c in reversed(attach):
        _attach(pts, spirals, (agl, source_of, speeds), j, np.array(c), turn_radius)
    if len(pts) < 2:
        raise fm.fail("", f"expected at least two positions to fly, found {len(pts)}")
    if fm.rally and not any("rally point" in n for n in notes):
        notes.append(f"{len(fm.rally)} rally point(s): no return to launch flies to them")
    from terrain.zone_file import zones_from_fields

    zones = zones_from_fields(fm.fences, grid, source=fm.source)
    return Resolved(
        np.array(pts, dtype=np.float64),
        tuple(spirals),
        agl,
        speeds,
        zones,
        (float(home_xy[0]), float(home_xy[1]), float(home_alt)),
        landing,
        tuple(skipped),
        tuple(notes),
        source_of,
    )


def _attach(
    pts: list[list[float]],
    spirals: list[Any],
    books: tuple[dict[int, Any], ...],
    j: int,
    centre: FloatArray,
    turn_radius: float,
) -> None:
    """Fly loiter-to-altitude spiral ``j`` at the waypoint before it when its circle touches the
    path there as a terrapath spiral would (:func:`planner.spiral.anchor`: tangent to the leg
    into the waypoint at its fillet's T1) -- how terrapath writes a spiral into a ``.plan``
    (:mod:`planner.export`), so that the round trip gives the same path -- instead of at a
    waypoint of its own where the leg meets the circle."""
    from dataclasses import replace

    from planner.spiral import centre as spiral_centre

    sp = spirals[j]
    k = sp.at - 1
    if any(s.at == k for s in spirals):
        return
    rest = [q for i, q in enumerate(pts) if i != sp.at]
    w = np.array(rest, dtype=np.float64)
    if len(w) < 2:
        return
    c = spiral_centre(w, replace(sp, at=k), turn_radius)
    if float(np.hypot(*(c - centre))) > max(2.0, 0.01 * sp.radius):
        return
    entry = pts[k][2]
    pts[k][2] = pts[sp.at][2]
    del pts[sp.at]
    spirals[j] = replace(sp, at=k, entry=entry)
    for i, s in enumerate(spirals):
        if i != j and s.at > sp.at:
            spirals[i] = replace(s, at=s.at - 1)
    for book in books:  # what is kept by waypoint index moves with the waypoints after
        moved = {(i - 1 if i > sp.at else i): v for i, v in book.items() if i != sp.at}
        book.clear()
        book.update(moved)


def _positioned(it: Item) -> bool:
    return (
        math.isfinite(it.lat)
        and math.isfinite(it.lon)
        and not (it.lat == 0 and it.lon == 0)
        and it.frame != MISSION_FRAME
    )


def to_mission(
    fm: ForeignMission,
    grid: HeightGrid,
    terrain: Any,
    *,
    vehicle: str,
    perf: Any,
) -> Any:
    """The terrapath :class:`~planner.mission.Mission` of ``fm`` on ``grid`` (its DEM
    reference ``terrain``), flown by ``vehicle`` with the limits ``perf``
    (:class:`~planner.performance.Performance`: its speed, its turn radius for the fillets and
    for loiters of radius 0 -- 10 m for a multirotor, which stops to turn -- and its turn climb
    gradient for the turns of a loiter-to-altitude). ``plan.imported`` records the file, its
    format, home, the items skipped and the notes."""
    from planner.mission import Mission, grid_crs_label

    radius = float(perf.turn_radius) or MULTIROTOR_LOITER_RADIUS
    parts = to_mission_parts(
        fm,
        grid,
        speed=float(perf.speed),
        turn_radius=radius,
        turn_climb_gradient=float(perf.turn_climb_gradient),
    )
    imported: dict[str, Any] = {
        "file": fm.source,
        "format": fm.format,
        "home": [round(v, 3) for v in parts.home],
        "items": len(fm.items),
    }
    if parts.skipped:
        imported["skipped"] = list(parts.skipped)
    if parts.notes:
        imported["notes"] = list(parts.notes)
    zones = parts.zones
    if fm.keep_in:
        from terrain.zone_file import zones_from_fields, zones_to_records
        from terrain.zones import outside_of

        # inclusion fences (map metres): outside their union is a no-fly zone for the plan,
        # check, the replay's judge and the avoiders alike
        fences = zones_from_fields(fm.keep_in, grid, source=fm.source)
        imported["keep_in"] = zones_to_records(fences)
        zones = (*zones, outside_of(fences, grid.bounds))
    if fm.cruise_speed is not None:
        imported["file_cruise_speed"] = fm.cruise_speed
    plan: dict[str, Any] = {"imported": imported}
    if parts.landing and len(parts.waypoints) >= 2:
        # the last leg is a landing's final approach (the replay flies it without a terrain
        # floor, down to the touchdown; the preflight holds it to the glide)
        w = parts.waypoints
        plan["landing"] = {
            "touchdown": [round(float(v), 3) for v in w[-1]],
            "approach_fix": [round(float(v), 3) for v in w[-2]],
            "go_around_altitude": round(float(w[-2, 2]), 2),
            "from": "NAV_LAND",
        }
    # corners are flown as fillets of the turn radius at the fastest speed flown (the same
    # bank: the radius grows with the square of the speed)
    fastest = max([float(perf.speed), *parts.speeds.values()])
    turn = float(perf.turn_radius) * (fastest / float(perf.speed)) ** 2
    return Mission(
        name=Path(fm.source).stem,
        waypoints=parts.waypoints,
        crs=grid_crs_label(grid),
        terrain=terrain,
        vehicle=vehicle,
        cruise_speed=float(perf.speed),
        cruise_altitude=float(parts.waypoints[0, 2]),
        turn_radius=None if getattr(perf, "hover", False) else turn,
        danger_zones=zones,
        plan=plan,
        source=fm.source,
        spirals=parts.spirals,
        terrain_heights=parts.terrain_heights,
        speeds=parts.speeds,
    )
