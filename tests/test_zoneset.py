"""ZoneSet: both kinds of zone packed together, columns in the order given, floors honoured;
agreement with the per-kind functions, the zones' own ``contains`` and a dense-sampling check;
cylinder floors in terrain.cylinders."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.cylinders import (
    path_inside_lengths,
    points_in_cylinders,
    segment_cylinder_lengths,
)
from terrain.errors import InputError
from terrain.prisms import polygon_arrays, segment_polygon_lengths
from terrain.zones import DangerZone, PolygonZone, Zone
from terrain.zoneset import ZoneSet

INF = math.inf
SQUARE = [[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]]


def mixed() -> tuple[Zone, ...]:
    return (
        PolygonZone.from_vertices(SQUARE, top=500.0, id="sq"),
        DangerZone(300.0, 50.0, 100.0, 800.0, "c", 200.0),
        PolygonZone.from_vertices([[400, 0], [600, 0], [500, 150]], floor=100.0, id="tri"),
        DangerZone(-200.0, -200.0, 300.0),
    )


def test_columns_follow_the_given_order():
    zones = mixed()
    zs = ZoneSet.of(zones)
    assert len(zs) == 4 and zs.zones == zones
    assert zs.cylinder_columns.tolist() == [1, 3] and zs.polygon_columns.tolist() == [0, 2]
    np.testing.assert_allclose(
        zs.sizes, [200 / math.sqrt(math.pi), 100.0, 2 * math.sqrt(15000 / math.pi), 300.0]
    )
    assert not zs.sizes.flags.writeable
    p0 = np.array([[-100, 50, 300], [-100, 50, 900], [250, 50, 150], [450, 50, 120]], float)
    p1 = np.array([[700, 50, 300], [700, 50, 900], [350, 50, 250], [550, 50, 50]], float)
    got = zs.segment_lengths(p0, p1)
    # row 0 at 300 m: the square (100), the cylinder (floor 200, top 800: 100), the triangle
    # at y = 50 spans x in [400 + 50 / 1.5, 600 - 50 / 1.5]; row 1 at 900 m: nothing has a
    # ceiling that high except the triangle (no top) and the far cylinder (not crossed)
    tri = 200 - 2 * 50 / 1.5
    want = np.array(
        [
            [100, 100, tri, 0],
            [0, 0, tri, 0],
            [0, 50 * math.sqrt(2), 0, 0],  # climbs 150 -> 250 over x 250 -> 350: inside z >= 200
            [0, 0, None, 0],
        ],
        dtype=object,
    )
    for i in range(3):
        np.testing.assert_allclose(got[i], want[i].astype(float), rtol=1e-12, atol=1e-9)
    # row 3 descends 120 -> 50 over x 450 -> 550: inside the triangle (x in [450, 550] at
    # y = 50 is inside) while z >= 100, i.e. for x <= 450 + 100 * 20 / 70
    assert got[3, 2] == pytest.approx((20 / 70) * math.dist(p0[3], p1[3]), rel=1e-12)
    # each kind's columns are exactly the per-kind functions
    c = zs.cylinders
    np.testing.assert_array_equal(
        got[:, [1, 3]], segment_cylinder_lengths(p0, p1, c.centers, c.radii, c.tops, c.floors)
    )
    np.testing.assert_array_equal(
        got[:, [0, 2]], segment_polygon_lengths(p0, p1, polygon_arrays([zones[0], zones[2]]))
    )


def test_path_lengths_sum_segments_for_a_swarm():
    zs = ZoneSet.of(mixed())
    rng = np.random.default_rng(4)
    paths = rng.uniform([-400, -400, 0], [800, 400, 1000], (30, 7, 3))
    got = zs.path_lengths(paths)
    assert got.shape == (30, 4)
    for p in range(30):
        per = zs.segment_lengths(paths[p, :-1], paths[p, 1:])
        np.testing.assert_allclose(got[p], per.sum(axis=0), rtol=1e-14, atol=1e-12)
    np.testing.assert_array_equal(zs.path_lengths(paths[:, ::-1]), got)  # reversed paths
    assert np.count_nonzero(got) > 20
    assert zs.path_lengths(np.zeros((3, 1, 3))).shape == (3, 4)
    with pytest.raises(InputError, match=r"\(P, W, 3\)"):
        zs.path_lengths(np.zeros((2, 3)))


def test_contains_agrees_with_each_zone():
    zones = mixed()
    zs = ZoneSet.of(zones)
    rng = np.random.default_rng(8)
    pts = rng.uniform([-450, -450, 0], [700, 250, 1000], (5000, 3))
    pts[:10] = [[0, 0, 500], [100, 50, 0], [350, 50, 200], [350, 50, 800], [300, 0, 199.9],
                [500, 150, 100], [450, 75, 99.9], [-200, -50, 5], [-200, -49.9, 5], [50, 50, 500.1]]  # fmt: skip
    got = zs.contains(pts)
    for k, z in enumerate(zones):
        np.testing.assert_array_equal(got[:, k], z.contains(pts[:, 0], pts[:, 1], pts[:, 2]))
    np.testing.assert_array_equal(got[:10].any(axis=1), [1, 1, 1, 1, 0, 1, 0, 1, 0, 0])
    assert got.sum() > 100


def test_empty_and_bad_sets():
    zs = ZoneSet.of([])
    assert len(zs) == 0 and zs.sizes.shape == (0,)
    assert zs.segment_lengths(np.zeros((5, 3)), np.ones((5, 3))).shape == (5, 0)
    assert zs.path_lengths(np.zeros((2, 4, 3))).shape == (2, 0)
    assert zs.contains(np.zeros((3, 3))).shape == (3, 0)
    with pytest.raises(InputError, match="zone 1 must be a DangerZone or a PolygonZone; got dict"):
        ZoneSet.of([DangerZone(0, 0, 1), {"x": 0}])  # type: ignore[list-item]
    with pytest.raises(InputError, match=r"\(M, 3\)"):
        ZoneSet.of(mixed()).segment_lengths(np.zeros((2, 2)), np.zeros((2, 2)))
    with pytest.raises(InputError, match=r"\(N, 3\)"):
        ZoneSet.of(mixed()).contains(np.zeros(3))


def test_polygon_circle_costs_what_the_cylinder_costs():
    """F_dangerzones = min(1, L / size): a 720-gon and its circle give the same term."""
    circle = DangerZone(1000.0, 1000.0, 600.0)
    a = 2 * math.pi * np.arange(720) / 720
    gon = PolygonZone.from_vertices(np.c_[1000 + 300 * np.cos(a), 1000 + 300 * np.sin(a)])
    zs = ZoneSet.of([circle, gon])
    paths = np.array([[[0, 1000, 50], [2000, 1000, 50]], [[0, 900, 50], [2000, 900, 50]]], float)
    f = np.minimum(1.0, zs.path_lengths(paths) / zs.sizes)
    np.testing.assert_allclose(f[:, 0], f[:, 1], atol=1e-4)
    assert f[0, 0] == 1.0 and 0.5 < f[1, 0] < 1.0


# -- cylinder floors -----------------------------------------------------------------------------------


def one(p0, p1, top=INF, floor=-INF, radius=100.0) -> float:
    return float(segment_cylinder_lengths([p0], [p1], [[0, 0]], [radius], [top], [floor])[0, 0])


def test_cylinder_floor_exact_cases():
    assert one((10, 20, 0), (10, 20, 900), top=600, floor=350) == 250.0
    assert one((10, 20, 900), (10, 20, 0), top=600, floor=350) == 250.0
    assert one((-300, 0, 350), (300, 0, 350), floor=350) == 200.0  # in the floor plane
    assert one((-300, 0, 349.999), (300, 0, 349.999), floor=350) == 0.0
    assert one((0, 0, 500), (50, 0, 600), floor=500) == pytest.approx(math.hypot(50, 100))
    assert one((0, 0, 500), (50, 0, 400), floor=500) == 0.0
    # descending from 200 to 0 over x in [-200, 200], floor 75: z >= 75 for x <= 50
    got = one((-200, 0, 200), (200, 0, 0), floor=75)
    assert got == pytest.approx(150 * math.hypot(400, 200) / 400, rel=1e-14)


def test_cylinder_floors_default_is_bit_identical():
    rng = np.random.default_rng(2)
    p0 = rng.uniform([-1000, -1000, 0], [1000, 1000, 1000], (300, 3))
    p1 = rng.uniform([-1000, -1000, 0], [1000, 1000, 1000], (300, 3))
    c, r = rng.uniform(-400, 400, (6, 2)), rng.uniform(100, 600, 6)
    t = np.where(rng.random(6) < 0.3, INF, rng.uniform(0, 1000, 6))
    old = segment_cylinder_lengths(p0, p1, c, r, t)
    np.testing.assert_array_equal(segment_cylinder_lengths(p0, p1, c, r, t, np.full(6, -INF)), old)
    paths = np.stack([p0[:100], p1[:100], p0[100:200]], axis=1)
    np.testing.assert_array_equal(
        path_inside_lengths(paths, c, r, t, [-INF] * 6), path_inside_lengths(paths, c, r, t)
    )
    with pytest.raises(InputError, match=r"floors must have shape \(6,\)"):
        segment_cylinder_lengths(p0, p1, c, r, t, [0.0])
    assert math.isnan(one((0, 0, 0), (1, 0, 0), floor=math.nan))


def test_points_in_cylinders_floor_closed():
    pts = np.array([[0, 0, 100], [0, 0, 99.99], [0, 0, 500], [100, 0, 300]], float)
    got = points_in_cylinders(pts, [[0, 0]], [100], [500], [100])
    np.testing.assert_array_equal(got[:, 0], [True, False, True, True])


# subnormal numbers (below 2.2e-308 m) are left out: a segment 1e-309 m below a floor is on it
# for the analytic clip and under it for the dense sampling, a difference of no meaning
coord = st.floats(-1000, 1000, allow_nan=False, allow_subnormal=False)
alt = st.floats(-200, 1200, allow_nan=False, allow_subnormal=False)
point = st.tuples(coord, coord, alt)


@settings(max_examples=200, deadline=None)
@given(point, point, st.tuples(coord, coord), st.floats(1, 500), alt, st.floats(0, 800))
def test_cylinder_with_floor_matches_dense_sampling(p0, p1, c, r, floor, height):
    top = floor + height if height > 0 else INF
    got = float(segment_cylinder_lengths([p0], [p1], [c], [r], [top], [floor])[0, 0])
    n = 20_000
    a, b = np.asarray(p0, float), np.asarray(p1, float)
    t = (np.arange(n) + 0.5) / n
    q = a + t[:, None] * (b - a)
    inside = (np.hypot(q[:, 0] - c[0], q[:, 1] - c[1]) <= r) & (q[:, 2] <= top) & (q[:, 2] >= floor)
    assert abs(got - inside.mean() * math.dist(p0, p1)) <= math.dist(p0, p1) / n + 1e-9
    assert got == float(segment_cylinder_lengths([p1], [p0], [c], [r], [top], [floor])[0, 0])


def test_path_lengths_add_segments_in_numpys_order():
    """Issue 38: a swarm's lengths inside two zones or more are added by a compiled loop in the
    order numpy's ``sum(axis=1)`` of the (P, S, K) lengths adds them (each path's segments one
    after the other), bit for bit; with one zone numpy's own sum (pairwise) is kept."""
    from terrain import kernels

    rng = np.random.default_rng(38)
    for p_n, s_n, k_n in ((1, 1, 2), (3, 9, 2), (110, 57, 2), (20, 130, 5), (7, 8, 17)):
        x = rng.uniform(0.0, 1.0, (p_n * s_n, k_n)) * 10.0 ** rng.uniform(-3, 4, (p_n * s_n, k_n))
        x[x < 0.3] = 0.0
        np.testing.assert_array_equal(
            kernels.run_sums(x, p_n), x.reshape(p_n, s_n, k_n).sum(axis=1)
        )
    zones = mixed()
    paths = rng.uniform([-400, -400, 0], [800, 400, 1000], (40, 25, 3))
    for zs in (ZoneSet.of(zones), ZoneSet.of(zones[1:2])):
        per = zs.segment_lengths(paths[:, :-1].reshape(-1, 3), paths[:, 1:].reshape(-1, 3))
        want = per.reshape(40, 24, len(zs)).sum(axis=1)
        np.testing.assert_array_equal(zs.path_lengths(paths), want)
        assert np.count_nonzero(want) > 5
