"""`terrapath plan`: DEM tiles + start/goal (+ danger zones) in, a mission and its exports out."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
import numpy as np

from terrapath.options import (
    airspace_options,
    dem_options,
    output_option,
    refuse_overwriting,
    seed_option,
    steady_wind_options,
    vehicle_option,
    wind_from_options,
)
from terrapath.progress import progress_bar

if TYPE_CHECKING:
    from planner.performance import Performance
    from planner.pipeline import PlanOutcome
    from planner.result import PlanResult

EXIT_INFEASIBLE = 3
DEFAULT_CRUISE_AGL = 150.0  # as planner.pipeline.DEFAULT_CRUISE_AGL


def _parse_point(ctx: click.Context, param: click.Parameter, value: str) -> tuple[float, ...]:
    try:
        parts = tuple(float(v) for v in value.split(","))
    except ValueError:
        parts = ()
    if len(parts) not in (2, 3) or not all(np.isfinite(parts)):
        raise click.BadParameter(
            f"expected A,B or A,B,ALT (numbers: lon,lat or x,y with --map-coords); got {value!r}"
        )
    from planner.mission import ALTITUDES

    if len(parts) == 3 and not ALTITUDES[0] <= parts[2] <= ALTITUDES[1]:
        raise click.BadParameter(
            f"ALT must be metres AMSL in {ALTITUDES[0]:,.0f}..{ALTITUDES[1]:,.0f}; got {value!r}"
        )
    return parts


def _check_population(ctx: click.Context, param: click.Parameter, value: int) -> int:
    """The swarm's upper limit, refused before the map is read (the planner refuses < 2)."""
    from planner.plan import MAX_POPULATION

    if value > MAX_POPULATION:
        raise click.BadParameter(f"must be at most {MAX_POPULATION:,}; got {value:,}")
    return value


def _check_algorithm(ctx: click.Context, param: click.Parameter, value: str) -> str:
    """The planner's four or an installed optimiser, refused before the map is read (nothing of
    a plugin is imported here: only its entry point's name is read)."""
    from planner.plan import check_algorithm
    from terrain.errors import InputError

    try:
        check_algorithm(value)
    except InputError as exc:
        raise click.BadParameter(str(exc)) from None
    return value


def _extra_terms(t: dict[str, float]) -> str:
    """The optional terms of the cost that are in use (above-ground band, preferred height,
    smoothness), as the summary line prints the others."""
    names = (("above_band", "above band"), ("preferred_height", "preferred height"),
             ("smoothness", "smoothness"))  # fmt: skip
    return "".join(f", {label} {t[key]:.4f}" for key, label in names if t.get(key))


def _check_output(output: str) -> None:
    """The mission file is YAML."""
    if not output.lower().endswith((".yaml", ".yml")):
        raise click.BadParameter(
            f"the mission file must end in .yaml; got {output!r}", param_hint="-o/--output"
        )


def _vehicle_limits(
    vehicle: str, speed: float | None
) -> tuple[Performance, Callable[[float, float], Performance]]:
    """The vehicle's limits at the cruise speed (``speed``, default the vehicle's cruise speed,
    checked against its envelope): at sea level, and over an altitude band (low, high)."""
    from planner.performance import Performance
    from replay.flight.fixedwing.presets import load_any_vehicle
    from replay.flight.multirotor.model import MultirotorParams

    if speed is not None and not speed > 0:
        raise click.BadParameter(f"expected a speed > 0 m/s; got {speed:g}", param_hint="--speed")
    params = load_any_vehicle(vehicle, base_dir=Path.cwd())
    if isinstance(params, MultirotorParams):
        return _multirotor_limits(params, speed)
    v = params.cruise_speed if speed is None else float(speed)
    if not v >= params.airspeed_min:
        raise click.BadParameter(
            f"{v:g} m/s is below {params.name}'s slowest airspeed at any altitude "
            f"({params.airspeed_min:g} m/s, at sea level)",
            param_hint="--speed",
        )
    # the limits at sea level until the map gives the altitude band; then the true-airspeed
    # envelope over the band and the climb the aircraft makes at its top (VehicleParams)
    performance = Performance(
        params.name, v, params.climb_rate_max, params.descent_rate_max, params.bank_max_deg
    )
    return performance, lambda low, high: params.performance(v, (low, high))


def _energy_at(vehicle: str, speed: float | None) -> Any:
    """The vehicle's energy table at the plan's speed (:func:`replay.flight.energy.energy_model`)
    over an altitude band with turns of a radius: ``(low, high, radius) -> EnergyModel``."""
    from replay.flight.energy import energy_model
    from replay.flight.fixedwing.presets import load_any_vehicle

    params = load_any_vehicle(vehicle, base_dir=Path.cwd())
    v = params.cruise_speed if speed is None else float(speed)

    def at(low: float, high: float, radius: float) -> Any:
        return energy_model(params, v, (low, high), turn_radius=radius or math.inf)

    return at


def _in_wind(
    wind: Any, performance: Performance, at: Callable[[float, float], Performance]
) -> tuple[Performance, Callable[[float, float], Performance]]:
    """The limits for a plan in ``wind``: at the strongest wind over the altitude band (a
    profile's at 300 m over the ground), the gradients over the ground and the fillets' radius
    at the fastest ground speed (:attr:`Performance.wind`)."""
    from dataclasses import replace

    def strongest(low: float, high: float) -> float:
        return float(wind.strongest(low, high))

    first = replace(performance, wind=strongest(-500.0, 9000.0))
    return first, lambda low, high: replace(at(low, high), wind=strongest(low, high))


def _multirotor_limits(
    params: Any, speed: float | None
) -> tuple[Performance, Callable[[float, float], Performance]]:
    """A multirotor's limits: its horizontal speed (at most ``speed_max``), the climb and
    descent rates of its controller, hovering (any gradient, no fillets); the ceiling where it
    still climbs (replay.preflight.multirotor_ceiling)."""
    from replay.source import performance_of

    v = params.cruise_speed if speed is None else float(speed)
    if v > params.speed_max:
        raise click.BadParameter(
            f"{v:g} m/s is above {params.name}'s {params.speed_max:g} m/s (speed_max)",
            param_hint="--speed",
        )
    performance = performance_of(params, v)
    return performance, lambda low, high: performance


def _run_with_progress(request: Any, output: str, alt_frame: str, force_export: bool) -> Any:
    """Run the planning pipeline with a progress bar (iteration, best cost) on a terminal."""
    from planner.pipeline import plan_mission

    algorithm = request.algorithm
    with progress_bar(request.iterations, f"{algorithm}: planning") as report:
        callback = None
        if report is not None:

            def callback(state: Any) -> None:
                report(int(state.iteration), f"{algorithm}: best cost {float(state.best_f):.4f}")

        return plan_mission(
            request, output, alt_frame=alt_frame, force_export=force_export, callback=callback
        )


@click.command("plan")
@dem_options
@click.option(
    "--start",
    required=True,
    callback=_parse_point,
    metavar="LON,LAT[,ALT]",
    help="Start; ALT in metres AMSL (default: --cruise-agl above the highest terrain around "
    "the point).",
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
@airspace_options
@steady_wind_options
@click.option(
    "--algorithm",
    default="ampso",
    show_default=True,
    callback=_check_algorithm,
    help="ampso: PSO with adaptive mutation (seed 002); apso: adaptive-parameter PSO; ga: real-coded "
    "GA; pso; or an optimiser an installed package gives (terrapath plugins).",
)
@click.option(
    "--waypoints",
    "n_waypoints",
    type=int,
    default=6,
    show_default=True,
    help="Number of free waypoints N.",
)
@click.option(
    "--population",
    type=int,
    callback=_check_population,
    default=60,
    show_default=True,
    help="Swarm (or GA population) size, 2 to 100,000.",
)
@click.option("--iterations", type=int, default=200, show_default=True)
@click.option(
    "--attempts",
    type=int,
    default=3,
    show_default=True,
    help="Restart from derived seeds while the result is infeasible (1: a single run).",
)
@seed_option("Random seed (recorded in the mission).")
@click.option(
    "--init",
    type=click.Choice(["graph", "corridor", "uniform"]),
    default="graph",
    show_default=True,
    help="Initial population: graph (routes from a search of the whole map, with the waypoints "
    "placed along the best three, seed a quarter of it, the rest random corridor paths), "
    "corridor (random paths from start to goal) or uniform (uniform in the box: seed 002's "
    "protocol).",
)
@click.option(
    "--routes",
    type=int,
    default=5,
    show_default=True,
    help="With --init graph: how many distinct routes the map search seeds.",
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
    "--agl-min",
    type=float,
    default=None,
    help="Floor of an above-ground band (m): the path keeps at least this above the terrain "
    "(raises --clearance).",
)
@click.option(
    "--agl-max",
    type=float,
    default=None,
    help="Top of an above-ground band (m): a path more than this above the ground anywhere is "
    "infeasible.",
)
@click.option(
    "--agl-pref",
    type=float,
    default=None,
    help="Preferred height above the ground (m): the cost's altitude term becomes the mean "
    "distance from it (SPSO's) instead of the altitude itself.",
)
@click.option(
    "--smoothness",
    type=float,
    default=0.0,
    show_default=True,
    help="Weight of a smoothness term: the mean turn and climb-angle change at the waypoints, "
    "in units of pi (SPSO's J4; 0: off, as in seed 002).",
)
@click.option(
    "--avoid-zones", is_flag=True, help="A path inside any danger zone counts as infeasible."
)
@click.option(
    "--zone-margin",
    type=click.FloatRange(min=0.0),
    default=25.0,
    show_default=True,
    help="With --avoid-zones, keep the path this far (m) from every zone, sideways and above "
    "its top (the aircraft tracks the planned path within a few metres, not exactly).",
)
@click.option(
    "--strict",
    is_flag=True,
    help="Refuse (instead of warning) a start or goal inside a danger zone.",
)
@click.option(
    "--start-on-ground",
    is_flag=True,
    help="The start is a launch point on the ground (give it without an altitude): the plan "
    "begins with a take-off climbing straight out from it (a multirotor: straight up) to "
    "--cruise-agl above the terrain, checked against the terrain, the map and the zones.",
)
@click.option(
    "--takeoff-heading",
    type=click.FloatRange(min=0.0, max=360.0),
    default=None,
    help="With --start-on-ground: the fixed wing's climb-out heading (deg from north; default: "
    "the one that reaches a safe height soonest, towards the goal on a tie).",
)
@click.option(
    "--land",
    is_flag=True,
    help="The goal is a landing point on the ground (give it without an altitude): the plan "
    "ends at an approach fix and descends from it on a final approach at the glide gradient "
    "(the planned descent gradient, at most 6 deg; a multirotor: straight down), checked "
    "against the terrain; the landing point's ground may slope at most 10 %.",
)
@click.option(
    "--land-heading",
    type=click.FloatRange(min=0.0, max=360.0),
    default=None,
    help="With --land: the final approach's heading (deg from north, the direction flown; "
    "default: the one closest to the arrival that fits, then the shortest).",
)
@click.option(
    "--cruise-agl",
    type=float,
    default=DEFAULT_CRUISE_AGL,
    show_default=True,
    help="Default start/goal height (m) above the highest terrain around the point (its "
    "cell and the eight around it: the terrain the planner checks).",
)
@click.option(
    "--speed",
    type=float,
    default=None,
    help="Cruise true airspeed (m/s; default: the vehicle's cruise speed). It must lie in the "
    "vehicle's envelope (equivalent airspeed: its true speeds grow with height) over the whole "
    "altitude band; the plan keeps the descent and turn limits at this speed and the climb the "
    "aircraft makes at the top of the band.",
)
@vehicle_option(
    "Vehicle preset (fixed-wing or multirotor) or vehicle file: the plan is flyable by it, "
    "and the mission names it.",
    default="aerosonde",
)
@click.option(
    "--allow-unknown-terrain",
    is_flag=True,
    help="Accept a path over terrain the DEM did not measure (filled nodata, outside the "
    "source raster), with a warning; by default that is infeasible, like the map's edge.",
)
@click.option(
    "--force-export",
    is_flag=True,
    help="Write the .plan and .waypoints files even for an infeasible plan.",
)
@click.option(
    "--alt-frame",
    type=click.Choice(["amsl", "relative"]),
    default="amsl",
    show_default=True,
    help="Altitude frame of the .plan and WPL exports (relative = above home, the ground "
    "under the start where the aircraft arms).",
)
@click.option("--name", default=None, help="Mission name (default: the output file's stem).")
@output_option("Mission YAML to write; exports go beside it.")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def plan_cmd(
    dem: tuple[str, ...],
    start: tuple[float, ...],
    goal: tuple[float, ...],
    map_coords: bool,
    zones: str | None,
    airspace: tuple[str, ...],
    start_time: str | None,
    wind_text: str | None,
    wind_profile: str,
    wind_file: str | None,
    algorithm: str,
    n_waypoints: int,
    population: int,
    iterations: int,
    attempts: int,
    seed: int,
    init: str,
    routes: int,
    clearance: float,
    zmin: float | None,
    zmax: float | None,
    agl_min: float | None,
    agl_max: float | None,
    agl_pref: float | None,
    smoothness: float,
    avoid_zones: bool,
    zone_margin: float,
    strict: bool,
    start_on_ground: bool,
    takeoff_heading: float | None,
    land: bool,
    land_heading: float | None,
    cruise_agl: float,
    speed: float | None,
    vehicle: str,
    allow_unknown_terrain: bool,
    force_export: bool,
    alt_frame: str,
    name: str | None,
    output: str,
    as_json: bool,
    **opts: Any,
) -> int:
    """Plan a collision-free 3D path over real terrain, flyable by the vehicle, and write the
    mission and its exports.

    Writes OUTPUT (mission YAML, the source of truth) and, beside it, .png (map and altitude
    profile) and, for a feasible plan, .geojson (WGS84), .plan (QGroundControl) and .waypoints
    (QGC WPL 110). Exit status: 0 feasible, 3 infeasible (the mission and picture are written,
    marked infeasible; no ground-station files unless --force-export), 1 error.
    """
    from planner.pipeline import PlanRequest
    from terrain.airspace import parse_start

    _check_output(output)
    stem = Path(output).with_suffix("")
    refuse_overwriting(
        [output, *(stem.with_suffix(s) for s in (".png", ".geojson", ".plan", ".waypoints"))],
        {"DEM": dem, "--zones": [zones] if zones else [], "--vehicle": [vehicle]},
    )
    performance, performance_at = _vehicle_limits(vehicle, speed)
    wind = wind_from_options(wind_text, wind_profile, wind_file)
    wind_at, wind_record = None, None
    if wind is not None and not wind.calm:
        performance, performance_at = _in_wind(wind, performance, performance_at)
        wind_record = wind.to_dict()

        def wind_at(altitude: float, height: float) -> tuple[float, float]:
            v = wind.velocity(altitude, height)
            return float(v[0]), float(v[1])

    request = PlanRequest(
        dem=tuple(dem),
        start=start,
        goal=goal,
        performance=performance,
        performance_at=performance_at,
        energy_at=_energy_at(vehicle, speed),
        vehicle=vehicle,
        map_coords=map_coords,
        start_on_ground=start_on_ground,
        takeoff_heading=takeoff_heading,
        land=land,
        land_heading=land_heading,
        dem_options=opts,
        zones=zones,
        airspace=tuple(airspace),
        start_time=parse_start(start_time) if start_time else None,
        wind_at=wind_at,
        wind_record=wind_record,
        algorithm=algorithm,
        n_waypoints=n_waypoints,
        population=population,
        iterations=iterations,
        attempts=attempts,
        seed=seed,
        init=init,
        routes=routes,
        clearance=clearance,
        zmin=zmin,
        zmax=zmax,
        agl_min=agl_min,
        agl_max=agl_max,
        agl_pref=agl_pref,
        smoothness=smoothness,
        avoid_zones=avoid_zones,
        zone_margin=zone_margin,
        strict=strict,
        cruise_agl=cruise_agl,
        allow_unknown=allow_unknown_terrain,
        name=name,
    )
    outcome = _run_with_progress(request, output, alt_frame, force_export)
    for warning in outcome.warnings:
        click.echo(f"terrapath: warning: {warning}", err=True)
    for note in outcome.notes:
        click.echo(f"terrapath: note: {note}", err=True)
    if as_json:
        _echo_json(outcome, performance, seed)
    else:
        _echo_summary(outcome, performance)
    return _exit_status(outcome.result, force_export)


def _echo_json(outcome: PlanOutcome, performance: Performance, seed: int) -> None:
    """The result as JSON (--json)."""
    import json

    result = outcome.result
    click.echo(
        json.dumps(
            {
                "status": result.status,
                "cost": result.terms,
                "vehicle_limits": (outcome.prepared.problem.performance or performance).as_dict(),
                "outputs": {k: str(v) for k, v in outcome.written.items()},
                "removed": [str(p) for p in outcome.removed],
                "violations": [v.as_dict() for v in result.violations],
                "seed": int(seed),
            },
            indent=2,
        )
    )


def _echo_summary(outcome: PlanOutcome, performance: Performance) -> None:
    """The result as text: the cost and its terms, the limits, the exploration, the files."""
    result = outcome.result
    t = result.terms
    click.echo(
        f"{result.status}: cost {t['total']:.4f} (length {t['length']:.4f}, altitude "
        f"{t['altitude']:.4f}, collision {t['collision']:.4f}, danger zones "
        f"{t['dangerzones']:.4f}, climb {t['climb']:.4f}, turn {t['turn']:.4f}, unknown "
        f"terrain {t['unknown']:.4f}{_extra_terms(t)}); flown path "
        f"{t['path_length_m'] / 1000:.2f} km, min "
        f"clearance {t['min_clearance_m']:.0f} m, {result.iterations} iterations, "
        f"{result.elapsed_s:.1f} s"
    )
    # the limits the plan was held to: over the altitude band once the map gave it (the climb
    # at the band's top, as the violations state it), with the ceiling at the cruise speed
    enforced = outcome.prepared.problem.performance or performance
    click.echo(f"  limits    {enforced.describe()}")
    if result.spirals:
        turns = sum(s.turns for s in result.spirals)
        at = ", ".join(str(s.at) for s in result.spirals)
        bound = t.get("climb_bound_m", 0.0)
        click.echo(
            f"  spirals   {len(result.spirals)} ({turns} turns of {result.spirals[0].radius:.0f} m, "
            f"at waypoint {at}): the climb and descent need at least {bound / 1000:.2f} km of "
            f"path at the gradients; the path is {t.get('length_over_bound', 0.0):.2f} x that"
        )
    energy = outcome.mission.plan.get("energy")
    if isinstance(energy, dict):
        from planner.energy import describe

        click.echo(f"  energy    {describe(energy)}")
    times = outcome.mission.plan.get("leg_times_s")
    if times:
        per_leg = ", ".join(f"{v / 60:.1f}" for v in times)
        click.echo(
            f"  in wind   {sum(times) / 60:.1f} min over the ground at "
            f"{enforced.speed:g} m/s (legs: {per_leg} min)"
        )
    ex = result.params.get("exploration")
    if isinstance(ex, dict):
        click.echo(f"  explored  {explored_line(ex, result.params.get('routes'))}")
    for k, v in outcome.written.items():
        click.echo(f"  {k:9s} {v}")
    for p in outcome.removed:
        click.echo(f"  removed   {p} (from an earlier run: this plan is infeasible)")


def explored_line(ex: dict[str, Any], routes: object) -> str:
    """What the map search before the swarm did (a result's ``exploration``, ``--routes``)."""
    graphs = ex.get("graphs", 1)
    where = (
        f"on {graphs} graph{'s' if graphs != 1 else ''} of the whole map in {ex['seconds']:.2f} s"
    )
    if not ex["routes"]:
        return f"no route {where} (start and goal unlinked)"
    candidates = ex.get("candidates", ex["routes"])
    distinct = ex.get("distinct", ex["routes"])
    placed = ex.get("placed", 0)
    line = (
        f"{candidates} candidate route{'s' if candidates != 1 else ''} {where}, kept the "
        f"{distinct} best distinct" + (f" (--routes {routes})" if routes is not None else "")
    )
    if placed:
        line += f" and {placed} placements of the waypoints along the best of them"
    seeds = ex["routes"]
    return (
        f"{line}: {seeds} seed{'s' if seeds != 1 else ''} for the swarm, the best at cost "
        f"{ex['route_F'][0]:.4f}"
    )


def _exit_status(result: PlanResult, force_export: bool) -> int:
    """0 for a feasible plan; for an infeasible one, say why on stderr and return 3."""
    if not result.feasible:
        first = result.violations[0].detail if result.violations else "constraint violated"
        more = len(result.violations) - 1
        click.echo(
            f"terrapath: infeasible: {first}{f' (and {more} more)' if more > 0 else ''}",
            err=True,
        )
        if not force_export:
            click.echo(
                "terrapath: no .plan/.waypoints written for an infeasible plan "
                "(--force-export writes them anyway)",
                err=True,
            )
        return EXIT_INFEASIBLE
    return 0
