"""Real-coded genetic algorithm (seed 002's and seed 000's comparison GA).

One generation (iteration) with population size P and E elites:

1. the E best members (lowest cost, stable order) are carried over unchanged and not re-evaluated;
2. ``ceil((P - E) / 2)`` pairs of parents are selected from the whole current population
   (``selection="roulette"``: windowed fitness-proportionate; ``"tournament"``: best of
   ``tournament_size``; see :mod:`planner.optim.operators`);
3. each pair crosses with probability ``crossover_rate`` (``crossover="single_point"`` or
   ``"blend"``, BLX-alpha with ``blend_alpha``), giving two children; the first P - E are kept;
4. each gene of each child mutates with probability ``mutation_rate``: ``"gaussian"`` adds
   ``sigma_d(t) * N(0, 1)`` with ``sigma_d(t) = mutation_sigma * (upper_d - lower_d) *
   (1 - mutation_shrink * min(t, T)/T)`` (MATLAB ``ga``'s ``mutationgaussian`` shrink rule, so the
   steps shrink as the run ends), ``"uniform"`` redraws the gene uniform in its range;
5. children are repaired into the box (``boundary="reflect"`` by default: mirroring does not pile
   children up on the walls the way clipping does; ``"clip"`` is available) and evaluated; the new
   population is elites + children (generational replacement).

Evaluations: P for the initial population, then P - E per generation. With E >= 1 the best member
of the population never gets worse. Default stop rule: ``MaxIterations(max_iterations)``.

Defaults: P = 50, tournament of 2, BLX-0.5 with rate 0.9, Gaussian mutation rate 0.1 with sigma 0.1
of the range shrinking to 0, 2 elites, reflect, 100 generations.

:meth:`GA.seed000` is seed 000 §6's GA: 30 generations, crossover rate 0.75, mutation rate 0.008,
roulette wheel, single-point crossover. What §6 does not state is filled in and marked here:
population 10 (PSO-CA's N of Table 2, which §6 also gives θ-MAFOA "the same as our PSO-CA"), uniform
gene mutation (a bare "mutation rate" is MATLAB's ``mutationuniform(rate)``; the paper used
MATLAB's toolbox, cf. SA's "Simulannealbnd") and one elite (MATLAB's default ``ceil(0.05 P)``).
Seed 000's fitness-change stop rule is in that paper's cost units; add it yourself, e.g.
``termination=MaxIterations(30) | Stall(5, 200.0)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planner.optim import operators as ops
from planner.optim.base import FloatArray, Optimizer, require_choice, require_int, require_real
from planner.optim.termination import MaxIterations, Termination
from terrain.errors import InputError

__all__ = ["GA"]


class GA(Optimizer):
    """Real-coded GA: selection, crossover, per-gene mutation, elitism, generational replacement."""

    name = "ga"

    def __init__(
        self,
        *,
        pop_size: int = 50,
        selection: str = "tournament",
        tournament_size: int = 2,
        crossover: str = "blend",
        crossover_rate: float = 0.9,
        blend_alpha: float = 0.5,
        mutation: str = "gaussian",
        mutation_rate: float = 0.1,
        mutation_sigma: float = 0.1,
        mutation_shrink: float = 1.0,
        elitism: int = 2,
        boundary: str = "reflect",
        max_iterations: int = 100,
    ) -> None:
        super().__init__()
        self.pop_size = require_int("pop_size", pop_size, 2)
        self.selection = require_choice("selection", selection, ("roulette", "tournament"))
        self.tournament_size = require_int("tournament_size", tournament_size, 1)
        self.crossover = require_choice("crossover", crossover, ("single_point", "blend"))
        self.crossover_rate = require_real("crossover_rate", crossover_rate, 0.0, 1.0)
        self.blend_alpha = require_real("blend_alpha", blend_alpha, 0.0, 1e6)
        self.mutation = require_choice("mutation", mutation, ("gaussian", "uniform"))
        self.mutation_rate = require_real("mutation_rate", mutation_rate, 0.0, 1.0)
        self.mutation_sigma = require_real(
            "mutation_sigma", mutation_sigma, 0.0, 1e6, open_low=True
        )
        self.mutation_shrink = require_real("mutation_shrink", mutation_shrink, 0.0, 1.0)
        self.elitism = require_int("elitism", elitism, 0)
        if self.elitism >= self.pop_size:
            raise InputError(
                f"elitism must be < pop_size ({self.pop_size}) so that children are made; "
                f"got {self.elitism}"
            )
        self.boundary = require_choice("boundary", boundary, ("clip", "reflect"))
        self.max_iterations = require_int("max_iterations", max_iterations, 1)

    @classmethod
    def seed000(cls, **overrides: Any) -> GA:
        """Seed 000 §6's GA (see the module docstring for what is stated and what is assumed)."""
        params: dict[str, Any] = {
            "max_iterations": 30,
            "crossover_rate": 0.75,
            "mutation_rate": 0.008,
            "selection": "roulette",
            "crossover": "single_point",
            "pop_size": 10,
            "mutation": "uniform",
            "elitism": 1,
        }
        params.update(overrides)
        return cls(**params)

    @property
    def params(self) -> dict[str, Any]:
        return {
            "pop_size": self.pop_size,
            "selection": self.selection,
            "tournament_size": self.tournament_size,
            "crossover": self.crossover,
            "crossover_rate": self.crossover_rate,
            "blend_alpha": self.blend_alpha,
            "mutation": self.mutation,
            "mutation_rate": self.mutation_rate,
            "mutation_sigma": self.mutation_sigma,
            "mutation_shrink": self.mutation_shrink,
            "elitism": self.elitism,
            "boundary": self.boundary,
            "max_iterations": self.max_iterations,
        }

    def default_termination(self) -> Termination:
        return MaxIterations(self.max_iterations)

    def _initialize(self, x0: FloatArray | None) -> None:
        self._x = self._with_seed_points(self._random_points(self.pop_size), x0)
        self._fx = self._evaluate(self._x)

    def _iterate(self) -> None:
        t = self._iteration + 1
        rng = self._rng
        n_children = self.pop_size - self.elitism
        n_pairs = (n_children + 1) // 2
        if self.selection == "roulette":
            parents = ops.roulette_selection(self._fx, 2 * n_pairs, rng)
        else:
            parents = ops.tournament_selection(
                self._fx, 2 * n_pairs, rng, size=self.tournament_size
            )
        A, B = self._x[parents[:n_pairs]], self._x[parents[n_pairs:]]
        if self.crossover == "single_point":
            C1, C2 = ops.single_point_crossover(A, B, self.crossover_rate, rng)
        else:
            C1, C2 = ops.blend_crossover(A, B, self.crossover_rate, rng, alpha=self.blend_alpha)
        children = np.concatenate([C1, C2])[:n_children]
        if self.mutation == "gaussian":
            shrink = 1.0 - self.mutation_shrink * min(t, self.max_iterations) / self.max_iterations
            sigma = self.mutation_sigma * shrink * self._range
            children = ops.gaussian_gene_mutation(children, self.mutation_rate, sigma, rng)
        else:
            children = ops.uniform_gene_mutation(
                children, self.mutation_rate, self._lower, self._upper, rng
            )
        repair = ops.reflect if self.boundary == "reflect" else ops.clip
        children = repair(children, self._lower, self._upper)
        elites = np.argsort(self._fx, kind="stable")[: self.elitism]
        F = self._evaluate(children)
        self._x = np.concatenate([self._x[elites], children])
        self._fx = np.concatenate([self._fx[elites], F])
