"""The generic optimisers: one contract every optimiser passes, then each algorithm's own checks.

Each optimiser passes the contract of the test kit (:class:`terrapath.testing.OptimizerContract`,
the one plugins subclass) with its stated bounds (10-D, box [-5.12, 5.12]^10; "measured" is the worst of seeds 0..29 when the bounds
were set; the tests run seeds 0..4):

=====================  ==========  ================  =================  ===================
optimiser              budget      sphere: bound     Rastrigin: bound   (measured worst)
=====================  ==========  ================  =================  ===================
PSO                    200 iter.   < 1e-8 (2.7e-10)  < 25  (18.9)       constant w: worst on
AdaptivePSO            200 iter.   < 1e-11 (3.1e-13) < 18  (12.9)       Rastrigin of the PSOs
AMPSO (radius 1e-6)    200 iter.   < 1e-8 (1.3e-10)  < 22  (16.9)
GA (defaults)          200 gen.    < 5e-3 (7.2e-4)   < 20  (15.0)
GA seed-000 operators  200 gen.,   < 3    (1.5)      < 22  (15.9)       pop 10 / 30 gen.:
                       pop 50                                           see its own test
=====================  ==========  ================  =================  ===================
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np
import pytest

from planner.optim import (
    AMPSO,
    GA,
    OPTIMIZERS,
    PSO,
    AdaptivePSO,
    MaxEvaluations,
    MaxIterations,
    Optimizer,
    Stall,
    make_optimizer,
)
from planner.optim import operators as ops
from terrain.errors import InputError
from terrapath.testing.optimizer import (
    HI,
    LO,
    D,
    FloatArray,
    OptimizerContract,
    Recorder,
    rastrigin,
    same,
    sphere,
)

# the contract lives in the test kit plugins use (terrapath.testing): one copy of it


class TestPSO(OptimizerContract):
    NAME = "pso"
    SPHERE_BOUND = 1e-8
    RASTRIGIN_BOUND = 25.0

    def make(self, **params: Any) -> Optimizer:
        return PSO(**params)


class TestAdaptivePSO(OptimizerContract):
    NAME = "apso"
    SPHERE_BOUND = 1e-11
    RASTRIGIN_BOUND = 18.0

    def make(self, **params: Any) -> Optimizer:
        return AdaptivePSO(**params)


class TestAMPSO(OptimizerContract):
    NAME = "ampso"
    SPHERE_BOUND = 1e-8
    RASTRIGIN_BOUND = 22.0
    BENCH: ClassVar[dict[str, Any]] = {"max_iterations": 200, "radius_eps": 1e-6}

    def make(self, **params: Any) -> Optimizer:
        return AMPSO(**{"radius_eps": 1e-9, **params})  # contract runs go to max_iterations


class TestGA(OptimizerContract):
    NAME = "ga"
    SPHERE_BOUND = 5e-3
    RASTRIGIN_BOUND = 20.0

    def make(self, **params: Any) -> Optimizer:
        return GA(**params)


class TestGASeed000(OptimizerContract):
    NAME = "ga"
    SPHERE_BOUND = 3.0
    RASTRIGIN_BOUND = 22.0
    BENCH: ClassVar[dict[str, Any]] = {"max_iterations": 200, "pop_size": 50}

    def make(self, **params: Any) -> Optimizer:
        return GA.seed000(**params)


# --------------------------------------------------------------------------- PSO family


def test_pso_coefficient_schedules_are_linear_in_the_iteration() -> None:
    opt = PSO(w=(0.09, 0.02), c1=2.0, c2=2.0, vmax_frac=0.1, pop_size=10, max_iterations=30)
    assert opt.coefficients(15) == pytest.approx((0.055, 2.0, 2.0))
    assert opt.coefficients(30) == pytest.approx((0.02, 2.0, 2.0))
    assert opt.coefficients(45) == opt.coefficients(30)  # past the budget: stays at the end value
    apso = AdaptivePSO(max_iterations=100)
    assert apso.coefficients(50) == pytest.approx((0.65, 1.5, 1.5))
    assert apso.coefficients(100) == pytest.approx((0.4, 0.5, 2.5))
    assert apso.params["w"] == [0.9, 0.4] and apso.params["c1"] == [2.5, 0.5]


def test_pso_velocity_is_clamped_and_starts_at_zero() -> None:
    opt = PSO(vmax_frac=0.1, max_iterations=10)
    lower, upper = np.zeros(3), np.array([1.0, 10.0, 100.0])
    opt.setup(lambda X: -np.sum(X, axis=1), lower, upper, seed=0)
    assert not opt.velocities.any()
    for _ in range(10):
        opt.step()
        assert np.all(np.abs(opt.velocities) <= 0.1 * (upper - lower))
    uniform = PSO(vmax_frac=0.1, init_velocity="uniform")
    uniform.setup(sphere, lower, upper, seed=0)
    V = uniform.velocities
    assert V.any() and np.all(np.abs(V) <= 0.1 * (upper - lower))


def test_pso_absorbing_wall_zeroes_the_velocity_that_hit_it() -> None:
    # the minimum is the corner `upper`: particles run into the walls and must stop there.
    opt = PSO(max_iterations=30)
    opt.setup(lambda X: -np.sum(X, axis=1), np.zeros(4), np.ones(4), seed=0)
    hits = 0
    for _ in range(30):
        opt.step()
        on_wall = opt.population == 1.0  # reached only by clipping (or by staying there)
        hits += int(on_wall.sum())
        assert not opt.velocities[on_wall].any()
    assert hits > 0
    result = opt.result()
    assert np.array_equal(result.x, np.ones(4))  # clipping lands exactly on the boundary optimum


def test_absorb_and_bounce_operators() -> None:
    lower, upper = np.array([0.0, -1.0]), np.array([1.0, 1.0])
    X = np.array([[1.5, 0.0], [-0.25, 3.5], [0.5, -6.5]])
    V = np.array([[0.7, 0.1], [-0.4, 2.0], [0.1, -3.0]])
    Xa, Va = ops.absorb(X, V, lower, upper)
    assert np.array_equal(Xa, [[1.0, 0.0], [0.0, 1.0], [0.5, -1.0]])
    assert np.array_equal(Va, [[0.0, 0.1], [0.0, 0.0], [0.1, 0.0]])
    Xb, Vb = ops.bounce(X, V, lower, upper)
    # 1.5 -> 0.5 (one fold); -0.25 -> 0.25 (one); 3.5 -> -1.5 -> -0.5 (two folds: same direction);
    # -6.5 -> 4.5 -> -2.5 -> 0.5 (three folds: direction reversed)
    assert np.allclose(Xb, [[0.5, 0.0], [0.25, -0.5], [0.5, 0.5]])
    assert np.array_equal(Vb, [[-0.7, 0.1], [0.4, 2.0], [0.1, 3.0]])
    assert np.array_equal(ops.reflect(X, lower, upper), Xb)
    assert np.array_equal(ops.clip(X, lower, upper), Xa)
    rng = np.random.default_rng(0)
    far = rng.normal(0.0, 50.0, (1000, 2))
    inside = ops.reflect(far, lower, upper)
    assert np.all(inside >= lower) and np.all(inside <= upper)
    clamped = ops.clamp_velocity(V, np.array([0.5, 1.0]))
    assert np.array_equal(clamped, [[0.5, 0.1], [-0.4, 1.0], [0.1, -1.0]])


def test_ampso_sigma_is_ten_percent_of_the_range_and_m_decreases() -> None:
    opt = AMPSO(max_iterations=50)
    lower, upper = np.array([0.0, -10.0, 100.0]), np.array([1.0, 10.0, 1100.0])
    opt.setup(sphere, lower, upper, seed=0)
    assert np.allclose(opt.sigma(), [0.1, 2.0, 100.0])
    m = np.array([opt.mutation_scale(t) for t in range(0, 51)])
    assert m[0] == 1.0 and m[-1] == 0.0 and np.all(np.diff(m) < 0.0)
    assert opt.mutation_scale(80) == 0.0


def test_gaussian_particle_mutation_step_and_rate() -> None:
    rng = np.random.default_rng(1)
    X = np.zeros((20000, 3))
    step = np.array([0.1, 1.0, 10.0])
    M = ops.gaussian_particle_mutation(X, 1.0, step, rng)
    assert np.allclose(M.std(axis=0) / step, 1.0, atol=0.03)
    M = ops.gaussian_particle_mutation(X, 0.3, step, rng)
    moved = np.any(M != 0.0, axis=1)
    assert abs(moved.mean() - 0.3) < 0.015
    assert np.all(M[moved] != 0.0)  # a mutated particle moves on every coordinate


@pytest.mark.parametrize("off", [{"mutation_rate": 0.0}, {"m0": 0.0}])
def test_ampso_without_mutation_is_its_base_pso_bit_for_bit(off: dict[str, Any]) -> None:
    a = AMPSO(max_iterations=60, radius_eps=1e-9, **off).run(rastrigin, LO, HI, seed=2)
    b = AdaptivePSO(max_iterations=60).run(rastrigin, LO, HI, seed=2)
    assert np.array_equal(a.x, b.x) and np.array_equal(a.history_best, b.history_best)
    assert np.array_equal(a.history_mean, b.history_mean) and a.evaluations == b.evaluations
    constant: dict[str, Any] = {"w": 0.7298, "c1": 1.49618, "c2": 1.49618}
    c = AMPSO(max_iterations=60, radius_eps=1e-9, **constant, **off).run(rastrigin, LO, HI, seed=2)
    d = PSO(max_iterations=60, **constant).run(rastrigin, LO, HI, seed=2)
    assert np.array_equal(c.x, d.x) and np.array_equal(c.history_mean, d.history_mean)
    # and with the mutation on, the runs differ:
    e = AMPSO(max_iterations=60, radius_eps=1e-9).run(rastrigin, LO, HI, seed=2)
    assert not np.array_equal(e.history_mean, b.history_mean)


def test_ampso_greedy_mutant_replaces_a_particle_only_when_better() -> None:
    f = Recorder(rastrigin)
    opt = AMPSO(max_iterations=40, radius_eps=1e-9, mutation_rate=0.3)
    opt.setup(f, LO, HI, seed=6)
    accepted = 0
    while not opt.done:
        before = len(f.calls)
        opt.step()
        moved, F_moved = f.calls[before], rastrigin(f.calls[before])
        X, F = opt.population, opt.population_f
        assert np.all(F <= F_moved)
        changed = np.flatnonzero(np.any(X != moved, axis=1))
        if len(f.calls) - before == 2:
            mutants = f.calls[before + 1]
            for i in changed:  # each replaced particle took one of this step's mutants, better
                assert np.any(np.all(mutants == X[i], axis=1)) and F[i] < F_moved[i]
            accepted += changed.size
        else:
            assert changed.size == 0
    assert accepted > 0
    assert opt.evaluations == f.rows > opt.pop_size * 41  # mutants cost extra, counted


def test_ampso_always_mutates_the_move_without_extra_evaluations() -> None:
    a = AMPSO(max_iterations=30, radius_eps=1e-9, acceptance="always").run(
        rastrigin, LO, HI, seed=0
    )
    b = AdaptivePSO(max_iterations=30).run(rastrigin, LO, HI, seed=0)
    assert a.evaluations == b.evaluations == 50 * 31
    assert not np.array_equal(a.history_mean, b.history_mean)
    for boundary in ("clip", "reflect"):  # mutants near the walls are repaired into the box
        f = Recorder(sphere)
        lower, upper = np.zeros(D), np.full(D, 0.1)
        opt = AMPSO(acceptance="always", mutation_rate=1.0, m0=20.0, boundary=boundary)
        opt.run(f, lower, upper, seed=0, termination=MaxIterations(20))
        X = np.concatenate(f.calls)
        assert np.all(X >= lower) and np.all(X <= upper)


def test_ampso_swarm_radius_stops_it_early_on_the_sphere() -> None:
    opt = AMPSO(max_iterations=200)  # default stop: MaxIterations(200) | SwarmRadius(1e-3)
    result = opt.run(sphere, LO, HI, seed=0)
    assert result.status == "converged" and result.iterations < 200
    assert opt.swarm_radius < 1e-3 and result.f < 1e-4
    assert result.params["termination"] == "MaxIterations(200) | SwarmRadius(0.001)"


# --------------------------------------------------------------------------- GA


def test_ga_elitism_never_loses_the_best() -> None:
    best: list[float] = []
    opt = GA(elitism=1, selection="roulette", mutation_rate=0.5, max_iterations=60)
    result = opt.run(
        rastrigin, LO, HI, seed=0, callback=lambda s: best.append(float(s.population_f.min()))
    )
    best.insert(0, float(result.history_best[0]))  # iteration 0: the initial population's best
    assert np.all(np.diff(best) <= 0.0)
    assert np.array_equal(best, result.history_best)  # the population always holds the best
    assert opt.evaluations == 50 + 60 * 49  # elites are not re-evaluated


def test_roulette_prefers_lower_costs_and_ignores_the_offset() -> None:
    f = np.array([0.0, 1.0, 2.0, 3.0])
    counts = np.bincount(ops.roulette_selection(f, 100_000, np.random.default_rng(0)), minlength=4)
    expected = np.array([3.03, 2.03, 1.03, 0.03]) / 6.12  # f_max - f + 0.01 (f_max - f_min)
    assert np.all(np.diff(counts) < 0)
    assert np.allclose(counts / 100_000, expected, atol=0.005)
    shifted = ops.roulette_selection(f + 1e6, 100_000, np.random.default_rng(0))
    assert np.array_equal(np.bincount(shifted, minlength=4), counts)
    ranked = np.bincount(
        ops.roulette_selection(f, 100_000, np.random.default_rng(0), scaling="rank"), minlength=4
    )
    assert np.allclose(ranked / 100_000, [0.4, 0.3, 0.2, 0.1], atol=0.005)
    never = ops.roulette_selection(np.array([1.0, np.inf, 2.0]), 1000, np.random.default_rng(0))
    assert 1 not in never
    equal = np.bincount(ops.roulette_selection(np.ones(4), 40_000, np.random.default_rng(0)))
    assert np.allclose(equal / 40_000, 0.25, atol=0.01)


def test_tournament_prefers_lower_costs() -> None:
    f = np.array([3.0, 0.0, 2.0, 1.0])
    counts = np.bincount(
        ops.tournament_selection(f, 100_000, np.random.default_rng(0)), minlength=4
    )
    # binary tournament with replacement: P(rank r of n) = ((n - r)^2 - (n - r - 1)^2) / n^2
    assert np.allclose(counts[[1, 3, 2, 0]] / 100_000, [7 / 16, 5 / 16, 3 / 16, 1 / 16], atol=0.005)


def test_single_point_crossover_children_are_the_parents_genes() -> None:
    rng = np.random.default_rng(0)
    A = np.arange(1.0, 9.0)[None, :] * np.ones((500, 1))
    B = -A
    C1, C2 = ops.single_point_crossover(A, B, 0.75, rng)
    assert np.array_equal(C1 + C2, A + B)  # every gene comes from one parent, at its position
    from_b = C1 == B
    crossed = from_b.any(axis=1)
    assert abs(crossed.mean() - 0.75) < 0.06
    cuts = np.argmax(from_b[crossed], axis=1)
    assert cuts.min() >= 1 and np.all(np.diff(from_b[crossed].astype(int), axis=1) >= 0)  # a tail
    assert set(cuts.tolist()) == set(range(1, 8))
    assert np.array_equal(C2[crossed], np.where(from_b[crossed], A[crossed], B[crossed]))


def test_blend_crossover_stays_in_the_widened_interval() -> None:
    rng = np.random.default_rng(0)
    A, B = rng.random((2000, 3)), rng.random((2000, 3))
    C1, C2 = ops.blend_crossover(A, B, 1.0, rng, alpha=0.5)
    low, high = np.minimum(A, B), np.maximum(A, B)
    width = high - low
    for C in (C1, C2):
        assert np.all(C >= low - 0.5 * width) and np.all(C <= high + 0.5 * width)
    assert np.any(C1 > high) and np.any(C1 < low)  # alpha widens the interval


def test_gene_mutations_use_the_per_gene_rate() -> None:
    rng = np.random.default_rng(0)
    X = np.full((2000, 50), 0.5)
    U = ops.uniform_gene_mutation(X, 0.008, np.zeros(50), np.ones(50), rng)
    assert abs(np.mean(U != 0.5) - 0.008) < 0.001 and np.all((U >= 0.0) & (U <= 1.0))
    G = ops.gaussian_gene_mutation(X, 0.1, np.full(50, 0.2), rng)
    changed = G != 0.5
    assert abs(changed.mean() - 0.1) < 0.003
    assert np.std(G[changed] - 0.5) == pytest.approx(0.2, rel=0.03)


def test_ga_seed000_preset_is_seed_000s_parameters() -> None:
    params = GA.seed000().params
    assert params["max_iterations"] == 30
    assert params["crossover_rate"] == 0.75
    assert params["mutation_rate"] == 0.008
    assert params["selection"] == "roulette"
    assert params["crossover"] == "single_point"
    # not stated in seed 000 §6, documented assumptions:
    assert (params["pop_size"], params["mutation"], params["elitism"]) == (10, "uniform", 1)
    assert GA.seed000(pop_size=20).params["pop_size"] == 20
    result = GA.seed000().run(sphere, LO, HI, seed=0)
    assert result.iterations == 30 and result.evaluations == 10 + 30 * 9


def test_ga_seed000_preset_beats_random_search_on_the_same_budget() -> None:
    # 30 generations of 10: 280 evaluations. Random search with 280 uniform points on the 10-D
    # sphere has a median best of 26.8 (1000 trials); the preset's median over 10 seeds is 16 and
    # its worst of 30 seeds was 31, so a weak optimiser, but better than sampling.
    finals = [GA.seed000().run(sphere, LO, HI, seed=s).f for s in range(10)]
    assert np.median(finals) < 22.0
    rng = np.random.default_rng(0)
    sampled = [sphere(LO + rng.random((280, D)) * (HI - LO)).min() for _ in range(10)]
    assert np.median(finals) < np.median(sampled)


# --------------------------------------------------------------------------- stop rules on runs


def test_stall_and_max_evaluations_end_runs_with_their_status() -> None:
    flat = PSO(max_iterations=100).run(
        lambda X: np.floor(np.sum(X * X, axis=1)), LO, HI, seed=0, termination=Stall(5, 0.0)
    )
    assert flat.status == "stalled" and flat.iterations < 100
    h = flat.history_best
    assert np.all(h[-6:] == h[-1]) and h[-7] > h[-1]
    capped = GA().run(sphere, LO, HI, seed=0, termination=MaxEvaluations(500) | MaxIterations(100))
    assert capped.status == "max_evaluations"
    assert 500 <= capped.evaluations < 500 + 48  # overshoot at most one generation (P - E)


def test_swarm_radius_is_the_normalised_spread_around_the_best() -> None:
    opt = GA(pop_size=5)
    lower, upper = np.array([0.0, 0.0]), np.array([1.0, 100.0])
    x0 = np.array([[0.5, 50.0], [0.5, 50.0], [0.5, 50.0], [0.5, 50.0], [1.0, 0.0]])
    opt.setup(lambda X: np.abs(X[:, 0] - 0.5), lower, upper, seed=0, x0=x0)
    # best (0.5, 50); farthest (1, 0): normalised offset (0.5, -0.5), over the diagonal sqrt(2)
    assert opt.swarm_radius == pytest.approx(0.5)


# --------------------------------------------------------------------------- registry and errors


def test_registry_names_and_unknown_names() -> None:
    from planner.optim import GCPSO, MAFOA, MPSO, SA

    assert OPTIMIZERS == {
        "pso": PSO,
        "apso": AdaptivePSO,
        "ampso": AMPSO,
        "ga": GA,
        "sa": SA,
        "mafoa": MAFOA,
        "gcpso": GCPSO,
        "mpso": MPSO,
    }
    assert make_optimizer("ampso", pop_size=12).params["pop_size"] == 12
    with pytest.raises(
        InputError,
        match="unknown optimiser 'nope'; expected one of ampso, apso, ga, gcpso, mafoa, mpso, pso, sa",
    ):
        make_optimizer("nope")
    with pytest.raises(InputError, match="unknown parameter 'popsize' for optimiser 'pso'"):
        make_optimizer("pso", popsize=10)


@pytest.mark.parametrize(
    ("build", "message"),
    [
        (lambda: PSO(w=-0.1), r"w must be a finite number in \[0.0, inf\]; got -0.1"),
        (lambda: PSO(c1=(2.5, -1)), r"c1\[1\] must be"),
        (
            lambda: PSO(w=(1, 2, 3)),  # type: ignore[arg-type]
            r"w must be a number or a pair",
        ),
        (lambda: PSO(vmax_frac=0), r"vmax_frac must be a finite number in \(0.0"),
        (lambda: PSO(boundary="wrap"), r"boundary must be one of 'clip', 'reflect'; got 'wrap'"),
        (lambda: PSO(init_velocity="big"), r"init_velocity must be one of"),
        (
            lambda: AMPSO(mutation_rate=-0.1),
            r"mutation_rate must be a finite number in \[0.0, 1.0\]",
        ),
        (lambda: AMPSO(sigma_frac=0.0), r"sigma_frac"),
        (lambda: AMPSO(radius_eps=2.0), r"radius_eps"),
        (lambda: AMPSO(acceptance="maybe"), r"acceptance must be one of 'greedy', 'always'"),
        (
            lambda: GA(crossover_rate=1.5),
            r"crossover_rate must be a finite number in \[0.0, 1.0\]; got 1.5",
        ),
        (lambda: GA(mutation_rate=-0.008), r"mutation_rate"),
        (lambda: GA(elitism=50), r"elitism must be < pop_size \(50\)"),
        (lambda: GA(elitism=-1), r"elitism must be an integer >= 0; got -1"),
        (lambda: GA(selection="rank"), r"selection must be one of 'roulette', 'tournament'"),
        (lambda: GA(crossover="two_point"), r"crossover must be one of"),
        (lambda: GA(pop_size=True), r"pop_size must be an integer >= 2; got True"),
        (lambda: GA(mutation_rate=float("nan")), r"mutation_rate must be a finite number"),
    ],
)
def test_bad_parameters_name_the_parameter(build: Callable[[], object], message: str) -> None:
    with pytest.raises(InputError, match=message):
        build()


def test_the_objective_cannot_edit_the_population() -> None:
    def vandal(X: FloatArray) -> FloatArray:
        X[:] = 0.0
        return sphere(X)

    with pytest.raises(ValueError, match="read-only"):
        PSO().run(vandal, LO, HI, seed=0)


class _Rowwise:
    """An objective that allows its calls batched (``rowwise``), counting them."""

    rowwise = True

    def __init__(self, f: Callable[[FloatArray], FloatArray]) -> None:
        self.f, self.calls = f, 0

    def __call__(self, X: FloatArray) -> FloatArray:
        self.calls += 1
        return self.f(X)


@pytest.mark.parametrize("boundary", ["clip", "reflect"])
def test_ampso_batches_the_mutants_with_the_move_bit_for_bit(boundary: str) -> None:
    """Issue 38: with a ``rowwise`` objective AMPSO evaluates the move and its mutants in one
    call -- the same run (best, history, evaluations) as two calls, in fewer calls."""
    lo, hi = np.full(6, -5.12), np.full(6, 5.12)
    kw: dict[str, Any] = {"pop_size": 20, "max_iterations": 60, "mutation_rate": 0.3}
    plain = AMPSO(boundary=boundary, **kw).run(lambda X: rastrigin(X), lo, hi, seed=4)
    batched_f = _Rowwise(rastrigin)
    batched = AMPSO(boundary=boundary, **kw).run(batched_f, lo, hi, seed=4)
    assert same(plain, batched)
    assert batched.evaluations == plain.evaluations
    assert batched_f.calls <= plain.iterations + 1 < plain.evaluations // 20
