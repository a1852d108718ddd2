"""`terrapath replay`: re-fly a mission (or the mission inside an earlier run) with pop-up threats."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import click

from terrain.atomic import output_folder
from terrain.docfile import parse_yaml
from terrain.errors import DataFileError
from terrapath.options import (
    airspace_options,
    dem_tiles_option,
    output_option,
    seed_option,
    speed_option,
    vehicle_option,
    wind_from_options,
    wind_options,
)
from terrapath.progress import progress_bar
from terrapath.runtext import duration, failure_summary, metrics_rows, report_lines

EXIT_FAILED = 3  # the flight was recorded but is not a success (as `plan`'s infeasible)


def _software_version() -> str:
    from terrapath import __version__

    return __version__


def _options(items: tuple[str, ...]) -> dict[str, Any]:
    """``KEY=VALUE`` strings as avoider options; a value is read as a YAML scalar (a number,
    true/false, or text)."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, raw = item.partition("=")
        if not sep or not key.strip():
            raise click.BadParameter(f"expected KEY=VALUE; got {item!r}", param_hint="--avoid-opt")
        try:
            value = parse_yaml(raw, "--avoid-opt") if raw.strip() else raw
        except DataFileError:
            value = raw
        if isinstance(value, dict | list):
            value = raw
        out[key.strip().replace("-", "_")] = value
    return out


def _help_avoider(ctx: click.Context, param: click.Parameter, value: str | None) -> None:
    """``--help-avoider NAME``: the avoider's options with their defaults, then exit."""
    if value is None or ctx.resilient_parsing:
        return
    import inspect

    from replay.avoidance.registry import (
        avoider_class,
        avoider_entry,
        avoider_names,
        avoider_options,
        avoider_plugin,
    )

    if value not in avoider_names():
        raise click.BadParameter(
            f"unknown avoider {value!r}; available: {', '.join(avoider_names())}",
            param_hint="--help-avoider",
        )
    plugin = avoider_plugin(value)
    given = "" if plugin.builtin else f" ({plugin.origin})"
    click.echo(f"{value}: {avoider_entry(value).summary}{given}")
    opts = avoider_options(value)
    if not opts:
        click.echo("  no options")
    meaning = getattr(avoider_class(value), "OPTION_HELP", {})
    width = max(len(k) for k in opts) if opts else 0
    for k, default in opts.items():
        shown = "(required)" if default is inspect.Parameter.empty else repr(default)
        text = f"  --avoid-opt {k + '=...':<{width + 4}}  default {shown}"
        click.echo(f"{text}: {meaning[k]}" if k in meaning else text)
    ctx.exit(0)


@click.command("replay")
@click.argument("source", type=click.Path(dir_okay=False, exists=False))
@click.option(
    "--threats",
    type=click.Path(dir_okay=False),
    default=None,
    help="Pop-up threats (YAML, or GeoJSON buildings). For an .mcap source, default: the threats "
    "of that run.",
)
@click.option(
    "--avoid",
    default="none",
    show_default=True,
    help="Avoidance algorithm: none (keep the mission), pso-ca (seed 000: waypoint re-planning), "
    "ctga (seed 001: circular trajectories), fga (seed 004: collision cones, critical start), "
    "priority (seed 003: rangefinder priority loop, multirotor) or one an installed package "
    "gives (terrapath plugins); --help-avoider NAME lists an avoider's options.",
)
@click.option(
    "--avoid-opt",
    "avoid_opts",
    multiple=True,
    metavar="KEY=VALUE",
    help="An option of the avoider (repeatable), e.g. --avoid-opt optimizer=ga --avoid-opt rs=1500.",
)
@click.option(
    "--help-avoider",
    metavar="NAME",
    callback=_help_avoider,
    expose_value=False,
    is_eager=True,
    help="List the options of avoider NAME with their defaults, and exit.",
)
@click.option(
    "--ca-optimizer",
    default=None,
    metavar="NAME",
    help="pso-ca: optimiser of the new waypoint: pso, ga, sa, mafoa, gcpso, mpso (seed 000 §6; "
    "default pso, Table 2) or one an installed package gives (terrapath plugins); same as "
    "--avoid-opt optimizer=NAME.",
)
@click.option(
    "--ca-safety-radius",
    type=float,
    default=None,
    help="pso-ca: safety radius RS kept from stationary obstacles (m; default seed 000's 1000 "
    "scaled to the map, at least the turn radius: --help-avoider pso-ca). The radar sees a static "
    "sphere as its centre: set it to at least the radius of your threats.",
)
@click.option(
    "--ca-moving-radius",
    type=float,
    default=None,
    help="pso-ca: safety radius around a moving intruder (m; default seed 000's 2000 scaled to the "
    "map, at least two turn radii).",
)
@click.option(
    "--ca-mxrsk",
    type=float,
    default=None,
    help="pso-ca: maximal risk distance MXRSK of the f2 term (m; default 3 RS, our choice: the "
    "paper gives none).",
)
@click.option(
    "--ca-paper",
    is_flag=True,
    help="pso-ca: seed 000's decision logic only -- straight legs (no cut corners), no rescue "
    "grid, narrower gap or skipped waypoint when the paper's search fails, and seed 000's distances "
    "whatever the map and vehicle (to reproduce the paper).",
)
@vehicle_option(
    "Vehicle preset (fixed-wing or multirotor) or file (default: the mission's; for an .mcap "
    "source, the vehicle that run flew)."
)
@dem_tiles_option(
    "DEM tile to fly over instead of the mission's (repeat for several tiles; the "
    "mission's cell size is kept; required for a .plan, .waypoints, GeoJSON or KML mission). "
    "Default: the mission's tiles, looked for beside the mission (or the .mcap), then as "
    "written."
)
@seed_option("Random seed (radar noise, avoiders); recorded in the MCAP.")
@click.option(
    "--duration",
    type=click.FloatRange(min=0.0, min_open=True),
    default=None,
    help="Time limit in simulated seconds (default: 1.5 x the planned flight time + 10 min).",
)
@click.option(
    "--log-rate",
    type=click.FloatRange(min=0.0, min_open=True),
    default=10.0,
    show_default=True,
    help="State log rate in the MCAP (Hz).",
)
@click.option(
    "--radar-range",
    type=click.FloatRange(min=0.0, min_open=True),
    default=10_000.0,
    show_default=True,
    help="Radar range (m).",
)
@click.option(
    "--radar-noise",
    "radar_noise_range",
    type=click.FloatRange(min=0.0),
    default=0.0,
    show_default=True,
    help="Radar range noise, 1 sigma (m).",
)
@click.option(
    "--sensor",
    type=click.Choice(["radar", "cooperative", "rangefinder"]),
    default=None,
    help="What the avoider sees: radar (seed 000: returns in range and line of sight, terrain "
    "too), cooperative (ADS-B-like: every threat in range reports its true position, "
    "velocity and size, with --coop-noise and --coop-latency) or rangefinder (seed 003: beams "
    "by ray casting at 10 Hz, with the --rangefinder-* options). Default: the avoider's only "
    "sensor if it works with one alone (--avoid priority: rangefinder), else radar.",
)
@click.option(
    "--rangefinder-range",
    type=click.FloatRange(min=0.0, min_open=True),
    default=20.0,
    show_default=True,
    help="Rangefinder range R (m).",
)
@click.option(
    "--rangefinder-beams",
    type=click.IntRange(min=1),
    default=4,
    show_default=True,
    help="Rangefinder beams, evenly spaced from the front (4: front, right, back, left).",
)
@click.option(
    "--rangefinder-mount",
    type=click.Choice(["gimballed", "body"]),
    default="gimballed",
    show_default=True,
    help="Rangefinder beams held level at the heading (gimballed) or fixed in the body, "
    "tilting with roll and pitch (body).",
)
@click.option(
    "--rangefinder-noise",
    type=click.FloatRange(min=0.0),
    default=0.0,
    show_default=True,
    help="Rangefinder range noise, 1 sigma (m).",
)
@click.option(
    "--rangefinder-spread",
    type=click.FloatRange(min=0.0, max=45.0, max_open=True),
    default=None,
    help="Half-angle of each beam's cone (deg; rays on its axis and rim, the nearest hit "
    "counts).  Default: the priority loop's atan(tau / (R - tau)), else 0 (a line).",
)
@click.option(
    "--coop-noise",
    type=(click.FloatRange(min=0.0), click.FloatRange(min=0.0)),
    default=(0.0, 0.0),
    metavar="POS VEL",
    help="Cooperative sensor: 1-sigma noise of the reported position (m) and velocity (m/s).",
)
@click.option(
    "--coop-latency",
    type=click.FloatRange(min=0.0),
    default=0.0,
    help="Cooperative sensor: age of the reports (s).",
)
@click.option(
    "--margin",
    type=click.FloatRange(min=0.0),
    default=0.0,
    show_default=True,
    help="Success needs every threat's and zone's separation (distance from its surface) to "
    "stay >= this many metres (e.g. FGA's d_m, CTGA's R_safe); reported with the metrics.",
)
@click.option(
    "--allow-unknown-terrain",
    is_flag=True,
    help="Accept time over terrain the DEM did not measure (filled nodata, outside the source "
    "raster); by default it is a failure (unknown_terrain), like the map's edge.",
)
@click.option(
    "--vertical-tolerance",
    type=click.FloatRange(min=0.0, min_open=True),
    default=None,
    help="Success needs the altitude within this many metres of the autopilot's altitude "
    "command along the plan (default: the larger of 30 m and half the planned clearance).",
)
@click.option(
    "--lateral-tolerance",
    type=click.FloatRange(min=0.0, min_open=True),
    default=None,
    help="Success needs the track within this many metres of the path it is meant to fly (the "
    "legs and their turn fillets, or an avoider's orbit, held course or held position; "
    "default: the larger of 50 m and a quarter of the turn radius).",
)
@click.option(
    "--return-time",
    type=click.FloatRange(min=0.0, min_open=True),
    default=None,
    help="Seconds the aircraft has to get back within the tolerances after an avoider's "
    "manoeuvre or new plan (or a leg change that is not a turn fillet); still off then: "
    "not_back_on_plan (default: the longer of 60 s and two corner distances of flight).",
)
@click.option(
    "--temperature-offset",
    type=click.FloatRange(min=-50.0, max=50.0),
    default=0.0,
    show_default=True,
    help="The day's temperature offset from the ISA standard atmosphere (K; a hot day > 0: "
    "thinner air, less lift and thrust). The air's density at the aircraft's altitude comes "
    "from the standard atmosphere.",
)
@airspace_options
@wind_options
@speed_option(
    "True airspeed to fly at, all the way (m/s; a multirotor's horizontal speed). Default: the "
    "mission's cruise speed and its speed changes; for a mission of another tool, the "
    "vehicle's own.",
    dest="airspeed",
)
@click.option(
    "--terrain-following",
    type=click.FloatRange(min=0.0),
    default=None,
    help="Keep at least this clearance (m) above the terrain ahead (default: the clearance the mission was planned with, when it has terrain; 0: off).",
)
@click.option(
    "--fly-anyway",
    is_flag=True,
    help="Fly a mission the vehicle cannot fly (above its ceiling, a leg steeper than it climbs, "
    "a turn radius tighter than it turns) instead of refusing it: each problem is a warning, "
    "and the flight is judged as any other (it fails, exit 3, where it does not fly the mission).",
)
@click.option("--no-terrain-mesh", is_flag=True, help="Do not store the terrain mesh in the MCAP.")
@click.option(
    "--no-picture",
    is_flag=True,
    help="Do not write RUN.png beside the MCAP (plan view with the planned and flown tracks, "
    "threats and decisions; separation to each threat and height above the terrain against time).",
)
@output_option("MCAP file to write.")
@click.option("--json", "as_json", is_flag=True, help="Print the metrics as JSON.")
def replay_cmd(
    source: str,
    avoid: str,
    avoid_opts: tuple[str, ...],
    dem_tiles: tuple[str, ...],
    airspace: tuple[str, ...],
    start_time: str | None,
    wind_text: str | None,
    wind_profile: str,
    turbulence: str | None,
    wind_file: str | None,
    coop_noise: tuple[float, float],
    no_terrain_mesh: bool,
    no_picture: bool,
    output: str,
    as_json: bool,
    **settings: Any,
) -> int:
    """Re-fly SOURCE (a mission YAML, an earlier run's .mcap, or a mission of another tool:
    a QGroundControl .plan, a MAVLink .waypoints file, a GeoJSON or KML path -- these need
    --dem) in the 6-DOF simulation, with pop-up threats, and record everything as MCAP for
    Foxglove.

    Before take-off it prints what the vehicle can do on the mission (its ceiling at the cruise
    speed, its climb at the highest waypoint) and refuses a mission it cannot fly: above that
    ceiling, a leg climbing or descending faster than it can, a cruise.turn_radius tighter than
    it turns (--fly-anyway flies it, and judges what it flew).

    Exit status: 0 success (the goal reached and the mission flown: no safety volume entered,
    no terrain contact on the measured heights, over known terrain on the map, no stall, the
    track within the tolerances of the plan), 3 the flight failed (still recorded; each failure
    named), 1 error (a refused mission among them)."""
    from replay.avoidance.registry import sensor_for
    from replay.run import ReplayRequest, prepare_replay, run_replay
    from terrain.airspace import parse_start

    _check_output(source, output)
    settings["sensor"] = sensor_for((avoid,), settings["sensor"], where="--sensor")
    options = {**_ca_options(avoid, settings), **_options(avoid_opts)}
    # the other options are named after the request's fields and the replay settings'
    request = ReplayRequest.of(
        source,
        avoid=avoid,
        avoid_options=options,
        dem=tuple(dem_tiles),
        airspace=tuple(airspace),
        start_time=parse_start(start_time) if start_time else None,
        coop_noise_position=coop_noise[0],
        coop_noise_velocity=coop_noise[1],
        wind=wind_from_options(wind_text, wind_profile, wind_file, turbulence),
        terrain_mesh=not no_terrain_mesh,
        command="terrapath " + " ".join(sys.argv[1:]) if sys.argv else "terrapath replay",
        software_version=_software_version(),
        **settings,
    )
    prepared = prepare_replay(request)  # every input error surfaces before anything is written
    for warning in prepared.warnings:
        click.echo(f"terrapath: warning: {warning}", err=True)
    if not as_json:  # before take-off: what the vehicle can do on this mission
        click.echo(prepared.preflight.describe())
    with progress_bar(int(prepared.time_limit), "replay (simulated s)") as report:
        progress = None
        if report is not None:

            def progress(t: float, total: float) -> None:
                report(int(t), None)

        result = run_replay(prepared, output, progress=progress)
    picture = None
    if not no_picture:  # drawn from the replay in memory, not read back from the MCAP
        from replay.record.picture import draw_run, replay_view

        view = replay_view(prepared, result, Path(output).name)
        picture = draw_run(view, Path(output).with_suffix(".png"))
    _report(result, output, as_json, picture)
    return _verdict(result.metrics, output)


def _check_output(source: str, output: str) -> None:
    if not output.lower().endswith(".mcap"):
        raise click.BadParameter(
            f"the output must end in .mcap; got {output!r}", param_hint="-o/--output"
        )
    if Path(output).resolve() == Path(source).resolve():
        raise click.BadParameter(
            f"{output!r} is the run being re-flown; write the new run to another file",
            param_hint="-o/--output",
        )
    output_folder(output, create=False)  # made when the recording starts, before the flight


def _ca_options(avoid: str, settings: dict[str, Any]) -> dict[str, Any]:
    """PSO-CA's options given by the ``--ca-*`` shortcuts (taken out of ``settings``)."""
    ca = {
        "optimizer": settings.pop("ca_optimizer"),
        "rs": settings.pop("ca_safety_radius"),
        "moving_rs": settings.pop("ca_moving_radius"),
        "mxrsk": settings.pop("ca_mxrsk"),
    }
    ca = {k: v for k, v in ca.items() if v is not None}
    if settings.pop("ca_paper"):
        ca.update(rescue=False, narrow=False, max_skip=0, corners=False, scale=False)
    if ca and avoid != "pso-ca":
        raise click.UsageError("the --ca-* options apply to --avoid pso-ca only")
    return ca


def _verdict(m: Any, output: str) -> int:
    """0 for a success; else say why the flight failed (each failure is listed above), and
    EXIT_FAILED."""
    if m.success:
        return 0
    reasons = failure_summary(m.as_dict())
    click.echo(
        f"terrapath: replay failed: {', '.join(reasons) or 'not a success'} "
        f"(the run is recorded in {output})",
        err=True,
    )
    return EXIT_FAILED


def _report(result: Any, output: str, as_json: bool, picture: Path | None = None) -> None:
    m = result.metrics
    if as_json:
        click.echo(
            json.dumps(
                {
                    "output": output,
                    "picture": None if picture is None else str(picture),
                    "seed": result.seed,
                    "wall_s": result.wall_s,
                    "metrics": m.as_dict(),
                    "final_waypoints": result.waypoints.tolist(),
                },
                indent=2,
            )
        )
        return
    metrics = m.as_dict()
    for line in report_lines(metrics_rows(metrics), metrics):
        click.echo(line)
    click.echo(
        f"\nwrote {output} (simulated {duration(m.flight_time_s)} in {result.wall_s:.1f} s of "
        "wall-clock time)"
    )
    if picture is not None:
        click.echo(f"wrote {picture} (plan view, separations and height above the terrain)")
    click.echo(
        f"see it: terrapath view {output} -o view.html (any browser), or in Foxglove "
        "(Open local file; the panels: terrapath layout -o layout.json, Layouts -> Import)"
    )
