"""Tests of `TerrainModel.line_of_sight`'s compiled rays (`terrain.kernels.segment_rays` and
`clear_segments`): the rays, lengths and answers of the numpy version, bit for bit."""

from __future__ import annotations

import numpy as np
import open3d as o3d
import pytest
from affine import Affine

from terrain import kernels
from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrain.model import TerrainModel, segment_rays_numpy

X0, Y0 = 400_000.0, 3_800_000.0


@pytest.fixture(scope="module")
def cone() -> TerrainModel:
    """A cone of slope 0.5 (apex 600 m) on a 100 m floor, 2 x 2 km of 10 m cells."""
    probe = HeightGrid(np.zeros((201, 201), np.float32), Affine(10.0, 0, X0, 0, -10.0, Y0))
    r, c = np.meshgrid(np.arange(201), np.arange(201), indexing="ij")
    x, y = probe.index_to_xy(r, c)
    cx, cy = X0 + 1005.0, Y0 - 1005.0
    z = np.maximum(100.0, 600.0 - 0.5 * np.hypot(x - cx, y - cy))
    return TerrainModel.from_grid(HeightGrid(z.astype(np.float32), probe.transform))


def line_of_sight_numpy(model: TerrainModel, a: object, b: object, tol: float) -> np.ndarray:
    """The answers as the numpy version of line_of_sight computed them."""
    pa, pb = np.broadcast_arrays(np.asarray(a, np.float64), np.asarray(b, np.float64))
    rays, length = segment_rays_numpy(pa, pb, tol, model.origin)
    t = model._scene.cast_rays(o3d.core.Tensor.from_numpy(rays.reshape(-1, 6)))["t_hit"]
    t = t.numpy().reshape(length.shape).astype(np.float64)
    return np.asarray((length <= 2 * tol) | (t >= length - 2 * tol))


def test_segment_rays_are_bit_identical_to_their_numpy_twin() -> None:
    rng = np.random.default_rng(13)
    n = 20_000
    a = rng.uniform(-1e5, 1e5, (n, 3)) + np.array([X0, Y0, 0.0])
    b = a + rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-6, 5, (n, 1))
    b[:50] = a[:50]  # zero segments
    b[50:60] = a[50:60] + 1e-300  # a few ulp apart
    shift = np.array([X0 + 123.4, Y0 - 56.7, 0.0])
    for tol in (0.0, 0.01, 1.0, 37.5):
        rays = np.empty((n, 6), np.float32)
        length, finite = kernels.segment_rays(a, b, tol, shift, rays)
        twin, twin_length = segment_rays_numpy(a, b, tol, shift)
        assert finite
        np.testing.assert_array_equal(rays.view(np.int32), twin.view(np.int32))
        np.testing.assert_array_equal(length.view(np.int64), twin_length.view(np.int64))
    for bad in ((a, 3, 1), (b, 7, 2)):
        arr = bad[0].copy()
        arr[bad[1], bad[2]] = np.inf
        pair = (arr, b) if bad[0] is a else (a, arr)
        assert not kernels.segment_rays(*pair, 1.0, shift, np.empty((n, 6), np.float32))[1]


def test_line_of_sight_gives_the_answers_of_the_numpy_version(cone: TerrainModel) -> None:
    rng = np.random.default_rng(14)
    n = 4000
    x0, y0, x1, y1 = cone.grid.bounds
    a = np.column_stack(
        [rng.uniform(x0, x1, n), rng.uniform(y0, y1, n), rng.uniform(80.0, 800.0, n)]
    )
    b = np.column_stack(
        [rng.uniform(x0, x1, n), rng.uniform(y0, y1, n), rng.uniform(80.0, 800.0, n)]
    )
    b[:20] = a[:20]
    on = cone.surface_height(a[20:40, 0], a[20:40, 1])  # observers on the ground
    a[20:40, 2] = on
    for tol in (0.0, 0.01, 1.0, 5):
        got = cone.line_of_sight(a, b, tolerance=tol)
        want = line_of_sight_numpy(cone, a, b, tol)
        assert got.dtype == bool and 0.2 * n < got.sum() < 0.8 * n
        np.testing.assert_array_equal(got, want)
        # one observer for many targets, many for one, one segment
        np.testing.assert_array_equal(
            cone.line_of_sight(a[0], b, tol), line_of_sight_numpy(cone, a[0], b, tol)
        )
        np.testing.assert_array_equal(
            cone.line_of_sight(a, b[0], tol), line_of_sight_numpy(cone, a, b[0], tol)
        )
        one = cone.line_of_sight(a[7], b[7], tol)
        assert one.shape == () and one == want[7]
        # not C-ordered
        np.testing.assert_array_equal(cone.line_of_sight(a.T.copy().T, b.T.copy().T, tol), want)


def test_line_of_sight_inputs_are_checked_as_before(cone: TerrainModel) -> None:
    o = np.array([X0 + 10.0, Y0 - 10.0, 900.0])
    cases = [
        (([X0, np.nan, 1.0], o), "a must be finite"),
        ((o, [[X0, 1.0, np.inf]]), "b must be finite"),
        ((np.zeros((2, 3)), np.zeros((3, 3))), "same number of points"),
        ((np.zeros(4), o), "a must be one point"),
        ((o, np.zeros((2, 2, 3))), "b must be one point"),
        (([np.nan, 0.0, 0.0], np.zeros((2, 2))), "a must be finite"),
    ]
    for args, message in cases:
        with pytest.raises(InputError, match=message):
            cone.line_of_sight(*args)
