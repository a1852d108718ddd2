"""Mission exports for other tools: GeoJSON (WGS84), QGroundControl ``.plan`` and ``QGC WPL 110``.

Altitude frames are explicit and never mixed within one file:

- ``amsl``: every mission item in MAV_FRAME_GLOBAL (0), altitudes metres above mean sea level
  (QGroundControl ``AltitudeMode`` 2, "absolute");
- ``relative``: every mission item in MAV_FRAME_GLOBAL_RELATIVE_ALT (3), altitudes relative to
  the home position, QGroundControl ``AltitudeMode`` 1.  PX4 and ArduPilot take home where the
  aircraft arms, on the ground, so home here is the launch point: the ground under the mission's
  start (``grid.height_at`` under waypoint 0), not the airborne start itself; launched from the
  ground (``--start-on-ground``), the ground the plan launched from.

Home is written as the ``.plan``'s ``plannedHomePosition`` and as WPL item 0, always AMSL as both
formats require.  The mission items are the waypoints, one each, at their planned AMSL altitudes
(expressed in the chosen frame): waypoint 0, the airborne start above the launch point, is a
``NAV_TAKEOFF`` (22) item, the aircraft being fixed-wing, and the others are ``NAV_WAYPOINT`` (16)
items.  So the aircraft climbs from the launch point to the start's altitude in its take-off
mode (that climb is the autopilot's, not part of the planned path) and then flies to waypoint 1;
an item's altitude plus home's is always the planned AMSL altitude.

A climb or descent spiral at a waypoint (:mod:`planner.spiral`) follows that waypoint's item as a
``NAV_LOITER_TO_ALT`` (31) item at the helix's centre: param 1 = 1 (leave only when heading for
the next waypoint, as the plan's helix leaves tangentially), param 2 the radius (positive
clockwise, negative counter-clockwise, MAVLink's convention), param 4 = 1 (then track from where it
leaves the circle to the next waypoint), the altitude the spiral ends at; the waypoint's own item
has the altitude the spiral is entered at.  The autopilot circles until the altitude is reached
(the plan's turn count is the one the climb needs at the planned gradient).

Launched from the ground (``plan.takeoff``), home is the launch point and the take-off item
climbs out to the plan's start (or, spiralling up over the launch, to the clearance, then
loiters up).  Landing (``plan.landing``): a ``DO_LAND_START`` (189) item at the approach fix
before the fix's own item, and a ``NAV_LAND`` (21) item at the touchdown point, param 1 the
go-around height above it.

Danger zones become exclusion geofences in the ``.plan``: cylinders as ``circles``, polygon zones as
``polygons`` (QGroundControl's ``{"inclusion": false, "polygon": [[lat, lon], ...], "version": 1}``,
one per part; the geofence has no holes, so a hole is left out of the exclusion, the safe side).
Geofences are 2D: a zone's floor and top are not part of them.  The GeoJSON carries the path, the
waypoints and every danger zone as a polygon (see :func:`terrain.zone_file.zone_feature`).  These
exports need a georeferenced map (lon/lat).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Literal

import numpy as np

from planner.mission import Mission
from terrain.atomic import atomic_output
from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrain.zone_file import zone_feature
from terrain.zones import OUTSIDE_FENCE_ID, DangerZone

AltFrame = Literal["amsl", "relative"]
MAV_FRAME_GLOBAL = 0
MAV_FRAME_GLOBAL_RELATIVE_ALT = 3
MAV_CMD_NAV_WAYPOINT = 16
MAV_CMD_NAV_TAKEOFF = 22
MAV_CMD_NAV_LOITER_TO_ALT = 31
MAV_CMD_NAV_LAND = 21
MAV_CMD_DO_LAND_START = 189
MAV_TYPE_FIXED_WING = 1
MAV_TYPE_QUADROTOR = 2
MAV_AUTOPILOT_PX4 = 12
QGC_ALT_MODE = {"relative": 1, "amsl": 2}


def _geo(mission: Mission, grid: HeightGrid) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if not grid.is_georeferenced:
        raise InputError(
            "GeoJSON, .plan and WPL exports need lon/lat, but this map has no CRS (local metres)"
        )
    w = mission.waypoints
    lon, lat = grid.to_lonlat(w[:, 0], w[:, 1])
    return np.asarray(lon), np.asarray(lat), w[:, 2].copy()


def _hover(mission: Mission) -> bool:
    """Whether the mission was planned for a multirotor (its plan's vehicle limits say so)."""
    limits = (mission.plan or {}).get("vehicle_limits")
    return isinstance(limits, dict) and bool(limits.get("hover"))


def _frame(frame: str) -> AltFrame:
    if frame not in ("amsl", "relative"):
        raise InputError(f"altitude frame must be 'amsl' or 'relative'; got {frame!r}")
    return frame  # type: ignore[return-value]


def _ground_under_start(mission: Mission, grid: HeightGrid) -> float:
    """The terrain height (m AMSL) under waypoint 0: the launch point, home for the autopilot.
    Launched from the ground (``plan.takeoff``), the ground the plan launched from -- its launch
    point less the launch height, on the planner's safety heights (on a coarse DEM the highest
    measured value round the cell, up to 100 m above the bilinear surface on RMNP's 233 m
    cells) -- so that home, the take-off and a relative frame agree with the plan."""
    from planner.launch import LAUNCH_HEIGHT

    takeoff = (mission.plan or {}).get("takeoff")
    if isinstance(takeoff, dict) and isinstance(takeoff.get("launch"), list | tuple):
        return float(takeoff["launch"][2]) - LAUNCH_HEIGHT
    w = mission.waypoints
    ground = float(np.asarray(grid.height_at(w[0, 0], w[0, 1])).reshape(-1)[0])
    if not math.isfinite(ground):
        raise InputError(
            f"no terrain height under the start ({w[0, 0]:.1f}, {w[0, 1]:.1f}); "
            "home is placed on the ground there"
        )
    return ground


def to_geojson(mission: Mission, grid: HeightGrid) -> dict[str, Any]:
    """A FeatureCollection: the path as a LineString [lon, lat, alt AMSL], waypoints as Points,
    then each danger zone as a Polygon (cylinders as their circumscribed 72-gon) with properties
    ``id``, ``kind``, ``floor``, ``top`` (metres AMSL, null when unset) and ``diameter`` for
    cylinders; lon/lat rings closed, exteriors counter-clockwise (RFC 7946)."""
    lon, lat, alt = _geo(mission, grid)
    ground = grid.height_at(mission.waypoints[:, 0], mission.waypoints[:, 1])
    coords = [
        [round(float(a), 8), round(float(b), 8), round(float(c), 2)]
        for a, b, c in zip(lon, lat, alt, strict=True)
    ]
    features: list[dict[str, Any]] = [
        {
            "type": "Feature",
            "geometry": {"type": "LineString", "coordinates": coords},
            "properties": {"name": mission.name, "altitude": "metres AMSL", **_provenance(mission)},
        }
    ]
    for i, (c, g) in enumerate(zip(coords, ground, strict=True)):
        features.append(
            {
                "type": "Feature",
                "geometry": {"type": "Point", "coordinates": c},
                "properties": {"index": i, "alt_amsl": c[2], "alt_agl": round(float(c[2] - g), 2)},
            }
        )
    for zone in mission.danger_zones:
        features.append(zone_feature(zone, grid, circles="polygons", digits=8))
    return {"type": "FeatureCollection", "features": features}


def _provenance(mission: Mission) -> dict[str, Any]:
    plan = mission.plan or {}
    return {k: plan[k] for k in ("algorithm", "seed", "feasible") if k in plan}


def _items(
    mission: Mission, grid: HeightGrid, home: float, frame: AltFrame
) -> list[tuple[int, float, float, float, float, float, float]]:
    """The mission items (command, param 1, param 2, param 4, lat, lon, altitude in ``frame``,
    2 decimals, relative to the rounded ``home``): take-off to waypoint 0, waypoints, and a
    loiter-to-altitude after each waypoint with a spiral (module docstring)."""
    from planner.spiral import centre

    lon, lat, alt = _geo(mission, grid)
    base = 0.0 if frame == "amsl" else home
    spirals = {s.at: s for s in mission.spirals}
    radius = float(mission.turn_radius or 0.0)
    # launched from the ground (planner.launch): waypoint 0 is the launch point, home; the
    # take-off item climbs out to waypoint 1, the plan's start
    launched = "takeoff" in (mission.plan or {})
    landing = (mission.plan or {}).get("landing")
    last = len(alt) - 1
    first = 1 if launched and 0 not in spirals else 0
    out = []
    for i in range(first, len(alt)):
        sp = spirals.get(i)
        arrive = float(alt[i]) if sp is None else sp.entry
        if launched and i == 0 and sp is not None:
            # spiralling up over the launch: take off to the clearance, loiter up from there
            clear = float((mission.plan or {}).get("clearance", 0.0) or 0.0)
            arrive = min(sp.entry + clear, float(alt[0]))
        cmd = MAV_CMD_NAV_TAKEOFF if i == first else MAV_CMD_NAV_WAYPOINT
        p1 = 15.0 if i == first and not _hover(mission) else 0.0  # take-off: minimum pitch
        if isinstance(landing, dict) and i == last - 1:
            # the landing sequence starts at the approach fix
            out.append((MAV_CMD_DO_LAND_START, 0.0, 0.0, 0.0, float(lat[i]), float(lon[i]), 0.0))
        if isinstance(landing, dict) and i == last:
            # touch down; param 1 the go-around (abort) height above the touchdown point
            cmd = MAV_CMD_NAV_LAND
            p1 = round(float(landing.get("go_around_altitude", arrive)) - arrive, 2)
        out.append((cmd, p1, 0.0, 0.0, float(lat[i]), float(lon[i]), round(arrive - base, 2)))
        if sp is not None:
            c = centre(mission.waypoints, sp, radius or sp.radius)
            clon, clat = grid.to_lonlat(c[0], c[1])
            signed = sp.radius if sp.clockwise else -sp.radius
            out.append(
                (
                    MAV_CMD_NAV_LOITER_TO_ALT,
                    1.0,
                    round(signed, 2),
                    1.0,
                    float(np.asarray(clat).reshape(-1)[0]),
                    float(np.asarray(clon).reshape(-1)[0]),
                    round(float(alt[i]) - base, 2),
                )
            )
    return out


def _geofence(mission: Mission, grid: HeightGrid) -> dict[str, Any]:
    """QGroundControl's geoFence: cylinders as exclusion circles, polygon parts as exclusion
    polygons (exterior rings, [lat, lon] vertices, not closed); the zone outside an imported
    plan's inclusion fences (:data:`~terrain.zones.OUTSIDE_FENCE_ID`) as inclusion polygons."""
    circles: list[dict[str, Any]] = []
    polygons: list[dict[str, Any]] = []
    for z in mission.danger_zones:
        if isinstance(z, DangerZone):
            lo, la = grid.to_lonlat(z.x, z.y)
            circles.append(
                {
                    "circle": {
                        "center": [round(float(la), 8), round(float(lo), 8)],
                        "radius": z.radius,
                    },
                    "inclusion": False,
                    "version": 1,
                }
            )
            continue
        # the zone outside an imported plan's inclusion fences goes back as those fences
        keep_in = z.id == OUTSIDE_FENCE_ID
        rings = [r for part in z.parts for r in part[1:]] if keep_in else z.outline()
        for ring in rings:
            ring = np.asarray(ring, dtype=np.float64)
            rlon, rlat = grid.to_lonlat(ring[:, 0], ring[:, 1])
            polygon = [
                [round(float(b), 8), round(float(a), 8)]
                for a, b in zip(np.atleast_1d(rlon), np.atleast_1d(rlat), strict=True)
            ]
            polygons.append({"inclusion": keep_in, "polygon": polygon, "version": 1})
    return {"circles": circles, "polygons": polygons, "version": 2}


def to_qgc_plan(mission: Mission, grid: HeightGrid, frame: str = "amsl") -> dict[str, Any]:
    """A QGroundControl plan (fileType "Plan", version 1, mission version 2): home on the ground
    under the start, then one item per waypoint (take-off to waypoint 0, then waypoints)."""
    frame_ = _frame(frame)
    lon, lat, _ = _geo(mission, grid)
    home_alt = round(_ground_under_start(mission, grid), 2)
    mav_frame = MAV_FRAME_GLOBAL if frame_ == "amsl" else MAV_FRAME_GLOBAL_RELATIVE_ALT
    items = []
    for i, (cmd, p1, p2, p4, la, lo, a) in enumerate(_items(mission, grid, home_alt, frame_)):
        items.append(
            {
                "AMSLAltAboveTerrain": None,
                "Altitude": a,
                "AltitudeMode": QGC_ALT_MODE[frame_],
                "autoContinue": True,
                "command": cmd,
                "doJumpId": i + 1,
                "frame": mav_frame,
                "params": [
                    p1,
                    p2,
                    0,
                    p4 if cmd == MAV_CMD_NAV_LOITER_TO_ALT else None,
                    round(la, 8),
                    round(lo, 8),
                    a,
                ],
                "type": "SimpleItem",
            }
        )
    return {
        "fileType": "Plan",
        "version": 1,
        "groundStation": "terrapath",
        "geoFence": _geofence(mission, grid),
        "rallyPoints": {"points": [], "version": 2},
        "mission": {
            "version": 2,
            "firmwareType": MAV_AUTOPILOT_PX4,
            "vehicleType": MAV_TYPE_QUADROTOR if _hover(mission) else MAV_TYPE_FIXED_WING,
            "cruiseSpeed": mission.cruise_speed,
            "hoverSpeed": 5,
            "globalPlanAltitudeMode": QGC_ALT_MODE[frame_],
            "plannedHomePosition": [round(float(lat[0]), 8), round(float(lon[0]), 8), home_alt],
            "items": items,
        },
    }


def to_wpl(mission: Mission, grid: HeightGrid, frame: str = "amsl") -> str:
    """``QGC WPL 110`` text: item 0 is home on the ground under the start (AMSL), then one item
    per waypoint in ``frame`` (take-off to waypoint 0, then waypoints)."""
    frame_ = _frame(frame)
    lon, lat, _ = _geo(mission, grid)
    home_alt = round(_ground_under_start(mission, grid), 2)
    mav_frame = MAV_FRAME_GLOBAL if frame_ == "amsl" else MAV_FRAME_GLOBAL_RELATIVE_ALT
    lines = ["QGC WPL 110"]
    row = "{i}\t{cur}\t{fr}\t{cmd}\t{p1:g}\t{p2:g}\t0\t{p4:g}\t{lat:.8f}\t{lon:.8f}\t{alt:.2f}\t1"
    lines.append(
        row.format(
            i=0,
            cur=1,
            fr=MAV_FRAME_GLOBAL,
            cmd=MAV_CMD_NAV_WAYPOINT,
            p1=0,
            p2=0,
            p4=0,
            lat=lat[0],
            lon=lon[0],
            alt=home_alt,
        )
    )
    for i, (cmd, p1, p2, p4, la, lo, a) in enumerate(_items(mission, grid, home_alt, frame_)):
        lines.append(
            row.format(
                i=i + 1, cur=0, fr=mav_frame, cmd=cmd, p1=p1, p2=p2, p4=p4, lat=la, lon=lo, alt=a
            )
        )
    return "\n".join(lines) + "\n"


def write_json(data: dict[str, Any], path: str | Path) -> Path:
    out = Path(path)
    with atomic_output(out) as tmp:
        tmp.write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")
    return out


def write_text(text: str, path: str | Path) -> Path:
    out = Path(path)
    with atomic_output(out) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return out
