"""Synthetic terrain: determinism, exact range, geometry, edge counts, argument checks."""

from __future__ import annotations

import numpy as np
import pytest
from rasterio.crs import CRS

from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrain.synthetic import synthetic_terrain


def test_same_seed_is_bit_identical():
    a = synthetic_terrain(64, 80, seed=11)
    b = synthetic_terrain(64, 80, seed=11)
    assert a.heights.tobytes() == b.heights.tobytes()
    c = synthetic_terrain(64, 80, seed=np.random.default_rng(11))
    assert c.heights.tobytes() == a.heights.tobytes()  # an int seed is default_rng(seed)


def test_different_seeds_differ():
    a = synthetic_terrain(64, 64, seed=1).heights
    b = synthetic_terrain(64, 64, seed=2).heights
    assert not np.array_equal(a, b)
    assert np.mean(np.abs(a - b)) > 50.0  # not just noise: the features move


def test_generator_is_advanced_not_reset():
    rng = np.random.default_rng(5)
    first = synthetic_terrain(32, 32, seed=rng).heights
    second = synthetic_terrain(32, 32, seed=rng).heights
    assert not np.array_equal(first, second)


def test_no_global_random_state_used():
    # Only reads the legacy global state (to prove it is neither used nor changed).
    before = np.random.get_state(legacy=False)  # noqa: NPY002
    synthetic_terrain(32, 32, seed=3)
    after = np.random.get_state(legacy=False)  # noqa: NPY002
    assert before["state"]["pos"] == after["state"]["pos"]
    assert np.array_equal(before["state"]["key"], after["state"]["key"])


@pytest.mark.parametrize(
    ("base", "relief"), [(200.0, 1500.0), (-50.0, 10.0), (0.0, 4000.0), (123.5, 0.25)]
)
def test_range_is_hit_exactly(base, relief):
    g = synthetic_terrain(48, 40, seed=4, base=base, relief=relief)
    assert g.heights.dtype == np.float32
    assert g.heights.min() == np.float32(base)
    assert g.heights.max() == np.float32(base + relief)


def test_shape_cell_size_origin_bounds():
    g = synthetic_terrain(30, 50, 12.5, seed=0, origin=(1000.0, -2000.0))
    assert isinstance(g, HeightGrid)
    assert g.shape == (30, 50)
    assert g.cell_size == (12.5, 12.5)
    assert g.bounds == (1000.0, -2000.0, 1000.0 + 50 * 12.5, -2000.0 + 30 * 12.5)
    assert g.crs is None
    assert g.sources and "seed=0" in g.sources[0]


def test_utm_origin_and_crs():
    x0, y0 = 376313.655, 3807917.83
    g = synthetic_terrain(20, 20, 30.0, origin=(x0, y0), crs=32611)
    assert g.crs == CRS.from_epsg(32611)
    xmin, ymin, xmax, ymax = g.bounds
    assert (xmin, xmax) == (x0, x0 + 600.0)
    assert ymin == pytest.approx(y0, abs=1e-9) and ymax == y0 + 600.0
    lon, lat = g.to_lonlat(x0 + 300.0, y0 + 300.0)
    assert -118.4 < float(lon) < -118.2 and 34.3 < float(lat) < 34.5


def test_minimum_grid_size():
    g = synthetic_terrain(2, 2, seed=0)
    assert g.shape == (2, 2)
    assert g.heights.min() == np.float32(200.0) and g.heights.max() == np.float32(1700.0)


def test_no_peaks_or_ridges_still_spans_range():
    grids = [
        synthetic_terrain(40, 40, seed=9, peaks=0),
        synthetic_terrain(40, 40, seed=9, ridges=0),
        synthetic_terrain(40, 40, seed=9, peaks=0, ridges=0),
        synthetic_terrain(40, 40, seed=9, peaks=0, ridges=0, valleys=0),  # noise only
    ]
    for g in grids:
        assert g.zmin == 200.0 and g.zmax == 1700.0
    assert not np.array_equal(grids[0].heights, grids[1].heights)


def test_flat_cases_are_base_everywhere():
    flat = synthetic_terrain(16, 16, peaks=0, ridges=0, valleys=0, roughness=0.0, base=75.0)
    assert np.all(flat.heights == np.float32(75.0))
    zero_relief = synthetic_terrain(16, 16, relief=0.0, base=-3.0)
    assert np.all(zero_relief.heights == np.float32(-3.0))


def test_roughness_zero_is_smooth_and_larger_roughness_is_rougher():
    def mean_abs_laplacian(h: np.ndarray) -> float:
        h = h.astype(np.float64)
        lap = h[1:-1, :-2] + h[1:-1, 2:] + h[:-2, 1:-1] + h[2:, 1:-1] - 4 * h[1:-1, 1:-1]
        return float(np.mean(np.abs(lap)))

    smooth = synthetic_terrain(128, 128, seed=1, roughness=0.0).heights
    rough = synthetic_terrain(128, 128, seed=1, roughness=0.5).heights
    assert mean_abs_laplacian(rough) > 2 * mean_abs_laplacian(smooth)


def test_a_single_peak_is_the_maximum_and_smooth():
    g = synthetic_terrain(64, 64, seed=0, peaks=1, ridges=0, valleys=0, roughness=0.0)
    h = g.heights
    r, c = np.unravel_index(np.argmax(h), h.shape)
    # Heights fall off monotonically along the row and column through the single peak.
    assert np.all(np.diff(h[r, : c + 1]) >= 0) and np.all(np.diff(h[r, c:]) <= 0)
    assert np.all(np.diff(h[: r + 1, c]) >= 0) and np.all(np.diff(h[r:, c]) <= 0)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"rows": 1}, "rows must be an integer >= 2; got 1"),
        ({"cols": 2.5}, "cols must be an integer >= 2; got 2.5"),
        ({"rows": True}, "rows must be an integer >= 2; got True"),
        ({"cell_size": 0.0}, "cell_size must be a finite number > 0; got 0.0"),
        ({"cell_size": float("nan")}, "cell_size must be a finite number > 0; got nan"),
        ({"relief": -1.0}, "relief must be a finite number >= 0; got -1.0"),
        ({"base": float("inf")}, "base must be a finite number; got inf"),
        ({"roughness": -0.1}, "roughness must be a finite number >= 0; got -0.1"),
        ({"peaks": -1}, "peaks must be an integer >= 0; got -1"),
        ({"ridges": 1.0}, "ridges must be an integer >= 0; got 1.0"),
        ({"valleys": -2}, "valleys must be an integer >= 0; got -2"),
        ({"seed": -1}, "seed must be an integer >= 0 or a numpy Generator; got -1"),
        ({"seed": "abc"}, "seed must be an integer >= 0 or a numpy Generator; got 'abc'"),
        ({"origin": (1.0,)}, "origin must be two finite numbers (x, y); got (1.0,)"),
        ({"origin": (0.0, float("nan"))}, "origin must be a finite number; got nan"),
        ({"crs": "not a crs"}, "crs: not a coordinate reference system: 'not a crs'"),
    ],
)
def test_bad_arguments(kwargs, message):
    with pytest.raises(InputError) as info:
        synthetic_terrain(**kwargs)
    assert message in str(info.value)
