"""Seed 003's priority loop on real maps (issue 19): the Prague buildings of momepy's Bubeneč over
their 1 m terrain, and a ridge of the Jacksboro Fault DEM, each crossed from one side to the
other with only the rangefinders' ray casts to see by."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
BUBENEC = ROOT / "data" / "scenarios" / "priority-bubenec-mission.yaml"
BUILDINGS = ROOT / "data" / "scenarios" / "bubenec-buildings.yaml"
TAU = 2.0  # the avoider's default tolerance


def _path_length(positions: np.ndarray) -> float:
    """The flown length in 3-D (the metrics' ``flown_length_m``: the climb or descent counts)."""
    return float(np.linalg.norm(np.diff(positions[:, :3], axis=0), axis=1).sum())


def test_bubenec_buildings_are_crossed_keeping_tau() -> None:
    """South of the block b53-b63 to the street on its far side, 203 m apart, at 5 m above the
    higher ground (221.8 m, under every roof of the block): reached, no building within tau
    (closest b59, 3.6 m), 9 set-points, 125 s, 270 m flown (1.33 x the straight line)."""
    from replay.run import ReplayRequest, run_replay

    r: Any = run_replay(
        ReplayRequest(
            source=str(BUBENEC),
            threats=str(BUILDINGS),
            avoid="priority",
            sensor="rangefinder",
            avoid_options={"above_m": 5.0},
        )
    )
    m = r.metrics
    assert m.end_reason == "goal" and m.success and not m.terrain_contact, m.as_dict()
    assert not m.violations
    assert len(m.min_separation) == 143
    assert min(v["value"] for v in m.min_separation.values()) >= TAU
    s = np.asarray(r.decisions[-1]["setpoints"], dtype=np.float64)
    assert s[0, 2] == pytest.approx(216.77 + 5.0, abs=0.01)  # the start's ground + above_m
    assert 2 <= len(s) <= 12
    late = r.times > 20.0
    assert np.abs(r.positions[late, 2] - s[0, 2]).max() < 0.5  # level under the roofs
    assert 250.0 <= m.flown_length_m <= 300.0
    assert m.flown_length_m == pytest.approx(_path_length(r.positions), rel=0.02)
    # the far side: within the flight stack's arrival distance of the target
    assert np.hypot(*(r.positions[-1, :2] - (-743855.0, -1041170.0))) <= 4.0
