"""Generic minimisers of f(X) over a box, for a population X of shape (P, D).

They know nothing of paths: :mod:`planner.optim.base` (interface and result),
:mod:`planner.optim.termination` (stop rules), :mod:`planner.optim.operators` (bound handling,
velocity clamp, selection, crossover, mutation), :mod:`planner.optim.pso` (PSO, AdaptivePSO,
AMPSO) and :mod:`planner.optim.ga` (GA). Pick one by name with :func:`make_optimizer`::

    opt = make_optimizer("ampso", pop_size=30, max_iterations=200)
    result = opt.run(cost, lower, upper, seed=7)
"""

from __future__ import annotations

import functools
import inspect
from typing import Any

from planner.optim.base import Objective, Optimizer, OptimizeResult, Seed
from planner.optim.foa import MAFOA
from planner.optim.ga import GA
from planner.optim.pso import AMPSO, GCPSO, MPSO, PSO, AdaptivePSO
from planner.optim.sa import SA
from planner.optim.termination import (
    AnyOf,
    MaxEvaluations,
    MaxIterations,
    Stall,
    SwarmRadius,
    Termination,
)
from terrain.errors import InputError

OPTIMIZERS: dict[str, type[Optimizer]] = {
    "pso": PSO,
    "apso": AdaptivePSO,
    "ampso": AMPSO,
    "ga": GA,
    "sa": SA,
    "mafoa": MAFOA,
    "gcpso": GCPSO,
    "mpso": MPSO,
}


@functools.cache
def _parameters(cls: type[Optimizer]) -> tuple[str, ...]:
    """The keyword parameters of an optimiser class (read once: ``inspect.signature`` costs a
    tenth of a PSO-CA decision, which builds its optimiser every time)."""
    return tuple(
        p for p in inspect.signature(cls).parameters if p not in ("self", "args", "kwargs")
    )


def make_optimizer(name: str, **params: Any) -> Optimizer:
    """The optimiser registered as ``name``, built with ``params`` (checked against its signature)."""
    cls = OPTIMIZERS.get(name) if isinstance(name, str) else None
    if cls is None:
        raise InputError(
            f"unknown optimiser {name!r}; expected one of {', '.join(sorted(OPTIMIZERS))}"
        )
    allowed = _parameters(cls)
    unknown = sorted(set(params) - set(allowed))
    if unknown:
        raise InputError(
            f"unknown parameter {unknown[0]!r} for optimiser {name!r}; expected one of "
            f"{', '.join(allowed)}"
        )
    return cls(**params)


__all__ = [
    "AMPSO",
    "GA",
    "GCPSO",
    "MAFOA",
    "MPSO",
    "OPTIMIZERS",
    "PSO",
    "SA",
    "AdaptivePSO",
    "AnyOf",
    "MaxEvaluations",
    "MaxIterations",
    "Objective",
    "OptimizeResult",
    "Optimizer",
    "Seed",
    "Stall",
    "SwarmRadius",
    "Termination",
    "make_optimizer",
]
