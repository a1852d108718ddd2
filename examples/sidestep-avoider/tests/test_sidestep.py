"""The sidestep plugin under terrapath's avoider contract (terrapath.testing): the four static
scenarios it promises. The two intruder scenarios are reported as skipped: it treats a moving
threat as where it is now, which the contract's intruders defeat. On the reference maps it is
held to its own baseline (reference-baseline.json beside this file, written by ``terrapath
regress --avoid sidestep --case rmnp --case jacksboro --baseline tests/reference-baseline.json
--update-baseline``): it fails both -- the crossing intruder is entered -- and must not do worse."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from terrapath.testing import AvoiderContract, ReferenceContract
from terrapath.testing.avoider import STATIC_SCENARIOS, STRAIGHT


class TestSidestep(AvoiderContract):
    avoider = "sidestep"
    scenarios = STATIC_SCENARIOS


class TestSidestepOnTheMaps(ReferenceContract):
    avoider = "sidestep"
    baseline = Path(__file__).with_name("reference-baseline.json")


def test_on_the_path_puts_its_obstacles_on_the_legs() -> None:
    from planner.mission import mission_from_dict
    from replay.campaign.generators import Params, threat_generator

    make = threat_generator("on-the-path")  # found by its entry point, as a campaign finds it
    assert make is not None
    mission = mission_from_dict(
        {"terrapath": 1, "name": "m", "crs": "local", "waypoints": STRAIGHT}
    )
    records = make(mission, 5, np.random.default_rng(1), Params(radius=500.0))
    assert [r["id"] for r in records] == [f"path{k}" for k in range(1, 6)]
    for r in records:
        x, y, _ = r["position"]
        assert 0.0 < x < 40000.0 and y == 0.0 and r["radius"] == 500.0
