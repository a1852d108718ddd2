"""Tests of `replay.sensors.radar_kernel`: the compiled terrain returns are their numpy twin's, bit
for bit (cells, points, their order and dtypes), by slots and by sorting."""

from __future__ import annotations

import numpy as np
import pytest
from affine import Affine

from replay.sensors import radar_kernel
from replay.sensors.radar import _ALT_SLACK_M, Radar
from replay.sensors.radar_kernel import terrain_returns, terrain_returns_numpy
from terrain.grid import HeightGrid
from terrain.model import TerrainModel

X0, Y0 = 400_000.0, 3_800_000.0


def assert_same(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> None:
    for x, y in zip(a, b, strict=True):
        assert x.dtype == y.dtype and x.shape == y.shape
        assert x.tobytes() == y.tobytes()


@pytest.fixture(scope="module")
def hills() -> TerrainModel:
    """20 x 20 km of rolling hills, 100 m to 1,300 m."""
    n, cell = 200, 100.0
    probe = HeightGrid(np.zeros((n, n), np.float32), Affine(cell, 0, X0, 0, -cell, Y0))
    r, c = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    x, y = probe.index_to_xy(r, c)
    u, v = (x - X0) / 1000.0, (Y0 - y) / 1000.0
    z = 700.0 + 300.0 * np.sin(0.9 * u) * np.cos(0.7 * v) + 300.0 * np.sin(0.4 * u + 1.3 * v)
    return TerrainModel.from_grid(HeightGrid(z.astype(np.float32), probe.transform))


@pytest.mark.parametrize("cell_m", [100.0, 30.0, 0.02])  # 0.02 m: too many cells for slots
def test_terrain_returns_of_scans_over_hills(hills: TerrainModel, cell_m: float) -> None:
    radar = Radar(terrain_cell_m=cell_m)
    dirs, n_fan = radar._rays, radar._n_fan
    rng = np.random.default_rng(5)
    taken = 0
    for _ in range(12):
        own = np.array(
            [X0 + rng.uniform(2e3, 18e3), Y0 - rng.uniform(2e3, 18e3), rng.uniform(600, 1500)]
        )
        clearance = float(rng.choice([0.0, 50.0, 100.0, 400.0]))
        origins = np.empty_like(dirs)
        origins[:n_fan] = own
        origins[n_fan:] = own - np.array([0.0, 0.0, clearance])
        dist = hills.raycast(origins, dirs, max_range=radar.range_m)
        args = (own, clearance, dirs, n_fan, dist, radar.range_m, cell_m, _ALT_SLACK_M)
        twin = terrain_returns_numpy(*args)
        assert_same(terrain_returns(*args), twin)
        taken += len(twin[0])
    assert taken > 100  # the hills are seen


def test_terrain_returns_of_random_hits_with_ties() -> None:
    """Rays in pairs mirrored about x = y from an aircraft on that line: equal ranges to
    different points of a cell, where the first ray's hit must be the one reported."""
    rng = np.random.default_rng(6)
    for _ in range(40):
        n = int(rng.integers(0, 400))
        d = rng.normal(size=(n, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        dirs = np.vstack([d, d[:, [1, 0, 2]]])
        dist = np.tile(rng.uniform(0.0, 1200.0, n), 2)
        dist[rng.random(2 * n) < 0.2] = np.inf
        order = rng.permutation(2 * n)
        dirs, dist = np.ascontiguousarray(dirs[order]), dist[order]
        own = np.full(3, rng.uniform(-500.0, 500.0))
        cell = float(rng.choice([1.0, 50.0, 300.0, 1e-3]))
        n_fan = int(rng.integers(0, 2 * n + 1))
        clearance = float(rng.uniform(0.0, 300.0))
        args = (own, clearance, dirs, n_fan, dist, 1000.0, cell, _ALT_SLACK_M)
        assert_same(terrain_returns(*args), terrain_returns_numpy(*args))
    # nothing kept: empty (0, 2) int64 and (0, 3) float64
    none = (np.zeros(3), 0.0, np.eye(3), 3, np.full(3, np.inf), 1000.0, 100.0, _ALT_SLACK_M)
    assert_same(terrain_returns(*none), terrain_returns_numpy(*none))
    assert terrain_returns(*none)[0].shape == (0, 2)


def test_both_ways_of_finding_each_cells_nearest_agree() -> None:
    rng = np.random.default_rng(7)
    m = 3000
    ci, cj = rng.integers(-20, 20, m), rng.integers(100, 140, m)
    ranges = rng.integers(0, 5, m).astype(np.float64)  # many ties
    by_slot = radar_kernel._nearest_by_bucket(ci, cj, ranges, m, ci.min(), cj.min(), 40)
    by_sort = radar_kernel._nearest_by_sort(ci, cj, ranges, m)
    np.testing.assert_array_equal(by_slot, by_sort)
