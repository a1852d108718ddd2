"""HeightGrid: bilinear lookup, map <-> index conversions, crop, GeoTIFF round trip."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rasterio.crs import CRS

from terrain.errors import InputError, TerrapathError
from terrain.grid import HeightGrid, crs_label
from terrain.load import load_dem
from tests.conftest import DATA_MAPS, make_grid

RNG = np.random.default_rng(7)
RANDOM = make_grid(RNG.uniform(100, 900, size=(23, 31)), cell=25.0)


@given(r=st.integers(0, 22), c=st.integers(0, 30))
def test_bilinear_is_exact_at_cell_centres(r: int, c: int) -> None:
    x, y = RANDOM.index_to_xy(r, c)
    assert RANDOM.height_at(x, y) == pytest.approx(float(RANDOM.heights[r, c]), abs=1e-4)


@given(row=st.floats(-5, 30, allow_nan=False), col=st.floats(-5, 40, allow_nan=False))
def test_map_index_round_trip(row: float, col: float) -> None:
    x, y = RANDOM.index_to_xy(row, col)
    r2, c2 = RANDOM.xy_to_index(x, y)
    assert r2 == pytest.approx(row, abs=1e-7)
    assert c2 == pytest.approx(col, abs=1e-7)


@settings(max_examples=50)
@given(fr=st.floats(0, 1), fc=st.floats(0, 1))
def test_bilinear_reproduces_a_plane(fr: float, fc: float) -> None:
    rows, cols = np.mgrid[0:10, 0:12]
    g = make_grid(3.0 * rows - 2.0 * cols + 500.0, cell=10.0)
    r, c = 2 + 5 * fr, 3 + 6 * fc
    x, y = g.index_to_xy(r, c)
    assert g.height_at(x, y) == pytest.approx(3.0 * r - 2.0 * c + 500.0, abs=1e-3)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_compiled_bilinear_is_its_numpy_twin_bit_for_bit(dtype: type) -> None:
    # terrain.kernels.bilinear against HeightGrid.height_at_numpy: inside, on the edges and
    # outside the grid (clamped), scalars, broadcasting and float32 heights
    g = make_grid(RNG.uniform(-50, 4000, size=(17, 29)).astype(dtype), cell=30.0, x0=1e5, y0=4e6)
    rng = np.random.default_rng(3)
    xmin, ymin, xmax, ymax = g.bounds
    x = np.concatenate([rng.uniform(xmin - 90, xmax + 90, 5000), [xmin, xmax, xmin + 15.0]])
    y = np.concatenate([rng.uniform(ymin - 90, ymax + 90, 5000), [ymin, ymax, ymax - 15.0]])
    got, want = g.height_at(x, y), g.height_at_numpy(x, y)
    assert got.dtype == np.float64 and got.shape == x.shape
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(
        g.height_at(x[:7].reshape(7, 1), y[:3]), g.height_at_numpy(x[:7].reshape(7, 1), y[:3])
    )
    assert np.shape(g.height_at(x[0], y[0])) == () and float(g.height_at(x[0], y[0])) == float(
        want[0]
    )


def test_geometry_and_cell_of() -> None:
    g = make_grid(np.zeros((4, 5)), cell=10.0, x0=100.0, y0=200.0)
    assert g.bounds == (100.0, 160.0, 150.0, 200.0)
    assert g.cell_size == (10.0, 10.0)
    r, c = g.cell_of([101.0, 149.9, 125.0], [199.0, 160.1, 185.0])
    assert r.tolist() == [0, 3, 1] and c.tolist() == [0, 4, 2]
    assert g.contains([99.0, 120.0], [180.0, 180.0]).tolist() == [False, True]


def test_grid_is_immutable() -> None:
    g = make_grid(np.ones((3, 3)))
    with pytest.raises(ValueError):
        g.heights[0, 0] = 5.0
    with pytest.raises(AttributeError):
        g.crs = None  # type: ignore[misc]


def test_nan_coordinates_are_refused_with_a_message() -> None:
    with pytest.raises(InputError, match="NaN"):
        RANDOM.height_at([1.0, np.nan], [2.0, 3.0])
    with pytest.raises(InputError, match="NaN"):
        RANDOM.xy_to_index(np.nan, 0.0)
    with pytest.raises(InputError):
        make_grid(np.full((3, 3), np.nan))


def test_crop_keeps_the_cells_of_the_box() -> None:
    g = make_grid(np.arange(100, dtype=float).reshape(10, 10), cell=10.0, x0=0.0, y0=100.0)
    c = g.crop(20.0, 30.0, 60.0, 80.0)
    assert c.bounds == (20.0, 30.0, 60.0, 80.0)
    assert c.heights[0, 0] == g.heights[2, 2]
    with pytest.raises(InputError, match="outside the map"):
        g.crop(500.0, 500.0, 600.0, 600.0)
    with pytest.raises(InputError, match="xmin < xmax"):
        g.crop(60.0, 30.0, 20.0, 80.0)


def test_lonlat_needs_a_crs() -> None:
    with pytest.raises(TerrapathError, match="no CRS"):
        RANDOM.to_lonlat(400100.0, 3799900.0)


def test_lonlat_round_trip_and_geotiff(tmp_path) -> None:  # type: ignore[no-untyped-def]
    g = make_grid(
        RNG.uniform(0, 100, (20, 20)), crs=CRS.from_epsg(32611), x0=376313.0, y0=3807917.0
    )
    lon, lat = g.to_lonlat(376500.0, 3807500.0)
    assert -119 < lon < -117 and 34 < lat < 35
    x, y = g.from_lonlat(lon, lat)
    assert x == pytest.approx(376500.0, abs=1e-3) and y == pytest.approx(3807500.0, abs=1e-3)
    out = g.to_geotiff(tmp_path / "g.tif")
    back = load_dem(out)
    assert np.array_equal(back.heights, g.heights)
    assert back.transform == g.transform and back.crs == g.crs
    assert not list(tmp_path.glob("*.part"))


def test_crs_label() -> None:
    g = load_dem(DATA_MAPS / "stars_olinda_utm25s" / "olinda_dem_utm25s.tif")
    assert crs_label(g.crs) == "EPSG:32000"  # SIRGAS 1995 / UTM zone 25S: what GDAL matches
    assert crs_label(CRS.from_epsg(32611)) == "EPSG:32611"
    custom = CRS.from_wkt(CRS.from_epsg(32611).to_wkt().replace('AUTHORITY["EPSG","32611"]', ""))
    assert crs_label(custom).startswith(("EPSG:", "WGS 84 / UTM zone 11N"))
    assert crs_label(None) == "local"


def test_too_small_grid_refused() -> None:
    with pytest.raises(InputError, match="2 x 2"):
        HeightGrid(np.zeros((1, 5), dtype=np.float32), make_grid(np.zeros((2, 2))).transform)


def test_fast_lonlat_matches_the_exact_transform() -> None:
    g = make_grid(
        RNG.uniform(0, 100, (700, 1200)), crs=CRS.from_epsg(32611), x0=376313.0, y0=3807917.0
    )
    fast = g.lonlat_interpolator()
    rng = np.random.default_rng(1)
    xmin, ymin, xmax, ymax = g.bounds
    x, y = rng.uniform(xmin, xmax, 500), rng.uniform(ymin, ymax, 500)
    lon, lat = g.to_lonlat(x, y)
    flon, flat = fast(x, y)
    # 1e-7 degrees is about a centimetre
    assert np.abs(flon - lon).max() < 1e-7 and np.abs(flat - lat).max() < 1e-7
    far = fast(xmax + 1e5, ymax)  # outside the lattice: the exact transform
    assert np.allclose(far, g.to_lonlat(xmax + 1e5, ymax))
