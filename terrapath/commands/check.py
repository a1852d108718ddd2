"""`terrapath check`: is this mission flyable here, by this aircraft? The report a pilot wants
before upload (issue 35): every leg and turn as flown against the measured terrain, the map,
unknown terrain, the zones, and the vehicle's climb, descent, ceiling and turns."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

from terrapath.options import airspace_options, dem_tiles_option, speed_option, vehicle_option

EXIT_INFEASIBLE = 3  # as `plan` and `replay`: the answer is "no", with the reasons


@click.command("check")
@click.argument("mission", type=click.Path(dir_okay=False))
@dem_tiles_option(
    "DEM tile the mission flies over (repeat for several; required for a .plan, .waypoints, "
    "GeoJSON or KML mission; default for a terrapath mission: its own tiles)."
)
@vehicle_option(
    "Vehicle preset or file (default: the mission's; for a mission of another tool, its kind "
    "of vehicle: quadrotor for a multirotor, else aerosonde)."
)
@speed_option(
    "True airspeed (m/s) the mission is flown at, all of it (default: the mission's cruise "
    "speed and its speed changes; for a mission of another tool, the vehicle's own)."
)
@click.option(
    "--clearance",
    type=click.FloatRange(min=0.0),
    default=None,
    help="Height above the measured terrain every leg and turn must keep (m; default: the "
    "clearance the mission was planned with, else 0: contact only, the margins reported).",
)
@airspace_options
@click.option(
    "--allow-unknown-terrain",
    is_flag=True,
    help="Accept flight over terrain the DEM did not measure (filled nodata).",
)
@click.option(
    "--temperature-offset",
    type=float,
    default=0.0,
    show_default=True,
    help="The day's temperature offset from ISA (K): thinner air on a hot day.",
)
@click.option(
    "--picture",
    type=click.Path(dir_okay=False),
    default=None,
    help="Where to write the picture (plan view and altitude profile with the violations "
    "marked; default: MISSION's stem + '-check.png' in the working directory).",
)
@click.option("--no-picture", is_flag=True, help="Do not draw the picture.")
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
def check_cmd(
    mission: str,
    dem_tiles: tuple[str, ...],
    vehicle: str | None,
    speed: float | None,
    clearance: float | None,
    airspace: tuple[str, ...],
    start_time: str | None,
    allow_unknown_terrain: bool,
    temperature_offset: float,
    picture: str | None,
    no_picture: bool,
    as_json: bool,
) -> int:
    """Check MISSION (a terrapath mission YAML, a QGroundControl .plan, a MAVLink .waypoints
    file, a GeoJSON or KML path) against the terrain and the vehicle before flying it: each leg
    and turn as the aircraft flies it (fillets, loiters, terrain-frame legs at their height
    above the ground) against the measured terrain with the clearance asked, the map edge,
    unknown terrain and the danger zones (a .plan's geofence too, and --airspace: OpenAir or
    ED-269 geozones, their AGL limits following the terrain); each leg's climb or descent
    against what the vehicle makes at that altitude (both gradients), the ceiling, the turn
    radius. Prints each leg's lowest clearance and the violations ranked, worst first; writes
    a picture.

    Exit status: 0 feasible, 3 not feasible (each violation named), 1 error."""
    from replay.preflight import feasibility
    from replay.source import mission_on_terrain
    from terrain.errors import InputError

    m, grid, params, _, _ = mission_on_terrain(mission, tuple(dem_tiles), vehicle, speed)
    if grid is None:
        raise InputError(
            f"{mission!r}: the mission names no terrain to check it against: give the DEM "
            "with --dem"
        )
    v = float(speed if speed is not None else m.cruise_speed)
    params.check_speed(v, "speed")
    asked = clearance if clearance is not None else float(m.plan.get("clearance", 0.0) or 0.0)
    extra: tuple[Any, ...] = ()
    notes: tuple[str, ...] = ()
    if airspace:
        from replay.sim import ReplayConfig, time_limit
        from terrain.airspace import load_airspace, parse_start

        start = parse_start(start_time) if start_time else None
        # the zones active while a replay of it may fly (its time limit)
        window = time_limit(m, ReplayConfig(airspeed=speed))
        air = load_airspace(airspace, grid, start=start, duration_s=window)
        extra, notes = air.zones, air.notes
    for note in notes:
        click.echo(f"terrapath: note: {note}", err=True)
    report = feasibility(
        m,
        grid,
        params,
        v,
        zones=extra,
        clearance=asked,
        changes=speed is None,  # --speed: one speed, the mission's changes set aside
        allow_unknown=allow_unknown_terrain,
        temperature_offset=temperature_offset,
    )
    out: Path | None = None
    if not no_picture:
        from planner.plot import save_check_picture

        out = Path(picture) if picture else Path(Path(mission).stem + "-check.png")
        title = f"{Path(mission).name}: {'feasible' if report.ok else 'NOT feasible'}"
        save_check_picture(grid, report.geometry, m.waypoints, report.findings, out, title,
                           asked, (*m.danger_zones, *extra))  # fmt: skip
    if as_json:
        doc: dict[str, Any] = report.as_dict()
        doc["picture"] = str(out) if out else None
        click.echo(json.dumps(doc, indent=2))
    else:
        for line in report.lines():
            click.echo(line)
        if out is not None:
            click.echo(f"picture   {out}")
    return 0 if report.ok else EXIT_INFEASIBLE
