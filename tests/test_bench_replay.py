"""The obstacle generator of benchmarks/bench_replay.py (no replays here)."""

from __future__ import annotations

import numpy as np

from benchmarks import bench_replay as b
from planner.mission import load_mission
from replay.threats.file import threats_from_records


def test_distance_to_polyline() -> None:
    w = np.array([[0.0, 0.0, 100.0], [1000.0, 0.0, 100.0], [1000.0, 1000.0, 100.0]])
    d = b.distance_to_polyline([[500.0, 30.0], [-300.0, -400.0], [1200.0, 500.0], [900, 100]], w)
    np.testing.assert_allclose(d, [30.0, 500.0, 200.0, 100.0])


def test_obstacles_lie_beside_the_path_within_radar_range() -> None:
    """Every obstacle is outside its safety sphere's reach of the path (so the run with them
    flies the same path) and inside the radar's 10 km (so every one is scanned and seen)."""
    m = load_mission(b.MISSION)
    recs = b.obstacle_records(m.waypoints, 100, 13, 200.0)
    assert recs == b.obstacle_records(m.waypoints, 100, 13, 200.0)  # seeded
    assert recs != b.obstacle_records(m.waypoints, 100, 14, 200.0)
    threats = threats_from_records(recs)
    assert len(threats) == 100 and {t.kind for t in threats} == {"static"}
    xy = np.array([r["position"][:2] for r in recs])
    d = b.distance_to_polyline(xy, m.waypoints)
    assert d.min() >= b.NEAR_M - 0.1 and d.max() <= b.FAR_M + 0.1
    assert b.NEAR_M - b.OBSTACLE_RS_M >= 1000.0  # >= the 1 km corner cut of the autopilot
    assert all(r["position"][2] == 200.0 and r["radius"] == b.OBSTACLE_RS_M for r in recs)
