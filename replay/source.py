"""What a replay flies: a mission file, or an earlier run (its ``.mcap``) re-flown with the
mission, vehicle and threats it recorded; the DEM tiles found (or replaced by ``--dem``) and the
vehicle chosen before anything is written. :func:`replay.run.prepare_replay` calls these.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from replay.flight.multirotor.model import MULTIROTOR_PRESETS, multirotor_from_dict
from terrain.docfile import parse_yaml
from terrain.errors import DataFileError, InputError

if TYPE_CHECKING:
    from planner.mission import Mission, TerrainRef
    from planner.performance import Performance
    from replay.flight.fixedwing.params import VehicleParams
    from replay.flight.multirotor.model import MultirotorParams
    from replay.record.reader import RunRecord
    from replay.threats.kinds import ThreatSet
    from terrain.grid import HeightGrid


def load_source(source: str) -> tuple[Mission, RunRecord | None]:
    """(mission, the earlier run when SOURCE is an .mcap, else None).

    The mission inside a run names its DEM tiles relative to the run's folder (see
    :func:`planner.mission.mission_to_dict`); they are looked for there, then as given, then where the run
    found them (metadata ``dem``)."""
    from planner.mission import load_mission

    if not source.lower().endswith(".mcap"):
        return load_mission(source), None
    from replay.record.reader import load_run

    run = load_run(source, with_states=False)
    return mission_of_run(run, source), run


def performance_of(params: VehicleParams | MultirotorParams, speed: float) -> Performance:
    """What the planner and the importer need of a vehicle at ``speed``: a fixed wing's limits
    (:meth:`VehicleParams.performance`, its envelope at sea level), a multirotor's rates, hover
    and ceiling."""
    from planner.performance import Performance
    from replay.flight.multirotor.model import MultirotorParams
    from replay.preflight import multirotor_ceiling

    if not isinstance(params, MultirotorParams):
        return params.performance(speed)
    return Performance(
        params.name,
        float(speed),
        params.climb_rate_max,
        params.descent_rate_max,
        params.bank_max_deg,
        ceiling=multirotor_ceiling(params),
        hover=True,
    )


def import_mission(
    source: str, dem_tiles: tuple[str, ...], vehicle: str | None, speed: float | None
) -> tuple[Mission, HeightGrid, VehicleParams | MultirotorParams, bytes | None]:
    """A mission of another tool (QGroundControl ``.plan``, WPL ``.waypoints``, GeoJSON, KML:
    :mod:`planner.imports`) on the DEM ``dem_tiles`` (required: these files hold lon/lat and
    name no terrain), flown by ``vehicle`` (default: the file's kind of vehicle -- a multirotor
    preset for a multirotor, else the default fixed wing) at ``speed`` (default: the vehicle's
    cruise speed; a file's own cruise speed is QGroundControl's planning estimate, recorded,
    not flown)."""
    from planner.imports import FORMAT_NAMES, read_foreign, to_mission
    from planner.mission import DEFAULT_VEHICLE, TerrainRef

    fm = read_foreign(source)
    if not dem_tiles:
        raise InputError(
            f"{source!r}: a {FORMAT_NAMES[fm.format]} mission holds lon/lat and names no terrain: give the DEM "
            "it flies over with --dem"
        )
    ref = _found(TerrainRef(tuple(str(Path(t).absolute()) for t in dem_tiles)))
    grid = ref.load()
    name = vehicle or (
        next(iter(MULTIROTOR_PRESETS)) if fm.vehicle_type == "multirotor" else DEFAULT_VEHICLE
    )
    params, vehicle_file = named_vehicle(name)
    v = float(speed) if speed is not None else float(params.cruise_speed)
    params.check_speed(v, "speed")
    mission = to_mission(fm, grid, ref, vehicle=name, perf=performance_of(params, v))
    return mission, grid, params, vehicle_file


def mission_on_terrain(
    source: str, dem_tiles: tuple[str, ...], vehicle: str | None, speed: float | None
) -> tuple[
    Mission, HeightGrid | None, VehicleParams | MultirotorParams, bytes | None, RunRecord | None
]:
    """(mission, its grid or None, vehicle parameters, the vehicle file to attach, the earlier
    run when SOURCE is an .mcap) of a mission
    file of any format (terrapath YAML, or another tool's with ``--dem``: :func:`import_mission`)
    or of an earlier run's ``.mcap``; the DEM tiles found (or replaced by ``dem_tiles``) before
    anything is written."""
    from planner.imports import is_foreign

    if is_foreign(source):
        mission, grid, params, vehicle_file = import_mission(source, dem_tiles, vehicle, speed)
        return mission, grid, params, vehicle_file, None
    mission, old_run = load_source(source)
    return (*on_its_terrain(mission, dem_tiles, vehicle, source, old_run), old_run)


def on_its_terrain(
    mission: Mission,
    dem_tiles: tuple[str, ...],
    vehicle: str | None,
    source: str,
    run: RunRecord | None,
) -> tuple[Mission, HeightGrid | None, VehicleParams | MultirotorParams, bytes | None]:
    """(mission, grid, vehicle parameters, vehicle file) of a terrapath mission: its DEM tiles
    found (or replaced by ``dem_tiles``) and loaded, its zones limited above the ground on that
    terrain, its vehicle (:func:`source_vehicle`)."""
    from planner.mission import on_terrain

    mission = find_terrain(mission, dem_tiles)
    grid = mission.terrain.load() if mission.terrain is not None else None
    params, vehicle_file = source_vehicle(vehicle, mission, source, run)
    return on_terrain(mission, grid), grid, params, vehicle_file


def mission_of_run(run: RunRecord, source: str) -> Mission:
    """The mission a recorded run flew (its ``mission.yaml`` attachment), with its DEM tiles
    looked for where :func:`load_source` says."""
    from planner.mission import mission_from_dict

    text = run.attachments.get("mission.yaml")
    if text is None:
        raise InputError(f"{source!r}: this run carries no mission.yaml attachment to re-fly")
    label = f"{source!r}, attachment 'mission.yaml'"
    try:
        decoded = text.decode("utf-8")
    except UnicodeDecodeError:
        raise DataFileError(f"{label}: not a valid mission YAML (not UTF-8 text)") from None
    doc = parse_yaml(decoded, label)
    mission = mission_from_dict(doc, source, attachment="mission.yaml")
    if mission.terrain is not None:
        try:
            flown = json.loads(run.metadata.get("dem", "[]"))
        except json.JSONDecodeError:
            flown = []
        if isinstance(flown, list) and all(isinstance(d, str) for d in flown):
            mission = replace(mission, terrain=mission.terrain.also_look_in(flown))
    return mission


def find_terrain(mission: Mission, dem_tiles: tuple[str, ...]) -> Mission:
    """The mission with its DEM tiles found (absolute paths), or replaced by ``--dem``; raises
    before anything is written when a tile is found nowhere."""
    from planner.mission import TerrainRef

    ref = mission.terrain
    if dem_tiles:
        cell = ref.cell_size if ref is not None else None
        local = ref.local_cell_size if ref is not None else None
        ref = TerrainRef(
            tuple(str(Path(t).absolute()) for t in dem_tiles), cell, local_cell_size=local
        )
    if ref is None:
        return mission
    return replace(mission, terrain=_found(ref))


def _found(ref: TerrainRef) -> TerrainRef:
    """``ref`` with every tile where it was found (absolute; an error naming the places looked
    for a tile found nowhere)."""
    from planner.mission import TerrainRef

    found = tuple(str(Path(t).resolve()) for t in ref.paths())
    return TerrainRef(found, ref.cell_size, local_cell_size=ref.local_cell_size)


def named_vehicle(vehicle: str) -> tuple[VehicleParams | MultirotorParams, bytes | None]:
    """(parameters, the file to attach or None) of a vehicle named on the command line: a
    multirotor preset by name, a fixed-wing preset, or a vehicle file (relative to the working
    directory)."""
    from replay.flight.fixedwing.presets import load_any_vehicle

    if vehicle in MULTIROTOR_PRESETS:
        return MULTIROTOR_PRESETS[vehicle], None
    params = load_any_vehicle(vehicle, base_dir=Path.cwd())
    path = Path(vehicle)
    is_file = path.suffix.lower() in (".yaml", ".yml") and path.is_file()
    return params, path.read_bytes() if is_file else None


def source_vehicle(
    vehicle: str | None, mission: Mission, source: str, run: RunRecord | None
) -> tuple[VehicleParams | MultirotorParams, bytes | None]:
    """(vehicle parameters, the vehicle file to attach or None).

    ``--vehicle`` paths are relative to the working directory.  Re-flying a run flies the
    vehicle that run flew (its ``vehicle.yaml`` attachment, or its preset).  A mission's
    ``vehicle:`` file is looked for beside the mission, then as given.  A multirotor preset
    (``quadrotor``) is taken by name."""
    from replay.flight.fixedwing.presets import PRESETS, load_any_vehicle, vehicle_from_dict
    from terrain.docfile import find_reference, reference_places

    if vehicle:
        return named_vehicle(vehicle)
    if run is not None:
        text = run.attachments.get("vehicle.yaml")
        if text is not None:
            label = f"{source} (attachment vehicle.yaml)"
            try:
                data = parse_yaml(text.decode("utf-8"), repr(label))
            except (DataFileError, UnicodeDecodeError):
                raise DataFileError(f"{label!r}: not a valid vehicle YAML") from None
            if isinstance(data, dict) and data.get("base") in MULTIROTOR_PRESETS:
                return multirotor_from_dict(data, label), text
            return vehicle_from_dict(data, label), text
        flown = run.metadata.get("vehicle", "")
        if flown in PRESETS:
            return PRESETS[flown], None
        if flown in MULTIROTOR_PRESETS:
            return MULTIROTOR_PRESETS[flown], None
    name = mission.vehicle
    if name in PRESETS:
        return PRESETS[name], None
    if name in MULTIROTOR_PRESETS:
        return MULTIROTOR_PRESETS[name], None
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
        return load_any_vehicle(path), path.read_bytes()
    return load_any_vehicle(name), None  # not a preset: says which presets exist


def recorded_threats(text: str, source: str, grid: HeightGrid | None) -> ThreatSet:
    """The threats an earlier run recorded (its ``threats.yaml`` attachment)."""
    from replay.threats.file import threats_from_records

    try:
        data = parse_yaml(text, repr(source))
    except DataFileError:
        data = None
    if not isinstance(data, dict):
        raise DataFileError(f"{source!r}, attachment 'threats.yaml': not a threat file")
    name = data.get("name")
    return threats_from_records(
        data.get("threats"), grid, source=source, name=name if isinstance(name, str) else None
    )
