"""Generic minimisers of f(X) over a box, for a population X of shape (P, D).

They know nothing of paths: :mod:`planner.optim.base` (interface and result),
:mod:`planner.optim.termination` (stop rules), :mod:`planner.optim.operators` (bound handling,
velocity clamp, selection, crossover, mutation), :mod:`planner.optim.pso` (PSO, AdaptivePSO,
AMPSO) and :mod:`planner.optim.ga` (GA). Pick one by name with :func:`make_optimizer`::

    opt = make_optimizer("ampso", pop_size=30, max_iterations=200)
    result = opt.run(cost, lower, upper, seed=7)

Installed packages add optimisers by entry point (group ``terrapath.optimizers``, a subclass of
:class:`Optimizer`; :mod:`terrain.plugins`): ``make_optimizer`` builds them by name as it builds
the built-ins, so ``terrapath plan --algorithm NAME`` and PSO-CA's ``optimizer`` option take them.
The base class checks every point evaluated against the bounds: an optimiser that leaves them
ends its run with a one-line :class:`~terrain.errors.ContractError`.
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
from terrain.errors import InputError, PluginError
from terrain.plugins import Plugin, Registry

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


def _check_plugin(obj: Any, plugin: Plugin) -> None:
    """An installed optimiser is a subclass of :class:`Optimizer` (whose ``_call`` keeps its
    points inside the bounds and whose result is typed)."""
    if not (isinstance(obj, type) and issubclass(obj, Optimizer)):
        raise PluginError(
            f"{plugin.describe()}: expected a subclass of planner.optim.Optimizer, found {obj!r}"
        )


REGISTRY = Registry(
    "terrapath.optimizers",
    {n: f"{cls.__module__}:{cls.__qualname__}" for n, cls in OPTIMIZERS.items()},
    _check_plugin,
)


def optimizer_names() -> list[str]:
    """Every optimiser's name, built-in or installed (nothing imported)."""
    return REGISTRY.names()


def optimizer_class(name: str) -> type[Optimizer]:
    """The class registered as ``name`` (an installed one imported now)."""
    cls = OPTIMIZERS.get(name) if isinstance(name, str) else None
    if isinstance(name, str) and name in REGISTRY:
        REGISTRY.find(name)  # a name given twice (a package and terrapath) is named
        if cls is None:
            cls = REGISTRY.load(name)
    if cls is None:
        raise InputError(
            f"unknown optimiser {name!r}; expected one of {', '.join(optimizer_names())}"
        )
    return cls


@functools.cache
def _parameters(cls: type[Optimizer]) -> tuple[str, ...]:
    """The keyword parameters of an optimiser class (read once: ``inspect.signature`` costs a
    tenth of a PSO-CA decision, which builds its optimiser every time)."""
    return tuple(
        p for p in inspect.signature(cls).parameters if p not in ("self", "args", "kwargs")
    )


def make_optimizer(name: str, **params: Any) -> Optimizer:
    """The optimiser registered as ``name``, built with ``params`` (checked against its signature)."""
    cls = optimizer_class(name)
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
    "REGISTRY",
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
    "optimizer_class",
    "optimizer_names",
]
