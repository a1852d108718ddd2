"""Simulated annealing (seed 000 §6's "solo search" comparison method) as a population optimiser.

SA keeps one current point ``x`` (cost ``f(x)``). To fit the population interface and make one
vectorised call of f per iteration, each iteration proposes ``pop_size`` neighbours of ``x`` at once
and submits only the best of them to the Metropolis test. Iteration t = 1, 2, ...:

    T(t)     = T0 * alpha ** (t - 1)                         geometric cooling (first move at T0)
    s_d(t)   = step_frac * (upper_d - lower_d) * T(t) / T0    neighbour scale, shrinks with T
    y_k      = repair(x + s(t) * N(0, I)),   k = 1 .. pop_size        (one call of f on all y_k)
    y*       = the y_k of lowest cost (first on ties),  delta = f(y*) - f(x)
    accept y* as the new x   if delta <= 0   or   u < exp(-delta / T(t)),  u ~ U[0, 1)

A ``u`` is drawn at every iteration (accepted or not) so that the random stream, and hence the run,
does not depend on how earlier comparisons came out in floating point. If the current cost is
``+inf`` (NaN costs count as ``+inf``) any proposal is accepted, so a run that starts in an infeasible
region walks out of it.

Why this scheme: SA needs exactly one candidate per Metropolis test (the acceptance rule is a
statement about one move), so the proposals are reduced to one before the test; taking the best
rather than a random one uses the evaluations that were paid for, and it leaves the Metropolis rule
to decide only when every proposal is worse (then ``delta`` is the smallest uphill step, accepted
with probability ``exp(-delta / T)``). With ``pop_size`` proposals per iteration the evaluation
budget equals a population method's (10 per iteration for seed 000's comparison), so the methods are
compared at equal cost.

Initial point: ``pop_size`` points uniform in the box (seed points ``x0`` replace the first rows),
evaluated once; the best (first on ties) is the starting ``x``.

Seed 000 §6: 30 iterations, initial temperature 100, "Acceptance Function - Simulannealbnd"
(MATLAB's ``simulannealbnd``). From MATLAB's defaults are kept: the exponential temperature
``T0 * 0.95 ** k`` and a step that scales with the temperature (``annealingfast`` takes a step of
length ``T``). Changed, and why: (1) the step is a fraction of the box (``step_frac`` of the range
at ``T0``) rather than ``T`` in the units of x, so it does not depend on how x is scaled;
(2) the acceptance is Metropolis ``exp(-delta / T)`` (MATLAB's ``acceptancesa`` uses
``1 / (1 + exp(delta / max T))``, which accepts even a tiny uphill step with probability 1/2 at most);
(3) no reannealing (MATLAB resets the temperature after 100 accepted points; a 30-iteration run does
not reach it). T is in *cost units*: T0 = 100 against seed 000's path costs of ~1e5 makes SA nearly
greedy there; on a problem with costs of order 1-100 it accepts uphill moves freely early on.
Boundary: ``"reflect"`` (default, mirrors the overshoot) or ``"clip"``. Default stop rule:
``MaxIterations(max_iterations)``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from planner.optim import operators as ops
from planner.optim.base import FloatArray, Optimizer, require_choice, require_int, require_real
from planner.optim.termination import MaxIterations, Termination

__all__ = ["SA"]


class SA(Optimizer):
    """Simulated annealing: ``pop_size`` Gaussian neighbours per iteration, Metropolis on the best."""

    name = "sa"

    def __init__(
        self,
        *,
        pop_size: int = 10,
        t0: float = 100.0,
        cooling: float = 0.95,
        step_frac: float = 0.1,
        boundary: str = "reflect",
        max_iterations: int = 30,
    ) -> None:
        super().__init__()
        self.pop_size = require_int("pop_size", pop_size, 2)
        self.t0 = require_real("t0", t0, 0.0, math.inf, open_low=True)
        self.cooling = require_real("cooling", cooling, 0.0, 1.0, open_low=True)
        self.step_frac = require_real("step_frac", step_frac, 0.0, 1e6, open_low=True)
        self.boundary = require_choice("boundary", boundary, ("clip", "reflect"))
        self.max_iterations = require_int("max_iterations", max_iterations, 1)
        self._accepted = 0

    @property
    def params(self) -> dict[str, Any]:
        return {
            "pop_size": self.pop_size,
            "t0": self.t0,
            "cooling": self.cooling,
            "step_frac": self.step_frac,
            "boundary": self.boundary,
            "max_iterations": self.max_iterations,
        }

    def default_termination(self) -> Termination:
        return MaxIterations(self.max_iterations)

    def temperature(self, t: int) -> float:
        """T(t) = T0 * cooling ** (t - 1) used by the move of iteration t (t >= 1)."""
        return self.t0 * self.cooling ** (t - 1)

    def step_scale(self, t: int) -> FloatArray:
        """Neighbour standard deviation per dimension at iteration t (needs a run's box)."""
        return self.step_frac * self._range * (self.temperature(t) / self.t0)

    def acceptance_probability(self, delta: float, t: int) -> float:
        """Metropolis: 1 for ``delta <= 0``, else ``exp(-delta / T(t))``."""
        return 1.0 if delta <= 0.0 else math.exp(-delta / self.temperature(t))

    @property
    def accepted(self) -> int:
        """How many moves have been accepted in this run."""
        return self._accepted

    def _initialize(self, x0: FloatArray | None) -> None:
        self._accepted = 0
        X = self._with_seed_points(self._random_points(self.pop_size), x0)
        F = self._evaluate(X)
        i = int(np.argmin(F))
        self._x, self._fx = X[i : i + 1].copy(), F[i : i + 1].copy()

    def _iterate(self) -> None:
        t = self._iteration + 1
        noise = self._rng.standard_normal((self.pop_size, self._lower.size))
        Y = self._x + self.step_scale(t) * noise
        repair = ops.reflect if self.boundary == "reflect" else ops.clip
        Y = repair(Y, self._lower, self._upper)
        F = self._evaluate(Y)
        u = float(self._rng.random())
        j = int(np.argmin(F))
        current = float(self._fx[0])
        delta = math.nan if math.isinf(current) else float(F[j]) - current
        if math.isnan(delta) or u < self.acceptance_probability(delta, t):
            self._x, self._fx = Y[j : j + 1].copy(), F[j : j + 1].copy()
            self._accepted += 1
