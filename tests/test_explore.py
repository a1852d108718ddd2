"""The global exploration stage before the swarm (issue 20, ``planner/explore.py``): routes over
the whole map, distinct and valid, turned into waypoint vectors that seed the population."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planner.explore import explore, explore_pool, graph_population
from planner.performance import Performance
from planner.plan import plan
from planner.problem import PlanningProblem
from terrain.errors import InputError
from terrain.zones import DangerZone
from tests.conftest import make_grid

PERF = Performance("test", 25.0, 5.0, 3.0, 30.0)  # R = 143.2 m, climb 16 %, descent 9.6 %


def _wall_grid() -> tuple[np.ndarray, float]:
    """A 6 km x 6 km flat map (50 m cells) split west-east by a wall 1000 m high with two gaps:
    a narrow one 1 km east of the straight start-goal line and a wide one 2 km west of it."""
    h = np.zeros((120, 120))
    h[58:62, :] = 1000.0  # the wall, rows 58-61 (y 2.9-3.1 km)
    h[58:62, 76:80] = 0.0  # gap at x 3.8-4.0 km
    h[58:62, 10:20] = 0.0  # gap at x 0.5-1.0 km
    return h, 50.0


def _problem(**kw: object) -> PlanningProblem:
    h, cell = _wall_grid()
    grid = make_grid(h, cell=cell, x0=0.0, y0=6000.0)
    start, goal = np.array([2900.0, 500.0, 100.0]), np.array([2900.0, 5500.0, 100.0])
    opts: dict[str, object] = {"clearance": 20.0, "zmax": 400.0, "performance": PERF}
    opts.update(kw)
    return PlanningProblem(grid, start, goal, 4, **opts)  # type: ignore[arg-type]


def _gaps(routes: tuple[object, ...]) -> list[float]:
    """Where each route crosses the wall (its x at y = 3 km)."""
    out = []
    for r in routes:
        xy = r.xy  # type: ignore[attr-defined]
        out.append(float(xy[np.argmin(np.abs(xy[:, 1] - 3000.0)), 0]))
    return out


def test_routes_thread_the_gaps_of_a_wall_the_band_cannot_cross() -> None:
    """The band tops at 400 m, the wall at 1000 m: the only ways are the two gaps.  On a graph
    of 50 m blocks the shortest route takes the near gap (200 m wide: 100 m once the terrain is
    dilated by a cell), another the far one; every seed is a feasible path."""
    pr = _problem()
    e = explore(pr, 3, cells=120)
    gaps = _gaps(e.routes)
    assert 3800.0 <= gaps[0] <= 4000.0 and any(500.0 <= g <= 1000.0 for g in gaps[1:])
    assert all(3800.0 <= g <= 4000.0 or 500.0 <= g <= 1000.0 for g in gaps)
    assert [r.cost for r in e.routes] == sorted(r.cost for r in e.routes)
    terms = pr.terms(np.array([r.x for r in e.routes]))
    assert pr.feasible(terms).all(), terms.row(0)
    # on 100 m blocks the near gap falls between two blocks, each half wall: closed there
    assert all(500.0 <= g <= 1000.0 for g in _gaps(explore(pr, 3, cells=60).routes))


def test_the_pool_scores_routes_by_the_problem_cost_and_keeps_them_distinct() -> None:
    """Several resolutions, every route scored by the problem's cost: the best is the near gap
    (seen only by the finest graph), the others distinct by at least 5 % of the 5 km span."""
    pr = _problem()
    e = explore_pool(pr, 5)
    f = [r.f for r in e.routes]
    assert f == sorted(f) and f[0] == pytest.approx(float(pr(e.routes[0].x[None])[0]))
    gaps = _gaps(e.routes)
    assert 3800.0 <= gaps[0] <= 4000.0 and any(500.0 <= g <= 1000.0 for g in gaps)
    assert pr.feasible(pr.terms(e.routes[0].x[None]))[0]


def test_a_hard_zone_on_the_line_is_gone_round() -> None:
    """A 2 km danger zone on the straight line of an open map: the routes' seeds stay out of it
    (its margin included)."""
    grid = make_grid(np.zeros((120, 120)), cell=50.0, x0=0.0, y0=6000.0)
    zone = DangerZone(3000.0, 3000.0, 2000.0)
    pr = PlanningProblem(
        grid,
        np.array([3000.0, 500.0, 100.0]),
        np.array([3000.0, 5500.0, 100.0]),
        4,
        zones=(zone,),
        avoid_zones=True,
        zone_margin=100.0,
        clearance=20.0,
        performance=PERF,
    )
    e = explore(pr, 2)
    assert len(e.routes) == 2  # round the west side and round the east side
    sides = {bool(np.mean(r.xy[:, 0]) < 3000.0) for r in e.routes}
    assert sides == {True, False}
    terms = pr.terms(np.array([r.x for r in e.routes]))
    assert (terms.inside.sum(axis=1) == 0.0).all() and pr.feasible(terms).all()


def test_no_route_when_the_wall_is_closed_and_the_plan_says_infeasible() -> None:
    h, cell = _wall_grid()
    h[58:62, :] = 1000.0  # no gap
    grid = make_grid(h, cell=cell, x0=0.0, y0=6000.0)
    pr = PlanningProblem(
        grid,
        np.array([2900.0, 500.0, 100.0]),
        np.array([2900.0, 5500.0, 100.0]),
        4,
        clearance=20.0,
        zmax=400.0,
        performance=PERF,
    )
    assert explore(pr, 3).routes == ()
    x0, found = graph_population(pr, 20, np.random.default_rng(0))
    assert found.routes == () and x0.shape == (20, 12)  # the corridor population alone
    r = plan(pr, "ampso", seed=0, population=20, iterations=20)
    assert not r.feasible and r.params["exploration"]["routes"] == 0


def test_the_population_holds_the_routes_then_jittered_copies_then_the_corridor() -> None:
    pr = _problem()
    x0, found = graph_population(pr, 40, np.random.default_rng(1), 3, share=0.25)
    n = len(found.routes)
    for i, r in enumerate(found.routes):
        np.testing.assert_array_equal(x0[i], r.x)
    assert not np.array_equal(x0[n], found.routes[0].x)  # a copy, moved
    assert np.abs(x0[n] - found.routes[0].x).max() < 2000.0
    again, _ = graph_population(pr, 40, np.random.default_rng(1), 3, share=0.25)
    np.testing.assert_array_equal(x0, again)  # reproducible from the seed


def test_a_plan_from_the_graph_takes_the_gap_and_records_the_exploration() -> None:
    pr = _problem()
    r = plan(pr, "ampso", seed=0, population=30, iterations=60)
    assert r.feasible and r.params["init"] == "graph" and r.params["routes"] == 5
    ex = r.params["exploration"]
    assert ex["routes"] >= 1 and ex["seconds"] > 0.0
    # the seeds, each the N free waypoints of a route, recorded for the plan's picture
    assert len(ex["route_waypoints"]) == ex["routes"]
    assert all(np.shape(w) == (4, 3) for w in ex["route_waypoints"])
    path = r.path  # the flown path crosses the wall (y 2.9-3.1 km) in the near gap
    x_at_wall = np.interp(3000.0, path[:, 1], path[:, 0])
    assert 3800.0 <= x_at_wall <= 4000.0, x_at_wall
    assert r.terms["total"] <= ex["route_F"][0] + 1e-9  # refined from the best seed, never worse


def test_the_exploration_counts_what_it_kept_and_says_it_as_the_plan_prints_it() -> None:
    from planner.explore import KEEP_PLACED, PLACED, RESOLUTIONS
    from terrapath.commands.plan import explored_line

    pr = _problem()
    k = 3
    found = explore_pool(pr, k)
    ex = found.summary()
    # the candidates are every graph's routes; at most --routes of them are kept as distinct;
    # the seeds are those and the placements of the waypoints along the best of them
    assert ex["candidates"] == sum(len(explore(pr, k, cells=c).routes) for c in RESOLUTIONS)
    assert ex["graphs"] == len(RESOLUTIONS)
    assert 1 <= ex["distinct"] <= k and ex["distinct"] <= ex["candidates"]
    assert ex["routes"] == ex["distinct"] + ex["placed"] == len(found.routes)
    assert 1 <= ex["placed"] <= min(PLACED, ex["distinct"]) * KEEP_PLACED
    line = explored_line(ex, k)
    assert line == (
        f"{ex['candidates']} candidate routes on 3 graphs of the whole map in "
        f"{ex['seconds']:.2f} s, kept the {ex['distinct']} best distinct (--routes 3) and "
        f"{ex['placed']} placements of the waypoints along the best of them: {ex['routes']} "
        f"seeds for the swarm, the best at cost {ex['route_F'][0]:.4f}"
    )
    none = {**ex, "routes": 0, "candidates": 0, "distinct": 0, "placed": 0}
    assert explored_line(none, k).startswith("no route on 3 graphs of the whole map in ")
    assert explored_line(none, k).endswith(" s (start and goal unlinked)")


@pytest.mark.parametrize("k", [0, -1, 2.5, True])
def test_routes_must_be_a_positive_integer(k: object) -> None:
    with pytest.raises(InputError, match=r"number of graph routes \(--routes\) must be an integer"):
        explore(_problem(), k)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="--routes"):
        plan(_problem(), "ampso", population=10, iterations=2, routes=k)  # type: ignore[arg-type]


def test_a_soft_zone_is_gone_round_when_that_costs_less_than_crossing_it() -> None:
    """Soft zones (cost only) weigh the graph's edges by their cost term: a 2 km zone on the
    line costs up to 1 to cross, a detour round it about 0.1, so the routes go round it (their
    four-waypoint seeds cut its edge by 435 m at most, against the straight line's 2 km) and the
    plans from them stay out of it, cheaper than the corridor start's (measured 0.394-0.398
    against 0.417-0.433, seeds 0-2)."""
    grid = make_grid(np.zeros((120, 120)), cell=50.0, x0=0.0, y0=6000.0)
    pr = PlanningProblem(
        grid,
        np.array([3000.0, 500.0, 100.0]),
        np.array([3000.0, 5500.0, 100.0]),
        4,
        zones=(DangerZone(3000.0, 3000.0, 2000.0),),
        clearance=20.0,
        performance=PERF,
    )
    e = explore(pr, 2)
    assert len(e.routes) == 2 and {bool(np.mean(r.xy[:, 0]) < 3000.0) for r in e.routes} == {
        True,
        False,
    }
    terms = pr.terms(np.array([r.x for r in e.routes]))
    straight = pr.terms(np.linspace(pr.start, pr.goal, 6)[1:-1].ravel()[None])
    assert straight.inside[0, 0] == pytest.approx(2000.0)
    assert (terms.inside[:, 0] < 500.0).all() and (terms.total < straight.total[0]).all()
    for seed in (0, 1):
        graph = plan(pr, "ampso", seed=seed, population=30, iterations=60)
        corridor = plan(pr, "ampso", seed=seed, population=30, iterations=60, init="corridor")
        assert graph.terms["inside_zones_m"] == 0.0
        assert graph.terms["total"] < corridor.terms["total"]


def test_batched_chord_test_agrees_with_the_chord_sampler() -> None:
    """String pulling tests chords in batches (``_clear_chords``); each answer is the one the
    per-chord sampler gives, over the wall, through its gaps and along it."""
    from planner.explore import Chords, _clear_chords, corridor_terrain

    problem = _problem()
    heights = corridor_terrain(problem)
    rng = np.random.default_rng(4)
    p = np.array([2900.0, 500.0, 150.0])
    qs = np.column_stack(
        [rng.uniform(0, 6000, 400), rng.uniform(0, 6000, 400), rng.uniform(0, 1300, 400)]
    )
    qs[:3, :2] = [[3900.0, 5500.0], [750.0, 5000.0], [2900.0, 500.0]]  # the gaps; no extent
    got = _clear_chords(problem, p, qs, heights)
    want = [Chords(problem, np.array([p[:2], q[:2]]), heights).clear(0, p[2], q[2]) for q in qs]
    assert got.tolist() == want
    assert 50 < int(got.sum()) < 350  # both answers are exercised


def test_compiled_chord_test_is_its_numpy_twin() -> None:
    """Issue 38: the compiled ``_clear_chords`` (each chord left at its first sample below)
    answers as the numpy twin, on the wall map at a clearance of 20 m and on a random terrain
    at 0 m (chords from a corner of a cell, of no extent, along the samples' edges)."""
    from planner.explore import _clear_chords, _clear_chords_numpy, corridor_terrain

    rng = np.random.default_rng(11)
    rough = make_grid(rng.uniform(0, 100, (80, 90)), cell=30.0, x0=1000.0, y0=9000.0)
    problems = [
        _problem(),
        PlanningProblem(rough, [1100.0, 6700.0, 400.0], [3600.0, 8800.0, 400.0], 3, zmax=700.0),
    ]
    clear = total = 0
    for problem in problems:
        heights = corridor_terrain(problem)
        x0, y0, x1, y1 = problem.grid.bounds
        for p in (problem.start, np.array([x0, y1, 250.0]), np.array([x1, y0, 320.0])):
            qs = np.column_stack(
                [rng.uniform(x0, x1, 500), rng.uniform(y0, y1, 500), rng.uniform(0, 1300, 500)]
            )
            qs[0] = p
            qs[1] = p + np.array([0.0, 0.0, 50.0])
            got = _clear_chords(problem, p, qs, heights)
            assert got.tolist() == _clear_chords_numpy(problem, p, qs, heights).tolist()
            clear += int(got.sum())
            total += len(got)
    assert 0.1 < clear / total < 0.9  # both answers are exercised


def test_compiled_tree_counts_match_the_python_twin() -> None:
    from planner.explore import _along, _along_py

    rng = np.random.default_rng(9)
    n = 500
    order = rng.permutation(n)
    pred = np.full(n, -9999)
    for i, v in enumerate(order[1:], start=1):  # a random tree, parents before children
        pred[v] = order[rng.integers(0, i)]
    top = order[: n - 20]  # the last 20 unreached
    flag = rng.random(n) < 0.3
    got = _along(pred, top, flag)
    np.testing.assert_array_equal(got, _along_py(pred, top, flag))
    assert got[order[-20:]].sum() == 0 and got.max() >= 3


def test_disc_stamps_are_scipys_dilation() -> None:
    """Issue 38: the nodes near a kept route (and round the start and goal) are found by
    stamping the disc round each node; the same cells as ``scipy.ndimage.binary_dilation`` of
    their mask, for round and elongated discs and nodes at the graph's edges and corners."""
    from scipy import ndimage

    from planner.explore import _discs

    rng = np.random.default_rng(38)
    for shape, (ry, rx) in (((40, 64), (3.0, 3.0)), ((86, 160), (4.6, 2.2)), ((9, 7), (5.5, 8.0))):
        yy, xx = np.mgrid[-math.ceil(ry) : math.ceil(ry) + 1, -math.ceil(rx) : math.ceil(rx) + 1]
        disc = (yy / ry) ** 2 + (xx / rx) ** 2 <= 1.0
        n = shape[0] * shape[1]
        corners = [0, shape[1] - 1, n - shape[1], n - 1]
        nodes = np.concatenate([corners, rng.choice(n, 25, replace=False)]).astype(np.int64)
        mask = np.zeros(shape, dtype=bool)
        mask.flat[nodes] = True
        want = ndimage.binary_dilation(mask, structure=disc)
        np.testing.assert_array_equal(_discs(shape, nodes, disc), want)
        assert 0 < int(want.sum()) < n or shape == (9, 7)
