"""terrapath beside SPSO (Phung & Ha 2021, the spherical-vector PSO) on SPSO's own scenario.

SPSO's Christmas Island model (``CreateModel.m`` and ``MyCost.m`` of github.com/duongpm/SPSO):
the 5 m DEM ``ChrismasTerrain.tif`` (``../shared/maps/spso_christmas_island``) used in *pixel
units* horizontally (x the column, y the row from the top, 1-based) and metres vertically; start
(200, 100) and goal (800, 800), both 150 m above the ground; heights above the ground kept in
[100, 200] m with 150 m preferred (its J3); six threat cylinders (x, y, R) = (400, 500, 80),
(600, 200, 70), (500, 350, 80), (350, 200, 70), (700, 550, 70), (650, 750, 80), a collision
inside R + 1 (the drone's size); 10 free nodes; population 500, 200 iterations.

terrapath plans the same geometry in the same units: the DEM is written without its CRS
(``build/compare_spso/christmas_pixels.tif``, one unit a cell, y up: SPSO's row y is map
``879.5 - y``, its column x map ``x - 0.5``) and loaded with ``--local-cell-size 1``; the
threats are hard danger zones of radius R + 1; the above-ground band is ``--agl-min 100
--agl-max 200`` with ``--agl-pref 150`` (SPSO keeps the band at its nodes only, terrapath along
the whole path); no aircraft limits (SPSO has none).  Lengths are in SPSO's units (pixels
horizontally, metres vertically, as its J1 adds them).

Each run's route is *direct* when the path passes every threat on the side the straight
start-goal line does (threading the gaps the line crosses between the threats), and a *detour*
otherwise (round the whole field, or round a threat the line leaves on its other side).  SPSO's figures
(issue 20, GNU Octave, 5 seeds, SPSO unmodified): every run direct, 3-D length 934-1024 units.
Target: direct in >= 9 of 10 runs at a tenth of SPSO's budget, length within 3 % of 934.

Run: ``.venv/bin/python benchmarks/compare_spso.py [--runs 10] [--budget tenth|full|both]
[--algorithms ampso,apso,pso,ga] [--no-record]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks._record import emit
from planner.plan import plan
from planner.problem import PlanningProblem
from terrain.load import load_dem
from terrain.zones import DangerZone

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT.parent / "shared" / "maps" / "spso_christmas_island" / "ChrismasTerrain.tif"
LOCAL = ROOT / "build" / "compare_spso" / "christmas_pixels.tif"
THREATS = ((400, 500, 80), (600, 200, 70), (500, 350, 80), (350, 200, 70), (700, 550, 70),
           (650, 750, 80))  # fmt: skip
START, GOAL = (200.0, 100.0), (800.0, 800.0)
DRONE = 1.0
SPSO_LENGTHS = (934.0, 1024.0)  # issue 20's Octave runs of SPSO, 5 seeds
BUDGETS = {"full": (500, 200), "tenth": (100, 100)}


def local_dem() -> Path:
    """SPSO's DEM without its CRS, one unit a cell, origin so that map y = 879.5 - SPSO's y."""
    import rasterio
    from affine import Affine

    LOCAL.parent.mkdir(parents=True, exist_ok=True)
    with rasterio.open(SOURCE) as src:
        h = src.read(1).astype(np.float32)
    h[h < 0] = 0.0  # CreateModel.m clamps H < 0 to 0
    tmp = LOCAL.with_suffix(".tmp.tif")
    with rasterio.open(tmp, "w", driver="GTiff", height=h.shape[0], width=h.shape[1], count=1,
                       dtype="float32", transform=Affine(1, 0, 0, 0, -1, h.shape[0])) as dst:  # fmt: skip
        dst.write(h, 1)
    tmp.replace(LOCAL)
    return LOCAL


def to_map(x: float, y: float, rows: int) -> tuple[float, float]:
    """SPSO's (column, row) to the local map's (x, y)."""
    return x - 0.5, rows + 0.5 - y


def problem(n_free: int = 10) -> PlanningProblem:
    grid = load_dem(str(local_dem()), local_cell_size=1.0)
    rows = grid.rows
    ground = np.asarray(grid.heights, dtype=np.float64)

    def at(x: float, y: float) -> np.ndarray:
        mx, my = to_map(x, y, rows)
        return np.array([mx, my, float(ground[int(round(y)) - 1, int(round(x)) - 1]) + 150.0])

    zones = tuple(
        DangerZone(*to_map(x, y, rows), 2.0 * (r + DRONE), id=f"T{i + 1}")
        for i, (x, y, r) in enumerate(THREATS)
    )
    return PlanningProblem(
        grid, at(*START), at(*GOAL), n_free, zones, avoid_zones=True, clearance=100.0,
        agl_min=100.0, agl_max=200.0, agl_pref=150.0,
    )  # fmt: skip


def route_of(path: np.ndarray, rows: int) -> str:
    """'direct' when the path passes every threat on the side the straight start-goal line does
    (its loop closed by that line back to the start winds round no threat's centre: the gaps
    the line threads), else 'detour' (module docstring)."""
    loop = np.vstack([path[:, :2], path[:1, :2]])  # back along the straight line
    for x, y, _ in THREATS:
        c = np.array(to_map(x, y, rows))
        a = np.arctan2(loop[:, 1] - c[1], loop[:, 0] - c[0])
        turns = np.diff(a)
        turns = (turns + np.pi) % (2 * np.pi) - np.pi
        if abs(turns.sum()) > np.pi:  # winds round it
            return "detour"
    return "direct"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--budget", choices=("tenth", "full", "both"), default="both")
    ap.add_argument("--algorithms", default="ampso")
    ap.add_argument("--init", default="graph")
    ap.add_argument("--no-record", action="store_true")
    args = ap.parse_args()
    if not SOURCE.exists():
        print(f"skipping: {SOURCE} not found")
        return
    pr = problem()
    rows = pr.grid.rows
    budgets = ["tenth", "full"] if args.budget == "both" else [args.budget]
    lines = []
    for budget in budgets:
        pop, its = BUDGETS[budget]
        for alg in args.algorithms.split(","):
            lengths, costs, routes, times, feas = [], [], [], [], 0
            for seed in range(args.runs):
                t0 = time.perf_counter()
                r = plan(pr, alg, seed=seed, population=pop, iterations=its, init=args.init)
                times.append(time.perf_counter() - t0)
                lengths.append(r.terms["path_length_m"])
                costs.append(r.terms["total"])
                routes.append(route_of(r.waypoints, rows))
                feas += r.feasible
                print(f"{budget} {alg} seed {seed}: {routes[-1]}, length {lengths[-1]:.0f}, "
                      f"F {costs[-1]:.4f}, {'feasible' if r.feasible else 'INFEASIBLE'}, "
                      f"{times[-1]:.1f} s", flush=True)  # fmt: skip
            n_direct = routes.count("direct")
            le = np.array(lengths)
            lines.append(
                (
                    f"{budget} budget (P {pop} x {its}) / {alg}",
                    f"direct {n_direct}/{args.runs}; length {le.mean():.0f} (min {le.min():.0f}, "
                    f"max {le.max():.0f}); F {np.mean(costs):.4f} +- {np.std(costs):.4f}; "
                    f"feasible {feas}/{args.runs}; {np.mean(times):.1f} s/run",
                    "direct >= 9/10 at a tenth, length within 3 % of 934"
                    if budget == "tenth"
                    else f"SPSO: all direct, {SPSO_LENGTHS[0]:.0f}-{SPSO_LENGTHS[1]:.0f}",
                )
            )
    emit(
        "compare: terrapath beside SPSO on its Christmas Island scenario",
        lines,
        f"initial population {args.init}; seeds 0..{args.runs - 1}; SPSO's units (pixels "
        "horizontally, metres vertically); threats hard zones of R + 1; band 100-200 m above the "
        "ground along the whole path, 150 m preferred; no aircraft limits; 10 free nodes",
        args.no_record,
    )


if __name__ == "__main__":
    main()
