"""Segment-in-cylinder lengths: exact cases, properties, and a dense-sampling reference."""

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
    zones_arrays,
)
from terrain.errors import InputError
from terrain.zones import DangerZone

INF = math.inf


def one(p0, p1, center=(0.0, 0.0), radius=100.0, top=INF) -> float:
    out = segment_cylinder_lengths([p0], [p1], [center], [radius], [top])
    assert out.shape == (1, 1) and out.dtype == np.float64
    return float(out[0, 0])


def brute_force(p0, p1, center, radius, top, n):
    """Midpoint-rule length inside: error at most |p1 - p0| / n (the inside set is one interval)."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    t = (np.arange(n) + 0.5) / n
    pts = p0 + t[:, None] * (p1 - p0)
    inside = (np.hypot(pts[:, 0] - center[0], pts[:, 1] - center[1]) <= radius) & (pts[:, 2] <= top)
    return inside.mean() * float(np.linalg.norm(p1 - p0))


# -- exact, axis-aligned cases ----------------------------------------------------------------------


def test_horizontal_through_centre_is_diameter():
    assert one((-300, 0, 50), (300, 0, 50), radius=100) == 200.0
    assert one((0, -300, 50), (0, 300, 50), center=(0, 0), radius=100) == 200.0


@pytest.mark.parametrize("offset", [0.0, 30.0, 60.0, 99.0, -80.0])
def test_chord_at_offset(offset):
    got = one((-500, offset, 10), (500, offset, 10), radius=100)
    assert got == pytest.approx(2 * math.sqrt(100**2 - offset**2), abs=1e-9)


def test_chord_far_from_origin_utm_coordinates():
    cx, cy = 376313.655 + 5000, 3807917.83 + 5000
    got = one((cx - 5000, cy + 60, 900), (cx + 5000, cy + 60, 900), center=(cx, cy), radius=100)
    assert got == pytest.approx(160.0, abs=1e-6)


def test_segment_entirely_inside_has_full_length():
    p0, p1 = (-30, -20, 0), (40, 10, 300)
    assert one(p0, p1, radius=100, top=1000) == pytest.approx(math.dist(p0, p1), rel=1e-15)


def test_segment_outside_and_tangent_give_zero():
    assert one((-500, 150, 0), (500, 150, 0), radius=100) == 0.0
    assert one((-500, 100, 0), (500, 100, 0), radius=100) == 0.0  # touches at one point
    assert one((200, 0, 0), (500, 0, 0), radius=100) == 0.0  # on the line but beyond the circle
    assert one((-50, 0, 600), (50, 0, 700), radius=100, top=500) == 0.0  # above the top


def test_vertical_segment_crossing_top_counts_part_below():
    assert one((10, 20, 100), (10, 20, 900), radius=100, top=350) == 250.0
    assert one((10, 20, 900), (10, 20, 100), radius=100, top=350) == 250.0
    assert one((10, 20, 100), (10, 20, 900), radius=100, top=INF) == 800.0
    assert one((150, 0, 100), (150, 0, 900), radius=100, top=INF) == 0.0  # outside the circle
    assert one((100, 0, 100), (100, 0, 900), radius=100, top=INF) == 800.0  # on the wall: inside


def test_degenerate_point_segment_is_zero():
    assert one((0, 0, 0), (0, 0, 0), radius=100) == 0.0


def test_horizontal_segment_at_top_is_inside_just_above_is_not():
    assert one((-300, 0, 500), (300, 0, 500), radius=100, top=500) == 200.0
    assert one((-300, 0, 500.001), (300, 0, 500.001), radius=100, top=500) == 0.0


def test_segments_starting_exactly_at_top():
    assert one((0, 0, 500), (50, 0, 400), radius=100, top=500) == pytest.approx(math.hypot(50, 100))
    assert one((0, 0, 500), (50, 0, 600), radius=100, top=500) == 0.0
    assert one((0, 0, 0), (50, 0, 1e-300), radius=100, top=0) == 0.0  # barely climbing


def test_slanted_segment_crossing_top_inside_circle():
    # From (-100, 0, 0) to (100, 0, 200), radius 1000 (always inside), top 50: t <= 0.25.
    got = one((-100, 0, 0), (100, 0, 200), radius=1000, top=50)
    assert got == pytest.approx(0.25 * math.hypot(200, 200), rel=1e-14)


def test_top_and_circle_combine():
    # Horizontal through centre, descending from 200 to 0 over x in [-200, 200]; top 150:
    # z <= 125 for x >= -50, circle for |x| <= 100 -> x in [-50, 100], 150 m of x.
    got = one((-200, 0, 200), (200, 0, 0), radius=100, top=125)
    assert got == pytest.approx(150 * math.hypot(400, 200) / 400, rel=1e-14)


def test_many_segments_and_cylinders_shape_and_values():
    p0 = np.array([[-300, 0, 0], [0, -300, 0], [1000, 1000, 0]], float)
    p1 = np.array([[300, 0, 0], [0, 300, 0], [1100, 1000, 0]], float)
    centers = np.array([[0, 0], [0, 200], [5000, 5000]], float)
    radii = np.array([100, 50, 10], float)
    tops = np.array([INF, 10, INF])
    out = segment_cylinder_lengths(p0, p1, centers, radii, tops)
    expected = np.array([[200, 0, 0], [200, 100, 0], [0, 0, 0]], float)
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-9)


def test_no_cylinders_and_no_segments():
    no_zones = segment_cylinder_lengths(np.zeros((4, 3)), np.ones((4, 3)), np.zeros((0, 2)), [], [])
    assert no_zones.shape == (4, 0)
    no_segments = segment_cylinder_lengths(np.zeros((0, 3)), np.zeros((0, 3)), [[0, 0]], [1], [INF])
    assert no_segments.shape == (0, 1)


def test_nan_input_gives_nan():
    assert math.isnan(one((math.nan, 0, 0), (1, 0, 0)))
    assert math.isnan(one((0, 0, 0), (1, 0, 0), top=math.nan))


def test_bad_shapes_are_refused():
    with pytest.raises(InputError, match=r"\(M, 3\)"):
        segment_cylinder_lengths(np.zeros((2, 2)), np.zeros((2, 2)), [[0, 0]], [1], [1])
    with pytest.raises(InputError, match=r"\(K, 2\)"):
        segment_cylinder_lengths(np.zeros((2, 3)), np.zeros((2, 3)), [0, 0], [1], [1])
    with pytest.raises(InputError, match=r"shape \(1,\)"):
        segment_cylinder_lengths(np.zeros((2, 3)), np.zeros((2, 3)), [[0, 0]], [1, 2], [1])
    with pytest.raises(InputError, match=r"\(P, W, 3\)"):
        path_inside_lengths(np.zeros((2, 3)), [[0, 0]], [1], [1])


# -- zones_arrays, paths, points -----------------------------------------------------------------


def test_zones_arrays():
    zones = [DangerZone(1, 2, 300, 800, "a"), DangerZone(-5, 6, 10)]
    arr = zones_arrays(zones)
    np.testing.assert_array_equal(arr.centers, [[1, 2], [-5, 6]])
    np.testing.assert_array_equal(arr.radii, [150, 5])
    np.testing.assert_array_equal(arr.tops, [800, INF])
    empty = zones_arrays([])
    assert empty.centers.shape == (0, 2) and empty.radii.shape == (0,) and empty.tops.shape == (0,)


def test_path_inside_lengths_sums_segments():
    # Path 0 crosses zone 0 twice (out and back) and never zone 1; path 1 is a single waypoint.
    paths = np.array(
        [
            [[-300, 0, 10], [300, 0, 10], [300, 50, 10], [-300, 50, 10]],
            [[0, 0, 10], [0, 0, 10], [0, 0, 10], [0, 0, 10]],
        ],
        float,
    )
    centers, radii, tops = [[0, 0], [1000, 0]], [100, 100], [INF, INF]
    out = path_inside_lengths(paths, centers, radii, tops)
    expected_0 = 200 + 2 * math.sqrt(100**2 - 50**2)
    np.testing.assert_allclose(out, np.array([[expected_0, 0], [0, 0]]), atol=1e-9, rtol=0)
    single = path_inside_lengths(np.zeros((3, 1, 3)), centers, radii, tops)
    np.testing.assert_array_equal(single, np.zeros((3, 2)))


def test_points_in_cylinders_closed():
    pts = np.array([[0, 0, 0], [100, 0, 500], [100, 0, 500.5], [100.5, 0, 0]], float)
    got = points_in_cylinders(pts, [[0, 0]], [100], [500])
    np.testing.assert_array_equal(got[:, 0], [True, True, False, False])


# -- properties -----------------------------------------------------------------------------------

coord = st.floats(-1000, 1000, allow_nan=False)
alt = st.floats(-200, 1200, allow_nan=False)
point = st.tuples(coord, coord, alt)
radius = st.floats(1, 500, allow_nan=False)
top = st.one_of(st.just(INF), st.floats(-100, 1000, allow_nan=False))

# Coordinates on a 1/8 m lattice and splits at t = k/64: the split point then lies exactly on the
# segment, so the only error left is rounding amplified near tangency, where the chord length is
# ill-conditioned by the factor L / |horizontal extent| (at most ~1e-10 (1 + L / |d|) measured).
eighth = st.integers(-8000, 8000).map(lambda v: v / 8)
lattice_point = st.tuples(eighth, eighth, st.integers(-1600, 9600).map(lambda v: v / 8))
lattice_radius = st.integers(8, 4000).map(lambda v: v / 8)
lattice_top = st.one_of(st.just(INF), st.integers(-800, 8000).map(lambda v: v / 8))


@settings(max_examples=300, deadline=None)
@given(point, point, st.tuples(coord, coord), radius, top)
def test_bounded_by_segment_and_non_negative(p0, p1, c, r, t):
    got = one(p0, p1, c, r, t)
    assert 0.0 <= got <= math.dist(p0, p1) * (1 + 1e-12)


@settings(max_examples=300, deadline=None)
@given(point, point, st.tuples(coord, coord), radius, top)
def test_symmetric_in_endpoints_bit_identical(p0, p1, c, r, t):
    assert one(p0, p1, c, r, t) == one(p1, p0, c, r, t)


@settings(max_examples=300, deadline=None)
@given(
    lattice_point,
    lattice_point,
    st.tuples(eighth, eighth),
    lattice_radius,
    lattice_top,
    st.integers(0, 64),
)
def test_additive_when_split(p0, p1, c, r, t, k):
    a, b = np.asarray(p0, float), np.asarray(p1, float)
    mid = a + (k / 64) * (b - a)
    whole = one(a, b, c, r, t)
    hor = math.hypot(*(b - a)[:2])
    conditioning = 1.0 + (math.dist(p0, p1) / hor if hor > 0 else 1.0)
    parts = one(a, mid, c, r, t) + one(mid, b, c, r, t)
    assert parts == pytest.approx(whole, abs=1e-6 * conditioning)


@settings(max_examples=150, deadline=None)
@given(point, point, st.tuples(coord, coord), radius, top)
def test_matches_dense_sampling(p0, p1, c, r, t):
    n = 20_000
    bound = math.dist(p0, p1) / n + 1e-9
    assert abs(one(p0, p1, c, r, t) - brute_force(p0, p1, c, r, t, n)) <= bound


def test_matches_dense_sampling_random_batch():
    rng = np.random.default_rng(7)
    m, k, n = 60, 8, 20_000
    p0 = rng.uniform([-1000, -1000, 0], [1000, 1000, 1000], (m, 3))
    p1 = rng.uniform([-1000, -1000, 0], [1000, 1000, 1000], (m, 3))
    centers = rng.uniform(-400, 400, (k, 2))
    radii = rng.uniform(100, 600, k)
    tops = np.where(rng.random(k) < 0.3, INF, rng.uniform(0, 1000, k))
    got = segment_cylinder_lengths(p0, p1, centers, radii, tops)
    assert np.count_nonzero(got) > m  # the batch really exercises intersections
    for i in range(m):
        for j in range(k):
            ref = brute_force(p0[i], p1[i], centers[j], radii[j], tops[j], n)
            assert abs(got[i, j] - ref) <= np.linalg.norm(p1[i] - p0[i]) / n + 1e-9


def _mixed_batch(seed: int):
    """Segments of every awkward kind against zones with and without tops and floors."""
    rng = np.random.default_rng(seed)
    m, k = 400, 7
    p0 = rng.uniform([-1000, -1000, 0], [1000, 1000, 1000], (m, 3))
    p1 = rng.uniform([-1000, -1000, 0], [1000, 1000, 1000], (m, 3))
    p1[:40, :2] = p0[:40, :2]  # vertical
    p1[40:60] = p0[40:60]  # points
    p1[60:120, 2] = p0[60:120, 2]  # level
    p0[60:90, 2] = p1[60:90, 2] = 500.0  # level in a top plane
    p1[120:140, :2] = p0[120:140, :2] + 1e-13  # almost vertical
    p0[140:160] += [376313.655, 3807917.83, 0.0]  # UTM-sized coordinates
    p1[140:160] += [376313.655, 3807917.83, 0.0]
    p0[160, 0] = np.nan
    p1[161, 2] = np.inf
    centers = rng.uniform(-400, 400, (k, 2))
    centers[6] = [376313.655, 3807917.83]
    radii = rng.uniform(100, 600, k)
    tops = np.array([INF, 500.0, 800.0, INF, 300.0, 500.0, 900.0])
    floors = np.array([-INF, 100.0, -INF, 400.0, 200.0, 500.0, 0.0])
    return p0, p1, centers, radii, tops, floors


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("with_floors", [False, True])
def test_compiled_and_numpy_backends_are_bit_identical(seed, with_floors):
    p0, p1, centers, radii, tops, floors = _mixed_batch(seed)
    f = floors if with_floors else None
    fast = segment_cylinder_lengths(p0, p1, centers, radii, tops, f)
    ref = segment_cylinder_lengths(p0, p1, centers, radii, tops, f, backend="numpy")
    assert np.count_nonzero(ref > 0) > 100  # the batch really exercises intersections
    assert np.isnan(ref[160:162]).all() and not np.isnan(ref[:160]).any()
    np.testing.assert_array_equal(fast, ref)  # NaN where NaN, equal bits elsewhere
    swapped = segment_cylinder_lengths(p1, p0, centers, radii, tops, f)
    np.testing.assert_array_equal(swapped, fast)


def test_nan_zone_gives_nan_column_in_both_backends():
    p0, p1 = np.zeros((3, 3)), np.ones((3, 3)) * 50
    for backend in ("numba", "numpy"):
        out = segment_cylinder_lengths(
            p0, p1, [[0, 0], [np.nan, 0]], [100, 100], [INF, INF], backend=backend
        )
        assert np.isnan(out[:, 1]).all() and (out[:, 0] > 0).all()
    with pytest.raises(InputError, match="backend"):
        segment_cylinder_lengths(p0, p1, [[0, 0]], [1], [1], backend="cuda")  # type: ignore[arg-type]


@pytest.mark.parametrize("seed", [0, 1])
def test_segments_far_from_the_cylinders_skip_to_zero_bit_identically(seed):
    """The compiled loop skips a cylinder whose footprint box lies beyond its radius from the
    segment's box (issue 38): the same bits as the full computation, at the edge of the box too
    (segments passing the circle at r (1 +- 1e-12)), with NaN and infinite inputs kept."""
    rng = np.random.default_rng(seed)
    k = 5
    centers = rng.uniform(-5000, 5000, (k, 2)) + np.array([376313.655, 3807917.83])
    radii = rng.uniform(100, 900, k)
    tops = np.array([INF, 500.0, 800.0, np.nan, 300.0])
    floors = np.array([-INF, 100.0, -INF, 0.0, np.nan])
    rows = []
    for j in range(k):  # horizontal segments tangent-ish above every circle, both directions
        for f in (0.0, 0.5, 1 - 1e-12, 1.0, 1 + 1e-12, 1 + 1e-9, 1 + 2e-9):
            y = centers[j, 1] + f * radii[j]
            rows.append(([centers[j, 0] - 3000, y, 200.0], [centers[j, 0] + 3000, y, 400.0]))
            rows.append(([centers[j, 0] + 50, y + 1e-6, 900.0], [centers[j, 0] - 50, y, 100.0]))
    m = 600
    a = rng.uniform(-12000, 12000, (m, 3)) + np.array([376313.655, 3807917.83, 0.0])
    b = a + rng.normal(0, 800, (m, 3))
    a[:, 2], b[:, 2] = rng.uniform(0, 1000, m), rng.uniform(0, 1000, m)
    a[5, 0], b[6, 1], a[7, 2] = np.nan, np.inf, -np.inf
    p0 = np.vstack([np.array([r[0] for r in rows]), a])
    p1 = np.vstack([np.array([r[1] for r in rows]), b])
    fast = segment_cylinder_lengths(p0, p1, centers, radii, tops, floors)
    ref = segment_cylinder_lengths(p0, p1, centers, radii, tops, floors, backend="numpy")
    assert np.count_nonzero(ref > 0) > 20 and np.count_nonzero(ref == 0) > 1000
    np.testing.assert_array_equal(fast, ref)
    np.testing.assert_array_equal(np.signbit(fast), np.signbit(ref))
