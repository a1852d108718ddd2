"""Mission exports for other tools: GeoJSON (WGS84), QGroundControl ``.plan`` and ``QGC WPL 110``.

Altitude frames are explicit and never mixed within one file:

- ``amsl``: every item in MAV_FRAME_GLOBAL (0), altitudes metres above mean sea level
  (QGroundControl ``AltitudeMode`` 2, "absolute");
- ``relative``: every item in MAV_FRAME_GLOBAL_RELATIVE_ALT (3), altitudes relative to the home
  position (the first waypoint), QGroundControl ``AltitudeMode`` 1.

The first waypoint is home (``plannedHomePosition`` / WPL item 0, always AMSL as both formats
require); the aircraft is fixed-wing, so the first mission item is a ``NAV_TAKEOFF`` (22) to the
second waypoint's altitude, then ``NAV_WAYPOINT`` (16) items. Danger zones become exclusion
geofence circles in the ``.plan``. These exports need a georeferenced map (lon/lat).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Literal

import numpy as np

from planner.mission import Mission
from terrain.atomic import atomic_output
from terrain.errors import InputError
from terrain.grid import HeightGrid

AltFrame = Literal["amsl", "relative"]
MAV_FRAME_GLOBAL = 0
MAV_FRAME_GLOBAL_RELATIVE_ALT = 3
MAV_CMD_NAV_WAYPOINT = 16
MAV_CMD_NAV_TAKEOFF = 22
MAV_TYPE_FIXED_WING = 1
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


def _frame(frame: str) -> AltFrame:
    if frame not in ("amsl", "relative"):
        raise InputError(f"altitude frame must be 'amsl' or 'relative'; got {frame!r}")
    return frame  # type: ignore[return-value]


def to_geojson(mission: Mission, grid: HeightGrid) -> dict[str, Any]:
    """A FeatureCollection: the path as a LineString [lon, lat, alt AMSL], waypoints as Points."""
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
    return {"type": "FeatureCollection", "features": features}


def _provenance(mission: Mission) -> dict[str, Any]:
    plan = mission.plan or {}
    return {k: plan[k] for k in ("algorithm", "seed", "feasible") if k in plan}


def to_qgc_plan(mission: Mission, grid: HeightGrid, frame: str = "amsl") -> dict[str, Any]:
    """A QGroundControl plan (fileType "Plan", version 1, mission version 2)."""
    frame_ = _frame(frame)
    lon, lat, alt = _geo(mission, grid)
    home_alt = float(alt[0])
    mav_frame = MAV_FRAME_GLOBAL if frame_ == "amsl" else MAV_FRAME_GLOBAL_RELATIVE_ALT
    items = []
    for i in range(1, len(alt)):
        a = float(alt[i]) if frame_ == "amsl" else float(alt[i]) - home_alt
        a = round(a, 2)
        cmd = MAV_CMD_NAV_TAKEOFF if i == 1 else MAV_CMD_NAV_WAYPOINT
        p1 = 15.0 if cmd == MAV_CMD_NAV_TAKEOFF else 0.0  # takeoff: minimum pitch (deg)
        items.append(
            {
                "AMSLAltAboveTerrain": None,
                "Altitude": a,
                "AltitudeMode": QGC_ALT_MODE[frame_],
                "autoContinue": True,
                "command": cmd,
                "doJumpId": i,
                "frame": mav_frame,
                "params": [p1, 0, 0, None, round(float(lat[i]), 8), round(float(lon[i]), 8), a],
                "type": "SimpleItem",
            }
        )
    circles = []
    if mission.danger_zones:
        zx = [z.x for z in mission.danger_zones]
        zy = [z.y for z in mission.danger_zones]
        zlon, zlat = grid.to_lonlat(zx, zy)
        for z, lo, la in zip(
            mission.danger_zones, np.atleast_1d(zlon), np.atleast_1d(zlat), strict=True
        ):
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
    return {
        "fileType": "Plan",
        "version": 1,
        "groundStation": "terrapath",
        "geoFence": {"circles": circles, "polygons": [], "version": 2},
        "rallyPoints": {"points": [], "version": 2},
        "mission": {
            "version": 2,
            "firmwareType": MAV_AUTOPILOT_PX4,
            "vehicleType": MAV_TYPE_FIXED_WING,
            "cruiseSpeed": mission.cruise_speed,
            "hoverSpeed": 5,
            "globalPlanAltitudeMode": QGC_ALT_MODE[frame_],
            "plannedHomePosition": [
                round(float(lat[0]), 8),
                round(float(lon[0]), 8),
                round(home_alt, 2),
            ],
            "items": items,
        },
    }


def to_wpl(mission: Mission, grid: HeightGrid, frame: str = "amsl") -> str:
    """``QGC WPL 110`` text: item 0 is home (AMSL), then takeoff and waypoints in ``frame``."""
    frame_ = _frame(frame)
    lon, lat, alt = _geo(mission, grid)
    mav_frame = MAV_FRAME_GLOBAL if frame_ == "amsl" else MAV_FRAME_GLOBAL_RELATIVE_ALT
    lines = ["QGC WPL 110"]
    row = "{i}\t{cur}\t{fr}\t{cmd}\t{p1}\t0\t0\t0\t{lat:.8f}\t{lon:.8f}\t{alt:.2f}\t1"
    lines.append(
        row.format(
            i=0,
            cur=1,
            fr=MAV_FRAME_GLOBAL,
            cmd=MAV_CMD_NAV_WAYPOINT,
            p1=0,
            lat=lat[0],
            lon=lon[0],
            alt=alt[0],
        )
    )
    for i in range(1, len(alt)):
        a = alt[i] if frame_ == "amsl" else alt[i] - alt[0]
        cmd = MAV_CMD_NAV_TAKEOFF if i == 1 else MAV_CMD_NAV_WAYPOINT
        lines.append(
            row.format(
                i=i,
                cur=0,
                fr=mav_frame,
                cmd=cmd,
                p1=15 if i == 1 else 0,
                lat=lat[i],
                lon=lon[i],
                alt=a,
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
