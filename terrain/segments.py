"""Segment-versus-terrain checks: how much of each 3D segment runs below the ground.

Seed 002 compares the altitude of the trajectory with the terrain "in a discrete way using
Bresenham's line drawing algorithm". Here that is made exact and vectorised:

- each segment's ends are mapped to fractional grid indices; the end cells are the cells that
  contain the ends; the walk starts at the lexicographically smaller end (row, col, z), so a
  segment and its reverse give the same length (Bresenham's tie-breaks depend on direction); the integer Bresenham line between them gives the visited cells (8-connected,
  one cell per step of the major axis);
- cell k stands for the part of the segment between the midpoints of t_{k-1}, t_k, t_{k+1}, where
  t_k is the parameter at which the major-axis coordinate of the segment reaches the cell centre
  (clamped to [0, 1]); these parts tile the segment exactly, so the lengths add up to the segment's
  3D length;
- that part counts as below ground when the segment's lowest altitude over it (at one of the
  part's ends: the segment is straight) is below the cell's height (plus an optional clearance).
  Cells outside the grid take the nearest edge cell's height.  Seed 002 samples one altitude a
  cell; taking the altitude at t_k (the first version here) let a climbing or descending segment
  dip up to its gradient x half a cell below terrain + clearance at a part's end, where the
  validity layer's samples then refused it (0.1-5 m, found on jacksboro once the planner's plans
  hugged the clearance floor; issue 20): the lowest altitude closes that gap.

Two implementations with the same arithmetic: :func:`below_terrain_lengths` uses the numba kernel
(``terrain.kernels``), :func:`below_terrain_lengths_numpy` is the pure-numpy reference (one
vectorised pass over all cells of all segments). Tests compare them.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import numpy.typing as npt

from terrain import kernels
from terrain.errors import InputError
from terrain.grid import HeightGrid

FloatArray = npt.NDArray[np.float64]
Backend = Literal["numba", "numpy"]


def bresenham_cells(r0: int, c0: int, r1: int, c1: int) -> npt.NDArray[np.int64]:
    """Cells (row, col) of the Bresenham line between two cells, ends included (numba)."""
    return np.asarray(kernels.bresenham_cells(int(r0), int(c0), int(r1), int(c1)))


def bresenham_cells_numpy(r0: int, c0: int, r1: int, c1: int) -> npt.NDArray[np.int64]:
    """Closed form of the same line: minor_k = floor((2 k d_minor + d_major - 1) / (2 d_major))."""
    dr, dc = abs(r1 - r0), abs(c1 - c0)
    sr = 1 if r1 >= r0 else -1
    sc = 1 if c1 >= c0 else -1
    n = max(dr, dc)
    k = np.arange(n + 1, dtype=np.int64)
    minor = (2 * k * min(dr, dc) + n - 1) // (2 * n) if n else k * 0
    if dc >= dr:
        return np.stack([r0 + sr * minor, c0 + sc * k], axis=1)
    return np.stack([r0 + sr * k, c0 + sc * minor], axis=1)


def _segment_table(
    grid: HeightGrid, p0: npt.ArrayLike, p1: npt.ArrayLike, backend: Backend = "numba"
) -> FloatArray:
    a = np.asarray(p0, dtype=np.float64)
    b = np.asarray(p1, dtype=np.float64)
    if a.shape != b.shape or a.ndim != 2 or a.shape[1] != 3:
        raise InputError(
            f"segment ends must be two (M, 3) arrays of x, y, z; got shapes {a.shape} and {b.shape}"
        )
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        raise InputError("segment coordinates must be finite; found NaN or infinity")
    if backend == "numpy":
        return segment_table_numpy(grid, a, b)
    dx, dy = grid.cell_size
    left, top = float(grid.transform.c), float(grid.transform.f)
    return np.asarray(
        kernels.segment_table(
            np.ascontiguousarray(a), np.ascontiguousarray(b), left, top, float(dx), float(dy)
        )
    )


def segment_table_numpy(grid: HeightGrid, a: FloatArray, b: FloatArray) -> FloatArray:
    """Pure-numpy twin of ``terrain.kernels.segment_table``."""
    r0, c0 = grid.xy_to_index(a[:, 0], a[:, 1])
    r1, c1 = grid.xy_to_index(b[:, 0], b[:, 1])
    length = np.linalg.norm(b - a, axis=1)
    return np.ascontiguousarray(np.stack([r0, c0, r1, c1, a[:, 2], b[:, 2], length], axis=1))


def below_terrain_lengths(
    grid: HeightGrid,
    p0: npt.ArrayLike,
    p1: npt.ArrayLike,
    clearance: float = 0.0,
    *,
    backend: Backend = "numba",
) -> FloatArray:
    """Length (m) of each segment p0[i] -> p1[i] that runs below terrain + clearance."""
    if backend == "numpy":
        return below_terrain_lengths_numpy(grid, p0, p1, clearance)
    if backend != "numba":
        raise InputError(f"backend must be 'numba' or 'numpy'; got {backend!r}")
    table = _segment_table(grid, p0, p1)
    return np.asarray(
        kernels.below_lengths(
            table, np.ascontiguousarray(grid.heights), float(clearance), grid.block_maxima
        )
    )


def below_terrain_lengths_numpy(
    grid: HeightGrid, p0: npt.ArrayLike, p1: npt.ArrayLike, clearance: float = 0.0
) -> FloatArray:
    """Pure-numpy reference of :func:`below_terrain_lengths` (same cells, same arithmetic)."""
    seg = _segment_table(grid, p0, p1, "numpy")
    m = seg.shape[0]
    if m == 0:
        return np.zeros(0)
    # walk from the lexicographically smaller end (as the kernel does)
    a, b = seg[:, [0, 1, 4]], seg[:, [2, 3, 5]]
    first = np.argmax(a != b, axis=1)
    rows = np.arange(m)
    flip = (a != b).any(axis=1) & (b[rows, first] < a[rows, first])
    seg[flip] = seg[flip][:, [2, 3, 0, 1, 5, 4, 6]]
    r0 = np.floor(seg[:, 0] + 0.5).astype(np.int64)
    c0 = np.floor(seg[:, 1] + 0.5).astype(np.int64)
    r1 = np.floor(seg[:, 2] + 0.5).astype(np.int64)
    c1 = np.floor(seg[:, 3] + 0.5).astype(np.int64)
    dr, dc = np.abs(r1 - r0), np.abs(c1 - c0)
    sr = np.where(r1 >= r0, 1, -1)
    sc = np.where(c1 >= c0, 1, -1)
    n = np.maximum(dr, dc)
    col_major = dc >= dr
    counts = n + 1
    idx = np.repeat(np.arange(m), counts)
    start = np.cumsum(counts) - counts
    k = np.arange(idx.size) - start[idx]
    ni, dmin = n[idx], np.minimum(dr, dc)[idx]
    minor = np.where(ni > 0, (2 * k * dmin + ni - 1) // np.maximum(2 * ni, 1), 0)
    cm = col_major[idx]
    rows = np.where(cm, r0[idx] + sr[idx] * minor, r0[idx] + sr[idx] * k)
    cols = np.where(cm, c0[idx] + sc[idx] * k, c0[idx] + sc[idx] * minor)

    f0 = np.where(col_major, seg[:, 1], seg[:, 0])
    span = np.where(col_major, seg[:, 3] - seg[:, 1], seg[:, 2] - seg[:, 0])
    maj0 = np.where(col_major, c0, r0)
    smaj = np.where(col_major, sc, sr)

    def t_of(kk: npt.NDArray[np.int64]) -> FloatArray:
        sp = span[idx]
        safe = np.where(sp == 0.0, 1.0, sp)
        t = np.clip((maj0[idx] + smaj[idx] * kk - f0[idx]) / safe, 0.0, 1.0)
        return np.where((sp == 0.0) | (ni == 0), 0.5, t)

    t_cur = t_of(k)
    t_prev = t_of(k - 1)
    t_next = t_of(k + 1)
    lo = np.where(k == 0, 0.0, 0.5 * (t_prev + t_cur))
    hi = np.where(k == ni, 1.0, 0.5 * (t_cur + t_next))
    rising = seg[idx, 5] >= seg[idx, 4]
    z = seg[idx, 4] + np.where(rising, lo, hi) * (seg[idx, 5] - seg[idx, 4])  # part's lowest
    rr = np.clip(rows, 0, grid.rows - 1)
    cc = np.clip(cols, 0, grid.cols - 1)
    below = z < grid.heights[rr, cc].astype(np.float64) + clearance
    part = np.where(below, (hi - lo) * seg[idx, 6], 0.0)
    return np.asarray(np.bincount(idx, weights=part, minlength=m), dtype=np.float64)


def path_below_lengths(
    grid: HeightGrid,
    paths: npt.ArrayLike,
    clearance: float = 0.0,
    *,
    backend: Backend = "numba",
) -> FloatArray:
    """Below-ground length of each path in a (P, W, 3) stack of polylines: one call for a swarm."""
    arr = np.asarray(paths, dtype=np.float64)
    if arr.ndim != 3 or arr.shape[2] != 3 or arr.shape[1] < 2:
        raise InputError(f"paths must be a (P, W >= 2, 3) array of x, y, z; got shape {arr.shape}")
    p, w = arr.shape[0], arr.shape[1]
    if backend == "numba":
        # the table straight from the paths (terrain.kernels.path_segment_table): the same rows
        # as from the segments' ends below, without copying them (issue 38)
        if not np.isfinite(arr).all():
            raise InputError("segment coordinates must be finite; found NaN or infinity")
        dx, dy = grid.cell_size
        table = kernels.path_segment_table(
            np.ascontiguousarray(arr),
            float(grid.transform.c),
            float(grid.transform.f),
            float(dx),
            float(dy),
        )
        below = kernels.below_lengths(
            table, np.ascontiguousarray(grid.heights), float(clearance), grid.block_maxima
        )
        return np.asarray(below).reshape(p, w - 1).sum(axis=1)
    a = arr[:, :-1, :].reshape(-1, 3)
    b = arr[:, 1:, :].reshape(-1, 3)
    return (
        below_terrain_lengths(grid, a, b, clearance, backend=backend).reshape(p, w - 1).sum(axis=1)
    )
