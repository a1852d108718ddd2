"""Compiled hot loops of the planner (numba), each with a pure-Python twin in the module that
uses it; the tests compare the two.  Kernels take plain arrays only, so they compile once and
cache on disk (``NUMBA_CACHE_DIR``)."""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True, nogil=True)
def along(pred: np.ndarray, top: np.ndarray, flag: np.ndarray) -> np.ndarray:  # pragma: no cover
    """``planner.explore._along``: flagged nodes on every node's tree path from the root."""
    out = np.zeros(pred.shape[0])
    for v in top:
        p = pred[v]
        out[v] = (1.0 if flag[v] else 0.0) + (out[p] if p >= 0 else 0.0)
    return out


@nb.njit(cache=True, nogil=True)
def flown(
    paths: np.ndarray,
    radius: float,
    chords: int,
    climb: float,
    descent: float,
    max_turn: float,
    eps: float,
    tolerance: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover - jit
    """``planner.flown.flown_paths`` and ``climb_excess`` of (P, W, 3) waypoint paths in one
    pass, without temporaries: (flown polylines (P, 2 + (W - 2)(chords + 1), 3), turn excess (P,),
    climb excess (P,)).  The same formulas in the same order as the numpy version; sums are
    sequential (numpy's are pairwise), so totals may differ in the last bits."""
    n_p, n_w = paths.shape[0], paths.shape[1]
    n_i = n_w - 2
    m = 2 + n_i * (chords + 1)
    out = np.empty((n_p, m, 3))
    turn_excess = np.zeros(n_p)
    climb_excess = np.zeros(n_p)
    length = np.empty(n_w - 1)
    qx = np.empty(n_w - 1)
    qy = np.empty(n_w - 1)
    angle = np.empty(max(n_i, 0))
    tan_half = np.empty(max(n_i, 0))
    wanted = np.empty(max(n_i, 0))
    scale = np.empty(n_w - 1)
    for i in range(n_p):
        for j in range(n_w - 1):
            dx = paths[i, j + 1, 0] - paths[i, j, 0]
            dy = paths[i, j + 1, 1] - paths[i, j, 1]
            length[j] = np.hypot(dx, dy)
            den = length[j] if length[j] > eps else 1.0
            qx[j] = dx / den
            qy[j] = dy / den
        for k in range(n_i):
            cos_d = min(max(qx[k] * qx[k + 1] + qy[k] * qy[k + 1], -1.0), 1.0)
            a = np.arccos(cos_d)
            if length[k] <= eps or length[k + 1] <= eps:
                a = 0.0
            angle[k] = a
            tan_half[k] = np.tan(0.5 * min(a, max_turn))
            wanted[k] = radius * tan_half[k]
        total = 0.0
        for j in range(n_w - 1):
            need = (wanted[j - 1] if j >= 1 else 0.0) + (wanted[j] if j < n_i else 0.0)
            total += max(0.0, need - length[j] - tolerance)
            scale[j] = length[j] / (need if need > 0 else 1.0) if need > length[j] else 1.0
        turn_excess[i] = total
        out[i, 0, :] = paths[i, 0, :]
        out[i, m - 1, :] = paths[i, n_w - 1, :]
        for k in range(n_i):
            wx, wy, wz = paths[i, k + 1, 0], paths[i, k + 1, 1], paths[i, k + 1, 2]
            used = wanted[k] * min(scale[k], scale[k + 1])
            arc_r = used / tan_half[k] if tan_half[k] > eps else radius
            t1x = wx - used * qx[k]
            t1y = wy - used * qy[k]
            t2x = wx + used * qx[k + 1]
            t2y = wy + used * qy[k + 1]
            fa = used / length[k] if length[k] > eps else 0.0
            fb = used / length[k + 1] if length[k + 1] > eps else 0.0
            t1z = wz - fa * (wz - paths[i, k, 2])
            t2z = wz + fb * (paths[i, k + 2, 2] - wz)
            bx = qx[k + 1] - qx[k]
            by = qy[k + 1] - qy[k]
            bn = np.hypot(bx, by)
            if bn > eps:
                bx = bx / bn
                by = by / bn
            else:
                bx = 0.0
                by = 0.0
            cos_half = np.cos(0.5 * min(angle[k], max_turn))
            reach = arc_r / cos_half
            cx = wx + reach * bx
            cy = wy + reach * by
            ax = t1x - cx
            ay = t1y - cy
            turn = (1.0 if (qx[k] * qy[k + 1] - qy[k] * qx[k + 1]) >= 0.0 else -1.0) * angle[k]
            base = 1 + k * (chords + 1)
            # the arc's inner points (its ends are the tangent points, set below)
            for s_i in range(1, chords):
                s = s_i * (1.0 / chords)
                th = turn * s
                c, sn = np.cos(th), np.sin(th)
                out[i, base + s_i, 0] = cx + ax * c - ay * sn
                out[i, base + s_i, 1] = cy + ax * sn + ay * c
                out[i, base + s_i, 2] = t1z + s * (t2z - t1z)
            out[i, base, 0], out[i, base, 1], out[i, base, 2] = t1x, t1y, t1z
            e = base + chords
            out[i, e, 0], out[i, e, 1], out[i, e, 2] = t2x, t2y, t2z
        over = 0.0
        for j in range(m - 1):
            dz = out[i, j + 1, 2] - out[i, j, 2]
            h = np.hypot(out[i, j + 1, 0] - out[i, j, 0], out[i, j + 1, 1] - out[i, j, 1])
            over += max(0.0, dz - climb * h - tolerance) + max(0.0, -dz - descent * h - tolerance)
        climb_excess[i] = over
    return out, turn_excess, climb_excess


PAIRWISE_BLOCK = 128  # numpy's PW_BLOCKSIZE: runs longer than this are split in two


@nb.njit(cache=True, nogil=True)
def _pairwise_block(a: np.ndarray, lo: int, n: int) -> float:  # pragma: no cover - jit
    """numpy's pairwise sum of ``a[lo:lo + n]`` for n <= PAIRWISE_BLOCK (:func:`pairwise_sum`)."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[lo + i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    while i < n - (n % 8):
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@nb.njit(cache=True, nogil=True)
def pairwise_sum(a: np.ndarray, lo: int, n: int) -> float:  # pragma: no cover - jit
    """numpy's sum of ``a[lo:lo + n]`` (float64, contiguous) bit for bit: its pairwise
    summation (``pairwise_sum`` in numpy's ``loops_utils.h``): fewer than 8 numbers added in
    order from 0.0, up to PAIRWISE_BLOCK in eight interleaved partial sums combined as
    ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7)) with the rest added after, longer runs
    split at a multiple of 8 near their middle and the halves' sums added.  The split is
    walked with an explicit stack (numba's cache breaks on recursive functions)."""
    if n <= PAIRWISE_BLOCK:
        return _pairwise_block(a, lo, n)
    los = np.empty(64, np.int64)
    ns = np.empty(64, np.int64)
    state = np.empty(64, np.int64)
    vals = np.empty(64)
    top, n_vals = 0, 0
    los[0], ns[0], state[0] = lo, n, 0
    while top >= 0:
        at, m = los[top], ns[top]
        if m <= PAIRWISE_BLOCK:
            vals[n_vals] = _pairwise_block(a, at, m)
            n_vals += 1
            top -= 1
            continue
        half = m // 2
        half -= half % 8
        if state[top] == 0:  # the first half next
            state[top] = 1
            top += 1
            los[top], ns[top], state[top] = at, half, 0
        elif state[top] == 1:  # then the second
            state[top] = 2
            top += 1
            los[top], ns[top], state[top] = at + half, m - half, 0
        else:  # both summed: the first's sum plus the second's
            vals[n_vals - 2] = vals[n_vals - 2] + vals[n_vals - 1]
            n_vals -= 1
            top -= 1
    return vals[0]


@nb.njit(cache=True, nogil=True)
def path_lengths(
    p: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover - jit
    """``planner.cost._lengths_numpy`` of (P, W, 3) polylines in one pass: (segment lengths
    (P, W - 1), path lengths, straight end-to-end distances, sums of segment length x mean
    altitude (P,)), the same operations in the same order and the sums numpy's
    (:func:`pairwise_sum`), so the same numbers bit for bit."""
    n_p, n_w = p.shape[0], p.shape[1]
    n_s = n_w - 1
    seg_len = np.empty((n_p, n_s))
    length = np.empty(n_p)
    straight = np.empty(n_p)
    weighted = np.empty(n_p)
    wz = np.empty(n_s)
    for i in range(n_p):
        for j in range(n_s):
            dx = p[i, j + 1, 0] - p[i, j, 0]
            dy = p[i, j + 1, 1] - p[i, j, 1]
            dz = p[i, j + 1, 2] - p[i, j, 2]
            s = np.sqrt(dx * dx + dy * dy + dz * dz)
            seg_len[i, j] = s
            wz[j] = s * (0.5 * (p[i, j, 2] + p[i, j + 1, 2]))
        length[i] = pairwise_sum(seg_len[i], 0, n_s)
        weighted[i] = pairwise_sum(wz, 0, n_s)
        ex = p[i, n_w - 1, 0] - p[i, 0, 0]
        ey = p[i, n_w - 1, 1] - p[i, 0, 1]
        ez = p[i, n_w - 1, 2] - p[i, 0, 2]
        straight[i] = np.sqrt(ex * ex + ey * ey + ez * ez)
    return seg_len, length, straight, weighted


@nb.njit(cache=True, nogil=True)
def chord_edges(
    rc: np.ndarray,
    xy: np.ndarray,
    levels: np.ndarray,
    floor: np.ndarray,
    block: int,
    step: float,
    pairs: np.ndarray,
    climb: float,
    descent: float,
    spiral: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover - jit
    """``planner.placement._chord_edges_py``: the clear, flyable chords between the altitude
    levels of candidate pairs, as (from state, to state, 3-D length, mid altitude); with
    ``spiral`` > 0 (the climb gradient in a turn) a chord steeper than the gradients is kept,
    the climb it cannot make flown in a helix: its length grows by excess / ``spiral``; a state is
    ``candidate * K + level``; ``floor`` holds the blocks of ``block`` x ``block`` cells, ``rc``
    and ``step`` are in cells.  The lowest clear end of a chord from ``za`` is found on the upper
    convex hull of the floor samples (the steepest sight line from a point left of them all ends
    on a hull vertex)."""
    n_k = levels.shape[1]
    n_r, n_col = floor.shape[0] * block, floor.shape[1] * block
    # r // block without an integer division (the loop's slowest step): r / block is a whole
    # number or at least 1 / block above one, and r * inv is within 1e-11 of it for any grid
    inv = 1.0 / block
    eps = 0.5 / block
    cap = pairs.shape[0] * n_k * n_k
    u = np.empty(cap, np.int64)
    v = np.empty(cap, np.int64)
    l3 = np.empty(cap)
    zm = np.empty(cap)
    count = 0
    most = 2
    for e in range(pairs.shape[0]):
        a, b = pairs[e, 0], pairs[e, 1]
        d = np.hypot(rc[b, 0] - rc[a, 0], rc[b, 1] - rc[a, 1])
        most = max(most, int(np.ceil(d / step)) + 1)
    ts = np.empty(most)
    fs = np.empty(most)
    ht = np.empty(most)
    hf = np.empty(most)
    for e in range(pairs.shape[0]):
        a, b = pairs[e, 0], pairs[e, 1]
        r0, c0, r1, c1 = rc[a, 0], rc[a, 1], rc[b, 0], rc[b, 1]
        m = max(2, int(np.ceil(np.hypot(r1 - r0, c1 - c0) / step)) + 1)
        # the samples in straight loops (no exit on the first infinite floor, one loop per
        # kind of floor: issue 38, a tenth faster), then whether any is infinite
        for i in range(m):
            ts[i] = i / (m - 1)
        ts[m - 1] = 1.0
        if block == 1:
            for i in range(m):
                r = min(max(int(np.floor(r0 + ts[i] * (r1 - r0) + 0.5)), 0), n_r - 1)
                c = min(max(int(np.floor(c0 + ts[i] * (c1 - c0) + 0.5)), 0), n_col - 1)
                fs[i] = floor[r, c]
        else:
            for i in range(m):
                r = min(max(int(np.floor(r0 + ts[i] * (r1 - r0) + 0.5)), 0), n_r - 1)
                c = min(max(int(np.floor(c0 + ts[i] * (c1 - c0) + 0.5)), 0), n_col - 1)
                fs[i] = floor[int(r * inv + eps), int(c * inv + eps)]
        finite = True
        for i in range(m):
            if not np.isfinite(fs[i]):
                finite = False
        if not finite:
            continue
        # upper hull of the samples after the first (t increasing), its last two vertices
        # also held in (x0, y0) and (x1, y1)
        h = 0
        x0 = y0 = x1 = y1 = 0.0
        for i in range(1, m):
            t, f = ts[i], fs[i]
            while h >= 2 and (x1 - x0) * (f - y0) - (y1 - y0) * (t - x0) >= 0.0:
                h -= 1
                x1, y1 = x0, y0
                if h >= 2:
                    x0, y0 = ht[h - 2], hf[h - 2]
            ht[h] = t
            hf[h] = f
            h += 1
            x0, y0 = x1, y1
            x1, y1 = t, f
        length = np.hypot(xy[b, 0] - xy[a, 0], xy[b, 1] - xy[a, 1])
        for ka in range(n_k):
            za = levels[a, ka]
            if not np.isfinite(za) or za < fs[0]:
                continue
            need = -np.inf
            for j in range(h):
                need = max(need, za + (hf[j] - za) / ht[j])
            for kb in range(n_k):
                zb = levels[b, kb]
                if not np.isfinite(zb) or zb < need:
                    continue
                dz = zb - za
                excess = max(dz - climb * length, -dz - descent * length, 0.0)
                if excess > 0.0 and spiral <= 0.0:
                    continue
                u[count] = a * n_k + ka
                v[count] = b * n_k + kb
                l3[count] = np.sqrt(length * length + dz * dz)
                if excess > 0.0:
                    l3[count] += excess / spiral
                zm[count] = 0.5 * (za + zb)
                count += 1
    return u[:count], v[:count], l3[:count], zm[:count]


@nb.njit(cache=True, nogil=True)
def steep_chords(
    u: np.ndarray, v: np.ndarray, l3: np.ndarray, xy: np.ndarray, levels: np.ndarray
) -> np.ndarray:  # pragma: no cover - jit
    """``planner.placement._steep_chords_numpy``: which edges of :func:`chord_edges` are longer
    than their straight 3-D chord by more than 1e-6 m (a helix added), in one pass: the same
    operations in the same order (``np.hypot`` is the C library's in both)."""
    k = levels.shape[1]
    # s // k without an integer division (as chord_edges does r // block): s / k is a whole
    # number or at least 1 / k above one, and s * inv is within 1e-11 of it for any lattice
    inv = 1.0 / k
    eps = 0.5 / k
    out = np.empty(u.shape[0], dtype=np.bool_)
    for e in range(u.shape[0]):
        a, b = int(u[e] * inv + eps), int(v[e] * inv + eps)
        flat = np.hypot(xy[b, 0] - xy[a, 0], xy[b, 1] - xy[a, 1])
        dz = levels[b, v[e] - b * k] - levels[a, u[e] - a * k]
        out[e] = l3[e] > np.sqrt(flat * flat + dz * dz) + 1e-6
    return out


@nb.njit(cache=True, nogil=True)
def layered_dp(
    u: np.ndarray,
    v: np.ndarray,
    w: np.ndarray,
    n_states: int,
    start: int,
    goal: int,
    layers: int,
    inner: np.ndarray,
) -> np.ndarray:  # pragma: no cover - jit
    """``planner.placement._layered_dp_py``: the cheapest chain start -> ``layers`` inner states
    -> goal over the edges (u, v, w), as its states (empty when there is none)."""
    best = np.full(n_states, np.inf)
    best[start] = 0.0
    back = np.full((layers, n_states), -1, np.int64)
    for layer in range(layers):
        new = np.full(n_states, np.inf)
        for e in range(u.shape[0]):
            if not inner[v[e]] or best[u[e]] == np.inf:
                continue
            c = best[u[e]] + w[e]
            if c < new[v[e]]:
                new[v[e]] = c
                back[layer, v[e]] = u[e]
        best = new
    end, at = np.inf, -1
    for e in range(u.shape[0]):
        if v[e] == goal:
            c = best[u[e]] + w[e]
            if c < end:
                end, at = c, u[e]
    if at < 0:
        return np.empty(0, np.int64)
    out = np.empty(layers + 2, np.int64)
    out[layers + 1] = goal
    for layer in range(layers - 1, -1, -1):
        out[layer + 1] = at
        at = back[layer, at]
    out[0] = start
    return out


@nb.njit(cache=True, nogil=True)
def chord_samples(
    pts: np.ndarray,
    heights: np.ndarray,
    lift: float,
    left: float,
    top: float,
    dx: float,
    dy: float,
    step: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover - jit
    """``planner.placement.Chords`` of the polyline ``pts`` (M, 2) in one pass: each chord's
    samples every ``step`` metres (``np.linspace(0, 1, m)``'s values: i * (1 / (m - 1)), the
    last exactly 1) and the floor there (``heights`` + ``lift`` + 1 m at
    ``HeightGrid.cell_of``'s cell, float32 heights read as the float64 they equal), as
    (t, floor, offsets): chord i's in ``[offsets[i]:offsets[i + 1]]``.  The same numbers as
    the numpy loop it replaces (``placement._chord_samples_numpy``)."""
    n = pts.shape[0] - 1
    rows, cols = heights.shape[0], heights.shape[1]
    offsets = np.zeros(n + 1, np.int64)
    for i in range(n):
        d = np.hypot(pts[i + 1, 0] - pts[i, 0], pts[i + 1, 1] - pts[i, 1])
        offsets[i + 1] = offsets[i] + max(2, int(np.ceil(d / step)) + 1)
    t_all = np.empty(offsets[n])
    f_all = np.empty(offsets[n])
    for i in range(n):
        m = offsets[i + 1] - offsets[i]
        px, py = pts[i, 0], pts[i, 1]
        ex, ey = pts[i + 1, 0] - px, pts[i + 1, 1] - py
        inc = 1.0 / (m - 1)
        for k in range(m):
            t = 1.0 if k == m - 1 else k * inc
            x = px + t * ex
            y = py + t * ey
            r = min(max(np.floor(((top - y) / dy - 0.5) + 0.5), 0.0), rows - 1.0)
            c = min(max(np.floor(((x - left) / dx - 0.5) + 0.5), 0.0), cols - 1.0)
            t_all[offsets[i] + k] = t
            f_all[offsets[i] + k] = heights[int(r), int(c)] + lift + 1.0
    return t_all, f_all, offsets


@nb.njit(cache=True, nogil=True)
def clear_chords(
    p: np.ndarray,
    qs: np.ndarray,
    heights: np.ndarray,
    left: float,
    top: float,
    dx: float,
    dy: float,
    step: float,
    clearance: float,
) -> np.ndarray:  # pragma: no cover - jit
    """``planner.explore._clear_chords_numpy``: for each chord p -> qs[i] (3-D, altitude linear),
    whether it clears ``heights`` + clearance + 1 m at its samples every ``step`` metres
    (``np.linspace(0, 1, m)``'s values, m from the horizontal length); the same samples and
    arithmetic (``HeightGrid.cell_of``'s cells), each chord left at its first sample below.
    ``heights`` float32 or float64: a float32 value is read as the float64 it equals."""
    rows, cols = heights.shape[0], heights.shape[1]
    out = np.ones(qs.shape[0], dtype=np.bool_)
    for i in range(qs.shape[0]):
        ex = qs[i, 0] - p[0]
        ey = qs[i, 1] - p[1]
        ez = qs[i, 2] - p[2]
        m = max(2, int(np.ceil(np.hypot(ex, ey) / step)) + 1)
        inv = 1.0 / (m - 1)
        for k in range(m):
            t = 1.0 if k == m - 1 else k * inv
            x = p[0] + t * ex
            y = p[1] + t * ey
            r = min(max(np.floor(((top - y) / dy - 0.5) + 0.5), 0.0), rows - 1.0)
            c = min(max(np.floor(((x - left) / dx - 0.5) + 0.5), 0.0), cols - 1.0)
            if p[2] + t * ez < heights[int(r), int(c)] + clearance + 1.0:
                out[i] = False
                break
    return out
