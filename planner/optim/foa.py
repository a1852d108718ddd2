"""θ-MAFOA: phase-angle-encoded fruit fly optimisation with mutation adaptation (seed 000 §6).

Basic FOA (Pan 2012): a swarm location; every iteration each fly searches "by smell" at a random
offset from the swarm location, the flies are evaluated, and the swarm flies "by vision" to the best
fly if it smells better than the swarm location (elitist). θ-MAFOA (Zhang, Lu, Jia & Li, Appl. Soft
Comput. 2018; seed 000 ref. [21]) encodes positions as phase angles and adds a mutation with an
adaptive rate. The paper was not available here; this module implements the three ideas in the
form below, which is geometrically sound for a box and stated exactly:

Phase encoding. A position is a phase vector θ; it decodes to the box by

    x_d(θ) = c_d + h_d sin θ_d,     c = (upper + lower) / 2,   h = (upper - lower) / 2

which maps [-π/2, π/2] one-to-one onto [lower_d, upper_d]. Any θ decodes inside the box, and a
phase past ±π/2 decodes to the mirror image of its overshoot (sin(π - θ) = sin θ): the encoding *is*
the reflecting wall (``boundary="reflect"``, default); ``boundary="clip"`` clips θ to [-π/2, π/2]
instead (absorbing wall). Stored phases are canonical, θ = arcsin((x - c) / h). Equal steps in θ are
small steps in x near the walls and large ones in the middle (dx = h cos θ dθ).

Osphresis (smell) search with mutation. With swarm location θ* (the phase of the best point so far)
and search radius σ(t) (radians), fly i = 1 .. P gets, for every dimension d,

    θ_id = θ*_d + σ(t) * (2 u_id - 1)   if m_id,   else θ*_d              u_id ~ U[0, 1)
    m_id ~ Bernoulli(mutation_rate), plus one dimension d_i (uniform) forced to mutate

i.e. a fly copies the swarm location and mutates each phase with probability ``mutation_rate``
(seed 000: 0.8; [21] reports rates in 0.5-0.9 work well, with 1 every dimension moves as in basic
FOA, whose "RandomValue" is uniform). The forced dimension (DE's j_rand) ensures no fly is a copy of
the swarm location, which would waste an evaluation (probability 0.2^D per fly otherwise).

Vision and adaptation. All P flies are decoded and evaluated in one call; if the best fly is better
than the swarm location (strictly), the swarm moves there (a *success*). The radius adapts by the
1/5 success rule (Rechenberg; the "mutation adaptation"): on a success σ <- min(σ * a, π), on a
failure σ <- σ * a^(-1/4), with a = ``adapt`` = 1.5, so σ is stationary when a fifth of the
iterations succeed, grows while the swarm keeps finding better points, and shrinks for a fine search
when it does not. σ(0) = ``sigma0`` = π/4 (a quarter of the phase interval each side).

Initial flies: P points uniform in x (not in θ, which would crowd the walls), seed points ``x0``
replacing the first rows; the swarm location is the best of them. Defaults (seed 000 §6): population
10, 30 iterations, mutation rate 0.8. Default stop rule: ``MaxIterations(max_iterations)``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from planner.optim.base import FloatArray, Optimizer, require_choice, require_int, require_real
from planner.optim.termination import MaxIterations, Termination

__all__ = ["MAFOA"]

HALF_PI = 0.5 * math.pi


class MAFOA(Optimizer):
    """θ-MAFOA: phase-encoded fruit flies, per-dimension mutation, 1/5-rule search radius."""

    name = "mafoa"

    def __init__(
        self,
        *,
        pop_size: int = 10,
        mutation_rate: float = 0.8,
        sigma0: float = 0.25 * math.pi,
        adapt: float = 1.5,
        boundary: str = "reflect",
        max_iterations: int = 30,
    ) -> None:
        super().__init__()
        self.pop_size = require_int("pop_size", pop_size, 2)
        self.mutation_rate = require_real("mutation_rate", mutation_rate, 0.0, 1.0)
        self.sigma0 = require_real("sigma0", sigma0, 0.0, math.pi, open_low=True)
        self.adapt = require_real("adapt", adapt, 1.0, 100.0, open_low=True)
        self.boundary = require_choice("boundary", boundary, ("clip", "reflect"))
        self.max_iterations = require_int("max_iterations", max_iterations, 1)
        self._sigma = self.sigma0
        self._theta = np.zeros(1)

    @property
    def params(self) -> dict[str, Any]:
        return {
            "pop_size": self.pop_size,
            "mutation_rate": self.mutation_rate,
            "sigma0": self.sigma0,
            "adapt": self.adapt,
            "boundary": self.boundary,
            "max_iterations": self.max_iterations,
        }

    def default_termination(self) -> Termination:
        return MaxIterations(self.max_iterations)

    # ----------------------------------------------------------------- encoding

    def encode(self, X: FloatArray) -> FloatArray:
        """Canonical phases θ in [-π/2, π/2] of points X in the box."""
        ratio = (X - (self._upper + self._lower) / 2.0) / (self._range / 2.0)
        return np.arcsin(np.clip(ratio, -1.0, 1.0))

    def decode(self, theta: FloatArray) -> FloatArray:
        """Points of the box for phases θ (any real θ; past ±π/2 reflects)."""
        X = (self._upper + self._lower) / 2.0 + (self._range / 2.0) * np.sin(theta)
        return np.clip(X, self._lower, self._upper)  # rounding at the walls only

    # ----------------------------------------------------------------- state

    @property
    def sigma(self) -> float:
        """Current search radius σ (radians of phase)."""
        return self._sigma

    @property
    def swarm_phase(self) -> FloatArray:
        """Phase θ* of the swarm location (decodes to the best point)."""
        return self._theta.copy()

    # ----------------------------------------------------------------- algorithm

    def _initialize(self, x0: FloatArray | None) -> None:
        self._sigma = self.sigma0
        self._x = self._with_seed_points(self._random_points(self.pop_size), x0)
        self._fx = self._evaluate(self._x)
        self._theta = self.encode(self._best_x[None, :])[0]

    def _iterate(self) -> None:
        P, D = self.pop_size, self._lower.size
        rng = self._rng
        mutate = rng.random((P, D)) < self.mutation_rate
        mutate[np.arange(P), rng.integers(0, D, P)] = True
        offsets = self._sigma * (2.0 * rng.random((P, D)) - 1.0)
        theta = self._theta + np.where(mutate, offsets, 0.0)
        if self.boundary == "clip":
            theta = np.clip(theta, -HALF_PI, HALF_PI)
        before = self._best_f
        self._x = self.decode(theta)
        self._fx = self._evaluate(self._x)
        if self._best_f < before:  # vision: the swarm flies to the better fly
            self._theta = self.encode(self._best_x[None, :])[0]
            self._sigma = min(self._sigma * self.adapt, math.pi)
        else:
            self._sigma *= self.adapt**-0.25
