"""Compiled (numba) hot loops of :class:`~replay.threats.body.BodyThreat`: the section's
circumscribed radius (:meth:`~replay.threats.body.BodyThreat.body_radius_at`) and its boundary
(:meth:`~replay.threats.body.BodyThreat.section_boundary`).

Both are iterative searches on one value or a few hundred (an 80-step golden-section search, a
40-step bisection), where numpy's per-call overhead was nearly all the cost (about 1.5 ms and
1 ms a call).  The kernels do the same arithmetic in the same order, one element at a time, with
numpy's own ``pow`` (:mod:`terrain.npmath`), so they return the same bits as the numpy code,
which is kept in ``body.py`` as their twin (``..._numpy``); ``tests/test_threats.py`` compares
them on random bodies.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from terrain.npmath import LANES, pow_, pow_lanes, scalar_pow

GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0
GOLDEN_STEPS = 80
BISECTION_STEPS = 40


@nb.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _f(u: float, a2: float, b2: float, e1: float, e2: float) -> float:  # pragma: no cover - jit
    """``A^2 u^2 + B^2 (1 - u^(2p))^(1/q)`` (the clip at 0 included), numpy's rounding."""
    v = scalar_pow(max(1.0 - scalar_pow(u, e1), 0.0), e2)
    return a2 * (u * u) + b2 * v


@nb.njit(cache=True, nogil=True, error_model="numpy")
def superellipse_radius(
    big_a: np.ndarray, big_b: np.ndarray, p: float, q: float, grid: np.ndarray
) -> np.ndarray:  # pragma: no cover - jit
    """max sqrt(X^2 + Y^2) on |X/A|^(2p) + |Y/B|^(2q) = 1 for A, B > 0 (M,): the best of the
    ``grid`` samples of u = X/A in [0, 1], refined by golden-section search between its
    neighbours (``body._superellipse_radius_numpy``'s steps)."""
    e1 = 2.0 * p
    e2 = 1.0 / q
    n = grid.shape[0]
    out = np.empty(big_a.shape[0])
    for i in range(big_a.shape[0]):
        a2 = big_a[i] * big_a[i]
        b2 = big_b[i] * big_b[i]
        k = 0
        best = _f(grid[0], a2, b2, e1, e2)
        for j in range(1, n):
            v = _f(grid[j], a2, b2, e1, e2)
            if v > best:
                best = v
                k = j
        lo = grid[max(k - 1, 0)]
        hi = grid[min(k + 1, n - 1)]
        x1 = hi - GOLDEN * (hi - lo)
        x2 = lo + GOLDEN * (hi - lo)
        f1 = _f(x1, a2, b2, e1, e2)
        f2 = _f(x2, a2, b2, e1, e2)
        for _ in range(GOLDEN_STEPS):
            if f1 > f2:  # the maximum lies in [lo, x2]
                hi = x2
            else:
                lo = x1
            x1 = hi - GOLDEN * (hi - lo)
            x2 = lo + GOLDEN * (hi - lo)
            f1 = _f(x1, a2, b2, e1, e2)
            f2 = _f(x2, a2, b2, e1, e2)
        top = f1 if f1 >= f2 else f2
        out[i] = math.sqrt(best if best >= top else top)
    return out


@nb.njit(cache=True, nogil=True, error_model="numpy")
def body_radius(
    z: np.ndarray, center_z: float, axes: np.ndarray, exponents: np.ndarray, grid: np.ndarray
) -> np.ndarray:  # pragma: no cover - jit
    """``BodyThreat.body_radius_at`` for altitudes z (M,): the section's half-axes A, B from
    ``s = 1 - |(z - z0)/c|^(2r)``, then :func:`superellipse_radius`; 0 where s <= 0."""
    a, b, c = axes[0], axes[1], axes[2]
    p, q, r = exponents[0], exponents[1], exponents[2]
    m = z.shape[0]
    big_a = np.empty(m)
    big_b = np.empty(m)
    live = np.zeros(m, dtype=np.bool_)
    for i in range(m):
        h = abs(z[i] - center_z) / c
        s = 1.0 - scalar_pow(min(h, 1.0), 2.0 * r) if h < 1.0 else 0.0
        big_a[i] = a * scalar_pow(s, 1.0 / (2.0 * p))
        big_b[i] = b * scalar_pow(s, 1.0 / (2.0 * q))
        live[i] = s > 0.0
    out = np.zeros(m)
    if np.any(live):
        out[live] = superellipse_radius(big_a[live], big_b[live], p, q, grid)
    return out


@nb.njit(cache=True, nogil=True, error_model="numpy")
def section_boundary(
    center: np.ndarray, axes: np.ndarray, powers: np.ndarray, z: float, u: np.ndarray, reach: float
) -> np.ndarray:  # pragma: no cover - jit
    """The section's boundary at altitude z along the unit directions u (n, 2) from the axis:
    per direction, 40 bisection steps on Gamma <= 1 over radii [0, reach] (seed 001 eq 3 with the
    powers 2p, 2q, 2r, summed in numpy's order); the points (n, 2).  Eight directions go
    together, so that each step's powers are two 8-lane calls."""
    c0, c1, c2 = center[0], center[1], center[2]
    tz = pow_(abs(z - c2) / axes[2], powers[2])
    n = u.shape[0]
    out = np.empty((n, 2))
    lo = np.empty(LANES)
    hi = np.empty(LANES)
    mid = np.empty(LANES)
    bx = np.empty(LANES)
    by = np.empty(LANES)
    tx = np.empty(LANES)
    ty = np.empty(LANES)
    kx = np.full(LANES, powers[0])
    ky = np.full(LANES, powers[1])
    for first in range(0, n, LANES):
        m = min(LANES, n - first)
        lo[:] = 0.0
        hi[:] = reach
        for _ in range(BISECTION_STEPS):
            for j in range(LANES):
                mid[j] = 0.5 * (lo[j] + hi[j])
                i = first + min(j, m - 1)  # spare lanes repeat the last direction
                bx[j] = abs((c0 + mid[j] * u[i, 0]) - c0) / axes[0]
                by[j] = abs((c1 + mid[j] * u[i, 1]) - c1) / axes[1]
            pow_lanes(bx, kx, tx)
            pow_lanes(by, ky, ty)
            for j in range(LANES):
                if (tx[j] + ty[j]) + tz <= 1.0:
                    lo[j] = mid[j]
                else:
                    hi[j] = mid[j]
        for j in range(m):
            r = 0.5 * (lo[j] + hi[j])
            out[first + j, 0] = c0 + r * u[first + j, 0]
            out[first + j, 1] = c1 + r * u[first + j, 1]
    return out
