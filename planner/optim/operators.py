"""Small, swappable operators shared by the optimisers (all vectorised over the population).

Arrays: positions ``X`` (P, D), velocities ``V`` (P, D), costs ``f`` (P,), box ``lower``/``upper``
(D,). Random draws come only from the ``rng`` passed in.

Bound handling (every returned position is inside ``[lower, upper]``):

- :func:`clip` — project each coordinate onto the box. For PSO, :func:`absorb` clips and also sets
  to zero the velocity component that hit the wall (the "absorbing wall"). Zeroing matters: a
  clipped particle that kept its velocity would push into the same wall on every following move and
  waste its evaluations on the boundary; with zero velocity its next move is driven only by the
  attraction to pbest and gbest, which lie inside the box. It also lets the swarm land exactly on an
  optimum that lies on the boundary.
- :func:`reflect` — mirror the overshoot back into the box (repeatedly, so any overshoot works:
  the coordinate is folded with period ``2 * range``). :func:`bounce` reflects and negates the
  velocity component of every coordinate that was mirrored an odd number of times, so the particle
  keeps moving the way its mirrored position suggests.

Velocity clamp (seed 000 Algorithm 10 lines 13-15): ``|v_d| <= vmax_d`` with
``vmax_d = vmax_frac * (upper_d - lower_d)``.

Selection (minimisation; returns indices into the population):

- :func:`roulette_selection` — fitness-proportionate. Costs become fitness by *windowing*:
  ``fit_i = f_max - f_i + eps`` with ``f_max``, ``f_min`` the largest/smallest finite cost and
  ``eps = 0.01 * (f_max - f_min)``, so selection does not depend on the sign or offset of the costs,
  the worst member keeps a small non-zero chance, and the best is ``1 + 1/0.01 = 101`` times as
  likely as the worst. Non-finite costs get zero fitness; if all costs are equal (or none is
  finite) the choice is uniform. ``scaling="rank"`` uses linear ranking instead
  (``fit = P - rank``, best rank 0), which ignores the cost scale entirely (robust to outliers).
- :func:`tournament_selection` — the best of ``size`` members drawn uniformly with replacement.

Crossover (pairs of parents ``A``, ``B`` (n, D) -> two children each; each pair crosses with
probability ``rate``, otherwise the children are copies of the parents):

- :func:`single_point_crossover` — a cut ``c`` uniform in ``1 .. D-1``; child 1 takes genes
  ``< c`` from A and the rest from B, child 2 the opposite. With D = 1 there is no cut: copies.
- :func:`blend_crossover` — BLX-alpha (Eshelman & Schaffer 1993): each gene uniform in
  ``[min - alpha*I, max + alpha*I]`` with ``I = |a - b|``, drawn independently for each child.
  Children may leave the box; the caller repairs them.

Mutation:

- :func:`gaussian_gene_mutation` — each gene with probability ``rate`` gets ``+ sigma_d * N(0, 1)``.
- :func:`uniform_gene_mutation` — each gene with probability ``rate`` is redrawn uniform in the box.
- :func:`gaussian_particle_mutation` — each row with probability ``rate`` gets
  ``+ step_d * N(0, 1)`` on every coordinate (seed 002 eq 14 with ``step = m * sigma``).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
Generator = np.random.Generator

__all__ = [
    "absorb",
    "blend_crossover",
    "bounce",
    "clamp_velocity",
    "clip",
    "gaussian_gene_mutation",
    "gaussian_particle_mutation",
    "reflect",
    "roulette_selection",
    "single_point_crossover",
    "tournament_selection",
    "uniform_gene_mutation",
]


# --------------------------------------------------------------------------- bounds


def clip(X: FloatArray, lower: FloatArray, upper: FloatArray) -> FloatArray:
    """Each coordinate projected onto ``[lower_d, upper_d]``."""
    return np.clip(X, lower, upper)


def reflect(X: FloatArray, lower: FloatArray, upper: FloatArray) -> FloatArray:
    """Each coordinate mirrored at the walls until it lies inside the box."""
    return _fold(X, lower, upper)[0]


def absorb(
    X: FloatArray, V: FloatArray, lower: FloatArray, upper: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """PSO absorbing walls: positions clipped, velocity components that hit a wall set to zero."""
    hit = (X < lower) | (X > upper)
    return np.clip(X, lower, upper), np.where(hit, 0.0, V)


def bounce(
    X: FloatArray, V: FloatArray, lower: FloatArray, upper: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """PSO reflecting walls: positions mirrored, velocity negated where mirrored an odd count."""
    folded, flipped = _fold(X, lower, upper)
    return folded, np.where(flipped, -V, V)


def _fold(
    X: FloatArray, lower: FloatArray, upper: FloatArray
) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
    span = upper - lower
    shifted = X - lower
    flipped = np.floor_divide(shifted, span) % 2 == 1
    y = np.mod(shifted, 2.0 * span)
    y = np.where(y > span, 2.0 * span - y, y)
    return np.clip(lower + y, lower, upper), flipped  # clip: rounding at the walls only


def clamp_velocity(V: FloatArray, vmax: FloatArray) -> FloatArray:
    """``|v_d| <= vmax_d`` component-wise."""
    return np.clip(V, -vmax, vmax)


# --------------------------------------------------------------------------- selection


def roulette_selection(
    f: FloatArray, n: int, rng: Generator, *, scaling: Literal["window", "rank"] = "window"
) -> IntArray:
    """``n`` indices drawn with probability proportional to the (windowed or ranked) fitness."""
    f = np.asarray(f, dtype=np.float64)
    finite = np.isfinite(f)
    if scaling == "rank":
        order = np.argsort(np.where(finite, f, np.inf), kind="stable")
        fitness = np.empty(f.size)
        fitness[order] = np.arange(f.size, 0, -1, dtype=np.float64)
        fitness[~finite] = 0.0
    else:
        fitness = np.zeros(f.size)
        if np.any(finite):
            f_max, f_min = np.max(f[finite]), np.min(f[finite])
            fitness[finite] = f_max - f[finite] + 0.01 * (f_max - f_min)
    total = float(np.sum(fitness))
    if not total > 0.0:
        return rng.integers(0, f.size, n)
    cdf = np.cumsum(fitness / total)
    cdf[-1] = 1.0
    # side="right" never lands on a zero-width bin (a member with zero fitness).
    return np.searchsorted(cdf, rng.random(n), side="right").astype(np.intp)


def tournament_selection(f: FloatArray, n: int, rng: Generator, *, size: int = 2) -> IntArray:
    """``n`` indices, each the best (lowest cost, first on ties) of ``size`` uniform draws."""
    candidates = rng.integers(0, f.size, (n, size))
    winner = np.argmin(np.asarray(f)[candidates], axis=1)
    return candidates[np.arange(n), winner].astype(np.intp)


# --------------------------------------------------------------------------- crossover


def single_point_crossover(
    A: FloatArray, B: FloatArray, rate: float, rng: Generator
) -> tuple[FloatArray, FloatArray]:
    """One cut per crossing pair; the children swap the tails after the cut."""
    n, d = int(A.shape[0]), int(A.shape[1])
    cross = rng.random(n) < rate
    if d < 2:
        return A.copy(), B.copy()
    cut = rng.integers(1, d, n)
    swap = cross[:, None] & (np.arange(d)[None, :] >= cut[:, None])
    return np.where(swap, B, A), np.where(swap, A, B)


def blend_crossover(
    A: FloatArray, B: FloatArray, rate: float, rng: Generator, *, alpha: float = 0.5
) -> tuple[FloatArray, FloatArray]:
    """BLX-alpha: every gene of a crossing pair uniform in the parents' interval widened by alpha."""
    n, d = int(A.shape[0]), int(A.shape[1])
    cross = rng.random(n) < rate
    low, high = np.minimum(A, B), np.maximum(A, B)
    spread = alpha * (high - low)
    low, width = low - spread, (high - low) + 2.0 * spread
    C1 = low + rng.random((n, d)) * width
    C2 = low + rng.random((n, d)) * width
    keep = ~cross[:, None]
    return np.where(keep, A, C1), np.where(keep, B, C2)


# --------------------------------------------------------------------------- mutation


def gaussian_gene_mutation(
    X: FloatArray, rate: float, sigma: FloatArray, rng: Generator
) -> FloatArray:
    """Each gene with probability ``rate``: ``x + sigma_d * N(0, 1)`` (may leave the box)."""
    mask = rng.random(X.shape) < rate
    return np.where(mask, X + sigma * rng.standard_normal(X.shape), X)


def uniform_gene_mutation(
    X: FloatArray, rate: float, lower: FloatArray, upper: FloatArray, rng: Generator
) -> FloatArray:
    """Each gene with probability ``rate``: redrawn uniform in ``[lower_d, upper_d]``."""
    mask = rng.random(X.shape) < rate
    fresh = np.minimum(lower + rng.random(X.shape) * (upper - lower), upper)
    return np.where(mask, fresh, X)


def gaussian_particle_mutation(
    X: FloatArray, rate: float, step: FloatArray, rng: Generator
) -> FloatArray:
    """Each row with probability ``rate``: ``x + step * N(0, I)`` on all coordinates."""
    rows = np.flatnonzero(rng.random(int(X.shape[0])) < rate)
    out = X.copy()
    out[rows] += step * rng.standard_normal((rows.size, X.shape[1]))
    return out
