"""The planning pipeline as one library call: DEM tiles, start, goal, zones and the aircraft in;
the plan and its files out. ``terrapath plan``, the benchmarks and the golden tests call it.

Steps of :func:`plan_mission`:

1. :func:`build_problem` loads the DEM (``terrain.load_dem`` with the DEM options), places start and
   goal (lon/lat or map metres; a missing altitude is ``cruise_agl`` above the highest terrain
   around the point, the terrain the planner checks), reads the danger zones and refuses input
   that cannot give a flyable plan (start = goal, a goal out of the aircraft's climb reach, turns
   too wide for the legs, a start or goal inside a zone with ``strict``);
2. :func:`planner.plan.plan` runs the optimiser with its restarts;
3. :func:`write_outputs` writes the mission YAML (the source of truth) and the picture, and —
   only for a feasible plan, or with ``force_export`` — the ground-station files (QGroundControl
   ``.plan``, ``QGC WPL 110``) and the GeoJSON. An infeasible plan removes ground-station files a
   previous run left under the same name, so nobody flies a stale one.

Everything is written to a temporary name and renamed when complete (``terrain.atomic``).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.energy import EnergyModel, mission_energy, shortfall
from planner.explore import ROUTES
from planner.launch import Landing, Takeoff
from planner.mission import Mission, TerrainRef, grid_crs_label, save_mission
from planner.performance import Performance, ground_speed
from planner.plan import DEFAULT_ALGORITHM, plan
from planner.problem import PlanningProblem, point_text, terrain_top
from planner.result import PlanResult, Violation, spiral_violation
from planner.spiral import respiral
from terrain.atomic import output_folder
from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrain.zones import DangerZone, Zone

FloatArray = npt.NDArray[np.float64]
DEFAULT_CRUISE_AGL = 150.0
TAKEOFF_TRIES = 3  # re-plans from a climb-out along the plan's first leg when the two do not join
GROUND_STATION_SUFFIXES = (".plan", ".waypoints")


@dataclass(frozen=True)
class PlanRequest:
    """Everything a plan is made from (what ``terrapath plan``'s options say).

    ``start`` / ``goal`` are (a, b) or (a, b, alt): lon/lat degrees, or map metres with
    ``map_coords``; alt is metres AMSL. ``dem_options`` are :func:`terrain.load.load_dem`'s keyword
    options (crs, cell_size, crop, crop_lonlat, band). ``zones`` is a danger-zone file (YAML or
    GeoJSON) or a list of zone records as in a mission's ``danger_zones:`` (lon/lat allowed). ``vehicle`` is what the mission records
    (a preset name or a vehicle file path); ``performance`` is that vehicle's limits.
    """

    dem: tuple[str, ...]
    start: tuple[float, ...]
    goal: tuple[float, ...]
    performance: Performance
    vehicle: str
    map_coords: bool = False
    # the vehicle's limits over the altitude band the plan may fly, (lowest, highest) m AMSL:
    # replaces ``performance`` once the map gives the band (VehicleParams.performance)
    performance_at: Callable[[float, float], Performance] | None = None
    dem_options: dict[str, Any] = field(default_factory=dict)
    zones: str | Sequence[dict[str, Any]] | None = None
    # airspace files (OpenAir, ED-269 JSON: terrain.airspace) whose zones join ``zones``, those
    # active during a flight from ``start_time`` (None: all of them)
    airspace: tuple[str, ...] = ()
    start_time: Any = None
    algorithm: str = DEFAULT_ALGORITHM
    n_waypoints: int = 6
    population: int = 60
    iterations: int = 200
    attempts: int = 3
    seed: int = 0
    init: str = "graph"  # the initial population (planner.plan.plan)
    routes: int = ROUTES  # with init "graph": the routes of the map search
    clearance: float = 50.0
    zmin: float | None = None
    zmax: float | None = None
    avoid_zones: bool = False
    strict: bool = False
    cruise_agl: float = DEFAULT_CRUISE_AGL
    allow_unknown: bool = False
    zone_margin: float = 25.0
    agl_min: float | None = None  # an above-ground band (planner.problem)
    agl_max: float | None = None
    agl_pref: float | None = None  # a preferred height above the ground
    smoothness: float = 0.0  # weight of the smoothness term
    name: str | None = None
    # take off from the start, a launch point on the ground (planner.launch): the plan starts
    # where the climb-out reaches the start height; ``takeoff_heading`` (deg) or the best one
    start_on_ground: bool = False
    takeoff_heading: float | None = None
    # land at the goal, a landing point on the ground: the plan ends at the approach fix, the
    # final approach descends from it (planner.launch); ``land_heading`` (deg) or the best one
    land: bool = False
    land_heading: float | None = None
    # the wind planned for (plan --wind): ``performance`` carries its strongest speed (the
    # gradients over the ground, the fillets' radius); ``wind_at(altitude, height)`` is the
    # air's (north, east) velocity m/s for the time per leg, ``wind_record`` what the mission
    # records of it
    wind_at: Callable[[float, float], tuple[float, float]] | None = None
    wind_record: dict[str, Any] | None = None
    # the vehicle's energy table over an altitude band (low, high) m AMSL with turns of a
    # radius (m; 0 none) (replay.flight.energy.energy_model): the plan reports the energy per
    # leg and the reserve
    energy_at: Callable[[float, float, float], EnergyModel] | None = None


def leg_times(
    waypoints: npt.ArrayLike,
    speed: float,
    wind_at: Callable[[float, float], tuple[float, float]] | None = None,
    ground: Callable[[float, float], float] | None = None,
) -> list[float]:
    """Seconds to fly each straight leg at airspeed ``speed``: its horizontal length over the
    ground speed along it -- the air's horizontal speed on the leg's gradient, crabbed into the
    cross wind, plus the along wind (``wind_at(altitude, height over the ground)`` at the leg's
    middle; still air without it)."""
    w = np.asarray(waypoints, dtype=np.float64)
    out = []
    for a, b in itertools.pairwise(w):
        d = b[:2] - a[:2]
        length = float(np.hypot(*d))
        if length <= 0.0:
            out.append(abs(float(b[2] - a[2])) / max(speed, 1e-9))
            continue
        horizontal = speed * math.cos(math.atan(abs(float(b[2] - a[2])) / length))
        over = horizontal
        if wind_at is not None:
            mid = 0.5 * (a + b)
            h = float(mid[2]) - (ground(float(mid[0]), float(mid[1])) if ground else 0.0)
            over = ground_speed(horizontal, wind_at(float(mid[2]), h), d / length)
        out.append(length / max(over, 1e-9))
    return out


@dataclass(frozen=True, eq=False)
class Prepared:
    """The loaded grid, the zones and the planning problem, with warnings for the user."""

    grid: HeightGrid
    zones: tuple[Zone, ...]
    problem: PlanningProblem
    warnings: tuple[str, ...]
    takeoff: Takeoff | None = None
    landing: Landing | None = None


# why a plan over a map without CRS has no ground-station files (they are in lon/lat)
NO_CRS_NOTE = (
    "no CRS: the map has no geographic reference (local metres), so no "
    ".geojson/.plan/.waypoints (lon/lat) were written; give the DEM its CRS (a GeoTIFF with "
    "one, or a .prj file beside it) to have them"
)


@dataclass(frozen=True, eq=False)
class PlanOutcome:
    """A finished plan: the result, the mission it became, the files written, the warnings and
    the notes (what was not written and why)."""

    result: PlanResult
    mission: Mission
    prepared: Prepared
    written: dict[str, Path]
    removed: tuple[Path, ...]
    warnings: tuple[str, ...]
    notes: tuple[str, ...] = ()

    @property
    def feasible(self) -> bool:
        return self.result.feasible


def _as_given(point: Sequence[float], map_coords: bool) -> str | None:
    """A start or goal as the user gave it, for messages: lon/lat, or None (map metres)."""
    return None if map_coords else f"lon {float(point[0]):.5f}, lat {float(point[1]):.5f}"


def _place(
    grid: HeightGrid,
    point: Sequence[float],
    name: str,
    map_coords: bool,
    agl: float,
    safety: HeightGrid,
) -> FloatArray:
    """Map metres and altitude AMSL of a start or goal as the user gave it."""
    a, b = float(point[0]), float(point[1])
    if map_coords:
        x, y = a, b
        if not bool(grid.contains(x, y)):
            xmin, ymin, xmax, ymax = grid.bounds
            raise InputError(
                f"{name} ({x:.1f}, {y:.1f}) lies outside the map "
                f"(x {xmin:.1f} .. {xmax:.1f}, y {ymin:.1f} .. {ymax:.1f} map metres)"
            )
    else:
        if not (-180.0 <= a <= 360.0 and -90.0 <= b <= 90.0):
            raise InputError(
                f"{name} {a},{b} is not lon,lat in degrees (use --map-coords for map metres)"
            )
        if grid.crs is None:
            xmin, ymin, xmax, ymax = grid.bounds
            raise InputError(
                f"{name} {a},{b} is lon,lat but the map has no CRS (a local grid in metres): "
                f"give --map-coords and the {name} in map metres X,Y "
                f"(x {xmin:.1f} .. {xmax:.1f}, y {ymin:.1f} .. {ymax:.1f})"
            )
        xa, ya = grid.from_lonlat(a, b)
        x, y = float(xa), float(ya)
        if not bool(grid.contains(x, y)):
            ll = grid.lonlat_bounds()
            extent = (
                f" (lon {ll[0]:.5f} .. {ll[2]:.5f}, lat {ll[1]:.5f} .. {ll[3]:.5f})" if ll else ""
            )
            raise InputError(f"{name} lon {a:.5f}, lat {b:.5f} lies outside the map{extent}")
    if len(point) >= 3:
        z = float(point[2])
    else:
        z = terrain_top(safety, x, y) + agl
    return np.array([x, y, z])


def _check_reach(problem: PlanningProblem, perf: Performance) -> None:
    """Refuse a mission the aircraft cannot fly whatever the path: a climb or descent between
    start and goal longer than the longest path the free waypoints can make, or turns wider than
    the legs of the shortest path."""
    s, g = problem.start, problem.goal
    span = float(np.hypot(*(g[:2] - s[:2])))
    rise = float(g[2] - s[2])
    xmin, ymin, xmax, ymax = problem.grid.bounds
    longest = (problem.n_waypoints + 1) * math.hypot(xmax - xmin, ymax - ymin)
    limit = perf.climb_gradient if rise > 0 else perf.descent_gradient
    if abs(rise) > limit * longest:
        verb = "climb" if rise > 0 else "descent"
        raise InputError(
            f"the goal is {abs(rise):.0f} m {'above' if rise > 0 else 'below'} the start: a "
            f"{verb} of {100 * abs(rise) / span:.1f} % over the {span / 1000:.2f} km between them; "
            f"the {perf.name} can {verb} {100 * limit:.1f} % at most, which needs "
            f"{abs(rise) / limit / 1000:.1f} km of path, more than {problem.n_waypoints} free "
            f"waypoints can make in this map ({longest / 1000:.1f} km)"
        )
    shortest_leg = span / (problem.n_waypoints + 1)
    if perf.turn_radius > 0.5 * shortest_leg:
        most = max(0, int(span / (2.0 * perf.turn_radius)) - 1)
        raise InputError(
            f"the {perf.name}'s turn radius ({perf.turn_radius:.0f} m at {perf.speed:g} m/s) is "
            f"larger than half the legs of the shortest path ({shortest_leg:.0f} m with "
            f"{problem.n_waypoints} free waypoints over {span / 1000:.2f} km); use at most "
            f"{most} waypoints (--waypoints) or a slower speed"
        )


def build_problem(request: PlanRequest) -> Prepared:
    """Load the DEM and zones and build the planning problem (step 1 of :func:`plan_mission`)."""
    from terrain.load import load_dem
    from terrain.zone_file import load_zones, zones_from_records

    r = request
    grid = load_dem(list(r.dem), **r.dem_options)
    safety = grid.safety()
    cruise = r.cruise_agl  # a start or goal without an altitude: inside an above-ground band
    if r.agl_pref is not None:
        cruise = r.agl_pref
    elif r.agl_max is not None:
        floor = max(r.clearance, r.agl_min or 0.0)
        cruise = min(cruise, 0.5 * (floor + r.agl_max))
    s = _place(grid, r.start, "start", r.map_coords, cruise, safety)
    g = _place(grid, r.goal, "goal", r.map_coords, cruise, safety)
    if isinstance(r.zones, str):
        zlist = load_zones(r.zones, grid)
    else:
        zlist = zones_from_records(list(r.zones or ()), grid, source="the plan request")
    airspace_notes: tuple[str, ...] = ()
    if r.airspace:
        from terrain.airspace import load_airspace

        air = load_airspace(r.airspace, grid, start=r.start_time)
        zlist = (*zlist, *air.zones)
        airspace_notes = air.notes
    takeoff = landing = None
    if r.start_on_ground:
        takeoff = _takeoff(r, grid, s, g, zlist, cruise)
        s = takeoff.start
    if r.land:
        landing = _landing(r, grid, g, s, zlist, cruise)
        g = landing.fix
    warnings: list[str] = list(airspace_notes)
    # the start and goal in messages as the user gave them (not a take-off's or landing's)
    named = (
        None if takeoff is not None else _as_given(r.start, r.map_coords),
        None if landing is not None else _as_given(r.goal, r.map_coords),
    )
    for label, p, given in (("start", s, named[0]), ("goal", g, named[1])):
        for z in zlist:
            if bool(np.asarray(z.contains(p[0], p[1], p[2])).any()):
                cx, cy = z.centroid
                what = f"diameter {z.diameter:g} m" if isinstance(z, DangerZone) else "a polygon"
                centre = f"{cx:.0f}, {cy:.0f}"
                if given is not None:  # the zone's centre in the units of the point too
                    lon, lat = grid.to_lonlat(cx, cy)
                    centre = f"lon {float(lon):.5f}, lat {float(lat):.5f}"
                msg = (
                    f"the {label} ({given or f'{p[0]:.1f}, {p[1]:.1f}'}) lies inside danger zone "
                    f"{z.id or ''} ({z.kind} centred at {centre}, {what})"
                )
                if r.strict:
                    raise InputError(msg + "; refused because of --strict")
                warnings.append(msg)
    problem = PlanningProblem(
        grid,
        s,
        g,
        r.n_waypoints,
        tuple(zlist),
        r.zmin,
        r.zmax,
        r.clearance,
        r.avoid_zones,
        performance=r.performance,
        allow_unknown=r.allow_unknown,
        zone_margin=r.zone_margin if r.avoid_zones else 0.0,
        agl_min=r.agl_min,
        agl_max=r.agl_max,
        agl_pref=r.agl_pref,
        smoothness=r.smoothness,
        # the turns from the climb-out onto the plan and from the plan onto the approach
        lead_in=_lead_in(takeoff),
        lead_out=(
            landing.touchdown if landing is not None and landing.heading_deg is not None else None
        ),
        named_ends=named,
    )
    if r.performance_at is not None:
        zmin, zmax = problem.band
        low = max(zmin, grid.zmin + r.clearance)
        problem = dataclasses.replace(problem, performance=r.performance_at(low, zmax))
    assert problem.performance is not None
    _check_reach(problem, problem.performance)
    return Prepared(grid, tuple(zlist), problem, tuple(warnings), takeoff, landing)


def _ground_point(
    r: PlanRequest, grid: HeightGrid, point: FloatArray, zones: Sequence[Zone], what: str, flag: str
) -> tuple[Performance, Any, Any]:
    """Checks of a launch or landing point on the ground: given without an altitude, over
    measured terrain, outside the zones; then the vehicle's limits over the map's altitudes,
    the validity check of a climb-out or approach (map, unknown terrain, zones) and the
    conservative terrain height ``top(x, y)``."""
    from planner.problem import unknown_mask_grid
    from terrain.validity import ValidityChecker

    given = r.start if what == "launch point" else r.goal
    if len(given) >= 3:
        raise InputError(
            f"{flag}: the {what} is on the ground; give it as lon,lat (or x,y) without an altitude"
        )
    x, y = float(point[0]), float(point[1])
    at = point_text(_as_given(given, r.map_coords), x, y)
    unknown = None if r.allow_unknown else unknown_mask_grid(grid)
    if unknown is not None and float(unknown.heights[unknown.cell_of(x, y)]) > 0:
        raise InputError(
            f"the {what} {at} lies over terrain the DEM did not measure: its "
            "ground height is not known (--allow-unknown-terrain accepts that)"
        )
    safety = grid.safety()
    for z in zones:
        if bool(np.asarray(z.contains(x, y, float(safety.height_at(x, y)) + 1.0)).any()):
            raise InputError(f"the {what} {at} lies inside danger zone {z.id or ''}")
    perf = r.performance
    if r.performance_at is not None:
        margin = r.clearance + max(50.0, 0.05 * (grid.zmax - grid.zmin))
        perf = r.performance_at(grid.zmin, grid.zmax + margin)
    checker = ValidityChecker(
        grid=grid,
        unknown=unknown,
        allow_unknown=r.allow_unknown,
        zones=tuple(zones) if r.avoid_zones else (),
        zone_margin=r.zone_margin if r.avoid_zones else 0.0,
    )
    return (
        perf,
        lambda pts: bool(checker.path(pts).valid.all()),
        lambda px, py: terrain_top(safety, px, py),
    )


def _takeoff(
    r: PlanRequest,
    grid: HeightGrid,
    launch: FloatArray,
    goal: FloatArray,
    zones: Sequence[Zone],
    cruise: float,
) -> Takeoff:
    """The take-off from the launch point ``launch`` (planner.launch)."""
    from planner.launch import plan_takeoff

    perf, fits, top = _ground_point(r, grid, launch, zones, "launch point", "--start-on-ground")
    return plan_takeoff(
        grid,
        (float(launch[0]), float(launch[1])),
        (float(goal[0]), float(goal[1])),
        perf,
        r.clearance,
        cruise,
        top,
        fits,
        r.takeoff_heading,
    )


def _landing(
    r: PlanRequest,
    grid: HeightGrid,
    touch: FloatArray,
    start: FloatArray,
    zones: Sequence[Zone],
    cruise: float,
) -> Landing:
    """The landing at the goal ``touch`` (planner.launch)."""
    from planner.launch import plan_landing

    perf, fits, top = _ground_point(r, grid, touch, zones, "landing point", "--land")
    return plan_landing(
        grid,
        (float(touch[0]), float(touch[1])),
        (float(start[0]), float(start[1])),
        perf,
        r.clearance,
        cruise,
        top,
        fits,
        r.land_heading,
    )


def _lead_in(takeoff: Takeoff | None) -> np.ndarray | None:
    """Where the take-off's last straight piece to the plan's start begins: the launch point,
    or above it where a spiral over the launch ends (None: a vertical take-off)."""
    if takeoff is None or takeoff.heading_deg is None:
        return None
    if takeoff.spiral is not None and takeoff.top is not None:
        return np.array([*takeoff.launch[:2], takeoff.top])
    return np.asarray(takeoff.launch, dtype=np.float64)


def _joined(request: PlanRequest, prepared: Prepared, result: PlanResult) -> str | None:
    """Why the take-off or landing does not join the plan (None: it does): the climb-out, the turn onto
    the plan's first leg and the spirals as the mission flies them (planner.spiral.flown_path)
    -- every turn fitting its legs, every piece within the gradients, and all but the climb-out
    and a final approach (each checked against its obstacle-clearance surface) clear for the
    validity layer."""
    from planner.flown import fillets
    from planner.spiral import flown_path, gradient_excess

    problem = prepared.problem
    perf = problem.performance
    if perf is None or perf.hover:
        return None
    mission = to_mission(request, prepared, result)  # with the launch and the touchdown
    w = np.asarray(mission.waypoints)
    excess = float(fillets(w[None], perf.turn_radius).turn_excess[0])
    if excess > 0:
        return (
            f"its climb-out and the plan's first leg turn more than a {perf.turn_radius:.0f} m "
            f"fillet fits ({excess:.0f} m too short)"
        )
    fp = flown_path(w, mission.spirals, perf.turn_radius, problem.chords)
    steep = np.flatnonzero(gradient_excess(fp, perf) > 0)
    if steep.size:
        i = int(steep[0])
        d = fp.points[i + 1] - fp.points[i]
        return (
            f"{fp.labels[i]} of the mission from the launch {'climbs' if d[2] > 0 else 'descends'} "
            f"at {100 * abs(d[2]) / max(float(np.hypot(d[0], d[1])), 1e-9):.1f} %, more steeply "
            "than the aircraft can"
        )
    climb_out = (fp.leg == 0) & fp.straight
    if prepared.takeoff is not None and prepared.takeoff.spiral is not None:
        climb_out |= fp.spiral == 0  # the spiral over the launch: its own surface
    if prepared.landing is not None:  # and the final approach: its own surface
        last = len(w) - 2
        climb_out |= (fp.leg == last) & fp.straight
    check = problem.validity.segments(fp.points[:-1], fp.points[1:])
    bad = np.flatnonzero(~check.valid & ~climb_out)
    if bad.size:
        k = int(bad[0])
        return f"{fp.labels[k]} is not clear of the terrain, the zones or the map"
    return None


def _explored(result: PlanResult) -> list[np.ndarray] | None:
    """The map search's seeds recorded in a result (None without one)."""
    ex = result.params.get("exploration")
    if not isinstance(ex, dict) or not ex.get("route_waypoints"):
        return None
    return [np.asarray(w, dtype=np.float64) for w in ex["route_waypoints"]]


def plan_request(
    request: PlanRequest,
    problem: PlanningProblem,
    callback: Callable[[Any], None] | None = None,
) -> PlanResult:
    """``problem`` (built from ``request``) planned with the request's algorithm, seed,
    population, iterations, attempts and initial population."""
    r = request
    return plan(
        problem,
        r.algorithm,
        seed=r.seed,
        population=r.population,
        iterations=r.iterations,
        attempts=r.attempts,
        init=r.init,
        routes=r.routes,
        callback=callback,
    )


def plan_mission(
    request: PlanRequest,
    output: str | Path | None = None,
    *,
    alt_frame: str = "amsl",
    force_export: bool = False,
    callback: Callable[[Any], None] | None = None,
) -> PlanOutcome:
    """Plan ``request``; with ``output`` (a ``.yaml`` path) write the mission and its files."""
    out = None
    if output is not None:
        out = Path(output)
        if out.suffix.lower() not in (".yaml", ".yml"):
            raise InputError(f"the mission file must end in .yaml; got {str(output)!r}")
        output_folder(out, create=False)  # made when the mission is written
    prepared = build_problem(request)
    r = request

    def run(prepared: Prepared) -> PlanResult:
        return plan_request(request, prepared.problem, callback)

    result = run(prepared)
    if (prepared.takeoff is not None or prepared.landing is not None) and result.feasible:
        why = _joined(request, prepared, result)
        tries = 0
        while (
            why is not None
            and prepared.takeoff is not None
            and r.takeoff_heading is None
            and tries < TAKEOFF_TRIES
        ):
            # climb out the way the plan goes on (straight, or spiralling up over the launch
            # first), and plan again from there
            tries += 1
            d = result.waypoints[1, :2] - result.waypoints[0, :2]
            heading = math.degrees(math.atan2(float(d[0]), float(d[1]))) % 360.0
            try:
                again = build_problem(dataclasses.replace(r, takeoff_heading=heading))
            except InputError as exc:
                why = f"{why}; a climb-out along the plan's first leg: {exc}"
                break
            result_again = run(again)
            if not result_again.feasible:
                break
            prepared, result = again, result_again
            request = dataclasses.replace(r, takeoff_heading=heading)
            why = _joined(request, prepared, result)
        if why is not None:
            result = dataclasses.replace(
                result,
                status="infeasible",
                violations=(
                    *result.violations,
                    spiral_violation(why, "joining the take-off and landing to the plan: "),
                ),
            )
    mission = to_mission(request, prepared, result, out)
    energy = mission.plan.get("energy")
    short_of = shortfall(energy) if isinstance(energy, dict) else None
    if result.feasible and short_of is not None:
        # a mission the aircraft cannot carry the energy for is not flyable
        g = mission.waypoints[-1]
        short = Violation(
            "energy",
            len(mission.waypoints) - 2,
            float(g[0]),
            float(g[1]),
            float(g[2]),
            0.0,
            short_of,
        )
        result = dataclasses.replace(
            result, status="infeasible", violations=(*result.violations, short)
        )
        mission = dataclasses.replace(
            mission,
            plan={
                **mission.plan,
                "feasible": False,
                "status": "infeasible",
                "violations": [v.as_dict() for v in result.violations],
            },
        )
    written: dict[str, Path] = {}
    removed: tuple[Path, ...] = ()
    warnings = list(prepared.warnings)
    notes: list[str] = []
    share = result.terms.get("over_unknown_share", 0.0)
    if share > 0:
        km = share * result.terms["path_length_m"] / 1000
        warnings.append(
            f"{100 * share:.1f} % of the path ({km:.2f} km) lies over terrain the DEM did not "
            "measure (--allow-unknown-terrain): its heights there are interpolated, not measured"
        )
    if out is not None:
        written, removed = write_outputs(
            mission, result, prepared, out, alt_frame=alt_frame, force_export=force_export
        )
        if force_export and not result.feasible:
            warnings.append(
                "ground-station files written for an INFEASIBLE plan (--force-export): "
                "do not fly them as they are"
            )
        if (result.feasible or force_export) and not prepared.grid.is_georeferenced:
            notes.append(NO_CRS_NOTE)
    return PlanOutcome(result, mission, prepared, written, removed, tuple(warnings), tuple(notes))


def to_mission(
    request: PlanRequest, prepared: Prepared, result: PlanResult, out: Path | None = None
) -> Mission:
    """The mission a plan becomes: waypoints, the vehicle, its cruise speed and turn radius (the
    replay flies the fillets the plan was checked with), zones and the plan's provenance."""
    r = request
    problem = prepared.problem
    perf = problem.performance or r.performance
    provenance = {
        "algorithm": r.algorithm,
        "parameters": result.params,
        "seed": int(r.seed),
        "feasible": result.feasible,
        "status": result.status,
        "cost": result.terms,
        "iterations": result.iterations,
        "evaluations": result.evaluations,
        "stop_reason": result.stop_reason,
        "elapsed_s": round(result.elapsed_s, 3),
        "n_waypoints": r.n_waypoints,
        "clearance": r.clearance,
        "altitude_band": list(problem.band),
        "avoid_zones": r.avoid_zones,
        "zone_margin": r.zone_margin if r.avoid_zones else 0.0,
        "init": r.init,
        **({"routes": r.routes} if r.init == "graph" else {}),
        **{
            k: v
            for k, v in (
                ("agl_min", r.agl_min),
                ("agl_max", r.agl_max),
                ("agl_pref", r.agl_pref),
                ("smoothness", r.smoothness or None),
            )
            if v is not None
        },
        "vehicle_limits": perf.as_dict(),
        "violations": [v.as_dict() for v in result.violations],
    }
    if r.wind_record is not None:
        provenance["wind"] = r.wind_record
    waypoints, spirals = result.waypoints, result.spirals
    to = prepared.takeoff
    if to is not None:
        # the launch point first: the take-off climbs from it to the plan's start (spiralling
        # over it first where no straight climb-out exists)
        provenance["takeoff"] = to.as_dict()
        launch = to.launch if to.spiral is None else np.array([*to.launch[:2], to.top])
        waypoints = np.vstack([launch[None, :], waypoints])
        spirals = tuple(dataclasses.replace(sp, at=sp.at + 1) for sp in spirals)
        if to.spiral is not None:
            spirals = (to.spiral, *spirals)
        limits = prepared.problem.performance
        if limits is not None and spirals:
            # the plan's start is a turn now: its spiral's helix changes (planner.spiral)
            spirals = respiral(waypoints, spirals, limits)
    if prepared.landing is not None:
        # the touchdown last: the final approach descends to it from the plan's goal, the fix
        provenance["landing"] = prepared.landing.as_dict()
        waypoints = np.vstack([waypoints, prepared.landing.touchdown[None, :]])
    if r.wind_at is not None:
        # the time of each leg over the ground in the wind (spirals not counted)
        grid = prepared.grid
        times = leg_times(
            waypoints, perf.speed, r.wind_at, lambda x, y: float(grid.height_at(x, y))
        )
        provenance["leg_times_s"] = [round(t, 1) for t in times]
    if r.energy_at is not None:
        # the energy per leg from the vehicle's performance model (planner.energy)
        grid = prepared.grid
        zs = waypoints[:, 2]
        radius = 0.0 if perf.hover else perf.turn_radius
        model = r.energy_at(float(zs.min()), float(zs.max()), radius)
        provenance["energy"] = mission_energy(
            waypoints,
            spirals,
            model,
            radius,
            hover=perf.hover,
            climb_rate=perf.climb_rate,
            descent_rate=perf.descent_rate,
            wind_at=r.wind_at,
            ground=lambda x, y: float(grid.height_at(x, y)),
        ).as_dict()
    return Mission(
        name=r.name or (out.stem if out is not None else "mission"),
        waypoints=waypoints,
        crs=grid_crs_label(prepared.grid),
        terrain=TerrainRef(
            tuple(str(Path(d).resolve()) for d in r.dem),
            r.dem_options.get("cell_size"),
            local_cell_size=r.dem_options.get("local_cell_size"),
        ),
        vehicle=r.vehicle,
        cruise_speed=perf.speed,
        cruise_altitude=round(float(np.mean(result.waypoints[:, 2])), 1),
        turn_radius=None if perf.hover else perf.turn_radius,  # a multirotor stops to turn
        danger_zones=prepared.zones,
        plan=provenance,
        spirals=spirals,
    )


def write_outputs(
    mission: Mission,
    result: PlanResult,
    prepared: Prepared,
    out: Path,
    *,
    alt_frame: str = "amsl",
    force_export: bool = False,
) -> tuple[dict[str, Path], tuple[Path, ...]]:
    """Write the mission YAML and picture; the GeoJSON and ground-station files only for a
    feasible plan or with ``force_export`` (stale ones of an earlier run are removed). Returns
    (files written by kind, files removed). The files go together: when one cannot be written
    (a full disk, an interrupt) the ones already written by this call are removed again, so no
    mission is left without its picture."""
    written: dict[str, Path] = {}
    try:
        removed = _write_outputs(mission, result, prepared, out, written, alt_frame, force_export)
    except BaseException:
        for path in written.values():
            path.unlink(missing_ok=True)
        raise
    return written, removed


def _write_outputs(
    mission: Mission,
    result: PlanResult,
    prepared: Prepared,
    out: Path,
    written: dict[str, Path],
    alt_frame: str,
    force_export: bool,
) -> tuple[Path, ...]:
    from planner.export import to_geojson, to_qgc_plan, to_wpl, write_json, write_text
    from planner.plot import save_plan_picture

    grid = prepared.grid
    written["mission"] = save_mission(mission, out, grid)
    stem = out.with_suffix("")
    removed: list[Path] = []
    export = result.feasible or force_export
    if grid.is_georeferenced and export:
        written["geojson"] = write_json(to_geojson(mission, grid), stem.with_suffix(".geojson"))
        written["qgc_plan"] = write_json(
            to_qgc_plan(mission, grid, alt_frame), stem.with_suffix(".plan")
        )
        written["wpl"] = write_text(
            to_wpl(mission, grid, alt_frame), stem.with_suffix(".waypoints")
        )
    elif not export:
        for suffix in (".geojson", *GROUND_STATION_SUFFIXES):
            stale = stem.with_suffix(suffix)
            if stale.is_file():
                stale.unlink()
                removed.append(stale)
    t = result.terms
    flown = result.path
    if prepared.takeoff is not None:  # the take-off from the launch point, then the plan
        flown = np.vstack([prepared.takeoff.path()[:-1], flown])
    if prepared.landing is not None:  # and the final approach
        flown = np.vstack([flown, prepared.landing.touchdown[None, :]])
    written["picture"] = save_plan_picture(
        grid,
        np.asarray(mission.waypoints),
        stem.with_suffix(".png"),
        prepared.zones,
        title=f"{mission.name}: {result.algorithm}, seed {result.seed} — "
        f"{result.status.upper() if not result.feasible else result.status}, "
        f"cost {t['total']:.4f}",
        clearance=prepared.problem.clearance,
        feasible=result.feasible,
        flown=flown,
        explored=_explored(result),
    )
    return tuple(removed)
