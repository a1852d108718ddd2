"""`terrapath plan`: DEM tiles + start/goal (+ danger zones) in, a mission and its exports out."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click
import numpy as np

from terrapath.options import dem_options, load_grid
from terrapath.progress import progress_bar

EXIT_INFEASIBLE = 3
DEFAULT_CRUISE_AGL = 150.0


def _parse_point(ctx: click.Context, param: click.Parameter, value: str) -> tuple[float, ...]:
    try:
        parts = tuple(float(v) for v in value.split(","))
    except ValueError:
        parts = ()
    if len(parts) not in (2, 3) or not all(np.isfinite(parts)):
        raise click.BadParameter(
            f"expected A,B or A,B,ALT (numbers: lon,lat or x,y with --map-coords); got {value!r}"
        )
    return parts


def _resolve(
    grid: Any, point: tuple[float, ...], map_coords: bool, agl: float, name: str
) -> np.ndarray:
    """Map metres and altitude AMSL of a point given as lon/lat or x/y, ALT AMSL or default AGL."""
    a, b = point[0], point[1]
    if map_coords:
        x, y = a, b
    else:
        if not (-180.0 <= a <= 360.0 and -90.0 <= b <= 90.0):
            raise click.BadParameter(
                f"{name} {a},{b} is not lon,lat in degrees (use --map-coords for map metres)"
            )
        xa, ya = grid.from_lonlat(a, b)
        x, y = float(xa), float(ya)
    if len(point) == 3:
        z = point[2]
    else:
        z = float(grid.height_at(x, y)) + agl if bool(grid.contains(x, y)) else agl
    return np.array([x, y, z])


def _run_with_progress(
    plan: Any,
    problem: Any,
    algorithm: str,
    seed: int,
    population: int,
    iterations: int,
    attempts: int,
) -> Any:
    """Run the planner with a progress bar (iteration, best cost) on an interactive terminal."""
    with progress_bar(iterations, f"{algorithm}: planning") as report:
        callback = None
        if report is not None:

            def callback(state: Any) -> None:
                report(int(state.iteration), f"{algorithm}: best cost {float(state.best_f):.4f}")

        return plan(
            problem,
            algorithm,
            seed=seed,
            population=population,
            iterations=iterations,
            attempts=attempts,
            callback=callback,
        )


@click.command("plan")
@dem_options
@click.option(
    "--start",
    required=True,
    callback=_parse_point,
    metavar="LON,LAT[,ALT]",
    help="Start; ALT in metres AMSL (default: --cruise-agl above the ground).",
)
@click.option(
    "--goal",
    required=True,
    callback=_parse_point,
    metavar="LON,LAT[,ALT]",
    help="Goal, as --start.",
)
@click.option(
    "--map-coords", is_flag=True, help="--start/--goal are map metres X,Y[,ALT] instead of lon/lat."
)
@click.option(
    "--zones", type=click.Path(dir_okay=False), default=None, help="Danger zones: YAML or GeoJSON."
)
@click.option(
    "--algorithm",
    type=click.Choice(["ampso", "pso", "apso", "ga"]),
    default="ampso",
    show_default=True,
    help="ampso: PSO with adaptive mutation (seed 002); apso: adaptive-parameter PSO; ga: real-coded GA.",
)
@click.option(
    "--waypoints",
    "n_waypoints",
    type=int,
    default=6,
    show_default=True,
    help="Number of free waypoints N.",
)
@click.option("--population", type=int, default=60, show_default=True)
@click.option("--iterations", type=int, default=200, show_default=True)
@click.option(
    "--attempts",
    type=int,
    default=3,
    show_default=True,
    help="Restart from derived seeds while the result is infeasible (1: a single run).",
)
@click.option(
    "--seed", type=int, default=0, show_default=True, help="Random seed (recorded in the mission)."
)
@click.option(
    "--clearance",
    type=float,
    default=50.0,
    show_default=True,
    help="Minimum terrain clearance (m) for feasibility (0: the path may touch the ground).",
)
@click.option(
    "--zmin",
    type=float,
    default=None,
    help="Lowest waypoint altitude (m AMSL); default just below the lowest terrain.",
)
@click.option(
    "--zmax",
    type=float,
    default=None,
    help="Highest waypoint altitude (m AMSL); default just above the highest terrain.",
)
@click.option(
    "--avoid-zones", is_flag=True, help="A path inside any danger zone counts as infeasible."
)
@click.option(
    "--strict",
    is_flag=True,
    help="Refuse (instead of warning) a start or goal inside a danger zone.",
)
@click.option(
    "--cruise-agl",
    type=float,
    default=DEFAULT_CRUISE_AGL,
    show_default=True,
    help="Default start/goal height above ground (m).",
)
@click.option(
    "--speed",
    type=float,
    default=25.0,
    show_default=True,
    help="Cruise speed written to the mission (m/s).",
)
@click.option(
    "--vehicle",
    default="aerosonde",
    show_default=True,
    help="Vehicle preset or file written to the mission.",
)
@click.option(
    "--alt-frame",
    type=click.Choice(["amsl", "relative"]),
    default="amsl",
    show_default=True,
    help="Altitude frame of the .plan and WPL exports (relative = above home).",
)
@click.option("--name", default=None, help="Mission name (default: the output file's stem).")
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(dir_okay=False),
    help="Mission YAML to write; exports go beside it.",
)
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def plan_cmd(
    dem: tuple[str, ...],
    start: tuple[float, ...],
    goal: tuple[float, ...],
    map_coords: bool,
    zones: str | None,
    algorithm: str,
    n_waypoints: int,
    population: int,
    iterations: int,
    attempts: int,
    seed: int,
    clearance: float,
    zmin: float | None,
    zmax: float | None,
    avoid_zones: bool,
    strict: bool,
    cruise_agl: float,
    speed: float,
    vehicle: str,
    alt_frame: str,
    name: str | None,
    output: str,
    as_json: bool,
    **opts: Any,
) -> int:
    """Plan a collision-free 3D path over real terrain and write the mission and its exports.

    Writes OUTPUT (mission YAML, the source of truth) and, beside it, .geojson (WGS84 LineString),
    .plan (QGroundControl), .waypoints (QGC WPL 110) and .png (map and altitude profile).
    Exit status: 0 feasible, 3 infeasible (still written, marked infeasible), 1 error.
    """
    import json

    from planner.export import to_geojson, to_qgc_plan, to_wpl, write_json, write_text
    from planner.mission import Mission, TerrainRef, grid_crs_label, save_mission
    from planner.plan import plan
    from planner.plot import save_plan_picture
    from planner.problem import PlanningProblem
    from terrain.zones import load_zones

    out = Path(output)
    if out.suffix.lower() not in (".yaml", ".yml"):
        raise click.BadParameter(
            f"the mission file must end in .yaml; got {output!r}", param_hint="-o/--output"
        )
    grid = load_grid(dem, **opts)
    s = _resolve(grid, start, map_coords, cruise_agl, "start")
    g = _resolve(grid, goal, map_coords, cruise_agl, "goal")
    zlist = load_zones(zones, grid) if zones else ()
    for label, p in (("start", s), ("goal", g)):
        for z in zlist:
            inside = (p[0] - z.x) ** 2 + (p[1] - z.y) ** 2 <= z.radius**2 and (
                z.top is None or p[2] <= z.top
            )
            if inside:
                msg = f"the {label} lies inside danger zone {z.id or ''} (centre {z.x:.0f}, {z.y:.0f}, diameter {z.diameter:g} m)"
                if strict:
                    raise click.UsageError(msg + "; refused because of --strict")
                click.echo(f"terrapath: warning: {msg}", err=True)
    problem = PlanningProblem(grid, s, g, n_waypoints, zlist, zmin, zmax, clearance, avoid_zones)

    result = _run_with_progress(plan, problem, algorithm, seed, population, iterations, attempts)

    provenance = {
        "algorithm": algorithm,
        "parameters": result.params,
        "seed": seed,
        "feasible": result.feasible,
        "status": result.status,
        "cost": result.terms,
        "iterations": result.iterations,
        "evaluations": result.evaluations,
        "stop_reason": result.stop_reason,
        "elapsed_s": round(result.elapsed_s, 3),
        "n_waypoints": n_waypoints,
        "clearance": clearance,
        "altitude_band": list(problem.band),
        "avoid_zones": avoid_zones,
        "violations": [v.as_dict() for v in result.violations],
    }
    mission = Mission(
        name=name or out.stem,
        waypoints=result.waypoints,
        crs=grid_crs_label(grid),
        terrain=TerrainRef(tuple(str(Path(d).resolve()) for d in dem), opts.get("cell_size")),
        vehicle=vehicle,
        cruise_speed=speed,
        cruise_altitude=round(float(np.mean(result.waypoints[:, 2])), 1),
        danger_zones=tuple(zlist),
        plan=provenance,
    )
    written = {"mission": save_mission(mission, out, grid)}
    stem = out.with_suffix("")
    if grid.is_georeferenced:
        written["geojson"] = write_json(to_geojson(mission, grid), stem.with_suffix(".geojson"))
        written["qgc_plan"] = write_json(
            to_qgc_plan(mission, grid, alt_frame), stem.with_suffix(".plan")
        )
        written["wpl"] = write_text(
            to_wpl(mission, grid, alt_frame), stem.with_suffix(".waypoints")
        )
    written["picture"] = save_plan_picture(
        grid,
        result.waypoints,
        stem.with_suffix(".png"),
        zlist,
        title=f"{mission.name}: {algorithm}, seed {seed} — {result.status}, cost {result.terms['total']:.4f}",
        clearance=clearance,
        feasible=result.feasible,
    )
    if as_json:
        click.echo(
            json.dumps(
                {
                    "status": result.status,
                    "cost": result.terms,
                    "outputs": {k: str(v) for k, v in written.items()},
                    "violations": provenance["violations"],
                    "seed": seed,
                },
                indent=2,
            )
        )
    else:
        t = result.terms
        click.echo(
            f"{result.status}: cost {t['total']:.4f} (length {t['length']:.4f}, altitude {t['altitude']:.4f}, "
            f"collision {t['collision']:.4f}, danger zones {t['dangerzones']:.4f}); "
            f"path {t['path_length_m'] / 1000:.2f} km, {result.iterations} iterations, {result.elapsed_s:.1f} s"
        )
        for k, v in written.items():
            click.echo(f"  {k:9s} {v}")
    if not result.feasible:
        click.echo(
            f"terrapath: infeasible: {result.violations[0].detail if result.violations else 'constraint violated'}"
            f"{f' (and {len(result.violations) - 1} more)' if len(result.violations) > 1 else ''}",
            err=True,
        )
        return EXIT_INFEASIBLE
    return 0
