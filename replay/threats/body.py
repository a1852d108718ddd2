"""The seed 001 convex body threat (``kind: body``, :class:`BodyThreat`): a superellipsoid and its
separation, which has no closed form.

``center: [x0, y0, z0]``, ``axes: [a, b, c]``, ``exponents: [p, q, r]`` (seed 001 eq 3)::

        Gamma(x, y, z) = |(x - x0)/a|^(2p) + |(y - y0)/b|^(2q) + |(z - z0)/c|^(2r)

Gamma < 1 inside, = 1 on the surface, > 1 outside; the no-fly set is Gamma <= 1
(:meth:`BodyThreat.contains`).  Absolute values make odd powers well defined; exponents must be
>= 0.5 so that every term is convex and so is the body (that is what "convex body" means in seed
001), and <= 100 (``EXPONENT_RANGE``).  ``center`` z0 is the body's centre: with z0 at the ground
(``z_base``) the buried lower half does not matter and the body rises to ``z0 + c``.
The horizontal section at altitude z is the superellipse
``|X/A|^(2p) + |Y/B|^(2q) = 1`` with ``A = a s^(1/(2p))``, ``B = b s^(1/(2q))`` and
``s = 1 - |(z - z0)/c|^(2r)`` (no section when s <= 0).  :meth:`BodyThreat.body_radius_at` returns
its circumscribed radius ``max sqrt(X^2 + Y^2)`` over that curve: with ``u = X/A`` in [0, 1],
``f(u) = A^2 u^2 + B^2 (1 - u^(2p))^(1/q)`` is maximised on 257 samples (both ends included)
refined by golden-section search around the best sample.  For p = q = 1 (an ellipse) the answer
is ``max(A, B)`` exactly (f is linear in u^2: a sample end is the maximum); for a = b and
p = q it is ``A 2^(1/2 - 1/(2p))`` when p >= 1, which the search finds to ~1e-12 relative.
It is 0 at the top ``z0 + c`` and the bottom ``z0 - c``.

*Separation* has no closed form; it is computed as a *conservative* value (never more than
the true signed distance) which is, outside the body, also exact to ~1e-9 relative:

- outside (Gamma > 1): for any surface point q and any (sub)gradient g of Gamma at q, the
  convex body lies in the half-space ``g.(x - q) <= 0``, so ``dist(p, body) >= g^.(p - q)``
  (``g^ = g / |g|``): a lower bound whatever q is.  Two surface points are tried.  q0 is the
  radial projection of p, ``c + s (p - c)`` with Gamma = 1 (Newton's method on log Gamma as a
  function of log s, convex and increasing, from the largest coordinate ratio: monotone).  q1
  solves the nearest-point conditions ``x - d = -(lam/2) grad Gamma(x)`` (centred coordinates,
  d = p - c): for a fixed multiplier each axis is the scalar equation
  ``X + mu X^(2p-1) = |d|``, ``mu = lam p / a^(2p)`` (Newton in log X: convex and increasing),
  and Gamma(x(lam)) = 1 is solved for log lam by bracketed Newton.  q1 is projected radially
  onto the surface and the larger bound is the separation; the closer point is
  :meth:`BodyThreat.nearest_point`.  At the nearest point the half-space bound *equals* the
  distance, so the result is exact when the solver converged and a safe lower bound when it
  did not.  Where an exponent is 0.5 the body has edges (|x/a| is not differentiable at 0);
  there the subgradient closest to the direction p - q is used.  Cost: ~1 ms for one point,
  ~10 us per point in batches (the nearest point alone of one point is compiled: ~5 us);
- inside: minus the smallest distance from p to a surface point found along the three axis
  directions and along the radial direction (each an upper bound of the depth);
- on the surface (Gamma = 1): 0.

The common interface of every kind (``active``, ``position``, ``separation``, ``shape``...) is
:class:`replay.threats.kinds.Threat`'s; the body's ``shape(t)`` is an ``"ellipsoid"`` with its
``exponents``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from replay.frames import as_points
from replay.threats import body_kernels
from replay.threats.kinds import EDGE_SUFFIXES, Threat, Vec3, finite_vec3, outline_edges
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

EXPONENT_RANGE = (0.5, 100.0)
_RADIUS_SAMPLES = 257
_GRID = np.linspace(0.0, 1.0, _RADIUS_SAMPLES)  # the samples of u = X/A (body_radius_at)
_GRID.flags.writeable = False


@functools.lru_cache(maxsize=4)
def _directions(n: int) -> FloatArray:
    """(n, 2) unit vectors one per 360/n degrees from the x axis (section_boundary's)."""
    theta = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    u = np.column_stack([np.cos(theta), np.sin(theta)])
    u.flags.writeable = False
    return u


# powers 2p below this (exponents below 0.55) make an edge or a vertex almost a kink: there the
# supporting plane at the nearest point found bounds the distance loosely (2.5 % found by
# Hypothesis), and the support function's bound along the direction to it is taken as well
NEAR_KINK_POWER = 1.1


@dataclass(frozen=True, kw_only=True)
class BodyThreat(Threat):
    """Seed 001 eq 3 convex body (superellipsoid); see the module docstring for the equations."""

    center: Vec3
    axes: Vec3
    exponents: Vec3

    kind: ClassVar[str] = "body"
    extended: ClassVar[bool] = True

    def __post_init__(self) -> None:
        super().__post_init__()
        what = f"threat {self.id!r}"
        object.__setattr__(self, "center", finite_vec3(self.center, f"{what} center"))
        axes = finite_vec3(self.axes, f"{what} axes")
        if min(axes) <= 0:
            raise InputError(f"{what} axes must all be > 0 metres; got {list(axes)}")
        ex = finite_vec3(self.exponents, f"{what} exponents")
        lo, hi = EXPONENT_RANGE
        if min(ex) < lo or max(ex) > hi:
            raise InputError(f"{what} exponents must lie in [{lo}, {hi}]; got {list(ex)}")
        # An exponent within rounding of 0.5 is 0.5: the body has an edge there, and the
        # separation must use the edge's subgradients (found by Hypothesis: exponents
        # (0.5 + 1 ulp, 0.5, 0.5) were treated as smooth and the bound fell 5 % short)
        ex = (
            lo if abs(ex[0] - lo) <= 1e-9 else ex[0],
            lo if abs(ex[1] - lo) <= 1e-9 else ex[1],
            lo if abs(ex[2] - lo) <= 1e-9 else ex[2],
        )
        object.__setattr__(self, "axes", axes)
        object.__setattr__(self, "exponents", ex)
        object.__setattr__(self, "_c", np.array(self.center))
        object.__setattr__(self, "_ax", np.array(axes))
        object.__setattr__(self, "_ex", np.array(ex))
        object.__setattr__(self, "_k", 2.0 * np.array(ex))  # the powers 2p, 2q, 2r

    _c: FloatArray = dataclasses.field(init=False, repr=False, compare=False)
    _ax: FloatArray = dataclasses.field(init=False, repr=False, compare=False)
    _ex: FloatArray = dataclasses.field(init=False, repr=False, compare=False)
    _k: FloatArray = dataclasses.field(init=False, repr=False, compare=False)

    @property
    def top(self) -> float:
        return self.center[2] + self.axes[2]

    @property
    def bottom(self) -> float:
        return self.center[2] - self.axes[2]

    def position(self, t: npt.ArrayLike = 0.0) -> FloatArray:
        return np.broadcast_to(self._c, (*np.shape(t), 3)).copy()

    def gamma(self, p: npt.ArrayLike) -> FloatArray:
        """Seed 001 eq 3: Gamma at map point(s) p (< 1 inside, 1 on the surface, > 1 outside)."""
        u = np.abs(as_points(p) - self._c) / self._ax
        with np.errstate(over="ignore"):
            return np.asarray(np.sum(u**self._k, axis=-1))

    def contains(self, p: npt.ArrayLike) -> BoolArray:
        """True where Gamma <= 1 (inside or on the surface: the no-fly set of seed 001)."""
        return np.asarray(self.gamma(p) <= 1.0)

    def body_radius_at(self, z: npt.ArrayLike) -> FloatArray:
        """Circumscribed radius (m) of the horizontal section at altitude(s) z; 0 outside it
        (compiled: :func:`replay.threats.body_kernels.body_radius`; its twin is
        :func:`body_radius_at_numpy`)."""
        za = np.asarray(z, dtype=np.float64)
        out = body_kernels.body_radius(za.ravel(), self.center[2], self._ax, self._ex, _GRID)
        return np.asarray(out.reshape(za.shape))

    def _radial(self, d: FloatArray) -> FloatArray:
        """Scale s (...) with Gamma(c + s d) = 1 for non-zero offsets d (..., 3)."""
        u = np.abs(d) / self._ax
        m = u.max(axis=-1)
        with np.errstate(divide="ignore"):
            lw = np.log(u / m[..., None])  # <= 0; -inf for zero components
        lam = np.zeros(m.shape)  # log of s * m; h(0) >= 0, h convex increasing: monotone Newton
        for _ in range(60):
            z = self._k * (lam[..., None] + lw)
            zmax = z.max(axis=-1)
            ez = np.exp(z - zmax[..., None])
            total = ez.sum(axis=-1)
            h = zmax + np.log(total)
            dh = (self._k * ez).sum(axis=-1) / total
            step = h / dh
            lam = lam - step
            if np.all(np.abs(step) < 1e-15):
                break
        return np.asarray(np.exp(lam) / m)

    def _plane_bound(self, x: FloatArray, d: FloatArray) -> FloatArray:
        """Lower bound ``g^.(d - x)`` of the distance from d to the body for surface points x
        (centred coordinates), g a subgradient of Gamma at x (the body lies in ``g.(y - x) <= 0``).

        Gamma is smooth except where an exponent is 0.5 (power k = 1) and x is on that axis plane;
        there any g_i in [-1/a_i, 1/a_i] is a subgradient, and the one closest to the direction
        d - x (scaled to the smooth components) is taken, which makes the bound exact at the
        nearest point of an edge or a vertex."""
        v = d - x
        u = x / self._ax
        g = self._k * np.sign(u) * np.abs(u) ** (self._k - 1.0) / self._ax
        kink = (self._k == 1.0) & (x == 0.0)
        plain = np.einsum("ij,ij->i", g, v) / np.linalg.norm(g, axis=-1)
        if not np.any(kink):
            return np.asarray(plain)
        smooth = ~kink
        vv = np.sum(np.where(smooth, v * v, 0.0), axis=-1)
        gv = np.sum(np.where(smooth, g * v, 0.0), axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(vv > 0, gv / vv, np.inf)[:, None]
            want = np.where(np.isfinite(t), t * v, np.sign(v) / self._ax)
        g2 = np.where(kink, np.clip(want, -1.0 / self._ax, 1.0 / self._ax), g)
        norm = np.linalg.norm(g2, axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            fitted = np.where(norm > 0, np.einsum("ij,ij->i", g2, v) / norm, -np.inf)
        with np.errstate(invalid="ignore"):
            return np.asarray(np.fmax(plain, fitted))

    def _inner(
        self, nu: FloatArray, big_d: FloatArray, start: FloatArray | None = None
    ) -> tuple[FloatArray, FloatArray]:
        """For log multipliers nu (N,) and |d| (N, 3): log X (N, 3) solving, per axis,
        ``X + mu X^(k-1) = |d|`` with ``mu = e^nu k / (2 a^k)``, and d(log X)/d(nu).

        Solved as ``psi(l) = log(e^l + mu e^((k-1) l)) - log|d| = 0`` in l = log X: psi is convex
        and increasing with slope >= min(1, k - 1), so Newton's method converges from any start
        (monotonically from the right; a start left of the root jumps right once).  The start is
        ``start`` (the previous outer iterate) where finite, else l = log|d|.  k = 1 has the closed
        form X = max(|d| - mu, 0)."""
        k, km1 = self._k, self._k - 1.0
        m = nu[:, None] + np.log(k / 2.0) - k * np.log(self._ax)  # log mu
        zero = big_d <= 0.0
        with np.errstate(divide="ignore"):
            ld = np.log(np.where(zero, 1.0, big_d))
        lx = ld.copy() if start is None else np.where(np.isfinite(start), start, ld)
        for _ in range(100):
            a2 = m + km1 * lx
            top = np.maximum(lx, a2)
            e1, e2 = np.exp(lx - top), np.exp(a2 - top)
            step = (top + np.log(e1 + e2) - ld) / ((e1 + km1 * e2) / (e1 + e2))
            step = np.where(km1 > 0.0, step, 0.0)
            lx = lx - step
            if np.all(np.abs(step) < 1e-14):
                break
        a2 = m + km1 * lx
        top = np.maximum(lx, a2)
        e1, e2 = np.exp(lx - top), np.exp(a2 - top)
        dlx = -e2 / (e1 + km1 * e2)
        linear = np.broadcast_to(km1 == 0.0, lx.shape)
        if np.any(linear):  # k = 1: X = |d| - mu, dX/dnu = -mu
            mu = np.exp(m)
            x1 = np.clip(np.exp(ld) - mu, 0.0, None)
            with np.errstate(divide="ignore", invalid="ignore"):
                lx = np.where(linear, np.log(x1), lx)
                dlx = np.where(linear, np.where(x1 > 0, -mu / x1, 0.0), dlx)
        lx = np.where(zero, -np.inf, lx)
        dlx = np.where(zero | ~np.isfinite(lx), 0.0, dlx)
        return lx, dlx

    def _outside(self, p: FloatArray) -> tuple[FloatArray, FloatArray]:
        """For points p (N, 3) outside: (lower bound of the distance (N,), closest surface point
        found (N, 3)).

        The nearest point x of the surface (centred coordinates, d = p - c) satisfies
        ``x - d = -(lam / 2) grad Gamma(x)``: per axis ``X + mu X^(k-1) = |d|`` (see
        :meth:`_inner`), and Gamma(x(lam)) decreases with lam.  ``log Gamma = 0`` is solved for
        nu = log lam by Newton's method kept inside a bracket (bisection when a step leaves it),
        started from the radial projection.  The radial projection and the solution each bound
        the distance from below through their supporting plane; the larger bound is returned."""
        d = p - self._c
        big_d = np.abs(d)
        q0 = self._radial(d)[:, None] * d
        lower0 = self._plane_bound(q0, d)
        u0 = np.abs(q0) / self._ax
        grad0 = np.linalg.norm(self._k * u0 ** (self._k - 1.0) / self._ax, axis=-1)
        nu = np.log(np.maximum(2.0 * np.linalg.norm(d - q0, axis=-1) / grad0, 1e-300))
        lo, hi = np.full(len(d), -np.inf), np.full(len(d), np.inf)
        la = np.log(self._ax)
        lx: FloatArray | None = None
        for _ in range(80):
            lx, dlx = self._inner(nu, big_d, lx)
            z = self._k * (lx - la)
            top = np.max(z, axis=-1)
            live = np.isfinite(top)  # else every X is 0 (k = 1 axes clamped): Gamma = 0
            w = np.exp(z - np.where(live, top, 0.0)[:, None])
            total = np.where(live, w.sum(axis=-1), 1.0)
            f = np.where(live, top + np.log(total), -np.inf)  # log Gamma
            df = np.sum(w * self._k * dlx, axis=-1) / total
            lo = np.where(f > 0, nu, lo)
            hi = np.where(f <= 0, nu, hi)
            with np.errstate(divide="ignore", invalid="ignore"):
                step = np.where(live & (df < 0), -f / df, np.where(live, 4.0, -4.0))
                step = np.clip(step, -4.0, 4.0)
            cand = nu + step
            out = (cand <= lo) | (cand >= hi)
            cand = np.where(out & np.isfinite(lo) & np.isfinite(hi), 0.5 * (lo + hi), cand)
            done = (np.abs(f) < 1e-14) | (hi - lo < 1e-13)
            nu = np.where(done, nu, cand)
            if np.all(done):
                break
        assert lx is not None
        x = np.sign(d) * np.exp(lx)
        x = np.where(np.any(x != 0.0, axis=-1)[:, None], x, q0)
        x = self._radial(x)[:, None] * x  # exactly onto the surface
        lower = self._plane_bound(x, d)
        closer = np.linalg.norm(d - x, axis=-1) <= np.linalg.norm(d - q0, axis=-1)
        best = np.where(closer[:, None], x, q0)
        bound = np.maximum(lower, lower0)
        if np.any((self._k > 1.0) & (self._k < NEAR_KINK_POWER)):
            v = d - best
            n = np.linalg.norm(v, axis=-1)
            live = n > 0
            if np.any(live):
                u = v[live] / n[live, None]
                dual = np.einsum("ij,ij->i", u, d[live]) - self._support(u)
                bound[live] = np.maximum(bound[live], dual)
        return np.maximum(bound, 0.0), best + self._c

    def _support(self, n: FloatArray) -> FloatArray:
        """An upper bound (tight to rounding) of the support function ``max n.y`` over the body
        (centred) for unit directions n (N, 3), so that ``n.d - h(n)`` bounds the distance from
        d to the body from below for any n (the body lies in ``n.y <= h(n)``).

        With ``w_i = |n_i| a_i`` and ``y_i = |x_i| / a_i``: h = max sum w_i y_i subject to
        sum y_i^k_i <= 1.  By Lagrangian duality, for every lam > 0
        ``h <= lam + sum_i sup_y (w_i y - lam y^k_i)``, the sup being
        ``(1 - 1/k) w (w / (lam k))^(1/(k-1))`` for k > 1 and 0 (when w <= lam) for k = 1; the
        right-hand side is convex in log lam and minimised by bisection on its slope, in logs
        (a near-kink power k = 1.004 raises to 1/(k-1) = 250).  Any lam gives a valid bound, so
        the search's accuracy only tightens it."""
        k = np.broadcast_to(self._k, n.shape)
        w = np.abs(n) * self._ax
        smooth = k > 1.0
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(smooth, 1.0 / (k - 1.0), 0.0)
            lw = np.log(w)
            # log of (1 - 1/k) w (w / k)^s and of its slope's weight s * c
            lc = np.where(smooth & (w > 0), np.log1p(-1.0 / k) + lw + s * (lw - np.log(k)), -np.inf)
            lcs = np.where(np.isfinite(lc), lc + np.log(np.where(smooth, s, 1.0)), -np.inf)
        # lam >= w_i on the axes with k = 1 (else their sup is infinite)
        floor = np.max(np.where(~smooth & (w > 0), lw, -np.inf), axis=-1)

        def lse(a: FloatArray) -> FloatArray:
            top = np.max(a, axis=-1)
            safe = np.where(np.isfinite(top), top, 0.0)
            with np.errstate(divide="ignore"):
                return np.asarray(safe + np.log(np.sum(np.exp(a - safe[:, None]), axis=-1)))

        finite_lw = np.where(np.isfinite(lw), lw, 0.0)
        lo = np.min(finite_lw, axis=-1) - 60.0
        hi = np.max(finite_lw, axis=-1) + 60.0
        for _ in range(200):  # the slope e^t - sum s c e^(-s t) is increasing in t = log lam
            t = 0.5 * (lo + hi)
            up = t >= lse(lcs - s * t[:, None])
            hi = np.where(up, t, hi)
            lo = np.where(up, lo, t)
            if np.all(hi - lo < 1e-12):
                break
        t = np.fmax(hi, floor)
        h = np.exp(t) + np.exp(lse(lc - s * t[:, None]))
        return np.asarray(h * (1.0 + 1e-12))

    def _depth(self, p: FloatArray) -> FloatArray:
        """Upper bound of the depth of points p (N, 3) inside: distance to the surface along the
        axis directions and the radial direction."""
        u = np.abs(p - self._c) / self._ax
        terms = u**self._k
        rest = terms.sum(axis=-1, keepdims=True) - terms
        exits = self._ax * np.clip(1.0 - rest, 0.0, None) ** (1.0 / self._k) - np.abs(p - self._c)
        depth = np.clip(exits, 0.0, None).min(axis=-1)
        d = p - self._c
        off = np.linalg.norm(d, axis=-1) > 0
        if np.any(off):
            s = self._radial(d[off])
            depth[off] = np.minimum(depth[off], (s - 1.0) * np.linalg.norm(d[off], axis=-1))
        return np.asarray(depth)

    def separation(self, p: npt.ArrayLike, t: npt.ArrayLike = 0.0) -> FloatArray:
        q = as_points(p)
        flat = q.reshape(-1, 3)
        g = self.gamma(flat)
        out = np.zeros(len(flat))
        outside, inside = g > 1.0, g < 1.0
        if np.any(outside):
            out[outside] = self._outside(flat[outside])[0]
        if np.any(inside):
            out[inside] = -self._depth(flat[inside])
        return out.reshape(q.shape[:-1])

    def nearest_point(self, p: npt.ArrayLike) -> FloatArray:
        """The closest surface point found for outside points (see the module docstring); the
        point itself inside (clipped to the body).  One point (the radar's question) is
        compiled: :func:`replay.threats.body_kernels.nearest_point`, the same steps (to rounding)."""
        q = as_points(p)
        if q.size == 3:
            near = body_kernels.nearest_point(q.reshape(3), self._c, self._ax, self._k)
            return np.asarray(near.reshape(q.shape))
        return nearest_point_numpy(self, q)

    def radar_points(
        self, t: float, observer: npt.ArrayLike, max_range: float = math.inf
    ) -> tuple[list[str], FloatArray]:
        """The nearest point, then the outline's left and right edges of the section at the
        nearest point's altitude, as a scanning radar sees the body's extent."""
        o = as_points(observer).reshape(1, 3)
        if np.linalg.norm(o - self._c) - np.linalg.norm(self._ax) > max_range:
            return [], np.zeros((0, 3))  # the body lies inside the sphere of radius |axes|
        near = self.nearest_point(o)
        z = float(near[0, 2])
        boundary = self.section_boundary(z)
        edges = None if boundary is None else outline_edges(o[0], boundary, z)
        if edges is None:
            return [self.id], near
        return [self.id, *(self.id + s for s in EDGE_SUFFIXES)], np.vstack([near, edges])

    def section_boundary(self, z: float, n: int = 360) -> FloatArray | None:
        """``n`` points (n, 2) of the horizontal section's boundary at altitude ``z`` (one per
        degree about the axis, by bisection on Gamma = 1), None where the section is empty
        (compiled: :func:`replay.threats.body_kernels.section_boundary`; its twin is
        :func:`section_boundary_numpy`)."""
        if not float(self.body_radius_at(z)) > 0.0:
            return None
        reach = float(np.hypot(self._ax[0], self._ax[1])) * 1.01
        return np.asarray(
            body_kernels.section_boundary(
                self._c, self._ax, self._k, float(z), _directions(n), reach
            )
        )

    def shape(self, t: float = 0.0) -> dict[str, Any]:
        return {
            "id": self.id,
            "kind": "ellipsoid",
            "center": list(self.center),
            "axes": list(self.axes),
            "exponents": list(self.exponents),
            "top": self.top,
            "bottom": self.bottom,
        }

    def to_record(self) -> dict[str, Any]:
        return {
            **super().to_record(),
            "center": list(self.center),
            "axes": list(self.axes),
            "exponents": list(self.exponents),
        }


def superellipse_radius_numpy(
    big_a: FloatArray, big_b: FloatArray, p: float, q: float
) -> FloatArray:
    """max sqrt(X^2 + Y^2) on |X/A|^(2p) + |Y/B|^(2q) = 1, for arrays A, B > 0 (M,): the numpy
    twin of :func:`replay.threats.body_kernels.superellipse_radius`."""

    def f(u: FloatArray) -> FloatArray:
        v = np.clip(1.0 - u ** (2 * p), 0.0, None) ** (1.0 / q)
        return np.asarray(big_a[:, None] ** 2 * u**2 + big_b[:, None] ** 2 * v)

    grid = _GRID
    vals = f(np.broadcast_to(grid, (len(big_a), len(grid))))
    k = vals.argmax(axis=1)
    best = vals[np.arange(len(k)), k]
    lo = grid[np.clip(k - 1, 0, len(grid) - 1)]
    hi = grid[np.clip(k + 1, 0, len(grid) - 1)]
    g = (math.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = f(x1[:, None])[:, 0], f(x2[:, None])[:, 0]
    for _ in range(80):
        left = f1 > f2  # the maximum lies in [lo, x2]
        hi = np.where(left, x2, hi)
        lo = np.where(left, lo, x1)
        x1n, x2n = hi - g * (hi - lo), lo + g * (hi - lo)
        x1, x2 = x1n, x2n
        f1, f2 = f(x1[:, None])[:, 0], f(x2[:, None])[:, 0]
    best = np.maximum(best, np.maximum(f1, f2))
    return np.asarray(np.sqrt(best))


def body_radius_at_numpy(body: BodyThreat, z: npt.ArrayLike) -> FloatArray:
    """The numpy twin of :meth:`BodyThreat.body_radius_at` (the tests compare the two)."""
    za = np.asarray(z, dtype=np.float64)
    a, b, c = body.axes
    p, q, r = body.exponents
    h = np.abs(za - body.center[2]) / c
    s = np.where(h < 1.0, 1.0 - np.minimum(h, 1.0) ** (2 * r), 0.0).ravel()
    big_a = a * s ** (1 / (2 * p))
    big_b = b * s ** (1 / (2 * q))
    out = np.zeros_like(s)
    live = s > 0
    if np.any(live):
        out[live] = superellipse_radius_numpy(big_a[live], big_b[live], p, q)
    return out.reshape(za.shape)


def section_boundary_numpy(body: BodyThreat, z: float, n: int = 360) -> FloatArray | None:
    """The numpy twin of :meth:`BodyThreat.section_boundary` (the tests compare the two)."""
    if not float(body_radius_at_numpy(body, z)) > 0.0:
        return None
    theta = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    u = np.column_stack([np.cos(theta), np.sin(theta)])
    lo = np.zeros(n)
    hi = np.full(n, float(np.hypot(body._ax[0], body._ax[1])) * 1.01)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        pts = np.column_stack(
            [body._c[0] + mid * u[:, 0], body._c[1] + mid * u[:, 1], np.full(n, z)]
        )
        inside = body.gamma(pts) <= 1.0
        lo = np.where(inside, mid, lo)
        hi = np.where(inside, hi, mid)
    r = 0.5 * (lo + hi)
    return np.column_stack([body._c[0] + r * u[:, 0], body._c[1] + r * u[:, 1]])


def nearest_point_numpy(body: BodyThreat, p: npt.ArrayLike) -> FloatArray:
    """:meth:`BodyThreat.nearest_point` in numpy, for batches (its loops stop when every point has
    converged) and as the twin of the one-point kernel (the tests compare the two)."""
    q = as_points(p)
    flat = q.reshape(-1, 3).copy()
    outside = body.gamma(flat) > 1.0
    if np.any(outside):
        flat[outside] = body._outside(flat[outside])[1]
    return flat.reshape(q.shape)
