"""Particle swarm optimisers: PSO, AdaptivePSO (linearly varying w, TVAC) and AMPSO (mutation).

All three share one implementation of seed 002 steps 1-3 (eqs 12-13, the inertia-weight PSO of
Shi & Eberhart 1998), for every particle i and dimension d:

    v_id <- w(t) v_id + c1(t) r1_id (pbest_id - x_id) + c2(t) r2_id (gbest_d - x_id)     (12)
    v_id <- clip(v_id, -vmax_d, vmax_d),   vmax_d = vmax_frac * (upper_d - lower_d)
    x_id <- x_id + v_id                                                                  (13)

with r1, r2 ~ U[0, 1) drawn per particle per dimension per iteration, then bound handling, then
evaluation, then pbest (strictly better replaces) and gbest (the best point ever evaluated).

Choices:

- Coefficients ``w``, ``c1``, ``c2`` are each a constant or a pair ``(start, end)`` varied linearly
  over the iteration budget T = ``max_iterations``: ``value(t) = start + (end - start) * min(t, T)/T``
  for the move of iteration t = 1, 2, ... (seed 000 Algorithm 10 line 10 and Ratnaweera et al.
  2004 use ``t / T``: the first move is slightly below ``start``, the T-th uses ``end``; past T the
  value stays at ``end``). Seed 000's Table 2 is ``PSO(pop_size=10, w=(0.09, 0.02), c1=2, c2=2,
  vmax_frac=0.1, max_iterations=30)``.
- Initial positions uniform in the box (seed points ``x0`` replace the first rows); initial
  velocities zero by default (seed 000 Table 2 "V = 0 for k = 1"; Engelbrecht 2012 found zero or
  small initial velocities best, as large ones throw particles out of the box on the first move), or
  uniform in ``(-vmax, vmax)`` with ``init_velocity="uniform"``.
- Walls: ``boundary="clip"`` (default) is the absorbing wall (clip the position, zero the velocity
  component that hit the wall); ``"reflect"`` mirrors the position and negates that component. See
  :mod:`planner.optim.operators` for why the velocity is changed too.
- Defaults of :class:`PSO`: 50 particles, w = 0.7298 and c1 = c2 = 1.49618 (Clerc's constriction
  coefficients written as inertia weights, Eberhart & Shi 2000), vmax_frac = 0.2, T = 100.

:class:`AdaptivePSO` ("PSO in [8]" of seed 002: coefficients that adapt with the search) is the same
algorithm with the defaults w from 0.9 to 0.4 (Shi & Eberhart 1999) and the time-varying
acceleration coefficients of Ratnaweera et al. 2004 (TVAC): c1 from 2.5 to 0.5 (the cognitive pull
weakens) and c2 from 0.5 to 2.5 (the social pull grows), all over the budget T = ``max_iterations``.

:class:`AMPSO` (seed 002's improved PSO, step 4, eq 14) adds an adaptive Gaussian mutation:

    x'_i = x_i + m(t) * sigma * N(0, I),   sigma_d = sigma_frac * (upper_d - lower_d), sigma_frac = 0.1
    m(t) = m0 * (1 - min(t, T)/T) ** m_power                       (m0 = 1, m_power = 2 by default)

Each particle is mutated independently with probability ``mutation_rate`` (default 0.1), on all of
its coordinates, and the mutant is repaired into the box (clip or reflect; position only, the
velocity is left as the PSO update made it). The paper does not say what happens to a mutant;
two rules are offered:

- ``acceptance="greedy"`` (default): after the move of iteration t has been evaluated and pbest
  updated, the mutants of the selected particles are evaluated (one extra call of f per iteration
  with about ``mutation_rate * P`` rows, counted in ``evaluations``) and a mutant replaces its
  particle only if it is strictly better (then pbest and gbest are updated from it). Why: the
  mutation is then a local probe of radius ~ m(t)·sigma around each particle, which can jump into a
  better basin (escape a local optimum) but can never move a particle uphill, so it does not undo
  the swarm's contraction: the velocity dynamics stay those of the base PSO, and the swarm-radius
  stop of step 5 stays reachable while m > 0.
- ``acceptance="always"`` (the literal step order of seed 002: step 4 mutates, step 2 then
  evaluates): the mutant *is* the particle's new position, evaluated once, so there is no extra
  evaluation; pbest/gbest are elitist so nothing found is lost. But a mutated particle then sits
  away from the swarm and the next velocity update pulls it back hard: measured over 20 seeds at
  15 000 evaluations in 10-D, this rule costs fine-convergence precision (sphere median 2e-8
  against 3e-21 for AdaptivePSO, Ackley 1e-3 against 5e-10) and did not improve Rastrigin (median
  7.0 against 4.0), so it is not the default.

Measured at equal budgets (15 000 evaluations, 10-D, medians over 60 seeds), the greedy AMPSO is
*not* better than AdaptivePSO on classic test functions: Rastrigin 5.5 against 5.0 (Mann-Whitney
p = 0.09), Griewank 0.087 against 0.078 (p = 0.26), Schwefel 691 against 701 (p = 0.94); it loses
fine precision to the extra evaluations (20 seeds: sphere 2e-19 against 3e-21, Ackley 5e-9 against
5e-10). Other rates (0.02, 0.05) and powers (1, 4) gave the same picture. The mutation is meant for
path costs with big penalty steps (seed 002's collision term), where a swarm collapsed into a poor
feasible basin needs a probe larger than its own radius. On the planner's hardest benchmark map
(jacksboro, seed 002 Table 2 protocol: P = 60, 200 iterations, 200 runs, benchmarks/RESULTS.md) it
does: AMPSO 0.529 ± 0.049 with 200/200 runs feasible, against AdaptivePSO 0.551 ± 0.217 (199/200),
PSO 0.585 ± 0.301 (198/200) and GA 0.561 ± 0.058. The gain is mostly robustness (no run left in a
colliding basin) and a small shift of the mean; the spread among feasible runs is the choice of
route through the ridges (a valley route near 0.47-0.50, routes over the plateau or the mountain
near 0.58-0.66), which a local polish of the final best does not change (a 5 000-evaluation
(1+20)-ES moved the mean of 30 runs by 0.003). Mutation rate 0.3 or 0.5, m power 1 and
``acceptance="always"`` gave means within 0.007 of the default and no smaller spread over seeds
100-299 (``bench_plan.py --ampso``; without mutation, ``mutation_rate=0``, the same seeds give 0.563
± 0.302 with 198/200 feasible), so the defaults stay.

Those figures are for seed 002's problem. With the aircraft's limits that ``terrapath plan`` now
imposes (issue 12: the aerosonde's climb and descent gradients, turn fillets of 143 m, clearance
on the conservative safety terrain; ``bench_plan.py --init corridor --runs 200``, seeds 0-199) the
mutation's edge over AdaptivePSO is gone within the noise on all three maps, and only its
robustness against plain PSO remains: jacksboro AMPSO 0.559 ± 0.047, AdaptivePSO 0.559 ± 0.044,
PSO 0.602 ± 0.303 (198/200 feasible), GA 0.587 ± 0.049; rmnp 0.573 ± 0.038, 0.573 ± 0.035,
0.581 ± 0.044, 0.596 ± 0.051; Big Tujunga 0.532 ± 0.023, 0.531 ± 0.021, 0.537 ± 0.024,
0.551 ± 0.039 (every other run 200/200 feasible). A 10-run sample shows AMPSO with the lowest
mean and spread 14-25 % of the time.

With ``mutation_rate = 0`` (or ``m0 = 0``) no mutation draws and no extra evaluations are made and
AMPSO is exactly its base PSO, bit for bit. The base coefficients are AdaptivePSO's (w 0.9 -> 0.4,
TVAC): seed 002's own comparison (its Fig. 5) is "improved PSO with adaptive mutation" against the
adaptive-coefficient PSO of its ref. [8], so with this base the mutation is the only difference
between ``"ampso"`` and ``"apso"``; and that base is the stronger one (Rastrigin median 4.0 against
7.0 for constant coefficients, Schwefel 770 against 1010, same budget as above). The paper's text
does not fix the base; any PSO coefficients can be given.

Step 5: the default stop rule is ``MaxIterations(max_iterations) | SwarmRadius(radius_eps)`` with
``radius_eps = 1e-3`` (the swarm within 0.1 % of the box diagonal of its best point).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.optim import operators as ops
from planner.optim.base import FloatArray, Optimizer, require_choice, require_int, require_real
from planner.optim.termination import MaxIterations, SwarmRadius, Termination
from terrain.errors import InputError

Coefficient = float | tuple[float, float]

__all__ = ["AMPSO", "PSO", "AdaptivePSO", "Coefficient"]


def _coefficient(name: str, value: object) -> Coefficient:
    """A constant >= 0 or a pair (start, end) of them."""
    if isinstance(value, Sequence) and not isinstance(value, str):
        if len(value) != 2:
            raise InputError(f"{name} must be a number or a pair (start, end); got {value!r}")
        return (
            require_real(f"{name}[0]", value[0], 0.0),
            require_real(f"{name}[1]", value[1], 0.0),
        )
    return require_real(name, value, 0.0)


def _plain(value: Coefficient) -> float | list[float]:
    return list(value) if isinstance(value, tuple) else value


class PSO(Optimizer):
    """Inertia-weight PSO (seed 002 eqs 12-13); ``w``, ``c1``, ``c2`` constant or (start, end)."""

    name = "pso"

    def __init__(
        self,
        *,
        pop_size: int = 50,
        w: Coefficient = 0.7298,
        c1: Coefficient = 1.49618,
        c2: Coefficient = 1.49618,
        vmax_frac: float = 0.2,
        init_velocity: str = "zero",
        boundary: str = "clip",
        max_iterations: int = 100,
    ) -> None:
        super().__init__()
        self.pop_size = require_int("pop_size", pop_size, 2)
        self.w = _coefficient("w", w)
        self.c1 = _coefficient("c1", c1)
        self.c2 = _coefficient("c2", c2)
        self.vmax_frac = require_real("vmax_frac", vmax_frac, 0.0, 1e6, open_low=True)
        self.init_velocity = require_choice("init_velocity", init_velocity, ("zero", "uniform"))
        self.boundary = require_choice("boundary", boundary, ("clip", "reflect"))
        self.max_iterations = require_int("max_iterations", max_iterations, 1)

    @property
    def params(self) -> dict[str, Any]:
        return {
            "pop_size": self.pop_size,
            "w": _plain(self.w),
            "c1": _plain(self.c1),
            "c2": _plain(self.c2),
            "vmax_frac": self.vmax_frac,
            "init_velocity": self.init_velocity,
            "boundary": self.boundary,
            "max_iterations": self.max_iterations,
        }

    def default_termination(self) -> Termination:
        return MaxIterations(self.max_iterations)

    def progress(self, t: int) -> float:
        """Fraction of the budget at iteration t: ``min(t, T) / T``."""
        return min(t, self.max_iterations) / self.max_iterations

    def coefficients(self, t: int) -> tuple[float, float, float]:
        """(w, c1, c2) used by the move of iteration t (t = 1 for the first move)."""
        s = self.progress(t)

        def at(c: Coefficient) -> float:
            return c if isinstance(c, float) else c[0] + (c[1] - c[0]) * s

        return at(self.w), at(self.c1), at(self.c2)

    # ----------------------------------------------------------------- state

    @property
    def velocities(self) -> FloatArray:
        return self._v.copy()

    @property
    def pbest(self) -> FloatArray:
        return self._pbest.copy()

    @property
    def pbest_f(self) -> FloatArray:
        return self._pbest_f.copy()

    # ----------------------------------------------------------------- algorithm

    def _initialize(self, x0: FloatArray | None) -> None:
        self._vmax = self.vmax_frac * self._range
        X = self._with_seed_points(self._random_points(self.pop_size), x0)
        if self.init_velocity == "uniform":
            V = (2.0 * self._rng.random(X.shape) - 1.0) * self._vmax
        else:
            V = np.zeros_like(X)
        self._x, self._v = X, V
        self._fx = self._evaluate(X)
        self._pbest, self._pbest_f = X.copy(), self._fx.copy()

    def _iterate(self) -> None:
        self._fx = self._evaluate(self._move())
        self._update_pbest(np.arange(self.pop_size))

    def _move(self) -> FloatArray:
        """Eqs 12-13, the walls and :meth:`_perturb`: the new positions (and velocities) of
        iteration ``self._iteration + 1``, kept as the current ones, not yet evaluated."""
        t = self._iteration + 1
        w, c1, c2 = self.coefficients(t)
        X, V = self._x, self._v
        r1 = self._rng.random(X.shape)
        r2 = self._rng.random(X.shape)
        V = w * V + c1 * r1 * (self._pbest - X) + c2 * r2 * (self._best_x - X)
        V = ops.clamp_velocity(V, self._vmax)
        wall = ops.absorb if self.boundary == "clip" else ops.bounce
        X, V = wall(X + V, V, self._lower, self._upper)
        X = self._perturb(X, t)
        self._x, self._v = X, V
        return X

    def _update_pbest(self, rows: npt.NDArray[np.intp]) -> None:
        better = rows[self._fx[rows] < self._pbest_f[rows]]
        self._pbest[better] = self._x[better]
        self._pbest_f[better] = self._fx[better]

    def _perturb(self, X: FloatArray, t: int) -> FloatArray:
        """Hook between the move and its evaluation (AMPSO's "always" mutation); identity here."""
        return X


class AdaptivePSO(PSO):
    """PSO with w 0.9 -> 0.4 and TVAC c1 2.5 -> 0.5, c2 0.5 -> 2.5 over ``max_iterations``."""

    name = "apso"

    def __init__(
        self,
        *,
        pop_size: int = 50,
        w: Coefficient = (0.9, 0.4),
        c1: Coefficient = (2.5, 0.5),
        c2: Coefficient = (0.5, 2.5),
        vmax_frac: float = 0.2,
        init_velocity: str = "zero",
        boundary: str = "clip",
        max_iterations: int = 100,
    ) -> None:
        super().__init__(
            pop_size=pop_size,
            w=w,
            c1=c1,
            c2=c2,
            vmax_frac=vmax_frac,
            init_velocity=init_velocity,
            boundary=boundary,
            max_iterations=max_iterations,
        )


class AMPSO(AdaptivePSO):
    """AdaptivePSO + adaptive Gaussian mutation (seed 002 eq 14) + swarm-radius stop (step 5)."""

    name = "ampso"

    def __init__(
        self,
        *,
        pop_size: int = 50,
        w: Coefficient = (0.9, 0.4),
        c1: Coefficient = (2.5, 0.5),
        c2: Coefficient = (0.5, 2.5),
        vmax_frac: float = 0.2,
        init_velocity: str = "zero",
        boundary: str = "clip",
        max_iterations: int = 100,
        mutation_rate: float = 0.1,
        sigma_frac: float = 0.1,
        m0: float = 1.0,
        m_power: float = 2.0,
        radius_eps: float = 1e-3,
        acceptance: str = "greedy",
    ) -> None:
        super().__init__(
            pop_size=pop_size,
            w=w,
            c1=c1,
            c2=c2,
            vmax_frac=vmax_frac,
            init_velocity=init_velocity,
            boundary=boundary,
            max_iterations=max_iterations,
        )
        self.mutation_rate = require_real("mutation_rate", mutation_rate, 0.0, 1.0)
        self.sigma_frac = require_real("sigma_frac", sigma_frac, 0.0, 1e6, open_low=True)
        self.m0 = require_real("m0", m0, 0.0)
        self.m_power = require_real("m_power", m_power, 0.0)
        self.radius_eps = require_real("radius_eps", radius_eps, 0.0, 1.0, open_low=True)
        self.acceptance = require_choice("acceptance", acceptance, ("greedy", "always"))

    @property
    def params(self) -> dict[str, Any]:
        return {
            **super().params,
            "mutation_rate": self.mutation_rate,
            "sigma_frac": self.sigma_frac,
            "m0": self.m0,
            "m_power": self.m_power,
            "radius_eps": self.radius_eps,
            "acceptance": self.acceptance,
        }

    def default_termination(self) -> Termination:
        return MaxIterations(self.max_iterations) | SwarmRadius(self.radius_eps)

    def mutation_scale(self, t: int) -> float:
        """m(t) = m0 (1 - min(t, T)/T) ** m_power: m0 at the start, 0 at the end of the budget."""
        return self.m0 * (1.0 - self.progress(t)) ** self.m_power

    def sigma(self) -> FloatArray:
        """sigma_d = sigma_frac * (upper_d - lower_d) of the current run."""
        return self.sigma_frac * self._range

    @property
    def _mutating(self) -> bool:
        return self.mutation_rate > 0.0 and self.m0 > 0.0

    def _mutants(self, X: FloatArray, t: int) -> tuple[npt.NDArray[np.intp], FloatArray]:
        """Rows chosen with probability mutation_rate and their repaired mutants."""
        rows = np.flatnonzero(self._rng.random(self.pop_size) < self.mutation_rate)
        step = self.mutation_scale(t) * self.sigma()
        M = X[rows] + step * self._rng.standard_normal((rows.size, X.shape[1]))
        repair = ops.clip if self.boundary == "clip" else ops.reflect
        return rows, repair(M, self._lower, self._upper)

    def _perturb(self, X: FloatArray, t: int) -> FloatArray:
        if self.acceptance != "always" or not self._mutating:
            return X
        rows, M = self._mutants(X, t)
        X = X.copy()
        X[rows] = M
        return X

    def _iterate(self) -> None:
        if self.acceptance != "greedy" or not self._mutating:
            super()._iterate()
            return
        X = self._move()
        # the mutants are drawn from the moved particles before the move is evaluated (no draw
        # comes between), so both go to the objective in one call when it allows
        rows, M = self._mutants(X, self._iteration + 1)
        self._fx, FM = self._evaluate_two(X, M)
        self._update_pbest(np.arange(self.pop_size))
        if rows.size == 0:
            return
        accepted = FM < self._fx[rows]
        rows = rows[accepted]
        self._x[rows] = M[accepted]
        self._fx[rows] = FM[accepted]
        self._update_pbest(rows)


# --------------------------------------------------------------------------- seed 000 §6 variants

__all__ += ["GCPSO", "MPSO"]

SEED000_PSO: dict[str, Any] = {
    "pop_size": 10,
    "w": (0.09, 0.02),
    "c1": 2.0,
    "c2": 2.0,
    "vmax_frac": 0.1,
    "max_iterations": 30,
}
"""Seed 000 Table 2 (PSO-CA): the base of its GCPSO and MPSO comparison (§6, Table 7)."""


class GCPSO(PSO):
    """Guaranteed-convergence PSO (van den Bergh & Engelbrecht 2002), seed 000 §6 / Table 7.

    Every particle but one moves by eqs 12-13 (:class:`PSO`). The global-best particle τ (the one
    whose pbest is the global best ŷ: lowest pbest cost, first on ties) instead moves by

        v_τ <- ŷ - x_τ + w v_τ + ρ(t) (1 - 2 r),   r ~ U[0, 1)^D
        x_τ <- x_τ + v_τ  (= ŷ + w v_τ + ρ(t)(1 - 2 r): a random search in a box of radius ρ
                            around ŷ, so the best particle never stalls with zero velocity)

    with ρ_d(t) = ``rho`` (t) * (upper_d - lower_d), i.e. ρ is a fraction of the box (the paper's
    ρ(0) = 1.0 is in the units of x; on its [-5.12, 5.12] Rastrigin box that is ~0.1 of the range,
    hence ``rho0 = 0.1``). τ's velocity is not clamped to vmax (clamping would stop the move from
    landing around ŷ when x_τ has drifted from it); the wall (clip/reflect) applies as for the others.

    After the move is evaluated, iteration t is a *success* if the global best improved (strictly)
    and a *failure* otherwise; consecutive counts are kept (a success zeroes the failure count and
    vice versa) and ρ for the next move is

        ρ <- 2 ρ    if #successes > s_c        ρ <- ρ / 2    if #failures > f_c

    (the paper's strict ">", s_c = 15, f_c = 5: the first doubling follows the 16th consecutive
    success, the first halving the 6th consecutive failure, and ρ keeps changing at each further
    consecutive one). Defaults: seed 000 Table 2's PSO (:data:`SEED000_PSO`) plus those.
    """

    name = "gcpso"

    def __init__(
        self,
        *,
        pop_size: int = 10,
        w: Coefficient = (0.09, 0.02),
        c1: Coefficient = 2.0,
        c2: Coefficient = 2.0,
        vmax_frac: float = 0.1,
        init_velocity: str = "zero",
        boundary: str = "clip",
        max_iterations: int = 30,
        rho0: float = 0.1,
        s_c: int = 15,
        f_c: int = 5,
    ) -> None:
        super().__init__(
            pop_size=pop_size,
            w=w,
            c1=c1,
            c2=c2,
            vmax_frac=vmax_frac,
            init_velocity=init_velocity,
            boundary=boundary,
            max_iterations=max_iterations,
        )
        self.rho0 = require_real("rho0", rho0, 0.0, 1e6, open_low=True)
        self.s_c = require_int("s_c", s_c, 0)
        self.f_c = require_int("f_c", f_c, 0)
        self._rho = self.rho0
        self._successes = 0
        self._failures = 0

    @property
    def params(self) -> dict[str, Any]:
        return {**super().params, "rho0": self.rho0, "s_c": self.s_c, "f_c": self.f_c}

    @property
    def rho(self) -> float:
        """ρ (fraction of the range) for the next move of the global-best particle."""
        return self._rho

    @property
    def successes(self) -> int:
        return self._successes

    @property
    def failures(self) -> int:
        return self._failures

    def global_best_particle(self) -> int:
        """Index τ of the particle whose pbest is the global best (first on ties)."""
        return int(np.argmin(self._pbest_f))

    def _initialize(self, x0: FloatArray | None) -> None:
        super()._initialize(x0)
        self._rho, self._successes, self._failures = self.rho0, 0, 0

    def _iterate(self) -> None:
        t = self._iteration + 1
        w, c1, c2 = self.coefficients(t)
        X, V0 = self._x, self._v
        tau = self.global_best_particle()
        r1 = self._rng.random(X.shape)
        r2 = self._rng.random(X.shape)
        r3 = self._rng.random(X.shape[1])
        V = w * V0 + c1 * r1 * (self._pbest - X) + c2 * r2 * (self._best_x - X)
        V = ops.clamp_velocity(V, self._vmax)
        V[tau] = self._best_x - X[tau] + w * V0[tau] + self._rho * self._range * (1.0 - 2.0 * r3)
        wall = ops.absorb if self.boundary == "clip" else ops.bounce
        X, V = wall(X + V, V, self._lower, self._upper)
        before = self._best_f
        self._x, self._v = X, V
        self._fx = self._evaluate(X)
        self._update_pbest(np.arange(self.pop_size))
        if self._best_f < before:
            self._successes, self._failures = self._successes + 1, 0
        else:
            self._successes, self._failures = 0, self._failures + 1
        if self._successes > self.s_c:
            self._rho *= 2.0
        elif self._failures > self.f_c:
            self._rho *= 0.5


class MPSO(PSO):
    """Multi-start PSO ("MPSO (slope)" of seed 000 §6 / Table 7, after van den Bergh 2002).

    A PSO (eqs 12-13) that restarts its swarm when the best cost stops changing: a counter of
    consecutive *moves* whose best-so-far improved by at most ``restart_tol`` (default 0: not at
    all) is kept; when it reaches ``restart_after`` (seed 000: 5), the next iteration is a restart
    instead of a move, and the counter starts again from 0 (the restart itself is not counted). A
    restart re-initialises every particle except the global-best one τ (lowest pbest cost, first
    on ties): new positions uniform in the box, velocities as at the start (zero by default), pbest
    = the new positions, all evaluated in that iteration's one call of f (P - 1 rows). τ keeps its
    position, velocity and pbest, so the global best is kept and the new swarm is drawn towards it.
    The restarts done are listed (by iteration) in :attr:`restarts`.

    Defaults: seed 000 Table 2's PSO (:data:`SEED000_PSO`), restart after 5 unchanged iterations.
    """

    name = "mpso"

    def __init__(
        self,
        *,
        pop_size: int = 10,
        w: Coefficient = (0.09, 0.02),
        c1: Coefficient = 2.0,
        c2: Coefficient = 2.0,
        vmax_frac: float = 0.1,
        init_velocity: str = "zero",
        boundary: str = "clip",
        max_iterations: int = 30,
        restart_after: int = 5,
        restart_tol: float = 0.0,
    ) -> None:
        super().__init__(
            pop_size=pop_size,
            w=w,
            c1=c1,
            c2=c2,
            vmax_frac=vmax_frac,
            init_velocity=init_velocity,
            boundary=boundary,
            max_iterations=max_iterations,
        )
        self.restart_after = require_int("restart_after", restart_after, 1)
        self.restart_tol = require_real("restart_tol", restart_tol, 0.0)
        self._unchanged = 0
        self._restarts: list[int] = []

    @property
    def params(self) -> dict[str, Any]:
        return {
            **super().params,
            "restart_after": self.restart_after,
            "restart_tol": self.restart_tol,
        }

    @property
    def restarts(self) -> list[int]:
        """Iterations at which the swarm was restarted, in order."""
        return list(self._restarts)

    @property
    def unchanged(self) -> int:
        """Consecutive moves without improvement since the last improvement or restart."""
        return self._unchanged

    def _initialize(self, x0: FloatArray | None) -> None:
        super()._initialize(x0)
        self._unchanged = 0
        self._restarts = []

    def _iterate(self) -> None:
        if self._unchanged >= self.restart_after:
            self._restart()
            self._unchanged = 0
            self._restarts.append(self._iteration + 1)
            return
        before = self._best_f
        super()._iterate()
        improved = before - self._best_f > self.restart_tol  # inf - inf = nan: not improved
        self._unchanged = 0 if improved else self._unchanged + 1

    def _restart(self) -> None:
        tau = int(np.argmin(self._pbest_f))
        rows = np.flatnonzero(np.arange(self.pop_size) != tau)
        X = self._random_points(rows.size)
        if self.init_velocity == "uniform":
            V = (2.0 * self._rng.random(X.shape) - 1.0) * self._vmax
        else:
            V = np.zeros_like(X)
        F = self._evaluate(X)
        self._x[rows], self._v[rows], self._fx[rows] = X, V, F
        self._pbest[rows], self._pbest_f[rows] = X, F
