"""Regression on real maps against tests/golden/plans.json (see tests/golden/README.md)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from planner.plan import plan
from tests.golden.scenarios import GOLDEN, SCENARIOS, SEEDS

GOLD = json.loads(GOLDEN.read_text())


@pytest.mark.parametrize("scenario", SCENARIOS, ids=lambda s: s.name)
def test_scenario_matches_golden(scenario) -> None:  # type: ignore[no-untyped-def]
    gold = GOLD[scenario.name]
    problem = scenario.problem()
    costs, feasible = [], 0
    for seed in SEEDS:
        r = plan(
            problem,
            scenario.algorithm,
            seed=seed,
            population=scenario.population,
            iterations=scenario.iterations,
        )
        costs.append(r.terms["total"])
        path = r.waypoints
        np.testing.assert_array_equal(path[0], problem.start)
        np.testing.assert_array_equal(path[-1], problem.goal)
        lo, hi = problem.bounds()
        inner = path[1:-1].ravel()
        assert ((inner >= lo) & (inner <= hi)).all()
        if r.feasible:
            feasible += 1
            assert r.terms["below_terrain_m"] == 0.0 and r.terms["collision"] == 0.0
            if scenario.avoid_zones:
                assert r.terms["inside_zones_m"] == 0.0
        else:
            assert r.violations and r.terms["total"] > 3.0
    assert feasible >= gold["feasible"]
    assert np.mean(costs) == pytest.approx(gold["mean_cost"], rel=0.03)
