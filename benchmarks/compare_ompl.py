"""terrapath's planner beside OMPL 2.0's asymptotically optimal planners on the golden scenarios.

The problems are the golden scenarios' (``tests/golden/scenarios.py``: jacksboro, rmnp, Big
Tujunga; the aerosonde's limits, hard danger zones with their margin, 50 m clearance, start and
goal 150 m above the highest terrain around them).  OMPL (the PyPI package ``ompl``, extra
``compare``) plans in a 3-D real vector state space bounded by the problem's box (the map's
cell-centre extent and the altitude band), from the problem's start to its goal, with terrapath's
validity layer as its checkers: a state is valid when ``problem.validity.points`` says so (on the
map, over measured terrain, at least the clearance above the conservative safety heights, out of
the zones grown by their margin), a motion (a straight 3-D segment) when
``problem.validity.segments`` does.  Both run in Python, about 0.3-0.5 ms a segment: OMPL's
sampling and search are C++, but every collision check crosses into terrapath's numpy code, so
OMPL does a few thousand motion checks a second here.  AORRTC is the exception: a Python
``MotionValidator`` crashes its solve in the 2.0 bindings (a segmentation fault), so it keeps
OMPL's discrete motion validator, which checks the states along a motion at the segments' own
sample spacing (half a cell) -- the same terrain samples, the zones sampled instead of exact.
It still segfaults inside its second search on rmnp (also with OMPL's validator; not without a
validity checker at all), recorded as *crashed*, and it overshoots its budget (it looks at the
termination condition between searches): its wall time is in the table.

Planners: RRT*, Informed RRT*, BIT* and AORRTC (all in the 2.0 bindings), each for 1, 3 and 10 s
of wall time per solve (``--budgets``), with two objectives:

- ``length``: OMPL's ``PathLengthOptimizationObjective``;
- ``length+alt``: the path integral of 1 + (z - Zmin) / (Zmax - Zmin) (an
  ``OptimizationObjective`` whose motion cost is the trapezoid rule, exact for straight
  segments, and whose heuristic is the distance): the length plus the length-weighted normalised
  altitude, seed 002's F_length + F_altitude in spirit.  Run with RRT* and BIT*
  (``--altitude-planners``).  Not a ``StateCostIntegralObjective`` with a Python ``stateCost``:
  the 2.0 bindings do not call that override from C++ (the objective silently stays the
  length), while a Python ``motionCost`` is called.

Every solve runs in a fresh forked process whose first act is ``ompl.util.RNG.setSeed``: OMPL's
seed only applies before its first random number in a process.  OMPL refuses seed 0, so the runs
use seeds 1..``--seeds`` (terrapath the same seeds).  A run is *solved* when OMPL reports an exact
solution within the budget; the time to the first solution is when the planner first holds one
(its ``bestCost`` finite, polled by the termination condition at every iteration); the path
length is the 3-D length of the returned polyline (not simplified).

terrapath's cost F of an OMPL path: ``PlanningProblem.polyline_terms`` evaluates the polyline
exactly as the planner evaluates its own waypoints -- flown with the aircraft's turn fillets,
climb and descent gradients, the conservative (dilated) Bresenham terrain check, the zones --
so OMPL's paths pay the penalty P = 3 for whatever its straight-segment 3-D world ignores (a climb
steeper than 16 %, a turn fillet that cuts into terrain, legs too short for their fillets).
*flyable* counts the paths that are feasible by terrapath's rules (the cost's hard terms and the
validity of the flown path, as ``planner.plan`` decides for its own results), *breaks* how many
paths break each hard term, and *F without limits* is the cost of the polyline itself without
the aircraft (no fillets, no gradients: the geometry OMPL optimises, judged by seed 002's cost).
The cost's terrain check (Bresenham cells of the safety heights dilated by one cell) is stricter
than the validity layer OMPL plans with (the bilinear safety heights sampled every half cell),
as it is for terrapath's own results, which must pass both: a path valid for OMPL can still
break the terrain term.  So by default OMPL's motion validator asks both (the segment's cost
terrain term must be zero too; not for AORRTC and vana, which use OMPL's own validators): both
planners then search the same world, and OMPL's paths fail only on what its R^3 cannot know
(climb gradients, turn fillets).  ``--loose-terrain`` gives OMPL the validity layer alone (the
first records).

Beside them terrapath at equal wall time: ``planner.plan.plan(problem, "ampso", seed=s)`` (graph
initial population, single attempt) with the population and iterations of ``TERRAPATH`` chosen so
one plan takes about 1 s, 3 s and 10 s on the 2-core machine of the record (re-measured with the
waypoint placement of the graph start, which takes 0.1-0.3 s of each: P=110 / 380 iterations
0.84-1.01 s on the three maps, 130 / 420 1.0-1.2 s, 280 / 680 2.8-3.1 s, 620 / 1200 9.7-10.5 s;
the plan default P=60 / 200 takes about 0.45 s); the 10 s plan is also a reference for the best F
reached at 10 s.

The kinematic comparison (``--planners vana``, not in the default set): RRT* in OMPL's
Dubins-airplane state space ``VanaStateSpace`` (x, y, z, yaw, pitch) with the aerosonde's turn
radius and a pitch limit of atan(min(climb, descent gradient)) (the 2.0 bindings take a single
symmetric limit: the pair constructor has no type caster), start and goal level and heading from
the start to the goal; ``VanaMotionValidator`` checks its curves state by state with terrapath's
point validity at half a cell.  RRT* warns that the space's distance is not symmetric (its
rewiring assumes it; it still returns valid paths).  The curve, sampled at half a cell, is the
flown path: its F is taken on it as is (no fillets), with the gradients checked on it.
``OwenStateSpace`` is in the bindings too but not run.

Target (issue 20): at equal wall time (1 s and 3 s) terrapath's mean F lower than the best OMPL
planner's (the lowest mean F among those that solved every seed) on all three maps, with a
smaller spread, and within 2 % of the best F any planner reached at 10 s.

Run (``pip install -e '.[compare]'`` first):
``.venv/bin/python benchmarks/compare_ompl.py [--maps jacksboro,rmnp,bigtujunga]
[--planners rrtstar,informed,bitstar,aorrtc] [--altitude-planners rrtstar,bitstar]
[--budgets 1,3,10] [--seeds 10] [--no-terrapath] [--no-record]``.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import multiprocessing as mp
import sys
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks._record import emit
from planner.flown import climb_excess
from planner.plan import plan
from planner.problem import PlanningProblem
from tests.golden.scenarios import MAPS

MAP_NAMES = ("jacksboro", "rmnp", "bigtujunga")
PLANNERS = {
    "rrtstar": "RRTstar",
    "informed": "InformedRRTstar",
    "bitstar": "BITstar",
    "aorrtc": "AORRTC",
    "vana": "RRTstar",  # in OMPL's Dubins-airplane state space (VanaStateSpace); not by default
}
DEFAULT_PLANNERS = ("rrtstar", "informed", "bitstar", "aorrtc")
OBJECTIVES = ("length", "length+alt")
ALTITUDE_PLANNERS = ("rrtstar", "bitstar")
# (population, iterations) of one terrapath plan taking about the budget (s) on the record's machine
# (10 s: a reference for the best F at 10 s; the target compares the equal-time budgets)
TERRAPATH = {1.0: (115, 390), 3.0: (280, 680), 10.0: (600, 1200)}
# the hard terms of a path's cost (CostTerms.row keys) and their names in the table
HARD = {
    "below_terrain_m": "terrain",
    "inside_zones_m": "zones",
    "climb_excess_m": "climb",
    "turn_excess_m": "turn",
    "unknown_terrain_m": "unknown",
}
EQUAL_TIME = (1.0, 3.0)
INSTALL = "pip install -e '.[compare]'"

_PROBLEMS: dict[str, PlanningProblem] = {}  # the forked solver processes read their problem here


@dataclass(frozen=True)
class Run:
    """One solve: OMPL's (planner, objective) or terrapath's ("terrapath", "F") at a budget."""

    map: str
    planner: str
    objective: str
    budget: float
    seed: int
    solved: bool
    first_s: float  # time to the first solution (nan: none)
    wall_s: float
    length_m: float  # 3-D length of the polyline (nan: none)
    cost: float  # terrapath's F of the path (nan: none)
    flyable: bool  # feasible by terrapath's rules
    broken: tuple[str, ...]  # the hard terms it breaks ("climb", "turn", "collision", ...)
    cost_bare: float  # F of the polyline without the aircraft's limits
    checks: int  # OMPL's motion + state checks, terrapath's cost evaluations
    crashed: bool = False  # the solver's process died (OMPL segfault)
    strict: bool = False  # motions also passed the cost's terrain check (--strict-terrain)


def _polyline_length(path: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())


def _judge(problem: PlanningProblem, polyline: np.ndarray) -> tuple[float, bool, tuple[str, ...]]:
    """(F, feasible, the hard terms it breaks) of a polyline, as ``planner.plan`` judges its own
    results (the cost's hard terms, the validity layer on the flown path)."""
    terms = problem.polyline_terms(polyline)
    flown = problem.flown(polyline)
    valid = bool(problem.validity.path(flown).valid.all())
    ok = bool(problem.feasible(terms)[0]) and valid
    row = terms.row(0)
    broken = tuple(k for k in HARD if row[k] > 0) + (() if valid else ("validity",))
    return float(terms.total[0]), ok, broken


def _judge_flown(
    problem: PlanningProblem, flown: np.ndarray
) -> tuple[float, bool, tuple[str, ...]]:
    """:func:`_judge` of a path that is already the flown one (a Dubins-airplane curve, densely
    sampled): no fillets added; the climb and descent gradients checked on it."""
    perf = problem.performance
    assert perf is not None
    terms = _bare(problem).polyline_terms(flown)
    excess = float(climb_excess(flown[None], perf.climb_gradient, perf.descent_gradient)[0])
    length = float(terms.path_length[0])
    cost = float(terms.total[0]) + (problem.penalty + excess / length if excess > 0 else 0.0)
    valid = bool(problem.validity.path(flown).valid.all())
    ok = bool(problem.feasible(terms)[0]) and excess <= 0 and valid
    row = {**terms.row(0), "climb_excess_m": excess}
    broken = tuple(k for k in HARD if row[k] > 0) + (() if valid else ("validity",))
    return cost, ok, broken


def _without_limits(problem: PlanningProblem, polyline: np.ndarray) -> float:
    """F of the polyline itself, without the aircraft's limits (no fillets, no gradients)."""
    return float(_bare(problem).polyline_terms(polyline).total[0])


_BARE: dict[int, PlanningProblem] = {}


def _bare(problem: PlanningProblem) -> PlanningProblem:
    if id(problem) not in _BARE:
        _BARE[id(problem)] = replace(problem, performance=None)
    return _BARE[id(problem)]


def solve_ompl(
    name: str, planner: str, objective: str, budget: float, seed: int, strict: bool = False
) -> Run:
    """One OMPL solve of map ``name``'s problem (run in a fresh forked process, see the module
    docstring)."""
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    ou.setLogLevel(ou.LOG_NONE)
    ou.RNG.setSeed(int(seed))
    strict = strict and planner not in ("aorrtc", "vana")  # those use OMPL's own validators
    problem = _PROBLEMS[name]
    validity = problem.validity
    lo, hi = problem.bounds()
    perf = problem.performance
    kinematic = planner == "vana"
    if kinematic and perf is None:
        raise ValueError("the Dubins-airplane comparison needs the aircraft's performance")
    space = (
        ob.VanaStateSpace(
            perf.turn_radius, math.atan(min(perf.climb_gradient, perf.descent_gradient))
        )
        if kinematic and perf is not None
        else ob.RealVectorStateSpace(3)
    )
    bounds = ob.RealVectorBounds(3)
    for i in range(3):
        bounds.setLow(i, float(lo[i]))
        bounds.setHigh(i, float(hi[i]))
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    counts = [0, 0]  # motion checks, state checks

    def xyz(s: Any) -> np.ndarray:
        return np.array([[s[0], s[1], s[2]]])

    class States(ob.StateValidityChecker):
        def isValid(self, s: Any) -> bool:
            counts[1] += 1
            return bool(si.satisfiesBounds(s)) and bool(validity.points(xyz(s)).valid[0])

    bare = _bare(problem)

    class Motions(ob.MotionValidator):
        def checkMotion(self, a: Any, b: Any) -> bool:
            counts[0] += 1
            pa, pb = xyz(a), xyz(b)
            ok = bool(validity.segments(pa, pb, clearance=False).valid[0])
            if ok and strict:  # and the cost's own terrain check of the segment
                ok = bool(bare.polyline_terms(np.vstack([pa, pb])).below_length[0] <= 0)
            return ok

    zmin, zmax = problem.band

    class LengthAltitude(ob.OptimizationObjective):
        """The integral of 1 + the normalised altitude along the path; a straight motion's is
        exact by the trapezoid rule.  (A Python ``stateCost`` of a ``StateCostIntegralObjective``
        is not seen by OMPL's C++ side in the 2.0 bindings; ``motionCost`` here is.)"""

        def __init__(self) -> None:
            super().__init__(si)

        def stateCost(self, s: Any) -> Any:
            return ob.Cost(1.0 + (s[2] - zmin) / (zmax - zmin))

        def motionCost(self, a: Any, b: Any) -> Any:
            alt = 0.5 * (a[2] + b[2]) - zmin
            return ob.Cost(si.distance(a, b) * (1.0 + alt / (zmax - zmin)))

        def motionCostHeuristic(self, a: Any, b: Any) -> Any:
            return ob.Cost(si.distance(a, b))  # admissible: the altitude term is >= 0

    states, motions = States(si), Motions(si)
    si.setStateValidityChecker(states)
    if planner in ("aorrtc", "vana"):
        # a Python MotionValidator crashes AORRTC's solve in the 2.0 bindings, and a Dubins
        # airplane's motions are curves: OMPL's validators check their states one by one, at the
        # segments' own sample spacing
        si.setStateValidityCheckingResolution(validity.step / space.getMaximumExtent())
        if kinematic:
            motions = ob.VanaMotionValidator(si)
    if planner != "aorrtc":
        si.setMotionValidator(motions)
    si.setup()
    pdef = ob.ProblemDefinition(si)
    start, goal = space.allocState(), space.allocState()
    for i in range(3):
        start[i] = float(problem.start[i])
        goal[i] = float(problem.goal[i])
    if kinematic:  # level, heading from the start to the goal at both ends
        yaw = math.atan2(problem.goal[1] - problem.start[1], problem.goal[0] - problem.start[0])
        for s in (start, goal):
            s.setYaw(yaw)
            s.setPitch(0.0)
    pdef.setStartAndGoalStates(start, goal)
    obj = ob.PathLengthOptimizationObjective(si) if objective == "length" else LengthAltitude()
    pdef.setOptimizationObjective(obj)
    solver = getattr(og, PLANNERS[planner])(si)
    solver.setProblemDefinition(pdef)
    solver.setup()
    best = getattr(solver, "bestCost", None)
    first = [math.nan]
    t0 = time.perf_counter()

    def stop() -> bool:
        now = time.perf_counter() - t0
        if math.isnan(first[0]) and (
            pdef.hasExactSolution() or (best is not None and math.isfinite(best().value()))
        ):
            first[0] = now
        return now >= budget

    status = solver.solve(ob.PlannerTerminationCondition(stop))
    wall = time.perf_counter() - t0
    solved = bool(pdef.hasExactSolution()) and "Exact" in status.asString()
    if not solved:
        return Run(name, planner, objective, budget, seed, False, math.nan, wall, math.nan,
                   math.nan, False, (), math.nan, sum(counts), strict=strict)  # fmt: skip
    path = pdef.getSolutionPath()
    if kinematic:  # the curve itself, sampled at the validity's spacing, is the flown path
        path.interpolate(int(math.ceil(path.length() / validity.step)) + 1)
    poly = np.array([xyz(path.getState(i))[0] for i in range(path.getStateCount())])
    cost, ok, broken = _judge_flown(problem, poly) if kinematic else _judge(problem, poly)
    t_first = first[0] if not math.isnan(first[0]) else wall
    return Run(name, planner, objective, budget, seed, True, t_first, wall, _polyline_length(poly),
               cost, ok, broken, _without_limits(problem, poly), sum(counts),
               strict=strict)  # fmt: skip


def _solve_in_child(
    fork: Any, name: str, planner: str, objective: str, budget: float, seed: int, strict: bool
) -> Run:
    """:func:`solve_ompl` in a fresh forked process; a crash (OMPL's AORRTC segfaults on some
    maps) is recorded as an unsolved, crashed run."""
    try:
        with ProcessPoolExecutor(1, mp_context=fork) as pool:
            result: Run = pool.submit(
                solve_ompl, name, planner, objective, budget, seed, strict
            ).result()
            return result
    except BrokenProcessPool:
        return Run(name, planner, objective, budget, seed, False, math.nan, math.nan, math.nan,
                   math.nan, False, (), math.nan, 0, crashed=True,
                   strict=strict and planner not in ("aorrtc", "vana"))  # fmt: skip


def solve_terrapath(name: str, budget: float, seed: int) -> Run:
    problem = _PROBLEMS[name]
    population, iterations = TERRAPATH[budget]
    t0 = time.perf_counter()
    r = plan(problem, "ampso", seed=seed, population=population, iterations=iterations)
    wall = time.perf_counter() - t0
    poly = np.asarray(r.waypoints)
    _, _, broken = _judge(problem, poly)
    return Run(name, "terrapath", "F", budget, seed, True, wall, wall, _polyline_length(poly),
               float(r.terms["total"]), r.feasible, broken, _without_limits(problem, poly),
               r.evaluations)  # fmt: skip


def _ms(values: Sequence[float], fmt: str) -> str:
    v = np.asarray([x for x in values if math.isfinite(x)])
    if not len(v):
        return "-"
    return f"{v.mean():{fmt}} ± {v.std():{fmt}}"


def _broken(runs: list[Run]) -> str:
    """ " (breaks climb 3, turn 1)": how many runs break each hard term."""
    counts = {k: sum(k in r.broken for r in runs) for k in (*HARD, "validity")}
    named = [f"{HARD.get(k, k)} {n}" for k, n in counts.items() if n]
    return f" (breaks {', '.join(named)})" if named else ""


def _row(runs: list[Run]) -> tuple[str, str, str]:
    r0 = runs[0]
    label = "terrapath AMPSO" if r0.planner == "terrapath" else f"{r0.planner} [{r0.objective}]"
    if r0.strict:
        label += " strict-terrain"
    if r0.planner == "terrapath":
        pop, its = TERRAPATH[r0.budget]
        label += f" P={pop}/{its} it"
    solved = [r for r in runs if r.solved]
    time_part = (
        f"wall {_ms([r.wall_s for r in runs], '.2f')} s"
        if r0.planner == "terrapath"
        else f"first {_ms([r.first_s for r in solved], '.2f')} s, wall "
        f"{_ms([r.wall_s for r in runs if not r.crashed], '.2f')} s"
    )
    crashed = sum(r.crashed for r in runs)
    value = (
        f"solved {len(solved)}/{len(runs)}"
        + (f" (crashed {crashed})" if crashed else "")
        + f", {time_part}, "
        f"length {_ms([r.length_m / 1000 for r in solved], '.2f')} km, "
        f"F {_ms([r.cost for r in solved], '.4f')}, "
        f"flyable {sum(r.flyable for r in solved)}/{len(runs)}{_broken(solved)}"
    )
    if r0.planner != "terrapath":  # terrapath's waypoints are meant to be flown with fillets
        value += f", F without limits {_ms([r.cost_bare for r in solved], '.4f')}"
    return (f"{r0.map} / {r0.budget:g} s / {label}", value, "")


def _target_rows(
    name: str, runs: list[Run], budgets: Sequence[float]
) -> list[tuple[str, str, str]]:
    """Per equal-time budget: terrapath's mean F and spread beside the best OMPL configuration's
    (lowest mean F among those that solved every seed), and against the best F of any planner at
    10 s."""
    rows = []
    at10 = [r.cost for r in runs if r.budget == 10.0 and r.solved]
    best10 = min(at10) if at10 else math.nan
    for budget in budgets:
        if budget not in EQUAL_TIME:
            continue
        tp = [r.cost for r in runs if r.budget == budget and r.planner == "terrapath"]
        if not tp:
            continue
        groups: dict[tuple[str, str], list[Run]] = {}
        for r in runs:
            if r.budget == budget and r.planner != "terrapath":
                groups.setdefault((r.planner, r.objective), []).append(r)
        full = {k: v for k, v in groups.items() if all(r.solved for r in v)}
        pool = full or {k: v for k, v in groups.items() if any(r.solved for r in v)}
        tm, ts = float(np.mean(tp)), float(np.std(tp))
        if pool:
            key = min(pool, key=lambda k: np.nanmean([r.cost for r in pool[k]]))
            oc = [r.cost for r in pool[key] if r.solved]
            om, os_ = float(np.mean(oc)), float(np.std(oc))
            note = "" if full else " (no OMPL planner solved every seed)"
            beside = f"best OMPL {key[0]} [{key[1]}] {om:.4f} ± {os_:.4f}{note}"
            lower = tm < om and ts < os_
        else:
            beside, lower = "no OMPL solution", True
        first = f"lower mean and spread: {'yes' if lower else 'no'}"
        if math.isfinite(best10):
            within = tm <= 1.02 * best10
            ten = (
                f"; best F at 10 s {best10:.4f}, terrapath {100 * (tm / best10 - 1):+.1f} % "
                f"(within 2 %: {'yes' if within else 'no'})"
            )
            holds = "holds" if lower and within else "does not hold"
        else:
            ten, holds = "; no 10 s runs", "the 10 s clause not measured"
        rows.append(
            (
                f"{name} / {budget:g} s / target",
                f"terrapath {tm:.4f} ± {ts:.4f}, {beside} ({first}){ten}: {holds}",
                "terrapath lower mean F, smaller spread, within 2 % of the best at 10 s",
            )
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--maps", default=",".join(MAP_NAMES), help="of " + ", ".join(MAP_NAMES))
    ap.add_argument(
        "--planners", default=",".join(DEFAULT_PLANNERS), help="of " + ", ".join(PLANNERS)
    )
    ap.add_argument(
        "--altitude-planners",
        default=",".join(ALTITUDE_PLANNERS),
        help="planners also run with the length+altitude objective ('' for none)",
    )
    ap.add_argument("--budgets", default="1,3,10", help="wall seconds per solve")
    ap.add_argument("--seeds", type=int, default=10, help="seeds 1..N")
    ap.add_argument(
        "--strict-terrain",
        action="store_true",
        default=True,
        help="a motion must also pass the cost's terrain check (dilated Bresenham cells; the "
        "default)",
    )
    ap.add_argument(
        "--loose-terrain",
        dest="strict_terrain",
        action="store_false",
        help="OMPL's motions checked by the validity layer alone",
    )
    ap.add_argument("--no-terrapath", action="store_true", help="only the OMPL planners")
    ap.add_argument("--no-record", action="store_true", help="print, do not append RESULTS.md")
    args = ap.parse_args()
    if importlib.util.find_spec("ompl") is None:
        raise SystemExit(f"compare_ompl: the OMPL Python bindings are not installed; {INSTALL}")
    maps = [m for m in args.maps.split(",") if m]
    planners = [p for p in args.planners.split(",") if p]
    alt_planners = [p for p in args.altitude_planners.split(",") if p]
    for m in maps:
        if m not in MAP_NAMES:
            ap.error(f"--maps: unknown map {m!r}; choose from {', '.join(MAP_NAMES)}")
    for p in planners + alt_planners:
        if p not in PLANNERS:
            ap.error(f"unknown planner {p!r}; choose from {', '.join(PLANNERS)}")
    try:
        budgets = [float(b) for b in args.budgets.split(",") if b]
    except ValueError:
        ap.error(f"--budgets: expected seconds separated by commas; got {args.budgets!r}")
    if not budgets or min(budgets) <= 0 or args.seeds < 1:
        ap.error("--budgets must be positive seconds and --seeds at least 1")
    seeds = range(1, args.seeds + 1)
    scenarios = {m.name: m for m in MAPS}
    configs = [(p, "length") for p in planners]
    configs += [(p, "length+alt") for p in alt_planners]
    rows: list[tuple[str, str, str]] = []
    done: list[str] = []
    fork = mp.get_context("fork")
    for name in maps:
        scenario = scenarios[name]
        if not Path(scenario.dem).exists():
            print(f"skipping {name}: {scenario.dem} not found")
            continue
        _PROBLEMS[name] = scenario.problem()
        done.append(name)
        runs: list[Run] = []
        if not args.no_terrapath:
            plan(_PROBLEMS[name], "ampso", seed=0, population=10, iterations=2)  # JIT warm-up
        for budget in budgets:
            groups: list[list[Run]] = []
            for planner, objective in configs:
                group = []
                for seed in seeds:
                    group.append(
                        _solve_in_child(
                            fork, name, planner, objective, budget, seed, args.strict_terrain
                        )
                    )
                    print(group[-1], flush=True)
                groups.append(group)
            if budget in TERRAPATH and not args.no_terrapath:
                group = [solve_terrapath(name, budget, seed) for seed in seeds]
                for r in group:
                    print(r, flush=True)
                groups.append(group)
            for group in groups:
                runs += group
                rows.append(_row(group))
                print(rows[-1], flush=True)
        if not args.no_terrapath:
            rows += _target_rows(name, runs, budgets)
    if not rows:
        raise SystemExit("compare_ompl: no map to compare (every DEM missing)")
    pops = ", ".join(f"{b:g} s: P={p}, {i} iterations" for b, (p, i) in TERRAPATH.items())
    emit(
        f"compare: terrapath beside OMPL on the golden scenarios ({args.seeds} seeds)",
        rows,
        f"maps {', '.join(done)}; OMPL 2.0 planners {', '.join(planners)} (length) and "
        f"{', '.join(alt_planners) or 'none'} (length + altitude integral) in R^3 bounded by the "
        f"map and the altitude band, terrapath's validity as state and motion checker; budgets "
        f"{', '.join(f'{b:g}' for b in budgets)} s of wall time per solve; seeds "
        f"1..{args.seeds}, one forked process per OMPL solve; F = terrapath's full cost of the "
        f"path (polyline_terms: flown with the aerosonde's fillets and gradients), flyable = "
        f"feasible by terrapath's rules; mean ± std over the solved runs; terrapath AMPSO "
        f"(graph start, single attempt) at {pops}"
        + (
            "; strict terrain: OMPL's motions (not AORRTC's, not vana's) also pass the cost's "
            "terrain check (dilated Bresenham cells)"
            if args.strict_terrain
            else "; --loose-terrain: OMPL's motions checked by the validity layer alone"
        ),
        args.no_record,
    )


if __name__ == "__main__":
    main()
