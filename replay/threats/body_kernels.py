"""Compiled (numba) hot loops of :class:`~replay.threats.body.BodyThreat`: the section's
circumscribed radius (:meth:`~replay.threats.body.BodyThreat.body_radius_at`), its boundary
(:meth:`~replay.threats.body.BodyThreat.section_boundary`) and the nearest point of one point
(:meth:`~replay.threats.body.BodyThreat.nearest_point`), which a radar scan asks for each body.

Each is an iterative search on one value or a few hundred (an 80-step golden-section search, a
40-step bisection, nested Newton loops), where numpy's per-call overhead was nearly all the cost
(about 1.5 ms, 3 ms and 0.6 ms a call).  The kernels do the same arithmetic in the same order,
one element at a time, with the C library's ``pow``, ``exp`` and ``log`` (numba's).  numpy's own
(Intel's SVML where the CPU has AVX-512) round differently in the last bit in a few per cent of
cases, so the kernels agree with the numpy code -- kept in ``body.py`` (``..._numpy``, and
``BodyThreat._outside`` for batches) -- to rounding, not to the bit: ``tests/test_threats.py``
compares them on random bodies (relative 1e-12 of the body's size).  numpy's shortcuts for
``array ** scalar`` (2: ``x * x``, 0.5: ``sqrt``, -1: ``1 / x``) are kept (:func:`scalar_pow`).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np


@nb.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def scalar_pow(x: float, e: float) -> float:  # pragma: no cover - jit
    """``x ** e`` as numpy computes an array to a Python scalar: its shortcuts for 2, 0.5, -1."""
    if e == 2.0:
        return x * x
    if e == 0.5:
        return math.sqrt(x)
    if e == -1.0:
        return 1.0 / x
    return math.pow(x, e)


GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0
GOLDEN_STEPS = 80
BISECTION_STEPS = 40


@nb.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _f(u: float, a2: float, b2: float, e1: float, e2: float) -> float:  # pragma: no cover - jit
    """``A^2 u^2 + B^2 (1 - u^(2p))^(1/q)`` (the clip at 0 included), in the numpy code's order
    of operations."""
    v = scalar_pow(max(1.0 - scalar_pow(u, e1), 0.0), e2)
    return a2 * (u * u) + b2 * v


@nb.njit(cache=True, nogil=True, error_model="numpy")
def superellipse_radius(
    big_a: np.ndarray, big_b: np.ndarray, p: float, q: float, grid: np.ndarray
) -> np.ndarray:  # pragma: no cover - jit
    """max sqrt(X^2 + Y^2) on |X/A|^(2p) + |Y/B|^(2q) = 1 for A, B > 0 (M,): the best of the
    ``grid`` samples of u = X/A in [0, 1], refined by golden-section search between its
    neighbours (``body.superellipse_radius_numpy``'s steps)."""
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
    powers 2p, 2q, 2r, summed in numpy's order); the points (n, 2)."""
    c0, c1, c2 = center[0], center[1], center[2]
    tz = math.pow(abs(z - c2) / axes[2], powers[2])
    n = u.shape[0]
    out = np.empty((n, 2))
    for i in range(n):
        lo, hi = 0.0, reach
        for _ in range(BISECTION_STEPS):
            mid = 0.5 * (lo + hi)
            tx = math.pow(abs((c0 + mid * u[i, 0]) - c0) / axes[0], powers[0])
            ty = math.pow(abs((c1 + mid * u[i, 1]) - c1) / axes[1], powers[1])
            if (tx + ty) + tz <= 1.0:
                lo = mid
            else:
                hi = mid
        r = 0.5 * (lo + hi)
        out[i, 0] = c0 + r * u[i, 0]
        out[i, 1] = c1 + r * u[i, 1]
    return out


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _radial(d: np.ndarray, axes: np.ndarray, powers: np.ndarray) -> float:  # pragma: no cover - jit
    """``BodyThreat._radial`` for one non-zero offset d (3,): s with Gamma(c + s d) = 1."""
    lw = np.empty(3)
    m = max(max(abs(d[0]) / axes[0], abs(d[1]) / axes[1]), abs(d[2]) / axes[2])
    for i in range(3):
        lw[i] = math.log((abs(d[i]) / axes[i]) / m)
    z = np.empty(3)
    lam = 0.0
    for _ in range(60):
        for i in range(3):
            z[i] = powers[i] * (lam + lw[i])
        zmax = max(max(z[0], z[1]), z[2])
        e0, e1, e2 = math.exp(z[0] - zmax), math.exp(z[1] - zmax), math.exp(z[2] - zmax)
        total = (e0 + e1) + e2
        h = zmax + math.log(total)
        dh = ((powers[0] * e0 + powers[1] * e1) + powers[2] * e2) / total
        step = h / dh
        lam = lam - step
        if abs(step) < 1e-15:
            break
    return math.exp(lam) / m


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _inner(
    nu: float,
    big_d: np.ndarray,
    lx: np.ndarray,
    dlx: np.ndarray,
    lk: np.ndarray,
    kla: np.ndarray,
    ld: np.ndarray,
    powers: np.ndarray,
) -> None:  # pragma: no cover - jit
    """``BodyThreat._inner`` for one point: log X and d(log X)/d(nu) into lx and dlx (3,), from
    the start in lx (the previous outer iterate; log|d| where not finite).  lk holds ``log(k / 2)``
    per axis, kla ``k log(a)``, ld ``log|d|`` (0 for zero components)."""
    m = np.empty(3)
    for i in range(3):
        m[i] = (nu + lk[i]) - kla[i]  # log mu
        if not np.isfinite(lx[i]):
            lx[i] = ld[i]
    for _ in range(100):
        small = True
        for i in range(3):
            km1 = powers[i] - 1.0
            a2 = m[i] + km1 * lx[i]
            top = max(lx[i], a2)
            e1, e2 = math.exp(lx[i] - top), math.exp(a2 - top)
            step = (top + math.log(e1 + e2) - ld[i]) / ((e1 + km1 * e2) / (e1 + e2))
            step = step if km1 > 0.0 else 0.0
            lx[i] = lx[i] - step
            small = small and abs(step) < 1e-14
        if small:
            break
    for i in range(3):
        km1 = powers[i] - 1.0
        a2 = m[i] + km1 * lx[i]
        top = max(lx[i], a2)
        e1, e2 = math.exp(lx[i] - top), math.exp(a2 - top)
        dlx[i] = -e2 / (e1 + km1 * e2)
        if km1 == 0.0:  # k = 1: X = |d| - mu, dX/dnu = -mu
            mu = math.exp(m[i])
            x1 = max(math.exp(ld[i]) - mu, 0.0)
            lx[i] = math.log(x1)
            dlx[i] = -mu / x1 if x1 > 0 else 0.0
        if big_d[i] <= 0.0:
            lx[i] = -np.inf
        if big_d[i] <= 0.0 or not np.isfinite(lx[i]):
            dlx[i] = 0.0


@nb.njit(cache=True, nogil=True, error_model="numpy")
def nearest_point(
    p: np.ndarray, center: np.ndarray, axes: np.ndarray, powers: np.ndarray
) -> np.ndarray:  # pragma: no cover - jit
    """``BodyThreat.nearest_point`` of one point p (3,): the closer of its radial projection and
    the nearest-point conditions' solution (``BodyThreat._outside``'s steps for one point); p
    itself when Gamma(p) <= 1.  The numpy loops stop when every point of a batch has converged,
    so only a batch of one has these iterations: batches stay with numpy."""
    d = np.empty(3)
    big_d = np.empty(3)
    for i in range(3):
        d[i] = p[i] - center[i]
        big_d[i] = abs(d[i])
    g = (
        math.pow(big_d[0] / axes[0], powers[0]) + math.pow(big_d[1] / axes[1], powers[1])
    ) + math.pow(big_d[2] / axes[2], powers[2])
    if not g > 1.0:
        return p.copy()
    s0 = _radial(d, axes, powers)
    q0 = np.empty(3)
    grad = np.empty(3)
    gap = np.empty(3)
    for i in range(3):
        q0[i] = s0 * d[i]
        grad[i] = powers[i] * math.pow(abs(q0[i]) / axes[i], powers[i] - 1.0) / axes[i]
        gap[i] = d[i] - q0[i]
    grad0 = math.sqrt((grad[0] * grad[0] + grad[1] * grad[1]) + grad[2] * grad[2])
    dist0 = math.sqrt((gap[0] * gap[0] + gap[1] * gap[1]) + gap[2] * gap[2])
    nu = math.log(max(2.0 * dist0 / grad0, 1e-300))
    lo, hi = -np.inf, np.inf
    la = np.empty(3)
    lk = np.empty(3)
    kla = np.empty(3)
    ld = np.empty(3)
    lx = np.full(3, np.nan)  # no start: log|d|
    dlx = np.empty(3)
    z = np.empty(3)
    for i in range(3):
        la[i] = math.log(axes[i])
        lk[i] = math.log(powers[i] / 2.0)
        kla[i] = powers[i] * la[i]
        ld[i] = math.log(big_d[i] if big_d[i] > 0.0 else 1.0)
    for _ in range(80):
        _inner(nu, big_d, lx, dlx, lk, kla, ld, powers)
        for i in range(3):
            z[i] = powers[i] * (lx[i] - la[i])
        top = max(max(z[0], z[1]), z[2])
        live = np.isfinite(top)  # else every X is 0 (k = 1 axes clamped): Gamma = 0
        shift = top if live else 0.0
        w0, w1, w2 = math.exp(z[0] - shift), math.exp(z[1] - shift), math.exp(z[2] - shift)
        total = (w0 + w1) + w2 if live else 1.0
        f = top + math.log(total) if live else -np.inf  # log Gamma
        df = ((w0 * powers[0] * dlx[0] + w1 * powers[1] * dlx[1]) + w2 * powers[2] * dlx[2]) / total
        if f > 0:
            lo = nu
        if f <= 0:
            hi = nu
        if live and df < 0:
            step = -f / df
        else:
            step = 4.0 if live else -4.0
        step = min(max(step, -4.0), 4.0)
        cand = nu + step
        if (cand <= lo or cand >= hi) and np.isfinite(lo) and np.isfinite(hi):
            cand = 0.5 * (lo + hi)
        if abs(f) < 1e-14 or hi - lo < 1e-13:
            break
        nu = cand
    x = np.empty(3)
    for i in range(3):
        sign = 1.0 if d[i] > 0.0 else (-1.0 if d[i] < 0.0 else 0.0)
        x[i] = sign * math.exp(lx[i])
    if x[0] == 0.0 and x[1] == 0.0 and x[2] == 0.0:
        x[:] = q0
    s = _radial(x, axes, powers)
    for i in range(3):
        x[i] = s * x[i]
        gap[i] = d[i] - x[i]
    dist = math.sqrt((gap[0] * gap[0] + gap[1] * gap[1]) + gap[2] * gap[2])
    best = x if dist <= dist0 else q0
    out = np.empty(3)
    for i in range(3):
        out[i] = best[i] + center[i]
    return out
