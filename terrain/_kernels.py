"""Compiled hot loops (numba). Every kernel here has a pure-numpy twin in the module that uses it,
and the tests compare the two; keep the arithmetic of both identical.

Kernels take plain arrays only (no grid objects) so that they compile once and cache on disk
(``NUMBA_CACHE_DIR``).
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True, nogil=True)
def bresenham_cells(r0: int, c0: int, r1: int, c1: int) -> np.ndarray:  # pragma: no cover - jit
    """The cells of the integer Bresenham line from (r0, c0) to (r1, c1), both ends included.

    Classic integer error form: step along the major axis; step the minor axis when the
    accumulated error D becomes positive (ties stay, ``D > 0``).
    """
    dr = abs(r1 - r0)
    dc = abs(c1 - c0)
    sr = 1 if r1 >= r0 else -1
    sc = 1 if c1 >= c0 else -1
    n = max(dr, dc)
    out = np.empty((n + 1, 2), dtype=np.int64)
    if dc >= dr:
        d = 2 * dr - dc
        r = r0
        for k in range(n + 1):
            out[k, 0] = r
            out[k, 1] = c0 + sc * k
            if d > 0:
                r += sr
                d -= 2 * dc
            d += 2 * dr
    else:
        d = 2 * dc - dr
        c = c0
        for k in range(n + 1):
            out[k, 0] = r0 + sr * k
            out[k, 1] = c
            if d > 0:
                c += sc
                d -= 2 * dr
            d += 2 * dc
    return out


@nb.njit(cache=True, nogil=True)
def below_lengths(
    seg: np.ndarray, heights: np.ndarray, clearance: float
) -> np.ndarray:  # pragma: no cover - jit
    """Length of each segment that runs below ``terrain + clearance``.

    ``seg`` is (M, 7): fractional row and col of both ends, z of both ends, 3D length. Each
    Bresenham cell k stands for the part of the segment between the midpoints of its parameter
    t_k and its neighbours' (t_k is where the cell centre projects on the major axis); that part is
    below ground when the segment's altitude at t_k is below the cell's height plus clearance.

    Single-threaded on purpose: a swarm's call is a few hundred segments (~0.2 ms), too small to
    gain from numba's threads, and with ``parallel=True`` a plan took 20x longer whenever another
    CPU-bound process shared the machine (issue 12: 0.16 s idle, 3.16 s beside one busy process)
    — campaigns run one process per core. benchmarks/bench_plan.py --under-load measures it.
    """
    m = seg.shape[0]
    rows = heights.shape[0]
    cols = heights.shape[1]
    out = np.zeros(m)
    for i in range(m):
        fr0 = seg[i, 0]
        fc0 = seg[i, 1]
        fr1 = seg[i, 2]
        fc1 = seg[i, 3]
        z0 = seg[i, 4]
        z1 = seg[i, 5]
        length = seg[i, 6]
        # walk from the lexicographically smaller end, so a segment and its reverse visit the
        # same cells (Bresenham's tie-breaks depend on the direction)
        if (fr1, fc1, z1) < (fr0, fc0, z0):
            fr0, fc0, z0, fr1, fc1, z1 = fr1, fc1, z1, fr0, fc0, z0
        r0 = int(np.floor(fr0 + 0.5))
        c0 = int(np.floor(fc0 + 0.5))
        r1 = int(np.floor(fr1 + 0.5))
        c1 = int(np.floor(fc1 + 0.5))
        dr = abs(r1 - r0)
        dc = abs(c1 - c0)
        sr = 1 if r1 >= r0 else -1
        sc = 1 if c1 >= c0 else -1
        n = max(dr, dc)
        col_major = dc >= dr
        if col_major:
            f0 = fc0
            span = fc1 - fc0
            d = 2 * dr - dc
        else:
            f0 = fr0
            span = fr1 - fr0
            d = 2 * dc - dr
        r = r0
        c = c0
        total = 0.0
        t_prev = 0.0
        t_cur = 0.0
        for k in range(n + 1):
            # parameter of this cell's centre along the major axis
            if n == 0 or span == 0.0:
                t_cur = 0.5
            else:
                maj = (c0 + sc * k) if col_major else (r0 + sr * k)
                t_cur = min(max((maj - f0) / span, 0.0), 1.0)
            if k < n:
                maj_next = (c0 + sc * (k + 1)) if col_major else (r0 + sr * (k + 1))
                t_next = 0.5 if span == 0.0 else min(max((maj_next - f0) / span, 0.0), 1.0)
                hi = 0.5 * (t_cur + t_next)
            else:
                hi = 1.0
            lo = 0.0 if k == 0 else 0.5 * (t_prev + t_cur)
            rr = min(max(r, 0), rows - 1)
            cc = min(max(c, 0), cols - 1)
            z = z0 + t_cur * (z1 - z0)
            if z < heights[rr, cc] + clearance:
                total += (hi - lo) * length
            t_prev = t_cur
            # Bresenham step to the next cell
            if col_major:
                c += sc
                if d > 0:
                    r += sr
                    d -= 2 * dc
                d += 2 * dr
            else:
                r += sr
                if d > 0:
                    c += sc
                    d -= 2 * dr
                d += 2 * dc
        out[i] = total
    return out
