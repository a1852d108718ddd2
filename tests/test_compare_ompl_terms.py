"""``PlanningProblem.polyline_terms``: the cost of a polyline with any number of vertices (another
planner's path, benchmarks/compare_ompl.py), the same as ``terms`` for the same waypoints."""

from __future__ import annotations

import numpy as np
import pytest

from planner.cost import CostTerms
from planner.performance import Performance
from planner.problem import PlanningProblem
from terrain.errors import InputError
from terrain.zones import DangerZone
from tests.conftest import make_grid

PERF = Performance("test", 25.0, 5.0, 3.0, 30.0)  # R = 143.2 m, climb 16 %, descent 9.6 %


def _problem(performance: Performance | None) -> PlanningProblem:
    # 60 x 80 cells of 30 m: a 250 m ridge across the middle, a zone on the straight line
    h = np.zeros((60, 80), np.float32)
    h[:, 38:42] = 250.0
    grid = make_grid(h)
    x0, y0 = 400000.0, 3800000.0
    return PlanningProblem(
        grid,
        start=np.array([x0 + 150.0, y0 - 900.0, 200.0]),
        goal=np.array([x0 + 2250.0, y0 - 900.0, 220.0]),
        n_waypoints=4,
        zones=(DangerZone(x0 + 600.0, y0 - 900.0, 200.0),),
        clearance=20.0,
        avoid_zones=True,
        performance=performance,
        smoothness=0.5,
    )


def _rows(t: CostTerms, i: int) -> dict[str, float]:
    return t.row(i)


@pytest.mark.parametrize("performance", [None, PERF])
def test_polyline_terms_equal_terms_of_the_same_waypoints(performance: Performance | None) -> None:
    problem = _problem(performance)
    rng = np.random.default_rng(3)
    x = problem.corridor_population(5, rng)
    x[0] = problem.straight_seeds()[0]  # the straight line: length term 0
    expected = problem.terms(x)
    polylines = problem.paths(x)
    assert polylines.shape == (5, problem.n_waypoints + 2, 3)
    got = problem.polyline_terms(polylines)
    for i in range(5):
        assert _rows(got, i) == pytest.approx(_rows(expected, i))
        one = problem.polyline_terms(polylines[i])  # a single (W, 3) polyline
        assert _rows(one, 0) == pytest.approx(_rows(expected, i))
    assert expected.length[0] == pytest.approx(0.0, abs=1e-12)


def test_polyline_terms_of_any_number_of_vertices() -> None:
    problem = _problem(None)
    s, g = problem.start, problem.goal
    # the straight start-goal line as 2 and as 9 vertices: the same cost (no fillets without a
    # performance, no turns on a straight line)
    two = np.stack([s, g])
    nine = s + np.linspace(0.0, 1.0, 9)[:, None] * (g - s)
    a, b = problem.polyline_terms(two), problem.polyline_terms(nine)
    assert _rows(a, 0) == pytest.approx(_rows(b, 0))
    assert a.length[0] == pytest.approx(0.0, abs=1e-12)
    assert a.collision[0] > 3.0  # through the ridge
    assert a.dangerzones[0] > 3.0  # and through the zone
    # a detour round the zone and over the ridge: longer, feasible
    over = np.array(
        [s, [s[0] + 900.0, s[1] + 300.0, 300.0], [g[0] - 900.0, g[1] + 300.0, 300.0], g]
    )
    t = problem.polyline_terms(over)
    assert t.length[0] > 0.0
    assert bool(problem.feasible(t)[0])


def test_polyline_terms_refuse_a_bad_shape() -> None:
    problem = _problem(None)
    with pytest.raises(InputError, match="polylines must have shape"):
        problem.polyline_terms(np.zeros((1, 3)))
    with pytest.raises(InputError, match="polylines must have shape"):
        problem.polyline_terms(np.zeros((4, 2)))
