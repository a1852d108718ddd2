"""Tests of `terrain.model.TerrainModel` on synthetic grids placed at UTM-sized coordinates."""

from __future__ import annotations

import math
import pickle
from collections.abc import Callable

import fcl
import numpy as np
import open3d as o3d
import pytest
import trimesh
from affine import Affine
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain import kernels
from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrain.model import (
    TerrainModel,
    airframe_box,
    airframe_sphere,
    grid_faces,
    rays_numpy,
)

X0, Y0 = 400_000.0, 3_800_000.0  # UTM-sized: float32 would round these to 0.03 m / 0.25 m
F32 = 2e-3  # float32 ray casting on coordinates ~1 km from the origin: a few ulp of ~6e-5 m

Surface = Callable[[np.ndarray, np.ndarray], np.ndarray]


def make_grid(f: Surface, rows: int, cols: int, dx: float = 10.0, dy: float = 10.0) -> HeightGrid:
    probe = HeightGrid(np.zeros((rows, cols), np.float32), Affine(dx, 0, X0, 0, -dy, Y0))
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    x, y = probe.index_to_xy(r, c)
    return HeightGrid(f(x, y).astype(np.float32), probe.transform, crs=None)


def plane(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return 500.0 + 0.05 * (x - X0) - 0.03 * (y - Y0)


FLAT = make_grid(lambda x, y: np.full_like(x, 100.0), 40, 60, dx=10.0, dy=12.0)
PLANE = make_grid(plane, 50, 70, dx=10.0, dy=10.0)
# cone of slope 0.5 (apex 600 m on the centre cell) on a 100 m floor
CX, CY = X0 + 100.5 * 10.0, Y0 - 100.5 * 10.0
CONE = make_grid(lambda x, y: np.maximum(100.0, 600.0 - 0.5 * np.hypot(x - CX, y - CY)), 201, 201)
# north-south ridge of slope 1, crest 300 m along the centre column, on a 100 m floor
RX = X0 + 60.5 * 10.0
RIDGE = make_grid(lambda x, y: 100.0 + np.maximum(0.0, 200.0 - np.abs(x - RX)), 41, 121)


@pytest.fixture(scope="module")
def flat() -> TerrainModel:
    return TerrainModel.from_grid(FLAT)


@pytest.fixture(scope="module")
def ridge() -> TerrainModel:
    return TerrainModel.from_grid(RIDGE)


def centre_extent(grid: HeightGrid) -> tuple[float, float, float, float]:
    (x0, x1), (y1, y0) = grid.index_to_xy([0, grid.rows - 1], [0, grid.cols - 1])
    return float(x0), float(y0), float(x1), float(y1)


def random_xy(grid: HeightGrid, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x0, y0, x1, y1 = centre_extent(grid)
    return rng.uniform(x0, x1, n), rng.uniform(y0, y1, n)


def assert_single_height_field(model: TerrainModel) -> None:
    mesh = model.mesh
    assert np.all(mesh.face_normals[:, 2] > 0)
    assert mesh.is_winding_consistent and not mesh.is_watertight
    assert mesh.euler_number == 1  # a disc: one piece, no holes
    parts = trimesh.graph.connected_components(
        mesh.face_adjacency, nodes=np.arange(len(mesh.faces))
    )
    assert len(parts) == 1
    assert len(np.unique(mesh.vertices[:, :2], axis=0)) == len(mesh.vertices)  # one z per (x, y)
    x0, y0, x1, y1 = centre_extent(model.grid)
    np.testing.assert_allclose(mesh.bounds[:, :2], [[x0, y0], [x1, y1]], rtol=0, atol=1e-6)


# -- mesh ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("grid", [FLAT, PLANE, CONE, RIDGE], ids=["flat", "plane", "cone", "ridge"])
def test_mesh_is_the_grid_of_cell_centres(grid: HeightGrid) -> None:
    model = TerrainModel.from_grid(grid)
    rows, cols = grid.shape
    assert model.mesh.vertices.dtype == np.float64
    assert len(model.mesh.vertices) == rows * cols
    assert len(model.mesh.faces) == 2 * (rows - 1) * (cols - 1)
    assert not model.decimated and model.grid is grid
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    x, y = grid.index_to_xy(r.ravel(), c.ravel())
    np.testing.assert_array_equal(
        model.mesh.vertices, np.column_stack([x, y, grid.heights.ravel()])
    )
    np.testing.assert_allclose(model.mesh.bounds[:, 2], [grid.zmin, grid.zmax])
    xmin, ymin, xmax, ymax = grid.bounds
    np.testing.assert_array_equal(model.origin, [(xmin + xmax) / 2, (ymin + ymax) / 2, 0.0])
    assert_single_height_field(model)


def test_grid_faces_cover_each_quad_with_two_up_facing_triangles() -> None:
    faces = grid_faces(3, 4)
    assert faces.shape == (12, 3)
    r, c = np.divmod(faces, 4)
    assert np.all(r.max(1) - r.min(1) == 1) and np.all(c.max(1) - c.min(1) == 1)
    quads = r.min(1) * 3 + c.min(1)
    assert np.all(np.bincount(quads) == 2)


def test_tilted_plane_is_reproduced_exactly() -> None:
    model = TerrainModel.from_grid(PLANE)
    x, y = random_xy(PLANE, 2000)
    want = plane(x, y)
    np.testing.assert_allclose(model.surface_height(x, y), want, rtol=0, atol=1e-4)  # float32 z
    top = np.column_stack([x, y, np.full_like(x, 2000.0)])
    hits = model.hit_points(top, [0.0, 0.0, -1.0])
    np.testing.assert_allclose(hits[:, 2], want, rtol=0, atol=1e-3)
    np.testing.assert_allclose(hits[:, :2], top[:, :2], rtol=0, atol=1e-3)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), rows=st.integers(2, 9), cols=st.integers(2, 9))
def test_ray_cast_heights_match_the_exact_surface(seed: int, rows: int, cols: int) -> None:
    rng = np.random.default_rng(seed)
    heights = rng.uniform(0.0, 300.0, (rows, cols)).astype(np.float32)
    grid = HeightGrid(heights, Affine(30.0, 0, X0, 0, -25.0, Y0))
    model = TerrainModel.from_grid(grid)
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    np.testing.assert_array_equal(model.surface_height(*grid.index_to_xy(r, c)), heights)
    x, y = random_xy(grid, 200, seed=seed)
    top = np.column_stack([x, y, np.full_like(x, 1000.0)])
    ray_z = 1000.0 - model.raycast(top, [0.0, 0.0, -1.0])
    np.testing.assert_allclose(ray_z, model.surface_height(x, y), rtol=0, atol=F32)


def test_surface_height_is_nan_off_the_mesh(flat: TerrainModel) -> None:
    x0, y0, x1, y1 = centre_extent(FLAT)
    z = flat.surface_height([x0 - 0.01, x1 + 0.01, x0, x1], [y0, y1, y0 - 0.01, y1 + 0.01])
    assert np.all(np.isnan(z))
    assert flat.surface_height(x0, y0) == 100.0 and flat.surface_height(x1, y1) == 100.0


# -- rays ------------------------------------------------------------------------------------------
def test_vertical_rays_over_flat_ground(flat: TerrainModel) -> None:
    x, y = random_xy(FLAT, 5000)
    top = np.column_stack([x, y, np.full_like(x, 1000.0)])
    np.testing.assert_allclose(flat.raycast(top, [0, 0, -1]), 900.0, rtol=0, atol=1e-3)
    assert np.all(np.isinf(flat.raycast(top, [0, 0, 1])))
    assert np.all(np.isinf(flat.raycast(top, [0, 0, -1], max_range=899.9)))
    np.testing.assert_allclose(flat.raycast(top, [0, 0, -1], max_range=900.1), 900.0, atol=1e-3)
    # non-unit directions give metres all the same
    np.testing.assert_allclose(flat.raycast(top, [0, 0, -1e-3]), 900.0, rtol=0, atol=1e-3)
    oblique = np.array([3.0, -4.0, -12.0])  # |d| = 13: range is 13/12 of the height
    centre = [flat.origin[0], flat.origin[1], 250.0]
    assert flat.raycast(centre, 7 * oblique) == pytest.approx(150.0 * 13 / 12, abs=1e-3)
    # a single ray gives a 0-d result; rays beside the map hit nothing
    assert flat.raycast(top[0], [0, 0, -1]).shape == ()
    x0, _, _, y1 = centre_extent(FLAT)
    assert np.isinf(flat.raycast([x0 - 1.0, y1, 1000.0], [0, 0, -1]))


def test_hit_points_are_map_coordinates_and_nan_for_misses(flat: TerrainModel) -> None:
    o = np.array([[flat.origin[0] + 12.5, flat.origin[1] - 7.25, 400.0]] * 2)
    hits = flat.hit_points(o, [[0, 0, -2.0], [0, 0, 2.0]])
    np.testing.assert_allclose(hits[0], [o[0, 0], o[0, 1], 100.0], rtol=0, atol=1e-3)
    assert np.all(np.isnan(hits[1]))


def test_horizontal_rays_hit_the_cone_at_the_analytic_range() -> None:
    model = TerrainModel.from_grid(CONE)
    az = np.linspace(0, 2 * np.pi, 73)[:-1]
    start = np.column_stack([CX + 900 * np.cos(az), CY + 900 * np.sin(az), np.full_like(az, 400.0)])
    d = model.raycast(start, np.column_stack([-np.cos(az), -np.sin(az), np.zeros_like(az)]))
    # cone height 400 m at r = 400 m, so the range is 500 m; the triangulated cone differs from the
    # true one by <= |Hessian| d**2 / 8 = (0.5 / 400) * 200 / 8 = 0.03 m, i.e. 0.06 m of range
    np.testing.assert_allclose(d, 500.0, rtol=0, atol=0.07)


def test_line_of_sight_over_a_ridge(ridge: TerrainModel) -> None:
    y = np.linspace(Y0 - 20.0, Y0 - 380.0, 50)
    west, east = RX - 500.0, RX + 500.0

    def los(z: float) -> np.ndarray:
        a = np.column_stack([np.full_like(y, west), y, np.full_like(y, z)])
        return ridge.line_of_sight(a, a + np.array([east - west, 0.0, 0.0]))

    assert not np.any(los(150.0)) and not np.any(los(299.95))  # the crest is exactly 300 m
    assert np.all(los(300.05)) and np.all(los(1000.0))
    # targets on the surface are seen on the near slope, hidden on the far one, unseen if buried
    eye = np.array([RX - 300.0, y[0], 400.0])
    x = np.linspace(RX - 190.0, RX + 190.0, 39)
    target = np.column_stack([x, np.full_like(x, y[0]), ridge.surface_height(x, y[0])])
    np.testing.assert_array_equal(ridge.line_of_sight(eye, target), x <= RX)
    np.testing.assert_array_equal(ridge.line_of_sight(target, eye), x <= RX)
    assert not np.any(ridge.line_of_sight(eye, target - [0.0, 0.0, 0.1]))
    # two points on the surface across the concave foot of the slope see each other
    foot, floor = [RX - 150.0, y[0], 150.0], [RX - 400.0, y[0], 100.0]
    assert ridge.line_of_sight(foot, floor) and ridge.line_of_sight(floor, foot)
    assert ridge.line_of_sight(foot, foot)


def test_ray_inputs_are_validated(flat: TerrainModel) -> None:
    o = np.tile([X0, Y0, 500.0], (4, 1))
    with pytest.raises(InputError, match="same number of points"):
        flat.raycast(o, np.tile([0.0, 0.0, -1.0], (3, 1)))
    with pytest.raises(InputError, match=r"\(N, 3\)"):
        flat.raycast(o[:, :2], [0, 0, -1])
    with pytest.raises(ValueError, match="NaN"):
        flat.line_of_sight([X0, np.nan, 1.0], o)
    with pytest.raises(InputError, match="non-zero"):
        flat.raycast(o, [0, 0, 0])
    with pytest.raises(InputError, match="max_range"):
        flat.raycast(o, [0, 0, -1], max_range=float("nan"))


def _raycast_numpy(model: TerrainModel, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """The ranges as the numpy version of raycast computed them (before issue 38)."""
    o, d = np.broadcast_arrays(np.asarray(origins, np.float64), np.asarray(directions, np.float64))
    rays = rays_numpy(o, d, model.origin)
    t = model._scene.cast_rays(o3d.core.Tensor.from_numpy(rays.reshape(-1, 6)))["t_hit"]
    return np.asarray(t.numpy().reshape(o.shape[:-1]).astype(np.float64))


def test_ray_buffer_is_bit_identical_to_its_numpy_twin() -> None:
    rng = np.random.default_rng(3)
    n = 20_000
    d = rng.normal(size=(n, 3)) * rng.uniform(1e-3, 1e3, (n, 1))
    o = rng.uniform(-1e6, 1e6, (n, 3)) + np.array([X0, Y0, 0.0])
    shift = np.array([X0 + 123.4, Y0 - 56.7, 0.0])
    rays = np.empty((n, 6), np.float32)
    assert kernels.ray_buffer(o, d, shift, rays) == 0
    np.testing.assert_array_equal(rays.view(np.int32), rays_numpy(o, d, shift).view(np.int32))
    for bad, bit in (((0, 1), 1), ((3, 4), 2)):
        oo, dd = o.copy(), d.copy()
        (oo if bit == 1 else dd)[bad[0] % n, bad[1] % 3] = np.nan
        assert kernels.ray_buffer(oo, dd, shift, rays) == bit
    d[7] = 0.0
    assert kernels.ray_buffer(o, d, shift, rays) == 4


def test_raycast_gives_the_ranges_of_the_numpy_version() -> None:
    cone = TerrainModel.from_grid(CONE)
    rng = np.random.default_rng(4)
    x0, y0, x1, y1 = cone.grid.bounds
    n = 3000
    o = np.column_stack(
        [rng.uniform(x0 - 50, x1 + 50, n), rng.uniform(y0 - 50, y1 + 50, n), rng.uniform(0, 900, n)]
    )
    d = rng.normal(size=(n, 3))
    t = _raycast_numpy(cone, o, d)
    assert np.isfinite(t).sum() > n // 4
    np.testing.assert_array_equal(cone.raycast(o, d), t)
    np.testing.assert_array_equal(
        cone.raycast(o, d, max_range=300.0), np.where(t <= 300, t, np.inf)
    )
    # one origin for many directions, one direction for many origins, one ray
    np.testing.assert_array_equal(cone.raycast(o[0], d), _raycast_numpy(cone, o[0], d))
    np.testing.assert_array_equal(cone.raycast(o, d[0]), _raycast_numpy(cone, o, d[0]))
    one = cone.raycast(o[5], d[5])
    assert one.shape == () and (one == t[5] or (np.isinf(one) and np.isinf(t[5])))
    # transposed (not C-ordered) inputs
    np.testing.assert_array_equal(cone.raycast(o.T.copy().T, d.T.copy().T), t)


def test_ray_inputs_are_checked_in_order(flat: TerrainModel) -> None:
    o = np.tile([X0, Y0, 500.0], (4, 1))
    bad = o.copy()
    bad[2, 1] = np.inf
    with pytest.raises(InputError, match="origins must be finite"):
        flat.raycast(bad, [0.0, 0.0, 0.0])
    with pytest.raises(InputError, match="directions must be finite"):
        flat.raycast(o, [0.0, np.nan, 0.0])
    with pytest.raises(InputError, match="origins must be finite"):
        flat.raycast(bad, np.tile([0.0, 0.0, -1.0], (3, 1)))  # finite checks before the shapes
    with pytest.raises(InputError, match="non-zero"):
        flat.raycast(o, [0, 0, 0], max_range=float("nan"))


# -- fcl -------------------------------------------------------------------------------------------
def test_sphere_contact_and_clearance_over_flat_ground(flat: TerrainModel) -> None:
    sphere = airframe_sphere(5.0)
    x, y = flat.origin[0] + 3.3, flat.origin[1] - 4.4
    assert flat.collides(sphere, [x, y, 103.0])
    assert not flat.collides(sphere, [x, y, 110.0])
    assert flat.distance(sphere, [x, y, 150.0]) == pytest.approx(45.0, abs=1e-3)
    assert flat.distance(sphere, [x, y, 110.0]) == pytest.approx(5.0, abs=1e-3)
    assert flat.distance(sphere, [x, y, 103.0]) == 0.0
    # wholly underground: touches no triangle, but collides and has negative clearance
    assert flat.collides(sphere, [x, y, 50.0])
    assert flat.distance(sphere, [x, y, 50.0]) == pytest.approx(-45.0, abs=1e-3)


def test_rotation_turns_a_box_into_the_ground(flat: TerrainModel) -> None:
    box = airframe_box(40.0, 2.0, 2.0)
    p = [flat.origin[0], flat.origin[1], 115.0]
    nose_down = np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]])  # body x to -z
    assert not flat.collides(box, p)
    assert flat.distance(box, p) == pytest.approx(14.0, abs=1e-3)
    assert flat.collides(box, p, nose_down)
    with pytest.raises(InputError, match="rotation"):
        flat.collides(box, p, 2 * np.eye(3))
    with pytest.raises(InputError, match="one point"):
        flat.distance(box, [p, p])
    with pytest.raises(InputError, match="positive"):
        airframe_box(40.0, 0.0, 2.0)


def test_sweep_finds_a_ridge_between_distant_samples(ridge: TerrainModel) -> None:
    sphere = airframe_sphere(5.0)
    y = Y0 - 200.0
    path = np.array([[RX - 600.0, y, 250.0], [RX + 600.0, y, 250.0]])
    assert not ridge.collides(sphere, path[0]) and not ridge.collides(sphere, path[1])
    assert ridge.sweep_collides(sphere, path).tolist() == [True]
    assert ridge.sweep_collides(sphere, path, step=5000.0).tolist() == [False]  # ends only
    # centre always above the surface, sphere grazing the crest: only fcl sees it
    graze = path + np.array([0.0, 0.0, 53.0])
    assert ridge.sweep_collides(sphere, graze).tolist() == [True]
    # 10 m above the 45-degree crest the sphere is 7.07 m from the slopes: clear
    assert ridge.sweep_collides(sphere, path + np.array([0.0, 0.0, 60.0])).tolist() == [False]
    legs = np.array(
        [[RX - 900, y, 250], [RX - 600, y, 250], [RX + 600, y, 250], [RX + 900, y, 250]]
    )
    assert ridge.sweep_collides(sphere, legs).tolist() == [False, True, False]


def test_sweep_interpolates_rotations(flat: TerrainModel) -> None:
    box = airframe_box(40.0, 2.0, 2.0)
    o = flat.origin
    path = np.array([[o[0] - 100, o[1], 115.0], [o[0] + 100, o[1], 115.0]])
    pitch = [np.eye(3), np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]])]
    assert flat.sweep_collides(box, path).tolist() == [False]
    assert flat.sweep_collides(box, path, pitch).tolist() == [True]
    # ending at 45 degrees: the nose reaches 115 - 20 sin 45 = 100.9 m, 0.9 m clear
    c = math.sqrt(0.5)
    half = [np.eye(3), np.array([[c, 0, c], [0, 1, 0], [-c, 0, c]])]
    assert flat.sweep_collides(box, path + np.array([0.0, 0.0, 0.5]), half).tolist() == [False]
    with pytest.raises(InputError, match="rotations"):
        flat.sweep_collides(box, path, np.stack(pitch * 2))
    with pytest.raises(InputError, match="at least 2"):
        flat.sweep_collides(box, path[:1])


# -- decimation and misc ---------------------------------------------------------------------------
def test_decimation_respects_the_budget_and_the_surface() -> None:
    amp, a, b = 60.0, 400.0, 650.0

    def smooth(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return 800.0 + amp * np.sin((x - X0) / a) * np.cos((y - Y0) / b)

    grid = make_grid(smooth, 121, 181)
    full = TerrainModel.from_grid(grid)
    budget = len(full.mesh.faces) // 10
    small = TerrainModel.from_grid(grid, max_faces=budget)
    assert small.decimated and small.grid is grid and small.max_faces == budget
    assert budget // 2 < len(small.mesh.faces) <= budget
    assert_single_height_field(small)
    rows, cols = small.mesh_shape
    assert len(small.mesh.vertices) == rows * cols
    # kept vertices are full-grid cell centres with their exact heights
    np.testing.assert_array_equal(
        small.mesh.vertices[:, 2], full.surface_height(*small.mesh.vertices[:, :2].T)
    )
    # linear interpolation error <= |Hessian| d**2 / 8 on each mesh, |Hessian| <= amp (1/a² + 1/b²)
    hess = amp * (1 / a**2 + 1 / b**2)
    tol = hess / 8 * (math.hypot(*small.mesh_spacing) ** 2 + math.hypot(10.0, 10.0) ** 2) + F32
    x, y = random_xy(grid, 5000)
    top = np.column_stack([x, y, np.full_like(x, 2000.0)])
    diff = small.raycast(top, [0, 0, -1]) - full.raycast(top, [0, 0, -1])
    assert np.max(np.abs(diff)) <= tol < 0.5


def test_max_faces_edge_cases() -> None:
    n = 2 * 39 * 59
    assert not TerrainModel.from_grid(FLAT, max_faces=n).decimated
    tiny = TerrainModel.from_grid(FLAT, max_faces=2)
    assert tiny.mesh_shape == (2, 2) and len(tiny.mesh.faces) == 2
    assert_single_height_field(tiny)
    for bad in (1, 0, 2.5, True):
        with pytest.raises(InputError, match="max_faces"):
            TerrainModel.from_grid(FLAT, max_faces=bad)  # type: ignore[arg-type]


def test_pickle_rebuilds_the_model(flat: TerrainModel) -> None:
    copy = pickle.loads(pickle.dumps(flat))
    top = [flat.origin[0], flat.origin[1], 1000.0]
    assert copy.raycast(top, [0, 0, -1]) == flat.raycast(top, [0, 0, -1])
    assert copy.collides(airframe_sphere(5.0), [top[0], top[1], 103.0])


def test_fcl_shapes_are_accepted(flat: TerrainModel) -> None:
    p = [flat.origin[0], flat.origin[1], 104.0]
    for shape in (fcl.Capsule(1.0, 8.0), fcl.Cylinder(1.0, 8.0), fcl.Ellipsoid(1.0, 2.0, 5.0)):
        assert flat.collides(shape, p)
        assert not flat.collides(shape, [p[0], p[1], 106.5])
