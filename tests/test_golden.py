"""Regression on real maps against tests/golden/plans.json (see tests/golden/README.md)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.golden.scenarios import ALGORITHMS, GOLDEN, MAPS

GOLD = json.loads(GOLDEN.read_text())
CASES = [(sc, alg) for sc in MAPS for alg in ALGORITHMS]


@pytest.mark.parametrize(("scenario", "algorithm"), CASES, ids=[f"{s.name}-{a}" for s, a in CASES])
def test_plan_matches_golden(scenario, algorithm: str) -> None:  # type: ignore[no-untyped-def]
    if not scenario.available():
        pytest.skip(f"{scenario.dem} not found")
    gold = GOLD[f"{scenario.name}/{algorithm}"]
    problem = scenario.problem()
    r = scenario.run(algorithm, problem)
    path = r.waypoints
    np.testing.assert_array_equal(path[0], problem.start)  # starts and ends where asked
    np.testing.assert_array_equal(path[-1], problem.goal)
    lo, hi = problem.bounds()
    inner = path[1:-1].ravel()
    assert ((inner >= lo) & (inner <= hi)).all()
    assert r.status == gold["status"]
    if gold["status"] == "feasible":
        assert r.terms["below_terrain_m"] == 0.0 and r.terms["collision"] == 0.0
        assert r.terms["inside_zones_m"] == 0.0  # zones are hard constraints here
        assert r.terms["min_clearance_m"] > 0.0  # clear of the real (bilinear) surface
        # a straight climb fits every reference scenario: no spiral (issue 33), and the path
        # is longer than the least its climb and descent need
        assert r.spirals == () and r.terms["length_over_bound"] > 1.0
    else:
        assert r.violations and r.terms["total"] > 3.0
    assert r.terms["total"] == pytest.approx(gold["cost"], rel=0.03)


def test_golden_records_every_map_and_algorithm() -> None:
    assert set(GOLD) == {f"{s.name}/{a}" for s in MAPS for a in ALGORITHMS}
    # every algorithm finds a feasible path on every reference map with the plan defaults
    assert all(g["status"] == "feasible" for g in GOLD.values())
