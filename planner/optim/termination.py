"""Stop rules: small objects evaluated on the optimiser state after every iteration.

A rule answers :meth:`Termination.reason` with its status string when it says "stop", else
``None``. Rules combine with ``|``: ``MaxIterations(100) | Stall(5, 200.0)`` stops when any of them
says stop, and the status reported is the one of the rule that fired first (the optimiser checks
after every iteration and stops at the first firing, so "first" is first in time; when several fire
at the same iteration, the leftmost wins).

Rules (``t`` is the iteration, 0 for the initial population):

- :class:`MaxIterations` ``(n)``: ``t >= n``; status ``"max_iterations"``.
- :class:`MaxEvaluations` ``(n)``: evaluations so far ``>= n``; status ``"max_evaluations"``. Checked
  after each iteration, so a run can overshoot ``n`` by at most one iteration's evaluations.
- :class:`Stall` ``(k, tol)``: the best-so-far cost has improved by at most ``tol`` (absolute) at
  each of the last ``k`` iterations, i.e. ``h[t-j-1] - h[t-j] <= tol`` for ``j = 0 .. k-1`` where
  ``h`` is the best-so-far history. This is seed 000's rule ("change in fitness < 200 for 5
  continuous iterations", Table 2 and §5.5) read per iteration, with ``<=`` so that ``tol = 0``
  means "no improvement at all". Status ``"stalled"``.
- :class:`SwarmRadius` ``(eps)`` (seed 002 step 5): the population has collapsed onto the best
  point. With every dimension divided by its range ``u_d - l_d`` (the box becomes the unit cube,
  whose diagonal is ``sqrt(D)``), the largest distance from a member of the population (particles
  for PSO, individuals for GA) to the best point is below ``eps * sqrt(D)``. The state reports that
  ratio as ``swarm_radius`` (0 = collapsed, 1 = one full diagonal). Status ``"converged"``.

The rules are stateless: they read what they need from the state (``iteration``, ``evaluations``,
``history_best``, ``swarm_radius``), so one rule object can serve many runs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from numbers import Integral, Real
from typing import Protocol

from terrain.errors import InputError

RUNNING = "running"
MAX_ITERATIONS = "max_iterations"
MAX_EVALUATIONS = "max_evaluations"
STALLED = "stalled"
CONVERGED = "converged"
STATUSES = (MAX_ITERATIONS, STALLED, CONVERGED, MAX_EVALUATIONS)

__all__ = [
    "CONVERGED",
    "MAX_EVALUATIONS",
    "MAX_ITERATIONS",
    "RUNNING",
    "STALLED",
    "STATUSES",
    "AnyOf",
    "MaxEvaluations",
    "MaxIterations",
    "Stall",
    "State",
    "SwarmRadius",
    "Termination",
]


class State(Protocol):
    """What a stop rule may read (an :class:`~planner.optim.base.Optimizer` provides it)."""

    @property
    def iteration(self) -> int: ...

    @property
    def evaluations(self) -> int: ...

    @property
    def history_best(self) -> Sequence[float]: ...

    @property
    def swarm_radius(self) -> float: ...


def _count(name: str, value: object, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, Integral) or int(value) < minimum:
        raise InputError(f"{name} must be an integer >= {minimum}; got {value!r}")
    return int(value)


def _real(name: str, value: object, *, positive: bool) -> float:
    number = float(value) if isinstance(value, Real) and not isinstance(value, bool) else math.nan
    if not math.isfinite(number) or (number <= 0.0 if positive else number < 0.0):
        expected = "a finite number > 0" if positive else "a finite number >= 0"
        raise InputError(f"{name} must be {expected}; got {value!r}")
    return number


class Termination:
    """Base of the stop rules. Subclasses set ``status`` and implement :meth:`fires`."""

    status: str = ""

    def fires(self, state: State) -> bool:
        raise NotImplementedError

    def reason(self, state: State) -> str | None:
        """The status string if this rule says stop now, else ``None``."""
        return self.status if self.fires(state) else None

    def __or__(self, other: Termination) -> AnyOf:
        if not isinstance(other, Termination):
            return NotImplemented
        return AnyOf(self, other)


class AnyOf(Termination):
    """Stop when any of ``rules`` says stop; the status is the leftmost rule that fires."""

    def __init__(self, *rules: Termination) -> None:
        flat: list[Termination] = []
        for rule in rules:
            if not isinstance(rule, Termination):
                raise InputError(f"termination rules must be Termination objects; got {rule!r}")
            flat.extend(rule.rules if isinstance(rule, AnyOf) else (rule,))
        if not flat:
            raise InputError("AnyOf needs at least one termination rule; got none")
        self.rules: tuple[Termination, ...] = tuple(flat)

    def fires(self, state: State) -> bool:
        return self.reason(state) is not None

    def reason(self, state: State) -> str | None:
        for rule in self.rules:
            status = rule.reason(state)
            if status is not None:
                return status
        return None

    def __repr__(self) -> str:
        return " | ".join(repr(rule) for rule in self.rules)


class MaxIterations(Termination):
    """Stop once ``n`` iterations have been done (the initial population is iteration 0)."""

    status = MAX_ITERATIONS

    def __init__(self, n: int) -> None:
        self.n = _count("MaxIterations n", n, 0)

    def fires(self, state: State) -> bool:
        return state.iteration >= self.n

    def __repr__(self) -> str:
        return f"MaxIterations({self.n})"


class MaxEvaluations(Termination):
    """Stop once at least ``n`` objective evaluations (rows passed to f) have been made."""

    status = MAX_EVALUATIONS

    def __init__(self, n: int) -> None:
        self.n = _count("MaxEvaluations n", n, 1)

    def fires(self, state: State) -> bool:
        return state.evaluations >= self.n

    def __repr__(self) -> str:
        return f"MaxEvaluations({self.n})"


class Stall(Termination):
    """Stop when the best cost improved by at most ``tol`` at each of the last ``k`` iterations."""

    status = STALLED

    def __init__(self, k: int, tol: float = 0.0) -> None:
        self.k = _count("Stall k", k, 1)
        self.tol = _real("Stall tol", tol, positive=False)

    def fires(self, state: State) -> bool:
        history = state.history_best
        if len(history) <= self.k:
            return False
        window = history[-self.k - 1 :]
        # inf - inf = nan (nothing finite found yet) compares False: it never counts as a stall.
        return all(window[j] - window[j + 1] <= self.tol for j in range(self.k))

    def __repr__(self) -> str:
        return f"Stall({self.k}, {self.tol!r})"


class SwarmRadius(Termination):
    """Stop when the population lies within ``eps`` (fraction of the box diagonal) of the best."""

    status = CONVERGED

    def __init__(self, eps: float) -> None:
        self.eps = _real("SwarmRadius eps", eps, positive=True)

    def fires(self, state: State) -> bool:
        return state.swarm_radius < self.eps

    def __repr__(self) -> str:
        return f"SwarmRadius({self.eps!r})"
