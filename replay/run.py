"""A replay as one library call: a mission (or an earlier run), threats, vehicle, avoider and
settings in; the typed result out, and the MCAP written when asked. ``terrapath replay``, the
benchmarks and the campaigns call :func:`run_replay`.

:func:`prepare_replay` does everything that can fail on bad input before anything is written:
it reads the source (a mission YAML, or the mission attached to an earlier run's MCAP, whose DEM
tiles are looked for beside the MCAP, then as written, then where that run found them), finds the
DEM tiles (or takes ``dem`` instead), the vehicle (``vehicle``; else a re-flown run's own, else the
mission's, a vehicle file looked for beside the mission), the threats (``threats``; else a re-flown
run's), builds the avoider from the explicit registry with its options, and the settings
(terrain following defaults to the clearance the mission was planned with).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from planner.mission import Mission
from replay.avoidance import Avoider, make_avoider
from replay.flight.fixedwing.params import VehicleParams
from replay.flight.multirotor.model import MultirotorParams
from replay.sim import (
    ReplayConfig,
    ReplayResult,
    estimated_flight_time,
    rangefinder_spread,
    simulate,
    time_limit,
)
from replay.source import find_terrain, load_source, recorded_threats, source_vehicle
from replay.threats.file import load_threats, recorded_text, threats_to_records
from replay.threats.kinds import ThreatSet
from terrain.errors import InputError
from terrain.grid import HeightGrid


@dataclass(frozen=True)
class ReplayRequest:
    """What a replay is made of (``terrapath replay``'s options). ``source`` is a mission YAML or
    an earlier run's ``.mcap``; ``threats`` a threat file or threats built in memory (recorded in
    the MCAP as a threat file); ``avoid_options`` are the avoider's keyword options."""

    source: str | Mission  # a mission file, a run (.mcap), or a mission built in memory
    threats: str | ThreatSet | None = None
    avoid: str = "none"
    avoid_options: dict[str, Any] = field(default_factory=dict)
    vehicle: str | None = None
    dem: tuple[str, ...] = ()
    seed: int = 0
    duration: float | None = None
    log_rate: float = 10.0
    radar_range: float = 10_000.0
    radar_noise: float = 0.0
    sensor: str = "radar"  # "cooperative": every threat in range reports itself (ADS-B-like);
    # "rangefinder": beams of range R by ray casting (replay.sensors.rangefinder)
    coop_noise_position: float = 0.0
    coop_noise_velocity: float = 0.0
    coop_latency: float = 0.0
    rangefinder_range: float = 20.0
    rangefinder_beams: int = 4
    rangefinder_mount: str = "gimballed"  # or "body"
    rangefinder_noise: float = 0.0
    rangefinder_spread: float | None = None  # deg; None: the avoider's choice (replay.sim)
    margin: float = 0.0  # success needs every separation >= this (m)
    temperature_offset: float = 0.0  # K off the ISA standard day
    terrain_following: float | None = None  # None: the mission's planned clearance; 0: off
    terrain_mesh: bool = True
    command: str = "terrapath replay"  # recorded in the MCAP
    software_version: str = ""


@dataclass(frozen=True, eq=False)
class PreparedReplay:
    """Everything a replay needs, validated; ``warnings`` for the user."""

    request: ReplayRequest
    mission: Mission
    grid: HeightGrid | None
    params: VehicleParams | MultirotorParams
    vehicle_file: bytes | None
    avoider: Avoider
    threats: ThreatSet
    threat_text: str | None
    config: ReplayConfig
    time_limit: float
    warnings: tuple[str, ...]


def prepare_replay(request: ReplayRequest) -> PreparedReplay:
    """Read and check everything a replay needs (nothing is written)."""
    r = request
    if isinstance(r.source, Mission):
        mission, old_run, source = r.source, None, f"mission {r.source.name!r}"
    else:
        mission, old_run = load_source(r.source)
        source = r.source
    mission = find_terrain(mission, r.dem)
    grid = mission.terrain.load() if mission.terrain is not None else None
    params, vehicle_file = source_vehicle(r.vehicle, mission, source, old_run)
    avoider = make_avoider(r.avoid, **r.avoid_options)
    threat_text: str | None = None
    old_threats = old_run.attachments.get("threats.yaml") if old_run is not None else None
    if isinstance(r.threats, ThreatSet):
        threats = r.threats
        doc = {"terrapath": 1, "name": threats.name, "threats": threats_to_records(threats)}
        threat_text = yaml.safe_dump(doc, sort_keys=False)
    elif r.threats:
        threats = load_threats(r.threats, grid)
        threat_text = recorded_text(r.threats, threats)
    elif old_threats is not None:
        threat_text = old_threats.decode("utf-8")
        threats = recorded_threats(threat_text, source, grid)
    else:
        threats = ThreatSet(())
    following = r.terrain_following
    if following is None and grid is not None:
        # keep the clearance the mission was planned with (0 turns it off)
        following = float(mission.plan.get("clearance", 0.0) or 0.0) or None
    elif following == 0:
        following = None
    config = ReplayConfig(
        seed=r.seed,
        duration=r.duration,
        radar_range=r.radar_range,
        radar_noise_range=r.radar_noise,
        terrain_following=following,
        sensor=r.sensor,
        coop_noise_position=r.coop_noise_position,
        coop_noise_velocity=r.coop_noise_velocity,
        coop_latency=r.coop_latency,
        rangefinder_range=r.rangefinder_range,
        rangefinder_beams=r.rangefinder_beams,
        rangefinder_mount=r.rangefinder_mount,
        rangefinder_noise=r.rangefinder_noise,
        rangefinder_spread=r.rangefinder_spread,
        margin=r.margin,
        temperature_offset=r.temperature_offset,
    )
    speed = config.airspeed or mission.cruise_speed
    params.check_speed(speed, "cruise speed")
    # e.g. FGA's eq 5: the aircraft must turn as tightly as it assumes
    avoider.check_vehicle(params, float(speed))
    # e.g. the priority loop: its sensor, a start outside the obstacles
    avoider.check_setup(config, mission, threats, grid, float(speed))
    planned = estimated_flight_time(mission.waypoints, speed)
    limit = time_limit(mission, config)
    warnings = tuple(threats.warn_after(planned))
    if following and not params.follows_terrain:
        warnings += (
            f"{params.name} is a multirotor: it flies the waypoints' altitudes and does not "
            f"follow the terrain ({following:g} m of clearance asked)",
        )
    return PreparedReplay(
        r,
        mission,
        grid,
        params,
        vehicle_file,
        avoider,
        threats,
        threat_text,
        config,
        limit,
        warnings,
    )


def run_replay(
    request: ReplayRequest | PreparedReplay,
    output: str | Path | None = None,
    *,
    progress: Callable[[float, float], None] | None = None,
) -> ReplayResult:
    """Fly the replay; with ``output`` (an ``.mcap`` path) record it (mission, threats and vehicle
    attached; DEM paths relative to the MCAP's folder, where they were found in the metadata)."""
    prep = request if isinstance(request, PreparedReplay) else prepare_replay(request)
    r = prep.request
    mission, grid = prep.mission, prep.grid
    terrain_model = None
    if grid is not None:
        from terrain.model import TerrainModel

        terrain_model = TerrainModel.from_grid(grid, max_faces=2_000_000)
    kwargs: dict[str, Any] = {
        "grid": grid,
        "terrain_model": terrain_model,
        "config": prep.config,
        "progress": progress,
    }
    if output is None:
        return simulate(mission, prep.threats, prep.avoider, prep.params, **kwargs)
    from planner.mission import mission_to_dict
    from replay.record.recorder import RunRecorder

    out = str(output)
    if not out.lower().endswith(".mcap"):
        raise InputError(f"the output must end in .mcap; got {out!r}")
    mission_doc = mission_to_dict(mission, out)
    extra = {
        "vehicle": prep.params.name,
        "source": str(r.source),
        "sensor": r.sensor,
        "atmosphere": f"ISA{r.temperature_offset:+g} K",
    }
    if r.sensor == "rangefinder":
        c = prep.config
        extra["rangefinder"] = json.dumps(
            {
                "range_m": c.rangefinder_range,
                "period_s": c.rangefinder_period,
                "beams": c.rangefinder_beams,
                "mount": c.rangefinder_mount,
                "noise_m": c.rangefinder_noise,
                "spread_deg": rangefinder_spread(c, prep.avoider),
            }
        )
    if mission.terrain is not None:
        extra["dem"] = json.dumps(list(mission.terrain.dem))
    options = "".join(f" {k}={v}" for k, v in r.avoid_options.items())
    with RunRecorder(
        out,
        map_origin=_map_origin(mission, grid),
        crs=mission.crs,
        seed=r.seed,
        command=r.command,
        avoid=r.avoid + options,
        software_version=r.software_version,
        to_lonlat=_lonlat(grid),
        log_rate_hz=r.log_rate,
        metadata=extra,
    ) as rec:
        rec.attach(
            "mission.yaml",
            yaml.safe_dump(mission_doc, sort_keys=False, default_flow_style=None).encode(),
            "application/yaml",
        )
        if prep.threat_text is not None:
            rec.attach("threats.yaml", prep.threat_text.encode("utf-8"), "application/yaml")
        if prep.vehicle_file is not None:
            rec.attach("vehicle.yaml", prep.vehicle_file, "application/yaml")
        if grid is not None and r.terrain_mesh:
            from terrain.model import TerrainModel

            mesh = TerrainModel.from_grid(grid, max_faces=400_000).mesh
            rec.write_terrain(np.asarray(mesh.vertices), np.asarray(mesh.faces))
        result = simulate(mission, prep.threats, prep.avoider, prep.params, recorder=rec, **kwargs)
    return result


def _lonlat(grid: HeightGrid | None) -> Any:
    """A fast map -> (lon, lat) for the recorder, or None without a georeferenced map."""
    if grid is None or not grid.is_georeferenced:
        return None
    return grid.lonlat_interpolator()


def _map_origin(mission: Any, grid: Any) -> tuple[float, float, float]:
    if grid is not None:
        xmin, ymin, xmax, ymax = grid.bounds
        return (round((xmin + xmax) / 2.0), round((ymin + ymax) / 2.0), 0.0)
    w = mission.waypoints
    return (float(w[0, 0]), float(w[0, 1]), 0.0)
