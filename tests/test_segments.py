"""Bresenham segment-versus-terrain checks: the cells walked, the lengths below ground, and the
agreement of the numba kernel with its pure-numpy twin."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain import kernels
from terrain import segments as segments_module
from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrain.segments import (
    below_terrain_lengths,
    below_terrain_lengths_numpy,
    bresenham_cells,
    bresenham_cells_numpy,
    path_below_lengths,
)
from tests.conftest import make_grid

ints = st.integers(-60, 60)


@given(r0=ints, c0=ints, r1=ints, c1=ints)
def test_bresenham_is_a_connected_run_between_the_end_cells(
    r0: int, c0: int, r1: int, c1: int
) -> None:
    cells = bresenham_cells(r0, c0, r1, c1)
    assert tuple(cells[0]) == (r0, c0) and tuple(cells[-1]) == (r1, c1)
    steps = np.abs(np.diff(cells, axis=0))
    assert (steps.max(axis=1) == 1).all()  # 8-connected, no repeats, no gaps
    assert len(cells) == max(abs(r1 - r0), abs(c1 - c0)) + 1
    assert np.array_equal(cells, bresenham_cells_numpy(r0, c0, r1, c1))


def test_bresenham_known_line() -> None:
    # the textbook octant-0 example: (0,0) -> (3 rows, 8 cols)
    cells = bresenham_cells(0, 0, 3, 8).tolist()
    assert cells == [[0, 0], [0, 1], [1, 2], [1, 3], [1, 4], [2, 5], [2, 6], [3, 7], [3, 8]]


FLAT = make_grid(np.full((50, 60), 100.0), cell=10.0, x0=0.0, y0=500.0)
RNG = np.random.default_rng(3)
ROUGH = make_grid(RNG.uniform(0.0, 300.0, size=(40, 45)), cell=30.0, x0=1000.0, y0=5000.0)


def test_flat_ground_cases_are_exact() -> None:
    p0 = np.array([[10.0, 20.0, 50.0], [10.0, 20.0, 150.0], [5.0, 5.0, 99.0], [300.0, 300.0, 10.0]])
    p1 = np.array(
        [[400.0, 480.0, 50.0], [400.0, 480.0, 150.0], [5.0, 5.0, 99.0], [300.0, 300.0, 10.0]]
    )
    length = np.linalg.norm(p1 - p0, axis=1)
    for backend in ("numba", "numpy"):
        got = below_terrain_lengths(FLAT, p0, p1, backend=backend)  # type: ignore[arg-type]
        assert got[0] == pytest.approx(length[0], rel=1e-12)  # entirely below
        assert got[1] == 0.0  # entirely above
        assert got[2] == 0.0 and got[3] == 0.0  # zero-length segments have no length below


def test_clearance_counts_as_ground() -> None:
    p0, p1 = np.array([[10.0, 20.0, 120.0]]), np.array([[400.0, 20.0, 120.0]])
    assert below_terrain_lengths(FLAT, p0, p1)[0] == 0.0
    assert below_terrain_lengths(FLAT, p0, p1, clearance=30.0)[0] == pytest.approx(390.0)


def test_descending_segment_is_below_for_about_half_its_length() -> None:
    # from 150 m to 50 m over flat 100 m ground: below for the second half, to within one cell
    p0, p1 = np.array([[5.0, 255.0, 150.0]]), np.array([[595.0, 255.0, 50.0]])
    got = below_terrain_lengths(FLAT, p0, p1)[0]
    length = float(np.linalg.norm(p1 - p0))
    assert abs(got - length / 2) <= length / 59 + 1e-9  # 60 cells walked


def test_a_part_counts_when_its_lowest_end_is_below() -> None:
    """A descending segment along one row of cells, over flat ground with 50 m clearance: from
    60 m to 41 m over four cell steps (cell centres at t = 0, 0.25, 0.5, 0.75, 1).  Cell 2's part
    runs t 0.375..0.625; at its centre (t = 0.5) the segment is at 50.5 m, clear, but it leaves the
    part at 48.1 m: below.  So cells 2, 3 and 4 count (t from 0.375 on), not only 3 and 4 (the
    altitude at the centre, which let a plan pass the cost and fail the validity layer's samples
    at a part's end)."""
    grid = make_grid(np.zeros((3, 8)), cell=10.0, x0=0.0, y0=30.0)
    p0, p1 = np.array([[5.0, 15.0, 60.0]]), np.array([[45.0, 15.0, 41.0]])
    length = float(np.linalg.norm(p1 - p0))
    for fn in (below_terrain_lengths, below_terrain_lengths_numpy):
        assert fn(grid, p0, p1, 50.0)[0] == pytest.approx(0.625 * length)
        assert fn(grid, p1, p0, 50.0)[0] == pytest.approx(0.625 * length)  # either direction


@settings(max_examples=60, deadline=None)
@given(
    pts=st.lists(st.floats(0.0, 1.0), min_size=6, max_size=6),
    clearance=st.floats(0.0, 50.0),
)
def test_parts_tile_the_segment_and_backends_agree(pts: list[float], clearance: float) -> None:
    xmin, ymin, xmax, ymax = ROUGH.bounds
    p0 = np.array([[xmin + pts[0] * (xmax - xmin), ymin + pts[1] * (ymax - ymin), 400 * pts[2]]])
    p1 = np.array([[xmin + pts[3] * (xmax - xmin), ymin + pts[4] * (ymax - ymin), 400 * pts[5]]])
    a = below_terrain_lengths(ROUGH, p0, p1, clearance)
    b = below_terrain_lengths_numpy(ROUGH, p0, p1, clearance)
    assert a[0] == pytest.approx(b[0], abs=1e-9)
    length = float(np.linalg.norm(p1 - p0))
    assert 0.0 <= a[0] <= length + 1e-9
    # with an infinite clearance every part is "below": the parts add up to the whole segment
    assert below_terrain_lengths(ROUGH, p0, p1, 1e9)[0] == pytest.approx(
        length, rel=1e-12, abs=1e-9
    )
    # the length below does not depend on the direction the segment is given in
    assert below_terrain_lengths(ROUGH, p1, p0, clearance)[0] == a[0]
    assert below_terrain_lengths_numpy(ROUGH, p1, p0, clearance)[0] == pytest.approx(b[0], abs=1e-9)


def test_swarm_of_paths_in_one_call_matches_numpy() -> None:
    xmin, ymin, xmax, ymax = ROUGH.bounds
    rng = np.random.default_rng(11)
    paths = np.stack(
        [
            rng.uniform(xmin, xmax, (64, 8)),
            rng.uniform(ymin, ymax, (64, 8)),
            rng.uniform(0, 400, (64, 8)),
        ],
        axis=2,
    )
    a = path_below_lengths(ROUGH, paths)
    b = path_below_lengths(ROUGH, paths, backend="numpy")
    assert a.shape == (64,)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-8)
    seg = np.linalg.norm(np.diff(paths, axis=1), axis=2).sum(axis=1)
    assert (a <= seg + 1e-9).all() and (a > 0).any() and (a < seg).any()


def test_the_compiled_segment_table_is_its_numpy_twin_bit_for_bit() -> None:
    # the walk's cells and parts depend on the table's exact bits (ties at cell borders)
    xmin, ymin, xmax, ymax = ROUGH.bounds
    rng = np.random.default_rng(5)
    lo, hi = np.array([xmin, ymin, 0.0]), np.array([xmax, ymax, 400.0])
    a, b = lo + rng.random((5000, 3)) * (hi - lo), lo + rng.random((5000, 3)) * (hi - lo)
    a[:10, :2] = np.round(a[:10, :2])  # on cell borders and centres
    table = segments_module._segment_table(ROUGH, a, b)
    assert np.array_equal(table, segments_module.segment_table_numpy(ROUGH, a, b))
    row, col = ROUGH.xy_to_index(a[:, 0], a[:, 1])
    assert np.array_equal(table[:, 0], row) and np.array_equal(table[:, 1], col)


def test_a_ridge_between_two_high_points_is_found() -> None:
    h = np.full((20, 40), 100.0)
    h[:, 20] = 800.0  # a one-cell wall across the map
    g = make_grid(h, cell=10.0, x0=0.0, y0=200.0)
    got = below_terrain_lengths(g, [[5.0, 100.0, 500.0]], [[395.0, 100.0, 500.0]])[0]
    assert got == pytest.approx(10.0, abs=1e-9)  # exactly one cell's share of the segment


def test_bad_segments_are_refused() -> None:
    with pytest.raises(InputError, match="finite"):
        below_terrain_lengths(FLAT, [[0.0, np.nan, 0.0]], [[1.0, 1.0, 1.0]])
    with pytest.raises(InputError, match=r"\(M, 3\)"):
        below_terrain_lengths(FLAT, [[0.0, 0.0]], [[1.0, 1.0]])
    with pytest.raises(InputError, match="backend"):
        below_terrain_lengths(FLAT, [[0.0, 0.0, 0]], [[1.0, 1.0, 1]], backend="fortran")  # type: ignore[arg-type]
    with pytest.raises(InputError, match="paths"):
        path_below_lengths(FLAT, np.zeros((3, 1, 3)))


def _hills() -> HeightGrid:
    """A 300 x 280 grid of smooth hills and one sharp one-cell spike."""
    yy, xx = np.mgrid[0:300, 0:280]
    h = 400.0 + 250.0 * np.sin(xx / 23.0) * np.cos(yy / 31.0) + 0.5 * xx
    h[150, 140] = 1500.0
    return make_grid(h, cell=30.0, x0=0.0, y0=9000.0)


def test_block_skipping_changes_no_bit() -> None:
    g = _hills()
    assert g.block_maxima.shape == (19, 18)  # 16-cell blocks, the last ones partial
    assert g.block_maxima[9, 8] == 1500.0  # the spike's block
    rng = np.random.default_rng(5)
    m = 3000
    xmin, ymin, xmax, ymax = g.bounds
    lo = [xmin - 500, ymin - 500, 200.0]
    hi = [xmax + 500, ymax + 500, 1100.0]
    p0, p1 = rng.uniform(lo, hi, (m, 3)), rng.uniform(lo, hi, (m, 3))
    p1[:300, :2] = p0[:300, :2] + rng.uniform(-60, 60, (300, 2))  # short, within a block or two
    p1[300:400, 0] = p0[300:400, 0]  # along a column
    p1[400:500, 1] = p0[400:500, 1]  # along a row
    p0[500:520] = [4200.0 - 900.0, 9000.0 - 4515.0, 1200.0]  # level, over the spike's row
    p1[500:520] = [4200.0 + 900.0, 9000.0 - 4515.0, 1200.0]
    table = segments_module._segment_table(g, p0, p1)
    for clearance in (0.0, 50.0):
        fast = below_terrain_lengths(g, p0, p1, clearance)
        full = kernels.below_lengths(
            table, g.heights, clearance, np.full_like(g.block_maxima, np.inf)
        )
        np.testing.assert_array_equal(fast, full)  # skipped cells add nothing
        np.testing.assert_allclose(
            fast, below_terrain_lengths_numpy(g, p0, p1, clearance), atol=1e-8
        )
        assert 0.05 * m < np.count_nonzero(fast) < 0.95 * m
        assert (fast[500:520] > 0).all()  # the spike is found inside a clear stretch
        # blocks claiming flat ground at -inf make the walk skip everything: the check consults them
        blind = kernels.below_lengths(
            table, g.heights, clearance, np.full_like(g.block_maxima, -np.inf)
        )
        assert not blind.any()


def test_cells_passed_without_their_parameters_change_no_bit() -> None:
    """Issue 38: inside a walked chunk the kernel passes a cell lower than the chunk's lowest
    altitude without computing its part, and carries a cell's parameters to the next; on
    segments hugging the terrain (most cells near the ground, a quarter below, climbing,
    descending and level, float32 heights) every length is the numpy twin's, bit for bit (the
    twin adds every cell's part, 0.0 for a clear one, in the walk's order)."""
    yy, xx = np.mgrid[0:200, 0:220]
    h = 600.0 + 180.0 * np.sin(xx / 9.0) * np.cos(yy / 13.0) + 0.7 * xx
    g = make_grid(h.astype(np.float32), cell=30.0, x0=1000.0, y0=8000.0)
    rng = np.random.default_rng(38)
    m = 4000
    xmin, ymin, xmax, ymax = g.bounds
    p0 = rng.uniform([xmin - 200, ymin - 200, 0.0], [xmax + 200, ymax + 200, 1.0], (m, 3))
    p1 = p0 + rng.normal(0.0, 1500.0, (m, 3)) * [1.0, 1.0, 0.0]
    p1[:500, :2] = p0[:500, :2] + rng.uniform(-90, 90, (500, 2))  # a few cells long
    ground0 = g.heights[g.cell_of(np.clip(p0[:, 0], xmin, xmax), np.clip(p0[:, 1], ymin, ymax))]
    ground1 = g.heights[g.cell_of(np.clip(p1[:, 0], xmin, xmax), np.clip(p1[:, 1], ymin, ymax))]
    p0[:, 2] = ground0 + rng.uniform(-40.0, 260.0, m)
    p1[:, 2] = ground1 + rng.uniform(-40.0, 260.0, m)
    p1[600:700, 2] = p0[600:700, 2]  # level
    for clearance in (0.0, 50.0):
        got = below_terrain_lengths(g, p0, p1, clearance)
        np.testing.assert_array_equal(got, below_terrain_lengths_numpy(g, p0, p1, clearance))
        assert 0.2 * m < np.count_nonzero(got) < 0.9 * m


def test_paths_table_is_the_segments_table_bit_for_bit() -> None:
    """Issue 38: a swarm's table is read straight from its (P, W, 3) paths; the same rows as
    the table of the segments' ends (``paths[:, :-1] -> paths[:, 1:]``), so the same lengths
    below as segment by segment; a NaN is refused as before."""
    xmin, ymin, xmax, ymax = ROUGH.bounds
    rng = np.random.default_rng(38)
    lo, hi = np.array([xmin, ymin, 0.0]), np.array([xmax, ymax, 400.0])
    paths = lo + rng.random((40, 9, 3)) * (hi - lo)
    paths[:3, :, :2] = np.round(paths[:3, :, :2])  # on cell borders and centres
    a, b = paths[:, :-1].reshape(-1, 3), paths[:, 1:].reshape(-1, 3)
    dx, dy = ROUGH.cell_size
    table = kernels.path_segment_table(
        paths, float(ROUGH.transform.c), float(ROUGH.transform.f), float(dx), float(dy)
    )
    assert np.array_equal(table, segments_module._segment_table(ROUGH, a, b))
    for clearance in (0.0, 30.0):
        per = below_terrain_lengths(ROUGH, a, b, clearance).reshape(40, 8).sum(axis=1)
        np.testing.assert_array_equal(path_below_lengths(ROUGH, paths, clearance), per)
    paths[5, 4, 1] = np.nan
    with pytest.raises(InputError, match="finite"):
        path_below_lengths(ROUGH, paths)
