"""The optimiser interface: minimise f(X) over a box, a step at a time, with a typed result.

An objective is any callable ``f(X) -> F`` with ``X`` a float64 array of shape (P, D) (a whole
population) and ``F`` an array of shape (P,). The box is ``lower (D,) < upper (D,)``, finite. The
optimisers know nothing of what the vectors mean.

Life cycle (pymoo-like): ``setup(f, lower, upper, seed=..., termination=..., x0=...)`` builds and
evaluates the initial population (iteration 0); each ``step()`` does one iteration (one swarm move,
one generation); after setup and after each step the stop rule is evaluated on the optimiser, and
``done`` / ``status`` tell the outcome; ``result()`` packs the state into an :class:`OptimizeResult`.
``run(...)`` is exactly ``setup`` + ``step`` until ``done`` (+ an optional callback after each step),
so a replay that runs a few iterations per tick gets the same result as a single ``run``.

Choices common to every optimiser:

- Randomness: one ``numpy.random.default_rng(seed)`` per run (a ``Generator`` is used as given),
  no global state; the same int seed gives the same result bit for bit.
- The best point is tracked here, over every row ever evaluated (strictly better replaces; ties keep
  the earlier point), so ``best_f == f(best_x)`` and the best-so-far history never increases.
- Costs that are NaN are treated as ``+inf`` (worse than anything), so a failing evaluation is never
  chosen as best and cannot poison comparisons. A cost array of the wrong shape is an InputError.
- Every row passed to f is checked to lie inside ``[lower, upper]``; an escape ends the run with a
  one-line :class:`~terrain.errors.ContractError` naming the optimiser (an installed one's
  package is in its class's module).
  f receives a read-only view (writing into it raises), so it cannot change the optimiser's state.
- Seed points ``x0`` (k, D) (or one point (D,)) replace the first k rows of the initial population;
  they must be finite and inside the box (refused, not clipped, so the caller learns of bad seeds).
- ``history_best[t]`` is the best-so-far cost after iteration t (t = 0: the initial population);
  ``history_mean[t]`` is the mean cost of the current population at iteration t.
- ``elapsed_s`` is the wall time spent in ``setup`` and ``step`` (objective included).
"""

from __future__ import annotations

import math
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from numbers import Integral, Real
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from planner.optim.termination import RUNNING, Termination
from terrain.errors import ContractError, InputError

FloatArray = npt.NDArray[np.float64]
Objective = Callable[[FloatArray], npt.ArrayLike]
"""f(X (P, D)) -> (P,).  An objective may say ``rowwise = True`` (an attribute): each row's cost
is the same whatever other rows share the call; optimisers may then batch their calls."""
Seed = int | np.random.Generator

__all__ = [
    "FloatArray",
    "Objective",
    "OptimizeResult",
    "Optimizer",
    "Seed",
    "require_choice",
    "require_int",
    "require_real",
]


# --------------------------------------------------------------------------- parameter checks


def require_int(name: str, value: object, minimum: int) -> int:
    """An int >= ``minimum`` (bools refused), else InputError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, Integral) or int(value) < minimum:
        raise InputError(f"{name} must be an integer >= {minimum}; got {value!r}")
    return int(value)


def require_real(
    name: str,
    value: object,
    low: float = -math.inf,
    high: float = math.inf,
    *,
    open_low: bool = False,
) -> float:
    """A finite real in ``[low, high]`` (``(low, high]`` if ``open_low``), else InputError."""
    number = float(value) if isinstance(value, Real) and not isinstance(value, bool) else math.nan
    too_low = number <= low if open_low else number < low
    if not math.isfinite(number) or too_low or number > high:
        bracket = "(" if open_low else "["
        raise InputError(
            f"{name} must be a finite number in {bracket}{low}, {high}]; got {value!r}"
        )
    return number


def require_choice(name: str, value: object, choices: Sequence[str]) -> str:
    if value not in choices:
        raise InputError(f"{name} must be one of {', '.join(map(repr, choices))}; got {value!r}")
    return str(value)


def _frozen(values: Sequence[float] | FloatArray) -> FloatArray:
    array = np.array(values, dtype=np.float64)
    array.setflags(write=False)
    return array


# --------------------------------------------------------------------------- result


@dataclass(frozen=True, eq=False)
class OptimizeResult:
    """Outcome of one optimiser run (arrays are read-only copies)."""

    x: FloatArray
    f: float
    status: str
    iterations: int
    evaluations: int
    history_best: FloatArray
    history_mean: FloatArray
    elapsed_s: float
    algorithm: str
    params: dict[str, Any]
    seed: int | None


# --------------------------------------------------------------------------- optimiser


class Optimizer(ABC):
    """Base class: bounds, seeding, evaluation bookkeeping, best tracking, termination, result.

    A subclass implements :meth:`_initialize` (build and evaluate the first population, honouring
    seed points), :meth:`_iterate` (one iteration), :attr:`params` and :meth:`default_termination`,
    and keeps its current population in ``self._x`` / ``self._fx`` (a single-solution method keeps
    one row). It evaluates only through :meth:`_evaluate` and draws only from ``self._rng``.
    """

    name: ClassVar[str] = "optimizer"

    def __init__(self) -> None:
        self._ready = False
        self._rng = np.random.default_rng(0)
        self._lower = np.zeros(1)
        self._upper = np.ones(1)
        self._range = np.ones(1)
        self._x = np.zeros((1, 1))
        self._fx = np.zeros(1)
        self._best_x = np.zeros(1)
        self._best_f = math.inf
        self._reset_counters()

    def _reset_counters(self) -> None:
        self._iteration = 0
        self._evaluations = 0
        self._history_best: list[float] = []
        self._history_mean: list[float] = []
        self._status: str | None = None
        self._elapsed = 0.0
        self._seed: int | None = None
        self._termination: Termination | None = None

    # ----------------------------------------------------------------- what subclasses provide

    @property
    @abstractmethod
    def params(self) -> dict[str, Any]:
        """The parameters of this optimiser, as plain data (YAML-ready)."""

    @abstractmethod
    def default_termination(self) -> Termination:
        """The stop rule used when ``setup`` gets none."""

    def max_seed_points(self) -> int:
        """How many seed points ``x0`` may hold (the population size for population methods)."""
        return int(self.params.get("pop_size", 1))

    @abstractmethod
    def _initialize(self, x0: FloatArray | None) -> None:
        """Build and evaluate the initial population; ``x0`` replaces its first rows."""

    @abstractmethod
    def _iterate(self) -> None:
        """One iteration (``self._iteration`` is the number of iterations done before it)."""

    # ----------------------------------------------------------------- driving

    def setup(
        self,
        f: Objective,
        lower: npt.ArrayLike,
        upper: npt.ArrayLike,
        *,
        seed: Seed,
        termination: Termination | None = None,
        x0: npt.ArrayLike | None = None,
    ) -> None:
        """Start a run: check inputs, seed the generator, build and evaluate iteration 0."""
        start = time.perf_counter()
        if not callable(f):
            raise InputError(f"the objective must be callable f(X (P, D)) -> (P,); got {f!r}")
        lo, hi = _check_bounds(lower, upper)
        seeds = None if x0 is None else _check_seed_points(x0, lo, hi, self.max_seed_points())
        if termination is not None and not isinstance(termination, Termination):
            raise InputError(f"termination must be a Termination rule; got {termination!r}")
        self._rng, seed_int = _make_rng(seed)
        self._reset_counters()
        self._seed = seed_int
        self._f = f
        self._lower, self._upper, self._range = lo, hi, hi - lo
        self._best_x = np.full(lo.shape, np.nan)
        self._best_f = math.inf
        self._termination = termination if termination is not None else self.default_termination()
        self._initialize(seeds)
        self._ready = True
        self._after_iteration()
        self._elapsed += time.perf_counter() - start

    def step(self) -> None:
        """One iteration. Calling it before ``setup`` or once ``done`` is a programming error."""
        if not self._ready:
            raise RuntimeError(f"{type(self).__name__}.step() called before setup()")
        if self.done:
            raise RuntimeError(
                f"{type(self).__name__}.step() called after the run ended ({self.status})"
            )
        start = time.perf_counter()
        self._iterate()
        self._iteration += 1
        self._after_iteration()
        self._elapsed += time.perf_counter() - start

    def run(
        self,
        f: Objective,
        lower: npt.ArrayLike,
        upper: npt.ArrayLike,
        *,
        seed: Seed,
        termination: Termination | None = None,
        x0: npt.ArrayLike | None = None,
        callback: Callable[[Optimizer], object] | None = None,
    ) -> OptimizeResult:
        """``setup`` then ``step`` until ``done``; ``callback(self)`` after each step."""
        self.setup(f, lower, upper, seed=seed, termination=termination, x0=x0)
        while not self.done:
            self.step()
            if callback is not None:
                callback(self)
        return self.result()

    def result(self) -> OptimizeResult:
        """The current state as a result (usable mid-run; ``status`` is "running" until done)."""
        if not self._ready:
            raise RuntimeError(f"{type(self).__name__}.result() called before setup()")
        return OptimizeResult(
            x=_frozen(self._best_x),
            f=float(self._best_f),
            status=self.status,
            iterations=self._iteration,
            evaluations=self._evaluations,
            history_best=_frozen(self._history_best),
            history_mean=_frozen(self._history_mean),
            elapsed_s=self._elapsed,
            algorithm=self.name,
            params={**self.params, "termination": repr(self._termination)},
            seed=self._seed,
        )

    # ----------------------------------------------------------------- state

    @property
    def best_x(self) -> FloatArray:
        return self._best_x.copy()

    @property
    def best_f(self) -> float:
        return float(self._best_f)

    @property
    def iteration(self) -> int:
        return self._iteration

    @property
    def evaluations(self) -> int:
        return self._evaluations

    @property
    def done(self) -> bool:
        return self._status is not None

    @property
    def status(self) -> str:
        return self._status if self._status is not None else RUNNING

    @property
    def history_best(self) -> Sequence[float]:
        return self._history_best

    @property
    def history_mean(self) -> Sequence[float]:
        return self._history_mean

    @property
    def population(self) -> FloatArray:
        return self._x.copy()

    @property
    def population_f(self) -> FloatArray:
        return self._fx.copy()

    @property
    def lower(self) -> FloatArray:
        return self._lower.copy()

    @property
    def upper(self) -> FloatArray:
        return self._upper.copy()

    @property
    def swarm_radius(self) -> float:
        """Largest range-normalised distance population -> best, as a fraction of the diagonal."""
        offsets = (self._x - self._best_x) / self._range
        return float(np.sqrt(np.max(np.sum(offsets * offsets, axis=1)) / offsets.shape[1]))

    # ----------------------------------------------------------------- helpers for subclasses

    def _evaluate(self, X: FloatArray) -> FloatArray:
        """f on the rows of X (all inside the box), counted; updates the best point."""
        F = self._call(X)
        self._account(X, F)
        return F

    def _evaluate_two(self, X: FloatArray, M: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``_evaluate(X)`` then ``_evaluate(M)`` (M may be empty: not evaluated), in one call of
        f when the objective says its rows are independent (``rowwise``: a row's cost does not
        depend on the other rows of the call) -- the same costs, counts and best point, one
        objective call less (issue 38: the call's own overhead is a tenth of a plan)."""
        if not M.shape[0]:
            return self._evaluate(X), np.zeros(0)
        if not getattr(self._f, "rowwise", False):
            return self._evaluate(X), self._evaluate(M)
        both = self._call(np.concatenate([X, M]))
        F, FM = both[: X.shape[0]], both[X.shape[0] :]
        self._account(X, F)
        self._account(M, FM)
        return F, FM

    def _call(self, X: FloatArray) -> FloatArray:
        """f on the rows of X (all inside the box), NaN costs as inf."""
        if (X < self._lower).any() or (X > self._upper).any():
            raise self._escaped(X)
        view = X.view()
        view.flags.writeable = False  # the population is the optimiser's state: f may not edit it
        F = np.asarray(self._f(view), dtype=np.float64)
        if F.shape != (X.shape[0],):
            raise InputError(
                f"the objective must return one cost per row, shape ({X.shape[0]},); got {F.shape}"
            )
        return np.where(np.isnan(F), np.inf, F)

    def _escaped(self, X: FloatArray) -> ContractError:
        """The one-line error of a point outside the box: which optimiser (its class names a
        plugin's package), which row and dimension, by how much."""
        low, high = X < self._lower, X > self._upper
        i, d = (int(k[0]) for k in np.nonzero(low | high))
        bound = f"lower[{d}]={self._lower[d]:g}" if low[i, d] else f"upper[{d}]={self._upper[d]:g}"
        cls = type(self)
        return ContractError(
            f"optimiser {self.name!r} ({cls.__module__}.{cls.__qualname__}) evaluated a point "
            f"outside its bounds: x[{d}]={X[i, d]:g} beyond {bound}; an optimiser keeps every "
            "point it evaluates inside [lower, upper]"
        )

    def _account(self, X: FloatArray, F: FloatArray) -> None:
        """Count the evaluations of X's rows and keep the best point (the first of equals)."""
        self._evaluations += X.shape[0]
        if X.shape[0]:
            i = int(np.argmin(F))
            if F[i] < self._best_f:
                self._best_f = float(F[i])
                self._best_x = X[i].copy()

    def _random_points(self, n: int) -> FloatArray:
        """n points uniform in the box."""
        X = self._lower + self._rng.random((n, self._lower.size)) * self._range
        return np.minimum(X, self._upper)  # lower + u*range can round above upper

    def _with_seed_points(self, X: FloatArray, x0: FloatArray | None) -> FloatArray:
        if x0 is not None:
            X[: x0.shape[0]] = x0
        return X

    def _after_iteration(self) -> None:
        self._history_best.append(float(self._best_f))
        # ndarray.mean's own arithmetic (the sum, then one division by the count) without its
        # Python wrapper: a PSO-CA decision records six of them (issue 38)
        fx = self._fx
        mean = float(np.add.reduce(fx, axis=None) / fx.size) if fx.size else math.nan
        self._history_mean.append(mean)
        assert self._termination is not None
        self._status = self._termination.reason(self)


# --------------------------------------------------------------------------- input checks


def _check_bounds(lower: npt.ArrayLike, upper: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    lo = np.atleast_1d(np.array(lower, dtype=np.float64))
    hi = np.atleast_1d(np.array(upper, dtype=np.float64))
    if lo.ndim != 1 or lo.shape != hi.shape or lo.size == 0:
        raise InputError(
            f"lower and upper must be 1-D arrays of the same length D >= 1; got shapes {lo.shape} "
            f"and {hi.shape}"
        )
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise InputError(f"lower and upper must be finite; got lower={lo}, upper={hi}")
    bad = np.flatnonzero(lo >= hi)
    if bad.size:
        d = int(bad[0])
        raise InputError(
            f"lower must be < upper in every dimension; got lower[{d}]={lo[d]} >= upper[{d}]={hi[d]}"
        )
    return lo, hi


def _check_seed_points(x0: npt.ArrayLike, lo: FloatArray, hi: FloatArray, limit: int) -> FloatArray:
    seeds = np.array(x0, dtype=np.float64)
    if seeds.ndim == 1:
        seeds = seeds[None, :]
    if seeds.ndim != 2 or seeds.shape[1] != lo.size:
        raise InputError(f"x0 must have shape (k, {lo.size}); got {np.shape(x0)}")
    if seeds.shape[0] > limit:
        raise InputError(f"x0 may hold at most {limit} seed points; got {seeds.shape[0]}")
    outside = ~np.all(np.isfinite(seeds) & (seeds >= lo) & (seeds <= hi), axis=1)
    if np.any(outside):
        i = int(np.flatnonzero(outside)[0])
        raise InputError(f"x0[{i}] must be finite and inside [lower, upper]; got {seeds[i]}")
    return seeds


def _make_rng(seed: object) -> tuple[np.random.Generator, int | None]:
    if isinstance(seed, np.random.Generator):
        return seed, None
    if isinstance(seed, Integral) and not isinstance(seed, bool) and int(seed) >= 0:
        return np.random.default_rng(int(seed)), int(seed)
    raise InputError(f"seed must be an integer >= 0 or a numpy.random.Generator; got {seed!r}")
