"""Compiled (numba) terrain returns of a radar scan: the ray hits of
:meth:`replay.sensors.radar.Radar._terrain_points` made into one return per cell.

The radar casts a few thousand rays a scan (1,800 scans in the demo replay); numpy's dozen
passes over them (hit points, ranges, the altitude and range tests, cells, a lexsort, the first
of each cell) cost as much as open3d's cast.  :func:`terrain_returns` does them in one pass and
a sort of the kept hits, with the arithmetic of :func:`terrain_returns_numpy`, its numpy twin
(``tests/test_radar_kernel.py`` checks both give the same bits):

- ray ``r``'s origin is ``own`` for the fan (``r < n_fan``), ``own - (0, 0, clearance)`` for
  the ring; its hit ``origin + dist * dir`` (float64, no fused multiply-add), its range
  ``sqrt((dx^2 + dy^2) + dz^2)`` from ``own`` (the order ``numpy.linalg.norm`` sums a row in);
- a hit is kept when its altitude is ``>= own_z - clearance - slack`` and its range
  ``<= range_m``; its cell is ``floor(x / cell_m), floor(y / cell_m)``;
- each cell reports its hit of least range, the first ray on a tie (``numpy.lexsort``'s order:
  it is stable), cells in increasing ``(i, j)``: found with a slot per cell of the hits'
  bounding box (up to ``BUCKETS`` cells; 201 x 201 for the default 10 km range and 100 m
  cells), else by sorting.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

BUCKETS = 1 << 17  # most cells of a hits' bounding box given a slot each (1 MB)


def terrain_returns_numpy(
    own: FloatArray,
    clearance: float,
    dirs: FloatArray,
    n_fan: int,
    dist: FloatArray,
    range_m: float,
    cell_m: float,
    slack: float,
) -> tuple[IntArray, FloatArray]:
    """(cells (M, 2), points (M, 3)): the nearest hit in each occupied cell (module docstring;
    ``dist`` (R,) the ranges of the rays ``dirs`` (R, 3), inf for a miss)."""
    origins = np.empty_like(dirs)
    origins[:n_fan] = own
    origins[n_fan:] = own - np.array([0.0, 0.0, clearance])
    hit = np.isfinite(dist)
    pts = origins[hit] + dist[hit, None] * dirs[hit]
    rng = np.linalg.norm(pts - own, axis=-1)
    keep = (pts[:, 2] >= own[2] - clearance - slack) & (rng <= range_m)
    pts, rng = pts[keep], rng[keep]
    if not len(pts):
        return np.zeros((0, 2), dtype=np.int64), np.zeros((0, 3))
    cells = np.floor(pts[:, :2] / cell_m).astype(np.int64)
    order = np.lexsort((rng, cells[:, 1], cells[:, 0]))
    cells, pts = cells[order], pts[order]
    first = np.ones(len(cells), dtype=bool)
    first[1:] = np.any(cells[1:] != cells[:-1], axis=1)
    return cells[first], pts[first]


@nb.njit(cache=True, nogil=True)
def terrain_returns(
    own: FloatArray,
    clearance: float,
    dirs: FloatArray,
    n_fan: int,
    dist: FloatArray,
    range_m: float,
    cell_m: float,
    slack: float,
) -> tuple[IntArray, FloatArray]:  # pragma: no cover - jit
    """:func:`terrain_returns_numpy`, compiled: the same cells and points, bit for bit."""
    n = dist.shape[0]
    px = np.empty(n)
    py = np.empty(n)
    pz = np.empty(n)
    rng = np.empty(n)
    ci = np.empty(n, dtype=np.int64)
    cj = np.empty(n, dtype=np.int64)
    ox, oy, oz = own[0], own[1], own[2]
    floor_z = own[2] - clearance - slack
    m = 0
    for r in range(n):
        t = dist[r]
        if not math.isfinite(t):
            continue
        if r < n_fan:
            ax, ay, az = ox, oy, oz
        else:
            ax, ay, az = ox - 0.0, oy - 0.0, oz - clearance
        x = ax + t * dirs[r, 0]
        y = ay + t * dirs[r, 1]
        z = az + t * dirs[r, 2]
        dx, dy, dz = x - ox, y - oy, z - oz
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        if not (z >= floor_z and d <= range_m):
            continue
        px[m], py[m], pz[m], rng[m] = x, y, z, d
        ci[m] = np.int64(math.floor(x / cell_m))
        cj[m] = np.int64(math.floor(y / cell_m))
        m += 1
    if m == 0:
        return np.zeros((0, 2), dtype=np.int64), np.zeros((0, 3))
    i0, i1, j0, j1 = ci[:m].min(), ci[:m].max(), cj[:m].min(), cj[:m].max()
    if i1 - i0 < BUCKETS and j1 - j0 < BUCKETS and (i1 - i0 + 1) * (j1 - j0 + 1) <= BUCKETS:
        best = _nearest_by_bucket(ci, cj, rng, m, i0, j0, j1 - j0 + 1)
    else:
        best = _nearest_by_sort(ci, cj, rng, m)
    k = best.shape[0]
    cells = np.empty((k, 2), dtype=np.int64)
    pts = np.empty((k, 3))
    for q in range(k):
        s = best[q]
        cells[q, 0], cells[q, 1] = ci[s], cj[s]
        pts[q, 0], pts[q, 1], pts[q, 2] = px[s], py[s], pz[s]
    return cells, pts


@nb.njit(cache=True, nogil=True)
def _nearest_by_bucket(
    ci: IntArray, cj: IntArray, rng: FloatArray, m: int, i0: int, j0: int, nj: int
) -> IntArray:  # pragma: no cover - jit
    """The hit of least range of each cell (the first on a tie), cells in increasing (i, j):
    one slot per cell of the hits' bounding box (a scan's 200 x 200 cells: cheaper than a
    sort)."""
    slot = np.full((ci[:m].max() - i0 + 1) * nj, -1, dtype=np.int64)
    for s in range(m):
        b = (ci[s] - i0) * nj + (cj[s] - j0)
        cur = slot[b]
        if cur < 0 or rng[s] < rng[cur]:
            slot[b] = s
    return slot[slot >= 0]


@nb.njit(cache=True, nogil=True)
def _nearest_by_sort(ci: IntArray, cj: IntArray, rng: FloatArray, m: int) -> IntArray:
    """As :func:`_nearest_by_bucket`, by stable sorts (hits spread over too many cells for a
    slot each)."""
    by_j = np.argsort(cj[:m], kind="mergesort")
    order = by_j[np.argsort(ci[by_j], kind="mergesort")]  # by (i, j), in ray order within
    out = np.empty(m, dtype=np.int64)
    k = -1
    for q in range(m):
        s = order[q]
        if k < 0 or ci[s] != ci[out[k]] or cj[s] != cj[out[k]]:
            k += 1
            out[k] = s
        elif rng[s] < rng[out[k]]:
            out[k] = s
    return out[: k + 1]
