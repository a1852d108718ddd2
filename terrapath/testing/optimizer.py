"""The contract every optimiser passes (issue 39: a kit for plugins; the bounds of terrapath's own
optimisers are stated in tests/test_optimizers.py and tests/test_optimizers_extra.py).

A subclass of :class:`OptimizerContract` names the optimiser (``NAME``: built with
:func:`planner.optim.make_optimizer`, so an installed one by its entry point) and states what
it promises on 10-D problems in the box [-5.12, 5.12]^10 with ``BENCH``'s budget (default 200
iterations): ``SPHERE_BOUND`` and ``RASTRIGIN_BOUND`` (seeds 0..4).  Their defaults are random
search's medians with 2,010 evaluations (18.0 and 82.3): an optimiser must at least beat
sampling at random.  The contract assumes what terrapath's own optimisers do and the planner
relies on: a subclass of :class:`planner.optim.Optimizer` taking ``pop_size`` and
``max_iterations`` keyword arguments (``boundary`` is tested when it takes one).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt
import pytest

from planner.optim import Optimizer, OptimizeResult, make_optimizer, optimizer_class
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
D = 10
LO = np.full(D, -5.12)
HI = np.full(D, 5.12)


def sphere(X: FloatArray) -> FloatArray:
    return np.sum(X * X, axis=1)


def rastrigin(X: FloatArray) -> FloatArray:
    return 10.0 * X.shape[1] + np.sum(X * X - 10.0 * np.cos(2.0 * np.pi * X), axis=1)


class Recorder:
    """Wraps an objective and keeps a copy of every population passed to it."""

    def __init__(self, f: Callable[[FloatArray], FloatArray]) -> None:
        self.f = f
        self.calls: list[FloatArray] = []

    def __call__(self, X: FloatArray) -> FloatArray:
        self.calls.append(np.array(X, copy=True))
        return self.f(X)

    @property
    def rows(self) -> int:
        return sum(len(X) for X in self.calls)


def same(a: OptimizeResult, b: OptimizeResult) -> bool:
    """Bit-for-bit equality of everything but the wall time."""
    return (
        np.array_equal(a.x, b.x)
        and a.f == b.f
        and np.array_equal(a.history_best, b.history_best)
        and np.array_equal(a.history_mean, b.history_mean)
        and (a.status, a.iterations, a.evaluations, a.params)
        == (b.status, b.iterations, b.evaluations, b.params)
    )


def plain(value: object) -> bool:
    if isinstance(value, dict):
        return all(isinstance(k, str) and plain(v) for k, v in value.items())
    if isinstance(value, list):
        return all(plain(v) for v in value)
    return value is None or type(value) in (bool, int, float, str)


class OptimizerContract:
    """Every optimiser passes these; a subclass names it (``NAME``) and states its bounds (or
    builds it its own way: ``make``)."""

    SPHERE_BOUND: ClassVar[float] = 18.0
    RASTRIGIN_BOUND: ClassVar[float] = 82.3
    BENCH: ClassVar[dict[str, Any]] = {"max_iterations": 200}
    NAME: ClassVar[str]

    def make(self, **params: Any) -> Optimizer:
        return make_optimizer(self.NAME, **params)

    def takes(self, parameter: str) -> bool:
        """Whether the optimiser has the keyword ``parameter``."""
        return parameter in inspect.signature(type(self.make())).parameters

    def test_same_seed_same_result_bit_for_bit(self) -> None:
        a = self.make(max_iterations=30).run(rastrigin, LO, HI, seed=3)
        b = self.make(max_iterations=30).run(rastrigin, LO, HI, seed=3)
        assert same(a, b)
        assert a.seed == 3 and a.algorithm == self.NAME

    def test_different_seeds_differ(self) -> None:
        a = self.make(max_iterations=10).run(rastrigin, LO, HI, seed=1)
        b = self.make(max_iterations=10).run(rastrigin, LO, HI, seed=2)
        assert not np.array_equal(a.x, b.x)
        assert not np.array_equal(a.history_mean, b.history_mean)

    def test_generator_seed_is_the_same_stream_as_its_int(self) -> None:
        a = self.make(max_iterations=10).run(rastrigin, LO, HI, seed=np.random.default_rng(5))
        b = self.make(max_iterations=10).run(rastrigin, LO, HI, seed=5)
        assert a.seed is None and b.seed == 5
        assert np.array_equal(a.x, b.x) and np.array_equal(a.history_best, b.history_best)

    @pytest.mark.parametrize("boundary", ["clip", "reflect"])
    def test_every_evaluated_point_is_inside_the_box(self, boundary: str) -> None:
        # the optimum lies outside an asymmetric box: the population presses on the walls.
        # (Optimizer._call also refuses a point outside: a ContractError ends the run.)
        if not self.takes("boundary") and boundary != "clip":
            pytest.skip(f"{self.NAME} has no boundary option: tested once")
        lower = np.linspace(-3.0, 1.0, D)
        upper = lower + np.linspace(0.5, 4.0, D)
        target = np.where(np.arange(D) % 2 == 0, upper + 2.0, lower - 2.0)
        f = Recorder(lambda X: np.sum((X - target) ** 2, axis=1) + np.sum(np.sin(7 * X), axis=1))
        given = {"boundary": boundary} if self.takes("boundary") else {}
        result = self.make(max_iterations=40, **given).run(f, lower, upper, seed=0)
        X = np.concatenate(f.calls)
        assert np.all(X >= lower) and np.all(X <= upper)
        assert result.evaluations == f.rows == len(X)
        assert np.all(result.x >= lower) and np.all(result.x <= upper)

    def test_history_is_best_so_far_and_ends_at_f(self) -> None:
        result = self.make(max_iterations=40).run(rastrigin, LO, HI, seed=4)
        h = result.history_best
        assert len(h) == len(result.history_mean) == result.iterations + 1
        assert np.all(np.diff(h) <= 0.0)
        assert h[-1] == result.f == rastrigin(result.x[None, :])[0]
        assert np.all(result.history_mean >= h)  # the population's mean is never below the best

    def test_step_by_step_equals_run(self) -> None:
        opt = self.make(max_iterations=25)
        opt.setup(rastrigin, LO, HI, seed=11)
        steps = 0
        while not opt.done:
            opt.step()
            steps += 1
        assert steps == opt.iteration == 25
        assert same(opt.result(), self.make(max_iterations=25).run(rastrigin, LO, HI, seed=11))

    def test_callback_after_every_iteration(self) -> None:
        seen: list[tuple[int, float]] = []
        self.make(max_iterations=7).run(
            sphere, LO, HI, seed=0, callback=lambda s: seen.append((s.iteration, s.best_f))
        )
        assert [i for i, _ in seen] == list(range(1, 8))

    def test_seed_points_are_in_the_initial_population(self) -> None:
        x0 = np.array([[0.5] * D, [-1.0] * D, np.linspace(-5.12, 5.12, D)])
        f = Recorder(sphere)
        self.make(max_iterations=3).run(f, LO, HI, seed=0, x0=x0)
        assert np.array_equal(f.calls[0][:3], x0)
        single = Recorder(sphere)
        self.make(max_iterations=1).run(single, LO, HI, seed=0, x0=np.zeros(D))
        assert np.array_equal(single.calls[0][0], np.zeros(D))

    def test_result_is_typed_and_plain(self) -> None:
        result = self.make(max_iterations=5).run(sphere, LO, HI, seed=0)
        assert result.status == "max_iterations" and result.iterations == 5
        assert result.x.shape == (D,) and isinstance(result.f, float) and result.elapsed_s >= 0.0
        assert plain(result.params) and result.params["termination"].startswith("MaxIterations(5)")
        with pytest.raises(ValueError):
            result.x[0] = 1.0  # read-only

    def test_finds_the_sphere_minimum(self) -> None:
        result = self.make(**self.BENCH).run(sphere, LO, HI, seed=0)
        assert result.f < self.SPHERE_BOUND

    @pytest.mark.parametrize("seed", range(5))
    def test_rastrigin_within_stated_bound(self, seed: int) -> None:
        assert self.make(**self.BENCH).run(rastrigin, LO, HI, seed=seed).f < self.RASTRIGIN_BOUND

    def test_bad_parameters(self) -> None:
        with pytest.raises(InputError, match=r"pop_size must be an integer >= 2; got 1"):
            self.make(pop_size=1)
        with pytest.raises(InputError, match=r"max_iterations"):
            self.make(max_iterations=0)
        opt = self.make()
        with pytest.raises(InputError, match=r"lower\[1\]=2\.0 >= upper\[1\]=2\.0"):
            opt.setup(sphere, [0.0, 2.0], [1.0, 2.0], seed=0)
        with pytest.raises(InputError, match="finite"):
            opt.setup(sphere, [0.0, np.nan], [1.0, 2.0], seed=0)
        with pytest.raises(InputError, match="same length"):
            opt.setup(sphere, [0.0, 0.0], [1.0, 1.0, 1.0], seed=0)
        with pytest.raises(InputError, match="seed must be an integer >= 0"):
            opt.setup(sphere, LO, HI, seed=-1)
        with pytest.raises(InputError, match="seed"):
            opt.setup(sphere, LO, HI, seed=1.5)  # type: ignore[arg-type]
        with pytest.raises(InputError, match=r"x0\[1\] must be finite and inside"):
            opt.setup(sphere, LO, HI, seed=0, x0=[[0.0] * D, [6.0] * D])
        with pytest.raises(InputError, match=r"x0 must have shape \(k, 10\)"):
            opt.setup(sphere, LO, HI, seed=0, x0=[[0.0] * 3])
        with pytest.raises(InputError, match="at most"):
            opt.setup(sphere, LO, HI, seed=0, x0=np.zeros((opt.max_seed_points() + 1, D)))
        with pytest.raises(InputError, match="one cost per row"):
            opt.setup(lambda X: np.zeros((len(X), 2)), LO, HI, seed=0)

    def test_step_outside_a_run_is_an_error(self) -> None:
        opt = self.make(max_iterations=1)
        with pytest.raises(RuntimeError, match="before setup"):
            opt.step()
        opt.run(sphere, LO, HI, seed=0)
        with pytest.raises(RuntimeError, match="after the run ended"):
            opt.step()

    def test_nan_costs_count_as_worst(self) -> None:
        def holes(X: FloatArray) -> FloatArray:
            F = sphere(X)
            return np.where(X[:, 0] > 0.0, np.nan, F)

        result = self.make(max_iterations=20).run(holes, LO, HI, seed=0)
        assert np.isfinite(result.f) and result.x[0] <= 0.0

    def test_registry_builds_it(self) -> None:
        opt = make_optimizer(self.NAME)
        assert isinstance(opt, Optimizer) and type(opt) is optimizer_class(self.NAME)
        assert opt.name == self.NAME  # results and recordings name it so


__all__ = [
    "HI",
    "LO",
    "D",
    "FloatArray",
    "OptimizerContract",
    "Recorder",
    "plain",
    "rastrigin",
    "same",
    "sphere",
]
