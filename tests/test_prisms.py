"""Segment-in-polygon-prism lengths: hand values, properties, the numpy twin, a dense-sampling
reference (shapely's closed point test) and a 720-gon against the analytic cylinder."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.cylinders import segment_cylinder_lengths
from terrain.errors import InputError
from terrain.prisms import (
    pack_polygons,
    points_in_polygons,
    polygon_arrays,
    segment_polygon_lengths,
    segment_polygon_lengths_numpy,
)
from terrain.zones import DangerZone, PolygonZone

INF = math.inf
SQUARE = [[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]]
BACKENDS = ("numba", "numpy")


def lengths(p0, p1, zones, backend="numba"):
    arrays = polygon_arrays(zones)
    out = segment_polygon_lengths(
        np.atleast_2d(np.asarray(p0, float)),
        np.atleast_2d(np.asarray(p1, float)),
        arrays,
        backend=backend,
    )
    assert out.dtype == np.float64
    return out


def one(p0, p1, zone, backend="numba") -> float:
    out = lengths([p0], [p1], [zone], backend)
    assert out.shape == (1, 1)
    return float(out[0, 0])


# -- hand values -------------------------------------------------------------------------------------


@pytest.mark.parametrize("backend", BACKENDS)
def test_square_hand_values(backend):
    sq = PolygonZone.from_vertices(SQUARE)
    cases = [
        (((-50, 50, 10), (150, 50, 10)), 100.0),  # straight through
        (((50, -50, 10), (50, 150, 10)), 100.0),
        (((-100, -100, 0), (200, 200, 0)), 100.0 * math.sqrt(2)),  # through two corners
        (((25, 25, 0), (75, 60, 300)), math.dist((25, 25, 0), (75, 60, 300))),  # wholly inside
        (((-50, 0, 10), (150, 0, 10)), 100.0),  # along the south wall: closed set
        (((-50, 100, 10), (50, 100, 10)), 50.0),  # half along the north wall
        (((-50, 150, 10), (150, 150, 10)), 0.0),  # outside
        (((100, -50, 10), (100, 150, 10)), 100.0),  # along the east wall
        (((150, 50, 10), (100, 50, 10)), 0.0),  # ends on the wall: a point, length 0
        (((50, 50, 100), (50, 50, 900)), 800.0),  # vertical inside
        (((150, 50, 100), (150, 50, 900)), 0.0),  # vertical outside
        (((0, 0, 100), (0, 0, 900)), 800.0),  # vertical on a corner
        (((50, 50, 5), (50, 50, 5)), 0.0),  # a point
        (((-50, 50, 0), (50, 50, 0)), 50.0),  # ends inside
    ]
    for (p0, p1), want in cases:
        assert one(p0, p1, sq, backend) == pytest.approx(want, rel=1e-15, abs=1e-12), (p0, p1)
        assert one(p1, p0, sq, backend) == one(p0, p1, sq, backend)


@pytest.mark.parametrize("backend", BACKENDS)
def test_square_floor_and_top(backend):
    sq = PolygonZone.from_vertices(SQUARE, floor=200.0, top=500.0)
    assert one((50, 50, 0), (50, 50, 900), sq, backend) == 300.0
    assert one((50, 50, 900), (50, 50, 0), sq, backend) == 300.0
    assert one((-50, 50, 300), (150, 50, 300), sq, backend) == 100.0
    assert one((-50, 50, 500), (150, 50, 500), sq, backend) == 100.0  # in the top plane
    assert one((-50, 50, 200), (150, 50, 200), sq, backend) == 100.0  # in the floor plane
    assert one((-50, 50, 500.001), (150, 50, 500.001), sq, backend) == 0.0
    assert one((-50, 50, 199.999), (150, 50, 199.999), sq, backend) == 0.0
    # climbing from 0 to 800 over x in [-100, 300]: z = 2 (x + 100); inside for x in [0, 100]
    # (z in [200, 400]), all within [floor, top]
    got = one((-100, 50, 0), (300, 50, 800), sq, backend)
    assert got == pytest.approx(100.0 * math.hypot(400, 800) / 400, rel=1e-14)
    # the same but the top cuts at z = 300, x = 50
    low = PolygonZone.from_vertices(SQUARE, floor=200.0, top=300.0)
    got = one((-100, 50, 0), (300, 50, 800), low, backend)
    assert got == pytest.approx(50.0 * math.hypot(400, 800) / 400, rel=1e-14)


@pytest.mark.parametrize("backend", BACKENDS)
def test_holes_and_parts(backend):
    hole = [[25.0, 25.0], [25.0, 75.0], [75.0, 75.0], [75.0, 25.0]]
    ring = PolygonZone.from_vertices(SQUARE, [hole])
    assert one((-50, 50, 0), (150, 50, 0), ring, backend) == pytest.approx(50.0, abs=1e-12)
    assert one((50, 50, 0), (50, 50, 100), ring, backend) == 0.0  # vertical in the hole
    assert one((10, 50, 0), (10, 50, 100), ring, backend) == 100.0
    right = [[200.0, 0.0], [300.0, 0.0], [300.0, 100.0], [200.0, 100.0]]
    twin = PolygonZone(((SQUARE,), (right,)))  # type: ignore[arg-type]
    assert one((-50, 50, 0), (350, 50, 0), twin, backend) == pytest.approx(200.0, abs=1e-12)
    touching = [[100.0, 100.0], [200.0, 100.0], [200.0, 200.0], [100.0, 200.0]]
    corner = PolygonZone(((SQUARE,), (touching,)))  # type: ignore[arg-type]
    d = one((0, 0, 0), (200, 200, 0), corner, backend)
    assert d == pytest.approx(200.0 * math.sqrt(2), rel=1e-14)  # through the shared corner


@pytest.mark.parametrize("backend", BACKENDS)
def test_concave_polygon_several_intervals(backend):
    # a U: the bottom bar y in [0, 20], the arms x in [0, 20] and [80, 100] up to y = 100
    u = PolygonZone.from_vertices(
        [[0, 0], [100, 0], [100, 100], [80, 100], [80, 20], [20, 20], [20, 100], [0, 100]]
    )
    assert one((-10, 50, 0), (110, 50, 0), u, backend) == pytest.approx(40.0, abs=1e-12)
    assert one((-10, 10, 0), (110, 10, 0), u, backend) == pytest.approx(100.0, abs=1e-12)
    assert one((50, 50, 0), (50, 150, 0), u, backend) == 0.0
    assert u.size == pytest.approx(2.0 * math.sqrt(5200.0 / math.pi), rel=1e-15)


def test_many_segments_and_prisms_shape_and_columns():
    sq = PolygonZone.from_vertices(SQUARE)
    far = PolygonZone.from_vertices([[5000, 5000], [5100, 5000], [5050, 5100]], top=10.0)
    p0 = np.array([[-50, 50, 0], [50, -50, 0], [4000, 5050, 0]], float)
    p1 = np.array([[150, 50, 0], [50, 150, 0], [6000, 5050, 0]], float)
    for backend in BACKENDS:
        out = lengths(p0, p1, [sq, far], backend)
        want = np.array([[100, 0], [100, 0], [0, 50]], float)
        np.testing.assert_allclose(out, want, rtol=0, atol=1e-9)


def test_empty_inputs():
    sq = polygon_arrays([PolygonZone.from_vertices(SQUARE)])
    none = polygon_arrays([])
    for backend in BACKENDS:
        assert segment_polygon_lengths(np.zeros((4, 3)), np.ones((4, 3)), none, backend).shape == (
            4,
            0,
        )
        assert segment_polygon_lengths(np.zeros((0, 3)), np.zeros((0, 3)), sq, backend).shape == (
            0,
            1,
        )


def test_nan_input_gives_nan_and_bad_input_is_refused():
    sq = PolygonZone.from_vertices(SQUARE)
    for backend in BACKENDS:
        assert math.isnan(one((math.nan, 0, 0), (1, 0, 0), sq, backend))
        assert math.isnan(one((0, 0, 0), (1, 0, math.inf), sq, backend))
    arrays = polygon_arrays([sq])
    with pytest.raises(InputError, match=r"\(M, 3\)"):
        segment_polygon_lengths(np.zeros((2, 2)), np.zeros((2, 2)), arrays)
    with pytest.raises(InputError, match="backend"):
        segment_polygon_lengths(np.zeros((2, 3)), np.zeros((2, 3)), arrays, "cuda")  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"shape \(1,\)"):
        pack_polygons([[np.array(SQUARE)]], [0.0, 1.0], [INF])
    with pytest.raises(InputError, match="3 or more"):
        pack_polygons([[np.array(SQUARE[:2])]], [-INF], [INF])


def test_points_in_polygons_closed():
    sq = polygon_arrays([PolygonZone.from_vertices(SQUARE, floor=0.0, top=500.0)])
    pts = np.array(
        [[50, 50, 0], [100, 50, 500], [100, 100, 10], [100.001, 50, 10], [50, 50, 500.1]], float
    )
    np.testing.assert_array_equal(points_in_polygons(pts, sq)[:, 0], [1, 1, 1, 0, 0])


# -- properties ----------------------------------------------------------------------------------------


def star(center, radii, angles):
    """A star-shaped (hence simple) ring: vertex i at angle angles[i] (increasing), radius radii[i]."""
    cx, cy = center
    return [
        [cx + r * math.cos(a), cy + r * math.sin(a)] for r, a in zip(radii, angles, strict=True)
    ]


@st.composite
def star_zones(draw):
    # angular gaps below 144 degrees: the ring stays star-shaped around the centre and every
    # edge stays farther than cos(72 deg) > 0.3 of the smallest radius from it
    n = draw(st.integers(4, 12))
    gaps = draw(st.lists(st.floats(0.5, 1.0), min_size=n, max_size=n))
    total = sum(gaps)
    angles = np.cumsum([2 * math.pi * g / total for g in gaps]) - 2 * math.pi * gaps[0] / total
    radii = draw(st.lists(st.floats(100.0, 600.0), min_size=n, max_size=n))
    center = draw(st.tuples(st.floats(-300, 300), st.floats(-300, 300)))
    outer = star(center, radii, angles)
    holes = []
    if draw(st.booleans()):  # a hole well inside the smallest radius
        h = 0.25 * min(radii)
        holes.append(star(center, [h, 0.6 * h, h, 0.7 * h], [0.3, 1.9, 3.4, 4.9]))
    floor = draw(st.one_of(st.none(), st.floats(-100, 400)))
    top = draw(st.one_of(st.none(), st.floats(500, 1100)))
    return PolygonZone.from_vertices(outer, holes, floor=floor, top=top)


coord = st.floats(-1000, 1000, allow_nan=False)
alt = st.floats(-200, 1200, allow_nan=False)
point = st.tuples(coord, coord, alt)


def brute_force(p0, p1, zone: PolygonZone, n: int) -> float:
    """Midpoint rule with shapely's closed test (``intersects_xy``) as the independent reference."""
    a, b = np.asarray(p0, float), np.asarray(p1, float)
    t = (np.arange(n) + 0.5) / n
    pts = a + t[:, None] * (b - a)
    inside = shapely.intersects_xy(zone.geometry, pts[:, 0], pts[:, 1])
    inside &= pts[:, 2] <= (INF if zone.top is None else zone.top)
    inside &= pts[:, 2] >= (-INF if zone.floor is None else zone.floor)
    return float(inside.mean()) * float(np.linalg.norm(b - a))


@settings(max_examples=200, deadline=None)
@given(point, point, star_zones())
def test_bounded_by_segment_and_symmetric(p0, p1, zone):
    got = one(p0, p1, zone)
    assert 0.0 <= got <= math.dist(p0, p1) * (1 + 1e-12)
    assert one(p1, p0, zone) == got  # bit-identical when reversed


@settings(max_examples=200, deadline=None)
@given(point, point, star_zones())
def test_numba_and_numpy_agree_exactly(p0, p1, zone):
    assert one(p0, p1, zone, "numba") == one(p0, p1, zone, "numpy")


@settings(max_examples=150, deadline=None)
@given(point, point, star_zones())
def test_matches_dense_sampling(p0, p1, zone):
    n = 20_000
    # the inside set is at most (edges + 2) / 2 intervals; the midpoint rule errs by at most
    # L / n per interval
    edges = sum(len(r) for r in zone.rings)
    bound = (edges + 2) * math.dist(p0, p1) / n + 1e-9
    assert abs(one(p0, p1, zone) - brute_force(p0, p1, zone, n)) <= bound


eighth = st.integers(-8000, 8000).map(lambda v: v / 8)
lattice_point = st.tuples(eighth, eighth, st.integers(-1600, 9600).map(lambda v: v / 8))


@settings(max_examples=200, deadline=None)
@given(lattice_point, lattice_point, star_zones(), st.integers(0, 64))
def test_additive_when_split(p0, p1, zone, k):
    a, b = np.asarray(p0, float), np.asarray(p1, float)
    mid = a + (k / 64) * (b - a)
    whole = one(a, b, zone)
    parts = one(a, mid, zone) + one(mid, b, zone)
    assert parts == pytest.approx(whole, abs=1e-7 * (1.0 + math.dist(p0, p1)))


def test_numba_and_numpy_agree_on_a_random_batch():
    rng = np.random.default_rng(12)
    zones = [
        PolygonZone.from_vertices(
            star(
                rng.uniform(-300, 300, 2),
                rng.uniform(100, 600, 20),
                np.sort(rng.uniform(0, 2 * math.pi, 20)),
            ),
            floor=float(rng.uniform(0, 300)) if i else None,
            top=float(rng.uniform(500, 1000)) if i != 1 else None,
        )
        for i in range(3)
    ]
    p0 = rng.uniform([-1000, -1000, 0], [1000, 1000, 1000], (2000, 3))
    p1 = rng.uniform([-1000, -1000, 0], [1000, 1000, 1000], (2000, 3))
    p1[:50, :2] = p0[:50, :2]  # vertical segments
    p1[50:100, 2] = p0[50:100, 2]  # level segments
    a = lengths(p0, p1, zones, "numba")
    b = segment_polygon_lengths_numpy(p0, p1, polygon_arrays(zones))
    assert np.count_nonzero(a) > 500  # the batch really crosses the zones
    np.testing.assert_array_equal(a, b)


# -- a 720-gon against the analytic cylinder ----------------------------------------------------------


def _gon(center, r, n=720):
    a = 2 * math.pi * np.arange(n) / n
    return np.stack([center[0] + r * np.cos(a), center[1] + r * np.sin(a)], axis=1)


@settings(max_examples=200, deadline=None)
@given(point, point, st.tuples(coord, coord), st.floats(50, 500), st.one_of(st.just(INF), alt))
def test_720_gon_brackets_the_cylinder(p0, p1, c, r, top):
    """The inscribed 720-gon lies inside the disc and the circumscribed one contains it, so their
    lengths bracket the cylinder's exactly (up to rounding)."""
    zone = DangerZone(c[0], c[1], 2 * r, None if top == INF else top)
    inner = PolygonZone.from_vertices(_gon(c, r), top=zone.top)
    outer = PolygonZone.from_vertices(zone.outline(720)[0], top=zone.top)
    cyl = float(segment_cylinder_lengths([p0], [p1], [c], [r], [top])[0, 0])
    lo, hi = lengths([p0], [p1], [inner, outer])[0]
    slack = 1e-9 * (1.0 + math.dist(p0, p1))
    assert lo <= cyl + slack and cyl <= hi + slack


def test_720_gon_matches_the_cylinder_through_the_middle():
    rng = np.random.default_rng(3)
    c, r = (376313.655 + 500.0, 3807917.83 - 800.0), 400.0  # UTM-sized coordinates
    gon = PolygonZone.from_vertices(_gon(c, r))
    # chords at most 0.9 r from the centre: far from tangency, so well conditioned
    ang = rng.uniform(0, 2 * math.pi, 500)
    off = rng.uniform(-0.9 * r, 0.9 * r, 500)
    ux, uy = np.cos(ang), np.sin(ang)
    mx, my = c[0] - off * uy, c[1] + off * ux
    p0 = np.stack([mx - 2 * r * ux, my - 2 * r * uy, rng.uniform(0, 100, 500)], axis=1)
    p1 = np.stack([mx + 2 * r * ux, my + 2 * r * uy, rng.uniform(0, 100, 500)], axis=1)
    got = lengths(p0, p1, [gon])[:, 0]
    want = segment_cylinder_lengths(p0, p1, [c], [r], [INF])[:, 0]
    # the polygon's edge lies within r (1 - cos(pi / 720)) of the circle: the chord moves by
    # about that over the chord's slope, a few centimetres at most here
    np.testing.assert_allclose(got, want, rtol=0, atol=0.05)
    assert gon.size == pytest.approx(2 * r, rel=1e-4)
