"""`terrapath replay`: re-fly a mission (or the mission inside an earlier run) with pop-up threats."""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import click
import numpy as np
import yaml

from terrain.errors import DataFileError, InputError
from terrapath.progress import progress_bar
from terrapath.runtext import duration, metrics_rows, report_lines

EXIT_FAILED = 3  # the flight was recorded but is not a success (as `plan`'s infeasible)


def _software_version() -> str:
    from terrapath import __version__

    return __version__


def _load_source(source: str) -> tuple[Any, Any]:
    """(mission, the earlier run when SOURCE is an .mcap, else None).

    The mission inside a run names its DEM tiles relative to the run's folder (see
    :func:`_recorded_mission`); they are looked for there, then as given, then where the run
    found them (metadata ``dem``)."""
    from planner.mission import load_mission, mission_from_dict

    if not source.lower().endswith(".mcap"):
        return load_mission(source), None
    from replay.reader import load_run

    run = load_run(source, with_states=False)
    text = run.attachments.get("mission.yaml")
    if text is None:
        raise InputError(f"{source!r}: this run carries no mission.yaml attachment to re-fly")
    try:
        doc = yaml.safe_load(text.decode("utf-8"))
    except (yaml.YAMLError, UnicodeDecodeError):
        raise DataFileError(
            f"{source!r}, attachment 'mission.yaml': not a valid mission YAML"
        ) from None
    mission = mission_from_dict(doc, source, attachment="mission.yaml")
    if mission.terrain is not None:
        try:
            flown = json.loads(run.metadata.get("dem", "[]"))
        except json.JSONDecodeError:
            flown = []
        if isinstance(flown, list) and all(isinstance(d, str) for d in flown):
            mission = replace(mission, terrain=mission.terrain.also_look_in(flown))
    return mission, run


def _terrain(mission: Any, dem_tiles: tuple[str, ...]) -> Any:
    """The mission with its DEM tiles found (absolute paths), or replaced by ``--dem``; raises
    before anything is written when a tile is found nowhere."""
    from planner.mission import TerrainRef

    ref = mission.terrain
    if dem_tiles:
        cell = ref.cell_size if ref is not None else None
        ref = TerrainRef(tuple(str(Path(t).absolute()) for t in dem_tiles), cell)
    if ref is None:
        return mission
    found = tuple(str(Path(t).resolve()) for t in ref.paths())
    return replace(mission, terrain=TerrainRef(found, ref.cell_size))


def _vehicle(vehicle: str | None, mission: Any, source: str, run: Any) -> tuple[Any, bytes | None]:
    """(vehicle parameters, the vehicle file to attach or None).

    ``--vehicle`` paths are relative to the working directory.  Re-flying a run flies the
    vehicle that run flew (its ``vehicle.yaml`` attachment, or its preset).  A mission's
    ``vehicle:`` file is looked for beside the mission, then as given."""
    from replay.vehicle.presets import PRESETS, load_vehicle, vehicle_from_dict
    from terrain.docfile import find_reference, reference_places

    if vehicle:
        params = load_vehicle(vehicle, base_dir=Path.cwd())
        path = Path(vehicle)
        is_file = path.suffix.lower() in (".yaml", ".yml") and path.is_file()
        return params, path.read_bytes() if is_file else None
    if run is not None:
        text = run.attachments.get("vehicle.yaml")
        if text is not None:
            label = f"{source} (attachment vehicle.yaml)"
            try:
                data = yaml.safe_load(text.decode("utf-8"))
            except (yaml.YAMLError, UnicodeDecodeError):
                raise DataFileError(f"{label!r}: not a valid vehicle YAML") from None
            return vehicle_from_dict(data, label), text
        flown = run.metadata.get("vehicle", "")
        if flown in PRESETS:
            return PRESETS[flown], None
    name = mission.vehicle
    if name in PRESETS:
        return PRESETS[name], None
    places = reference_places(name, source)
    if (
        Path(name).suffix.lower() in (".yaml", ".yml")
        or "/" in name
        or any(Path(q).exists() for q in places)
    ):
        path = Path(
            find_reference(
                places,
                name,
                holder=source,
                attachment="mission.yaml" if run is not None else None,
                field="vehicle",
                what="vehicle file",
                hint="; give it with --vehicle",
            )
        )
        return load_vehicle(path), path.read_bytes()
    return load_vehicle(name), None  # not a preset: says which presets exist


@click.command("replay")
@click.argument("source", type=click.Path(dir_okay=False, exists=False))
@click.option(
    "--threats",
    "threats_path",
    type=click.Path(dir_okay=False),
    default=None,
    help="Pop-up threats (YAML). For an .mcap source, default: the threats of that run.",
)
@click.option(
    "--avoid",
    default="none",
    show_default=True,
    help="Avoidance algorithm: none (keep the mission) or pso-ca (seed 000: radar-driven waypoint re-planning).",
)
@click.option(
    "--ca-optimizer",
    type=click.Choice(["pso", "ga", "sa", "mafoa", "gcpso", "mpso"]),
    default=None,
    help="pso-ca: optimiser of the new waypoint (seed 000 §6; default pso, Table 2).",
)
@click.option(
    "--ca-safety-radius",
    type=float,
    default=None,
    help="pso-ca: safety radius RS kept from stationary obstacles (m; default 1000, seed 000). "
    "Set it to at least the radius of your threats.",
)
@click.option(
    "--ca-moving-radius",
    type=float,
    default=None,
    help="pso-ca: safety radius around a moving intruder (m; default 2000, seed 000 §5.7).",
)
@click.option(
    "--ca-mxrsk",
    type=float,
    default=None,
    help="pso-ca: maximal risk distance MXRSK of the f2 term (m; default 3000, our choice: the paper gives none).",
)
@click.option(
    "--ca-paper",
    is_flag=True,
    help="pso-ca: seed 000's decision logic only -- straight legs (no cut corners) and no rescue "
    "grid, narrower gap or skipped waypoint when the paper's search fails (to reproduce the paper).",
)
@click.option(
    "--vehicle",
    default=None,
    help="Vehicle preset or file (default: the mission's; for an .mcap source, the vehicle that run flew).",
)
@click.option(
    "--dem",
    "dem_tiles",
    multiple=True,
    type=click.Path(exists=True, dir_okay=False),
    help="DEM tile to fly over instead of the mission's (repeat for several tiles; the "
    "mission's cell size is kept). Default: the mission's tiles, looked for beside the mission "
    "(or the .mcap), then as written.",
)
@click.option(
    "--seed",
    type=int,
    default=0,
    show_default=True,
    help="Random seed (radar noise, avoiders); recorded in the MCAP.",
)
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
    type=click.FloatRange(min=0.0),
    default=0.0,
    show_default=True,
    help="Radar range noise, 1 sigma (m).",
)
@click.option(
    "--terrain-following",
    type=click.FloatRange(min=0.0),
    default=None,
    help="Keep at least this clearance (m) above the terrain ahead (default: the clearance the mission was planned with, when it has terrain; 0: off).",
)
@click.option("--no-terrain-mesh", is_flag=True, help="Do not store the terrain mesh in the MCAP.")
@click.option(
    "-o", "--output", required=True, type=click.Path(dir_okay=False), help="MCAP file to write."
)
@click.option("--json", "as_json", is_flag=True, help="Print the metrics as JSON.")
def replay_cmd(
    source: str,
    threats_path: str | None,
    avoid: str,
    ca_optimizer: str | None,
    ca_safety_radius: float | None,
    ca_moving_radius: float | None,
    ca_mxrsk: float | None,
    ca_paper: bool,
    vehicle: str | None,
    dem_tiles: tuple[str, ...],
    seed: int,
    duration: float | None,
    log_rate: float,
    radar_range: float,
    radar_noise: float,
    terrain_following: float | None,
    no_terrain_mesh: bool,
    output: str,
    as_json: bool,
) -> int:
    """Re-fly SOURCE (a mission YAML, or an earlier run's .mcap) in the 6-DOF simulation, with
    pop-up threats, and record everything as MCAP for Foxglove.

    Exit status: 0 success (goal reached, no safety volume entered, no terrain contact), 3 the
    flight failed (still recorded), 1 error."""
    from replay.avoidance import make_avoider
    from replay.record import RunRecorder
    from replay.sim import ReplayConfig, estimated_flight_time
    from replay.threats import ThreatSet, load_threats

    if not output.lower().endswith(".mcap"):
        raise click.BadParameter(
            f"the output must end in .mcap; got {output!r}", param_hint="-o/--output"
        )
    if Path(output).resolve() == Path(source).resolve():
        raise click.BadParameter(
            f"{output!r} is the run being re-flown; write the new run to another file",
            param_hint="-o/--output",
        )
    mission, old_run = _load_source(source)
    mission = _terrain(mission, dem_tiles)
    grid = mission.terrain.load() if mission.terrain is not None else None
    params, vehicle_file = _vehicle(vehicle, mission, source, old_run)
    ca = {
        "optimizer": ca_optimizer,
        "rs": ca_safety_radius,
        "moving_rs": ca_moving_radius,
        "mxrsk": ca_mxrsk,
    }
    ca = {k: v for k, v in ca.items() if v is not None}
    if ca_paper:
        ca.update(rescue=False, narrow=False, max_skip=0, corners=False)
    if ca and avoid != "pso-ca":
        raise click.UsageError("the --ca-* options apply to --avoid pso-ca only")
    avoider = make_avoider(avoid, **ca)
    threat_text: str | None = None
    old_threats = old_run.attachments.get("threats.yaml") if old_run is not None else None
    if threats_path:
        threats = load_threats(threats_path, grid)
        threat_text = Path(threats_path).read_text(encoding="utf-8")
    elif old_threats is not None:
        threat_text = old_threats.decode("utf-8")
        threats = _recorded_threats(threat_text, source, grid)
    else:
        threats = ThreatSet(())
    if terrain_following is None and grid is not None:
        # keep the clearance the mission was planned with (0 turns it off)
        terrain_following = float(mission.plan.get("clearance", 0.0) or 0.0) or None
    elif terrain_following == 0:
        terrain_following = None
    config = ReplayConfig(
        seed=seed,
        duration=duration,
        radar_range=radar_range,
        radar_noise_range=radar_noise,
        terrain_following=terrain_following,
    )
    planned = estimated_flight_time(mission.waypoints, config.airspeed or mission.cruise_speed)
    limit = duration or 1.5 * planned + 600.0
    for warning in threats.warn_after(planned):
        click.echo(f"terrapath: warning: {warning}", err=True)

    terrain_model = None
    if grid is not None:
        from terrain.model import TerrainModel

        terrain_model = TerrainModel.from_grid(grid, max_faces=2_000_000)
    origin = _map_origin(mission, grid)
    from planner.mission import mission_to_dict

    # DEM paths relative to the MCAP's folder: the run can be re-flown after moving it together
    # with its DEM; the metadata keeps where they were found, for a run moved on its own
    mission_doc = mission_to_dict(mission, output)
    extra = {"vehicle": params.name, "source": str(source)}
    if mission.terrain is not None:
        extra["dem"] = json.dumps(list(mission.terrain.dem))
    with RunRecorder(
        output,
        map_origin=origin,
        crs=mission.crs,
        seed=seed,
        command="terrapath " + " ".join(sys.argv[1:]) if sys.argv else "terrapath replay",
        avoid=avoid + "".join(f" {k}={v}" for k, v in ca.items()),
        software_version=_software_version(),
        to_lonlat=grid.lonlat_interpolator()
        if grid is not None and grid.is_georeferenced
        else None,
        log_rate_hz=log_rate,
        metadata=extra,
    ) as rec:
        rec.attach(
            "mission.yaml",
            yaml.safe_dump(mission_doc, sort_keys=False, default_flow_style=None).encode(),
            "application/yaml",
        )
        if threat_text is not None:
            rec.attach("threats.yaml", threat_text.encode("utf-8"), "application/yaml")
        if vehicle_file is not None:
            rec.attach("vehicle.yaml", vehicle_file, "application/yaml")
        if terrain_model is not None and not no_terrain_mesh:
            mesh = (
                TerrainModel.from_grid(grid, max_faces=400_000).mesh if grid is not None else None
            )
            if mesh is not None:
                rec.write_terrain(np.asarray(mesh.vertices), np.asarray(mesh.faces))
        result = _run(mission, threats, avoider, params, grid, terrain_model, config, rec, limit)
    _report(result, output, as_json, threats)
    m = result.metrics
    if not m.success:
        reasons = []
        if m.end_reason != "goal":
            reasons.append(f"ended by {m.end_reason}")
        if m.violations:
            n = len(m.violations)
            reasons.append(f"{n} safety violation{'s' if n != 1 else ''}")
        click.echo(
            f"terrapath: replay failed: {', '.join(reasons) or 'not a success'} "
            f"(the run is recorded in {output})",
            err=True,
        )
        return EXIT_FAILED
    return 0


def _recorded_threats(text: str, source: str, grid: Any) -> Any:
    """The threats an earlier run recorded (its ``threats.yaml`` attachment)."""
    from replay.threats import threats_from_records

    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError:
        data = None
    if not isinstance(data, dict):
        raise DataFileError(f"{source!r}, attachment 'threats.yaml': not a threat file")
    name = data.get("name")
    return threats_from_records(
        data.get("threats"), grid, source=source, name=name if isinstance(name, str) else None
    )


def _map_origin(mission: Any, grid: Any) -> tuple[float, float, float]:
    if grid is not None:
        xmin, ymin, xmax, ymax = grid.bounds
        return (round((xmin + xmax) / 2.0), round((ymin + ymax) / 2.0), 0.0)
    w = mission.waypoints
    return (float(w[0, 0]), float(w[0, 1]), 0.0)


def _run(
    mission: Any,
    threats: Any,
    avoider: Any,
    params: Any,
    grid: Any,
    terrain_model: Any,
    config: Any,
    rec: Any,
    limit: float,
) -> Any:
    from replay.sim import simulate

    kwargs = {"grid": grid, "terrain_model": terrain_model, "config": config, "recorder": rec}
    with progress_bar(int(limit), "replay (simulated s)") as report:
        if report is None:
            return simulate(mission, threats, avoider, params, **kwargs)

        def progress(t: float, total: float) -> None:
            report(int(t), None)

        return simulate(mission, threats, avoider, params, progress=progress, **kwargs)


def _report(result: Any, output: str, as_json: bool, threats: Any) -> None:
    m = result.metrics
    if as_json:
        click.echo(
            json.dumps(
                {
                    "output": output,
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
    click.echo(
        "open it in Foxglove: Open local file, 3D panel with display frame 'map'; plots from /vehicle/state"
    )
