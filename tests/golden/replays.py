"""Golden end-to-end runs: each reference map's golden AMPSO plan (``scenarios.py``), flown with a
fixed pop-up threat set by each avoider; the outcome recorded in ``replays.json``.

The threats of a map are placed on its planned path (the waypoint polyline, at the cruise speed
from the start: the undisturbed timeline):

- ``sphere``: a static threat at 35 % of the path, at the path's altitude there;
- ``cylinder``: a cylinder at 70 %, from the ground to 500 m above the path;
- ``crosser``: an intruder at 15 m/s crossing the path at right angles at 55 %, timed to meet
  the undisturbed aircraft there (it appears 150 s before and goes 150 s after);

radius 500 m, or 6 % of the path on a short one; the static ones pop up when the undisturbed
aircraft is 3 km from them.  The aircraft flies with the radar (10 km, 1 Hz) and terrain following
as planned.

Regenerate (only when a change is meant to move these figures; say why in the commit):
``.venv/bin/python -m tests.golden.regen --replays``
"""

from __future__ import annotations

from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from tests.golden.scenarios import MAPS, MapScenario

GOLDEN_REPLAYS = Path(__file__).resolve().parent / "replays.json"
AVOIDERS = ("none", "pso-ca", "ctga")
SEED = 0
# what a change may move without being a regression (the test states them)
TOL_PLR = 0.02  # relative
TOL_SEPARATION = (25.0, 0.10)  # metres or relative, whichever is larger
TOL_WAYPOINTS = 1
TOL_FLIGHT = 0.02  # relative


@cache
def mission_of(scenario: MapScenario) -> Any:
    """The golden AMPSO plan of the map as a mission."""
    from planner.pipeline import to_mission

    prepared = scenario.prepared()
    result = scenario.run("ampso", prepared.problem)
    return to_mission(scenario.request("ampso"), prepared, result)


def _along(wps: np.ndarray, frac: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The point at ``frac`` of the polyline's length, the unit direction there, and the
    distance from the start."""
    seg = np.diff(wps, axis=0)
    lengths = np.linalg.norm(seg[:, :2], axis=1)
    target = frac * lengths.sum()
    k = int(np.searchsorted(np.cumsum(lengths), target))
    k = min(k, len(seg) - 1)
    before = lengths[:k].sum()
    u = (target - before) / lengths[k]
    p = wps[k] + u * seg[k]
    d = seg[k, :2] / lengths[k]
    return p, d, target


def threat_records(mission: Any) -> list[dict[str, Any]]:
    wps = np.asarray(mission.waypoints, dtype=np.float64)
    speed = float(mission.cruise_speed)
    total = float(np.linalg.norm(np.diff(wps[:, :2], axis=0), axis=1).sum())
    radius = min(500.0, 0.06 * total)
    p1, _, s1 = _along(wps, 0.35)
    p2, _, s2 = _along(wps, 0.70)
    p3, d3, s3 = _along(wps, 0.55)
    t_meet = s3 / speed
    across = np.array([-d3[1], d3[0], 0.0]) * 15.0
    lead = 150.0
    return [
        {
            "id": "sphere",
            "kind": "static",
            "position": [float(p1[0]), float(p1[1]), float(p1[2])],
            "radius": radius,
            "appears_at": max(0.0, (s1 - 3000.0) / speed),
        },
        {
            "id": "cylinder",
            "kind": "cylinder",
            "center": [float(p2[0]), float(p2[1])],
            "radius": radius,
            "top": float(p2[2]) + 500.0,
            "appears_at": max(0.0, (s2 - 3000.0) / speed),
        },
        {
            "id": "crosser",
            "kind": "intruder",
            "position": [float(v) for v in (p3 - across * lead)],
            "velocity": [float(v) for v in across],
            "radius": radius,
            "appears_at": max(0.0, t_meet - lead),
            "disappears_at": t_meet + lead,
        },
    ]


def fly(scenario: MapScenario, avoid: str) -> dict[str, Any]:
    """The golden figures of one flight."""
    from replay.run import ReplayRequest, run_replay
    from replay.threats.file import threats_from_records

    prepared = scenario.prepared()
    mission = mission_of(scenario)
    threats = threats_from_records(
        threat_records(mission), prepared.grid, name=f"golden-{scenario.name}"
    )
    mission_file = _mission_file(scenario)
    result = run_replay(
        ReplayRequest.of(
            str(mission_file), threats=threats, avoid=avoid, seed=SEED, terrain_mesh=False
        )
    )
    m = result.metrics
    return {
        "success": bool(m.success),
        "end_reason": m.end_reason,
        "min_separation": {k: v["value"] for k, v in m.min_separation.items()},
        "plr": float(m.plr),
        "waypoints_added": int(m.waypoints_added),
        "flight_time_s": float(m.flight_time_s),
        "min_terrain_clearance_m": float(m.min_terrain_clearance_m),
        "off_map_s": float(m.off_map_s),
    }


@cache
def _mission_file(scenario: MapScenario) -> Path:
    """The mission written where the replay reads it (a temporary folder per process)."""
    import tempfile

    from planner.mission import save_mission

    folder = Path(tempfile.mkdtemp(prefix="terrapath-golden-"))
    path = folder / f"{scenario.name}.yaml"
    save_mission(mission_of(scenario), path)
    return path


CASES = [(sc, av) for sc in MAPS for av in AVOIDERS]

__all__ = ["AVOIDERS", "CASES", "GOLDEN_REPLAYS", "fly", "threat_records"]
