"""Waypoint placement along an explored route (issue 20, ``planner/placement.py``): the compiled
chord table and layered search against their numpy twins, and what the placement buys on a map
whose best path flies over ridges at their lowest points."""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
import pytest

from planner import kernels
from planner.explore import _flyable, explore_pool
from planner.performance import Performance
from planner.placement import (
    LEVELS,
    Chords,
    Lattice,
    _chord_edges_py,
    _chord_samples_numpy,
    _layered_dp_py,
    _steep_chords_numpy,
    candidates,
    chord_pairs,
    corridor_terrain,
    levels_of,
    place,
    polish,
    repair,
)
from planner.problem import PlanningProblem
from terrain.grid import block_max
from terrain.segments import below_terrain_lengths
from tests.conftest import make_grid

PERF = Performance("test", 25.0, 5.0, 3.0, 30.0)  # R = 143.2 m, climb 16 %, descent 9.6 %


def _ridges() -> np.ndarray:
    """A 12 km x 4 km map (50 m cells): ground at 0 m crossed by three north-south ridges
    600 m high, each with a saddle 250 m high 1 km wide, the saddles alternately north and
    south of the straight start-goal line, so the cheap path weaves through them."""
    h = np.zeros((80, 240))
    for col, row in ((60, 25), (120, 55), (180, 25)):
        h[:, col - 3 : col + 3] = 600.0
        h[row - 10 : row + 10, col - 3 : col + 3] = 250.0
    return h


def _problem(**kw: object) -> PlanningProblem:
    grid = make_grid(_ridges(), cell=50.0, x0=0.0, y0=4000.0)
    start, goal = np.array([500.0, 2000.0, 120.0]), np.array([11500.0, 2000.0, 120.0])
    opts: dict[str, object] = {"clearance": 30.0, "zmax": 900.0, "performance": PERF}
    opts.update(kw)
    return PlanningProblem(grid, start, goal, 6, **opts)  # type: ignore[arg-type]


def _tables(pr: PlanningProblem, block: int) -> tuple[Any, ...]:
    route = np.array([pr.start[:2], pr.goal[:2]])
    xy, station = candidates(pr, route)
    lat = Lattice(pr, corridor_terrain(pr))
    coarse = block_max(lat.floor, block, -np.inf)
    levels = levels_of(pr, xy, lat.floor, LEVELS)
    row, col = pr.grid.xy_to_index(xy[:, 0], xy[:, 1])
    rc = np.ascontiguousarray(np.column_stack([row, col]), dtype=np.float64)
    pairs = chord_pairs(pr, xy, station)[::7]  # a sample of the pairs keeps the twin quick
    args = (rc, xy, levels, coarse, block, 0.5 * block, pairs, lat.climb, lat.descent, lat.spiral)
    return args


@pytest.mark.parametrize("block", [1, 3])
def test_the_compiled_chord_table_matches_its_twin(block: int) -> None:
    """The same edges (the hull finds the same lowest clear ends as every sample) with the same
    lengths and mid altitudes, on fine and on blocked floors."""
    args = _tables(_problem(), block)
    got = kernels.chord_edges(*args)
    want = _chord_edges_py(*args)
    assert len(want[0]) > 1000
    order_g = np.lexsort((got[1], got[0]))
    order_w = np.lexsort((want[1], want[0]))
    for g, w in zip(got, want, strict=True):
        np.testing.assert_allclose(g[order_g], w[order_w], rtol=0, atol=1e-9)


def test_the_compiled_steep_chord_flags_are_their_twins() -> None:
    """Issue 38: which chords carry a helix (the search's surcharge) comes from one compiled
    pass, the numpy twin's flags exactly, on a table with steep chords and on one without."""
    for pr in (_problem(), _problem(spirals=False)):
        args = _tables(pr, 1)
        u, v, l3, _ = kernels.chord_edges(*args)
        xy, levels = args[1], args[2]
        got = kernels.steep_chords(u, v, l3, xy, levels)
        np.testing.assert_array_equal(got, _steep_chords_numpy(u, v, l3, xy, levels))
        if args[-1] > 0.0:
            assert 0 < int(got.sum()) < len(got)
        else:
            assert not got.any()


def test_chords_clear_the_floor_and_keep_the_gradients() -> None:
    """Every edge of the table, sampled finely, stays above the floor it was built on to within
    the altitude it changes over one of the kernel's samples (half a cell apart: the chord may
    clip a cell's corner between two; the seeds' finishing and repair use the exact floor), and
    climbs and descends within the gradients -- or, where the plan may spiral, is as long as
    the chord plus the helix that climbs the rest at the climb gradient in a turn."""
    pr = _problem()
    rc, xy, levels, coarse, block, step, pairs, climb, descent, spiral = _tables(pr, 1)
    assert spiral == pytest.approx(PERF.turn_climb_gradient)
    u, v, l3, zm = kernels.chord_edges(
        rc, xy, levels, coarse, block, step, pairs, climb, descent, spiral
    )
    steep = 0
    k = levels.shape[1]
    pick = np.random.default_rng(1).choice(len(u), 400, replace=False)
    for e in pick.tolist():
        a, ka, b, kb = u[e] // k, u[e] % k, v[e] // k, v[e] % k
        za, zb = levels[a, ka], levels[b, kb]
        t = np.linspace(0.0, 1.0, 400)
        p = xy[a] + t[:, None] * (xy[b] - xy[a])
        r, c = pr.grid.cell_of(p[:, 0], p[:, 1])
        m = max(2, math.ceil(float(np.hypot(*(rc[b] - rc[a]))) / step) + 1)
        slack = abs(zb - za) / (m - 1) + 1e-6
        assert np.all(za + t * (zb - za) >= coarse[r, c] - slack)
        h = float(np.hypot(*(xy[b] - xy[a])))
        excess = max(zb - za - climb * h, za - zb - descent * h, 0.0)
        steep += excess > 0
        assert l3[e] == pytest.approx(math.hypot(h, zb - za) + excess / spiral)
        assert zm[e] == pytest.approx(0.5 * (za + zb))
    assert steep > 0  # the ridges need chords steeper than the aircraft climbs
    # without spirals, every chord keeps the gradients
    rc, xy, levels, coarse, block, step, pairs, climb, descent, spiral = _tables(
        _problem(spirals=False), 1
    )
    assert spiral == 0.0
    u, v, l3, zm = kernels.chord_edges(
        rc, xy, levels, coarse, block, step, pairs, climb, descent, spiral
    )
    dz = levels.flat[v] - levels.flat[u]
    h = np.hypot(*(xy[v // levels.shape[1]] - xy[u // levels.shape[1]]).T)
    assert np.all((-descent * h - 1e-9 <= dz) & (dz <= climb * h + 1e-9))


def test_the_layered_search_matches_its_twin() -> None:
    """Random layered graphs (negative weights too): the kernel's chain costs what the dense
    twin's does, and is a chain of edges from the start through exactly ``layers`` inner states
    to the goal."""
    rng = np.random.default_rng(7)
    for _ in range(30):
        n_states, layers = 40, 4
        m = 400
        u = rng.integers(0, n_states - 1, m)
        v = rng.integers(1, n_states, m)
        w = rng.normal(1.0, 1.0, m)
        inner = np.ones(n_states, dtype=bool)
        inner[[0, n_states - 1]] = False
        chain = kernels.layered_dp(u, v, w, n_states, 0, n_states - 1, layers, inner)
        cost, want = _layered_dp_py(u, v, w, n_states, 0, n_states - 1, layers, inner)
        if want.size == 0:
            assert chain.size == 0
            continue
        assert len(chain) == layers + 2 and chain[0] == 0 and chain[-1] == n_states - 1
        assert inner[chain[1:-1]].all()
        got = 0.0
        for a, b in itertools.pairwise(chain):
            got += float(w[(u == a) & (v == b)].min())
        assert got == pytest.approx(cost, abs=1e-9)


def test_placement_weaves_through_the_saddles_lower_than_the_graph_seed() -> None:
    """The graph's seed of the route and the placement along it, scored by the problem's cost:
    the placement is feasible, flies lower on average and costs less; its waypoints cross each
    ridge within its saddle (the low way over)."""
    pr = _problem()
    heights = corridor_terrain(pr)
    ex = explore_pool(pr, 1, placed=0)
    route = ex.routes[0]
    xs = place(pr, route.xy, heights)
    assert xs
    terms = pr.terms(np.array([route.x, *xs]))
    ok = pr.feasible(terms)
    best = 1 + int(np.argmin(np.where(ok[1:], terms.total[1:], np.inf)))
    assert ok[best]
    assert terms.total[best] < terms.total[0] - 0.05, (terms.total[0], terms.total[best])
    assert terms.mean_altitude[best] < terms.mean_altitude[0]
    flown = pr.flown(pr.paths(xs[best - 1]))
    for col, row in ((60, 25), (120, 55), (180, 25)):
        x = col * 50.0
        j = int(np.argmin(np.abs(flown[:, 0] - x)))
        y_row = (4000.0 - flown[j, 1]) / 50.0
        assert row - 10 <= y_row <= row + 10, (col, y_row)


def test_explore_pool_keeps_the_placements_that_beat_the_graph() -> None:
    """With placement (the default) the first seed is a placement, cheaper than any graph seed,
    and the summary says how long the placement took."""
    pr = _problem()
    plain = explore_pool(pr, 3, placed=0)
    placed = explore_pool(pr, 3)
    assert placed.routes[0].f < min(r.f for r in plain.routes) - 0.05
    assert placed.routes[0].feasible
    assert [r.f for r in placed.routes] == sorted(r.f for r in placed.routes)
    assert 0.0 < placed.placement_s <= placed.elapsed_s
    assert placed.summary()["placement_seconds"] == round(placed.placement_s, 4)


def test_polish_lowers_the_placements_on_the_true_cost_and_keeps_them_flyable() -> None:
    """The compass search returns a point and its true cost, never above where it started; from
    this map's placements (fillets and cells the surrogate does not see) it gains, and the
    polished seeds explore_pool keeps are cheaper than the unpolished ones and pass the checks a
    plan's result must."""
    pr = _problem()
    plain = explore_pool(pr, 3, polished=0)
    done = explore_pool(pr, 3)
    x0 = plain.routes[0].x
    x, f = polish(pr, x0)
    assert f == float(pr(x[None, :])[0])
    assert f < plain.routes[0].f - 1e-3
    # explore_pool polishes the two cheapest placements: its best is at least as cheap (the
    # second may polish lower than the first)
    assert done.routes[0].f <= f + 1e-12
    assert bool(pr.feasible(pr.terms(x[None, :]))[0]) and _flyable(pr, x)
    lo, hi = pr.bounds()
    assert (x >= lo).all() and (x <= hi).all()
    # polishing a polished point again never costs more
    y, g = polish(pr, x)
    assert g <= f and polish(pr, y)[1] <= g


def test_repair_lifts_the_flown_path_over_the_floor() -> None:
    """Waypoints low in the valleys between the ridges, so the flown path (legs and fillets) runs
    into them: the repair raises only altitudes, never moves a waypoint sideways, ends with the
    flown path clear of the floor the cost checks, and leaves a clear path as it is."""
    pr = _problem()
    xy = [(2000.0, 1500.0), (4000.0, 2600.0), (5000.0, 1000.0), (7000.0, 2500.0), (8000.0, 1200.0),
          (10000.0, 2000.0)]  # fmt: skip
    x = np.array([[a, b, 150.0] for a, b in xy]).ravel()
    flown = pr.flown(pr.paths(x))
    assert below_terrain_lengths(pr.check_grid, flown[:-1], flown[1:], pr.clearance).sum() > 0.0
    fixed = repair(pr, x, corridor_terrain(pr))
    flown = pr.flown(pr.paths(fixed))
    assert below_terrain_lengths(pr.check_grid, flown[:-1], flown[1:], pr.clearance).sum() == 0.0
    np.testing.assert_array_equal(fixed.reshape(-1, 3)[:, :2], x.reshape(-1, 3)[:, :2])
    assert (fixed.reshape(-1, 3)[:, 2] >= x.reshape(-1, 3)[:, 2]).all()
    assert (fixed.reshape(-1, 3)[:, 2] <= pr.band[1]).all()
    assert np.array_equal(repair(pr, fixed, corridor_terrain(pr)), fixed)


def test_no_placement_with_a_preferred_height() -> None:
    """With --agl-pref the objective is another one: explore_pool places nothing."""
    pr = _problem(agl_pref=100.0)
    ex = explore_pool(pr, 2)
    plain = explore_pool(pr, 2, placed=0)
    assert ex.placement_s == 0.0
    assert len(ex.routes) == len(plain.routes) > 0
    for a, b in zip(ex.routes, plain.routes, strict=True):
        np.testing.assert_array_equal(a.x, b.x)


def test_compiled_chord_samples_are_their_twins() -> None:
    """Issue 38: :class:`Chords` samples its chords in one compiled pass; the same t and floors
    bit for bit as the numpy twin (np.linspace, HeightGrid.cell_of), on the problem's float32
    corridor terrain and on a float64 array, for chords across the map, off its edges, of no
    length and along a row."""
    pr = _problem()
    rng = np.random.default_rng(38)
    xmin, ymin, xmax, ymax = pr.grid.bounds
    pts = np.column_stack(
        [rng.uniform(xmin - 300, xmax + 300, 12), rng.uniform(ymin - 300, ymax + 300, 12)]
    )
    pts[5] = pts[4]  # no length
    pts[7, 1] = pts[6, 1]  # along a row
    heights = corridor_terrain(pr)
    for terrain in (heights, np.asarray(heights, dtype=np.float64)):
        got = Chords(pr, pts, terrain)
        want_t, want_f = _chord_samples_numpy(pr, pts, terrain)
        assert len(got.t) == len(want_t) == 11
        for a, b in zip(got.t + got.floor, want_t + want_f, strict=True):
            np.testing.assert_array_equal(a, b)
