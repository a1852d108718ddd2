"""Run a global planning problem with one of the optimisers and return a :class:`PlanResult`."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from planner.explore import ROUTES, check_routes, graph_population
from planner.optim import REGISTRY, make_optimizer
from planner.optim.termination import MaxIterations, SwarmRadius
from planner.problem import PlanningProblem
from planner.profile import sample_path
from planner.result import PlanResult, find_violations, flown_checks, spiral_violation
from planner.spiral import Spiral, climb_bound, only_too_steep, spiral_repair
from terrain.errors import InputError

ALGORITHMS = ("ampso", "pso", "apso", "ga")
INITS = ("graph", "corridor", "uniform")
DEFAULT_ALGORITHM = "ampso"
SWARM_RADIUS_EPS = 1e-4
# The largest swarm: the papers fly 30-200; 100,000 is ~150 MB of working arrays on rmnp, while
# 100,000,000 took 23 GB before the optimiser's first step.
MAX_POPULATION = 100_000


def flown_figures(problem: PlanningProblem, flown: np.ndarray) -> tuple[float, float]:
    """(smallest height of the flown path above the terrain, share of it over unknown terrain),
    from one dense sampling (every half cell) -- finer than the Bresenham walk of the cost,
    reported so users see the true margin. The height is above the conservative safety grid
    (bilinear between its cells); the share is by horizontal distance over cells the DEM did not
    measure, 0 on a fully measured grid."""
    s = sample_path(problem.safety_grid, flown)
    clearance = float(s.clearance.min())
    grid = problem.grid
    if grid.known is None or not grid.has_unknown:
        return clearance, 0.0
    over = ~grid.known[grid.cell_of(s.points[:, 0], s.points[:, 1])]
    step = np.diff(s.distance)
    total = float(step.sum())
    if total <= 0:
        return clearance, float(over.any())
    return clearance, float((step * (over[:-1] | over[1:])).sum() / total)


def attempt_seed(seed: int, attempt: int) -> int:
    """The seed of restart ``attempt`` (0 is ``seed`` itself): derived, so a run is reproducible."""
    if attempt == 0:
        return int(seed)
    return int(np.random.SeedSequence([int(seed), int(attempt)]).generate_state(1, np.uint32)[0])


def plan(
    problem: PlanningProblem,
    algorithm: str = DEFAULT_ALGORITHM,
    *,
    seed: int = 0,
    population: int = 60,
    iterations: int = 200,
    params: dict[str, Any] | None = None,
    straight_seeds: bool = False,
    attempts: int = 1,
    init: str = "graph",
    routes: int = ROUTES,
    callback: Callable[[Any], None] | None = None,
) -> PlanResult:
    """Minimise the seed-002 cost of ``problem`` with ``algorithm``.

    The initial population is ``init="graph"`` (default: the ``routes`` routes of a search of the
    whole map and jittered copies of them in a quarter of it, the corridor population in the rest,
    :func:`planner.explore.graph_population`), ``"corridor"`` (random paths that progress from
    start to goal with every waypoint above the ground under it,
    :meth:`PlanningProblem.corridor_population`, drawn from the run's seed) or ``"uniform"``
    (uniform in the box, as in seed 002's protocol).
    Measured with AMPSO, 10 seeds, P=60, 200 iterations: feasible runs on rmnp 5/10 -> 10/10,
    jacksboro 3/10 -> 10/10 (every algorithm 10/10 there). ``straight_seeds`` puts the two
    straight start-goal paths of :meth:`PlanningProblem.straight_seeds` into it as well; measured
    over 10 seeds on three real maps (benchmarks/RESULTS.md) that did not help AMPSO — the swarm
    gathers round the straight route — so it is off by default.
    ``attempts`` > 1 restarts the optimiser from derived seeds (:func:`attempt_seed`) while the
    result is infeasible and keeps the best run (feasible first, then lowest cost); the result
    records every seed used.
    """
    if init not in INITS:
        raise InputError(f"init must be one of {', '.join(INITS)}; got {init!r}")
    routes = check_routes(routes)
    if isinstance(attempts, bool) or int(attempts) != attempts or attempts < 1:
        raise InputError(f"attempts must be an integer >= 1; got {attempts!r}")
    best: PlanResult | None = None
    seeds: list[int] = []
    for k in range(int(attempts)):
        seeds.append(attempt_seed(seed, k))
        r = _plan_once(
            problem,
            algorithm,
            seeds[-1],
            population,
            iterations,
            params,
            straight_seeds,
            init,
            routes,
            callback,
        )
        if best is None or (r.feasible, -r.terms["total"]) > (best.feasible, -best.terms["total"]):
            best = r
        if best.feasible:
            break
    assert best is not None
    params_out = {**best.params, "attempts": int(attempts), "attempt_seeds": seeds, "init": init}
    if init == "graph":
        params_out["routes"] = routes
    return replace(best, seed=int(seed), params=params_out)


def algorithms() -> list[str]:
    """The algorithms a plan may use: the global planner's four (:data:`ALGORITHMS`) and every
    optimiser an installed package gives (``terrapath.optimizers``)."""
    return [*ALGORITHMS, *REGISTRY.plugin_names()]


def check_algorithm(algorithm: str) -> None:
    """Refuse an algorithm the planner does not fly (naming those it does)."""
    if algorithm not in algorithms():
        raise InputError(
            f"unknown algorithm {algorithm!r}; choose one of {', '.join(algorithms())}"
        )


def _plan_once(
    problem: PlanningProblem,
    algorithm: str,
    seed: int,
    population: int,
    iterations: int,
    params: dict[str, Any] | None,
    straight_seeds: bool,
    init: str,
    routes: int,
    callback: Callable[[Any], None] | None,
) -> PlanResult:
    check_algorithm(algorithm)
    if isinstance(population, bool) or int(population) != population or population < 2:
        raise InputError(f"population must be an integer >= 2; got {population!r}")
    if population > MAX_POPULATION:
        raise InputError(f"population must be at most {MAX_POPULATION:,}; got {population:,}")
    if isinstance(iterations, bool) or int(iterations) != iterations or iterations < 1:
        raise InputError(f"iterations must be an integer >= 1; got {iterations!r}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer):
        raise InputError(f"seed must be an integer; got {seed!r}")
    options: dict[str, Any] = {"pop_size": int(population)}
    if algorithm in ("apso", "ampso"):
        options["max_iterations"] = int(iterations)
    options.update(params or {})
    optimizer = make_optimizer(algorithm, **options)
    termination: Any = MaxIterations(int(iterations))
    if algorithm == "ampso":
        termination = termination | SwarmRadius(SWARM_RADIUS_EPS)
    lower, upper = problem.bounds()
    x0 = None
    explored = None
    t0 = time.perf_counter()
    rng = np.random.default_rng([int(seed), 2])
    if init == "corridor":
        x0 = problem.corridor_population(int(population), rng)
    elif init == "graph":
        x0, explored = graph_population(problem, int(population), rng, routes)
    if straight_seeds:
        seeds = problem.straight_seeds()
        x0 = seeds if x0 is None else np.vstack([seeds, x0[len(seeds) :]])
    res = optimizer.run(
        problem, lower, upper, seed=int(seed), termination=termination, x0=x0, callback=callback
    )
    elapsed = time.perf_counter() - t0
    terms = problem.terms(res.x[None, :])
    path = problem.paths(res.x)
    flown = problem.flown(path)
    # feasible: the cost's hard terms hold (the swarm's check, on the Bresenham cells) and the
    # flown path sampled every half cell passes the validity layer and the band's top
    flown_ok, check, top = flown_checks(problem, flown)
    feasible = bool(problem.feasible(terms)[0]) and flown_ok
    row = terms.row(0)
    spirals: tuple[Spiral, ...] = ()
    spiral_note = None
    if not feasible and flown_ok and problem.performance is not None and only_too_steep(row):
        repaired = spiral_repair(problem, path)
        if repaired.reason is None:
            path, flown, row, spirals = (
                repaired.path,
                repaired.flown,
                repaired.terms,
                repaired.spirals,
            )
            flown_ok, check, top = flown_checks(problem, flown)
            feasible = repaired.feasible and flown_ok
        else:
            spiral_note = repaired.reason
    row["min_clearance_m"], row["over_unknown_share"] = flown_figures(problem, flown)
    if problem.performance is not None:
        # how much longer than the climb and descent need the path is (spirals lengthen it)
        bound = climb_bound(path, problem.performance)
        row["climb_bound_m"] = bound
        flat = float(np.hypot(*np.diff(flown[:, :2], axis=0).T).sum())
        row["length_over_bound"] = flat / bound if bound > 0 else math.inf
    if top is not None:
        row["max_above_ground_m"] = top
    violations = () if feasible else find_violations(problem, path, check)
    if spiral_note is not None:
        violations = (*violations, spiral_violation(spiral_note))
    return PlanResult(
        status="feasible" if feasible else "infeasible",
        waypoints=path,
        terms=row,
        algorithm=algorithm,
        params={
            **dict(res.params),
            "population": int(population),
            "iterations": int(iterations),
            "straight_seeds": straight_seeds,
            **({"exploration": explored.summary()} if explored is not None else {}),
        },
        seed=int(seed),
        iterations=int(res.iterations),
        evaluations=int(res.evaluations),
        elapsed_s=elapsed,
        stop_reason=str(res.status),
        history_best=np.asarray(res.history_best),
        history_mean=np.asarray(res.history_mean),
        violations=violations,
        flown=flown,
        spirals=spirals,
    )
