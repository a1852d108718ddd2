"""Stop rules on a fake optimiser state: each fires exactly when it should; `|` and its status."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import pytest

from planner.optim import AMPSO, GA, PSO, AdaptivePSO
from planner.optim.termination import (
    AnyOf,
    MaxEvaluations,
    MaxIterations,
    Stall,
    SwarmRadius,
    Termination,
)
from terrain.errors import InputError


@dataclass
class FakeState:
    iteration: int = 0
    evaluations: int = 0
    history_best: Sequence[float] = field(default_factory=list)
    swarm_radius: float = 1.0


def test_max_iterations_fires_at_n() -> None:
    rule = MaxIterations(30)
    assert rule.reason(FakeState(iteration=29)) is None
    assert rule.reason(FakeState(iteration=30)) == "max_iterations"
    assert MaxIterations(0).fires(FakeState(iteration=0))


def test_max_evaluations_fires_at_n() -> None:
    rule = MaxEvaluations(500)
    assert not rule.fires(FakeState(evaluations=499))
    assert rule.reason(FakeState(evaluations=500)) == "max_evaluations"
    assert rule.fires(FakeState(evaluations=548))


def test_stall_needs_k_consecutive_small_improvements() -> None:
    # seed 000: "change in fitness < 200 for 5 continuous iterations"
    rule = Stall(5, 200.0)
    history = [10_000.0, 9_000.0, 8_900.0, 8_850.0, 8_800.0, 8_700.0]  # t = 0..5
    assert not rule.fires(FakeState(history_best=history))  # 10 000 -> 9 000 is in the window
    history.append(8_600.0)  # the last 5 gains: 100, 50, 50, 100, 100
    assert rule.reason(FakeState(history_best=history)) == "stalled"
    history.append(8_300.0)  # a gain of 300 breaks the run
    assert not rule.fires(FakeState(history_best=history))
    assert not rule.fires(FakeState(history_best=[5.0] * 5))  # 4 iterations only: too early
    assert rule.fires(FakeState(history_best=[5.0] * 6))
    exact = Stall(2, 0.0)  # tol 0: no improvement at all
    assert exact.fires(FakeState(history_best=[3.0, 2.0, 2.0, 2.0]))
    assert not exact.fires(FakeState(history_best=[3.0, 2.0, 2.0, 1.999]))
    assert not exact.fires(FakeState(history_best=[math.inf] * 4))  # nothing finite found yet


def test_swarm_radius_fires_below_eps() -> None:
    rule = SwarmRadius(1e-3)
    assert not rule.fires(FakeState(swarm_radius=1e-3))
    assert rule.reason(FakeState(swarm_radius=9e-4)) == "converged"


def test_or_stops_on_any_and_reports_the_rule_that_fired() -> None:
    rule = MaxIterations(100) | Stall(3, 0.0) | SwarmRadius(1e-3)
    assert isinstance(rule, AnyOf) and len(rule.rules) == 3  # flattened
    assert repr(rule) == "MaxIterations(100) | Stall(3, 0.0) | SwarmRadius(0.001)"
    assert rule.reason(FakeState(iteration=10, history_best=[1.0, 0.5, 0.2, 0.1])) is None
    stalled = FakeState(iteration=10, history_best=[1.0, 0.5, 0.5, 0.5, 0.5])
    assert rule.reason(stalled) == "stalled"
    assert rule.reason(FakeState(iteration=10, swarm_radius=1e-4)) == "converged"
    # several at once: the leftmost wins
    both = FakeState(iteration=100, history_best=[0.5] * 5, swarm_radius=0.0)
    assert rule.reason(both) == "max_iterations"
    assert (SwarmRadius(1e-3) | MaxIterations(100)).reason(both) == "converged"


def test_bad_rule_parameters() -> None:
    with pytest.raises(InputError, match=r"MaxIterations n must be an integer >= 0; got -1"):
        MaxIterations(-1)
    with pytest.raises(InputError, match=r"MaxEvaluations n must be an integer >= 1; got 2.5"):
        MaxEvaluations(2.5)  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"Stall k must be an integer >= 1; got 0"):
        Stall(0, 1.0)
    with pytest.raises(InputError, match=r"Stall tol must be a finite number >= 0; got -200"):
        Stall(5, -200)
    with pytest.raises(InputError, match=r"SwarmRadius eps must be a finite number > 0; got nan"):
        SwarmRadius(float("nan"))
    with pytest.raises(InputError, match="Termination objects"):
        AnyOf(MaxIterations(3), 5)  # type: ignore[arg-type]
    assert (MaxIterations(3).__or__(5)) is NotImplemented  # type: ignore[operator]


def test_default_terminations() -> None:
    assert repr(PSO(max_iterations=30).default_termination()) == "MaxIterations(30)"
    assert repr(AdaptivePSO().default_termination()) == "MaxIterations(100)"
    assert repr(AMPSO(radius_eps=0.01).default_termination()) == (
        "MaxIterations(100) | SwarmRadius(0.01)"
    )
    assert repr(GA.seed000().default_termination()) == "MaxIterations(30)"
    assert all(isinstance(o.default_termination(), Termination) for o in (PSO(), GA()))
