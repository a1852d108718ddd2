"""Compiled (numba) penalised cost of :class:`~replay.avoidance.pso_ca_geometry.WaypointProblem`.

The same arithmetic as ``WaypointProblem.terms(X).penalised`` (f = Wt f1 + Wo f2 plus the penalty
of the checked constraints g1-g6; ``WaypointProblem.__call__`` adds g7, the world check, outside
it), one candidate at a time with no temporary arrays: an optimiser
evaluates 10 candidates per call, where numpy's per-call overhead (about 1 ms for the vectorised
version) would dominate a decision.  ``tests/test_pso_ca_geometry.py`` checks both agree.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


@nb.njit(cache=True, nogil=True, inline="always")
def _seg_clearance(ax: float, ay: float, bx: float, by: float, ox: float, oy: float) -> float:
    dx = bx - ax
    dy = by - ay
    dd = dx * dx + dy * dy
    rx = ox - ax
    ry = oy - ay
    s = (rx * dx + ry * dy) / (dd if dd > 0.0 else 1.0)
    s = min(max(s, 0.0), 1.0)
    gx = rx - s * dx
    gy = ry - s * dy
    return math.sqrt(gx * gx + gy * gy)


@nb.njit(cache=True, nogil=True, inline="always")
def _corner(
    wx: float, wy: float, ux: float, uy: float, vx: float, vy: float, sw: float, tan_app: float
) -> tuple[float, float, float, float, float, float, float]:
    """pso_ca_geometry.corner_cut for one waypoint: c1, m and the end of the second segment,
    and corner_reach's reach along the next leg (not capped at its length)."""
    lu = math.hypot(ux, uy)
    lv = math.hypot(vx, vy)
    eux, euy = (ux / lu, uy / lu) if lu > 0.0 else (ux, uy)
    evx, evy = (vx / lv, vy / lv) if lv > 0.0 else (vx, vy)
    cut = min(sw, 0.5 * lu)
    cx = wx - cut * eux
    cy = wy - cut * euy
    rx = cx - wx
    ry = cy - wy
    along = rx * evx + ry * evy
    dd = abs(evx * ry - evy * rx)
    free = along + dd / tan_app
    reach = min(free, lv)
    mx = wx + reach * evx
    my = wy + reach * evy
    if reach < 0.0:
        return cx, cy, mx, my, wx, wy, free
    return cx, cy, mx, my, mx, my, free


@nb.njit(cache=True, nogil=True)
def penalised_costs(
    X: FloatArray,
    pos: FloatArray,
    target: FloatArray,
    after: FloatArray,
    avoided: FloatArray,
    others: FloatArray,
    consts: FloatArray,
    flags: npt.NDArray[np.int64],
) -> FloatArray:
    """Penalised costs (P,) of candidates X (P, 2).

    ``consts`` = [rs, tolerance, search_limit, mxrsk, wt, wo, turn_radius, leg_margin,
    switch_distance, tan(approach angle), penalty_offset, penalty_weight, big]; ``flags`` = [g2 centred on the
    obstacle, check_inbound, check_outbound, normalise, side, has_after, corner_fit]; ``after`` is the
    waypoint after the target (ignored without has_after)."""
    rs, tol, lim, mxrsk, wt, wo, radius, margin, sw, tan_app, pen_off, pen_w, big = consts
    g2_obstacle, inbound, outbound, normalise, side, has_after, corner_fit = flags
    n = X.shape[0]
    k_av = avoided.shape[0]
    k_ot = others.shape[0]
    lx = target[0] - pos[0]
    ly = target[1] - pos[1]
    leg = math.hypot(lx, ly)
    out = np.empty(n)
    for i in range(n):
        px = X[i, 0]
        py = X[i, 1]
        ix = px - pos[0]
        iy = py - pos[1]
        ox = target[0] - px
        oy = target[1] - py
        l_in = math.hypot(ix, iy)
        l_out = math.hypot(ox, oy)
        f1 = l_in + l_out
        if normalise:
            f1 = f1 / max(leg, 1e-9)
        s = 0.0
        for k in range(k_ot):
            dis = math.hypot(px - others[k, 0], py - others[k, 1])
            if mxrsk - dis > 0.0:
                s += mxrsk - dis
        if normalise:
            s = s / mxrsk
        f = wt * f1 + wo * s * s
        dmin = math.inf
        g3 = math.inf
        g5 = math.inf
        # corners cut by the autopilot (pso_ca_geometry.corner_cut): at p and at the target
        c1x, c1y, mx, my, bx, by, reach = _corner(px, py, ix, iy, ox, oy, sw, tan_app)
        d1x, d1y, nx, ny, ex, ey, _ = _corner(
            target[0], target[1], ox, oy, after[0] - target[0], after[1] - target[1], sw, tan_app
        )
        for k in range(k_av):
            ax = avoided[k, 0]
            ay = avoided[k, 1]
            dmin = min(dmin, math.hypot(px - ax, py - ay))
            g3 = min(g3, _seg_clearance(px, py, target[0], target[1], ax, ay) - (rs + margin))
            need = min(rs + margin, math.hypot(ax - pos[0], ay - pos[1]) - 1.0)
            g5 = min(g5, _seg_clearance(pos[0], pos[1], px, py, ax, ay) - need)
            if sw > 0.0:
                g5 = min(g5, _seg_clearance(c1x, c1y, mx, my, ax, ay) - need)
                g5 = min(g5, _seg_clearance(mx, my, bx, by, ax, ay) - need)
                if has_after:
                    g3 = min(g3, _seg_clearance(d1x, d1y, nx, ny, ax, ay) - (rs + margin))
                    g3 = min(g3, _seg_clearance(nx, ny, ex, ey, ax, ay) - (rs + margin))
        g1 = dmin - (rs + tol)
        g2 = lim - dmin if g2_obstacle else lim - l_in
        denom = l_in * l_out
        cos_t = (ix * ox + iy * oy) / denom if denom > 0.0 else 1.0
        theta = math.acos(min(max(cos_t, -1.0), 1.0))
        lead = radius * math.tan(min(theta, math.pi * (1.0 - 1e-12)) / 2.0)
        g4 = min(l_in, l_out) - lead
        if sw > 0.0 and corner_fit:  # the cut corner fits in the leg (constraint_report)
            g4 = min(g4, l_out - reach)
        viol = 0.0
        ok = True
        for g in (g1, g2, g4):
            if g < 0.0:
                ok = False
                viol += min(-g, big)
        if side != 0:
            g6 = side * (lx * iy - ly * ix) / max(leg, 1e-9)
            if g6 < 0.0:
                ok = False
                viol += min(-g6, big)
        if outbound and g3 < 0.0:
            ok = False
            viol += min(-g3, big)
        if inbound and g5 < 0.0:
            ok = False
            viol += min(-g5, big)
        out[i] = f if ok else f + (pen_off + pen_w * viol)
    return out


@nb.njit(cache=True, nogil=True)
def segment_clearances(a0: FloatArray, a1: FloatArray, o: FloatArray) -> FloatArray:
    """Closest distance (P, K) from each segment ``a0[i] -> a1[i]`` ((P, D) each) to each centre
    ``o[k]`` ((K, D)): :func:`~replay.avoidance.pso_ca_geometry.segment_clearance`'s arithmetic,
    one pair at a time (the avoider tests a few legs against all radar points every scan)."""
    n_seg, dims = a0.shape
    out = np.empty((n_seg, o.shape[0]))
    for i in range(n_seg):
        dd = 0.0
        for d in range(dims):
            dd += (a1[i, d] - a0[i, d]) ** 2
        den = dd if dd > 0.0 else 1.0
        for k in range(o.shape[0]):
            s = 0.0
            for d in range(dims):
                s += (o[k, d] - a0[i, d]) * (a1[i, d] - a0[i, d])
            s = min(max(s / den, 0.0), 1.0)
            g = 0.0
            for d in range(dims):
                g += ((o[k, d] - a0[i, d]) - s * (a1[i, d] - a0[i, d])) ** 2
            out[i, k] = math.sqrt(g)
    return out


@nb.njit(cache=True, nogil=True, inline="always")
def _clear(a0x: float, a0y: float, a1x: float, a1y: float, ox: float, oy: float) -> float:
    """:func:`segment_clearances` for one pair, its operations in its order (the same bits)."""
    dx = a1x - a0x
    dy = a1y - a0y
    dd = 0.0
    dd += dx**2
    dd += dy**2
    den = dd if dd > 0.0 else 1.0
    rx = ox - a0x
    ry = oy - a0y
    s = 0.0
    s += rx * dx
    s += ry * dy
    s = min(max(s / den, 0.0), 1.0)
    g = 0.0
    g += (rx - s * dx) ** 2
    g += (ry - s * dy) ** 2
    return math.sqrt(g)


@nb.njit(cache=True, nogil=True)
def report_geometry(
    X: FloatArray,
    pos: FloatArray,
    target: FloatArray,
    after: FloatArray,
    avoided: FloatArray,
    consts: FloatArray,
    flags: npt.NDArray[np.int64],
) -> FloatArray:
    """The geometric parts of ``WaypointProblem.constraint_report`` (9, P): g1, g2, g3, g5, g6,
    the turn's cosine, the two legs' lengths and the corner-fit bound on g4 (inf when not asked)
    -- the same operations in the same order as the numpy version (so the same bits); the
    arccos and tan of the turn stay with numpy (its SIMD functions round differently from the
    C library's).  ``consts`` and ``flags`` as :func:`penalised_costs`'s, ``consts[13]`` the
    straight leg's length as the numpy version takes it (at least 1e-9)."""
    rs, tol, lim = consts[0], consts[1], consts[2]
    margin, sw, tan_app, leg_n = consts[7], consts[8], consts[9], consts[13]
    g2_obstacle, side, has_after, corner_fit = flags[0], flags[4], flags[5], flags[6]
    n = X.shape[0]
    k_av = avoided.shape[0]
    keep = rs + margin
    lx = target[0] - pos[0]
    ly = target[1] - pos[1]
    out = np.empty((9, n))
    for i in range(n):
        px = X[i, 0]
        py = X[i, 1]
        ix = px - pos[0]
        iy = py - pos[1]
        ox = target[0] - px
        oy = target[1] - py
        l_in = math.hypot(ix, iy)
        l_out = math.hypot(ox, oy)
        if sw > 0.0:
            c1x, c1y, mx, my, bx, by, reach = _corner(px, py, ix, iy, ox, oy, sw, tan_app)
            if has_after:
                d1x, d1y, nx, ny, ex, ey, _ = _corner(
                    target[0],
                    target[1],
                    ox,
                    oy,
                    after[0] - target[0],
                    after[1] - target[1],
                    sw,
                    tan_app,
                )
        dmin = math.inf
        g3 = math.inf
        g5 = math.inf
        for k in range(k_av):
            ax = avoided[k, 0]
            ay = avoided[k, 1]
            dmin = min(dmin, math.sqrt((px - ax) ** 2 + (py - ay) ** 2))
            g3 = min(g3, _clear(px, py, target[0], target[1], ax, ay))
            need = min(keep, math.hypot(ax - pos[0], ay - pos[1]) - 1.0)
            g5 = min(g5, _clear(pos[0], pos[1], px, py, ax, ay) - need)
        g3 = g3 - keep
        if sw > 0.0:
            c5 = math.inf
            c5b = math.inf
            for k in range(k_av):
                ax = avoided[k, 0]
                ay = avoided[k, 1]
                need = min(keep, math.hypot(ax - pos[0], ay - pos[1]) - 1.0)
                c5 = min(c5, _clear(c1x, c1y, mx, my, ax, ay) - need)
                c5b = min(c5b, _clear(mx, my, bx, by, ax, ay) - need)
            g5 = min(g5, c5)
            g5 = min(g5, c5b)
            if has_after:
                c3 = math.inf
                c3b = math.inf
                for k in range(k_av):
                    ax = avoided[k, 0]
                    ay = avoided[k, 1]
                    c3 = min(c3, _clear(d1x, d1y, nx, ny, ax, ay))
                    c3b = min(c3b, _clear(nx, ny, ex, ey, ax, ay))
                g3 = min(g3, c3 - keep)
                g3 = min(g3, c3b - keep)
        denom = l_in * l_out
        out[0, i] = dmin - (rs + tol)
        out[1, i] = lim - dmin if g2_obstacle else lim - l_in
        out[2, i] = g3
        out[3, i] = g5
        out[4, i] = side * (lx * iy - ly * ix) / leg_n if side != 0 else math.inf
        out[5, i] = (ix * ox + iy * oy) / denom if denom > 0 else 1.0
        out[6, i] = l_in
        out[7, i] = l_out
        out[8, i] = l_out - reach if sw > 0.0 and corner_fit else math.inf
    return out


@nb.njit(cache=True, nogil=True)
def leg_clearances(
    pos: FloatArray,
    target: FloatArray,
    after: FloatArray,
    switch: float,
    tan_app: float,
    o: FloatArray,
) -> FloatArray:
    """Closest distance (K,) from the leg ``pos -> target`` to each centre ``o`` (K, 2) and, with
    ``switch`` > 0, from the corner the autopilot cuts at ``target`` towards ``after``
    (pso_ca_geometry.corner_cut of the leg drawn at twice its length, as the avoider's collision
    test asks): :func:`segment_clearances` of the three segments and their minimum, in the same
    operations (the same bits), without the seven small arrays of each corner."""
    n = o.shape[0]
    out = np.empty(n)
    c1x = c1y = mx = my = bx = by = 0.0
    if switch > 0.0:
        c1x, c1y, mx, my, bx, by, _ = _corner(
            target[0],
            target[1],
            2.0 * (target[0] - pos[0]),
            2.0 * (target[1] - pos[1]),
            after[0] - target[0],
            after[1] - target[1],
            switch,
            tan_app,
        )
    for k in range(n):
        ox = o[k, 0]
        oy = o[k, 1]
        c = _clear(pos[0], pos[1], target[0], target[1], ox, oy)
        if switch > 0.0:
            c = min(c, _clear(c1x, c1y, mx, my, ox, oy))
            c = min(c, _clear(mx, my, bx, by, ox, oy))
        out[k] = c
    return out
