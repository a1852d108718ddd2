"""A replay as one library call: a mission (or an earlier run), threats, vehicle, avoider and
settings in; the typed result out, and the MCAP written when asked. ``terrapath replay``, the
benchmarks and the campaigns call :func:`run_replay`.

:func:`prepare_replay` does everything that can fail on bad input before anything is written:
it reads the source (a mission YAML, or the mission attached to an earlier run's MCAP, whose DEM
tiles are looked for beside the MCAP, then as written, then where that run found them), finds the
DEM tiles (or takes ``dem`` instead), the vehicle (``vehicle``; else a re-flown run's own, else the
mission's, a vehicle file looked for beside the mission), the threats (``threats``; else a re-flown
run's), builds the avoider from the explicit registry with its options, and the settings
(terrain following defaults to the clearance the mission was planned with). Then it asks whether
the vehicle can fly the mission at all (:mod:`replay.preflight`: the ceiling at the cruise speed,
the climb each leg needs against the climb available, the turn radius) and refuses one it cannot.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from planner.mission import Mission
from replay.avoidance import Avoider, make_avoider
from replay.avoidance.registry import AVOIDERS, avoider_plugin, hook_checked
from replay.flight.fixedwing.params import VehicleParams
from replay.flight.multirotor.model import MultirotorParams
from replay.preflight import Preflight, preflight
from replay.sim import (
    ReplayConfig,
    ReplayResult,
    check_mission,
    check_wind,
    estimated_flight_time,
    rangefinder_spread,
    simulate,
    strongest_wind,
    time_limit,
)
from replay.source import mission_on_terrain, on_its_terrain, recorded_threats
from replay.threats.file import load_threats, recorded_text, threats_to_records
from replay.threats.kinds import ThreatSet
from terrain.errors import InputError
from terrain.grid import HeightGrid


@dataclass(frozen=True)
class ReplayRequest:
    """What a replay is made of (``terrapath replay``'s options): what to fly (``source``: a
    mission YAML, an earlier run's ``.mcap``, or a mission built in memory), among which threats
    (a threat file, or threats built in memory, recorded in the MCAP as a threat file), avoided
    by which avoider (``avoid_options``: its keyword options), with which vehicle and DEM tiles
    (default: the mission's), the loop's settings (``config``, :class:`replay.sim.ReplayConfig`:
    seed, sensor, limits, margin, atmosphere) and how it is recorded.

    ``terrain_following`` is the user's: None keeps the clearance the mission was planned with,
    0 turns it off; :func:`prepare_replay` puts the resolved clearance into the config.
    :meth:`of` and :meth:`but` take the config's fields by name beside the request's own."""

    source: str | Mission  # a mission file, a run (.mcap), or a mission built in memory
    threats: str | ThreatSet | None = None
    avoid: str = "none"
    avoid_options: dict[str, Any] = field(default_factory=dict)
    vehicle: str | None = None
    dem: tuple[str, ...] = ()
    # airspace files (OpenAir, ED-269 JSON) whose zones join the mission's danger zones, those
    # active during the flight from ``start_time`` (None: all of them)
    airspace: tuple[str, ...] = ()
    start_time: Any = None
    config: ReplayConfig = field(default_factory=ReplayConfig)
    terrain_following: float | None = None  # None: the mission's planned clearance; 0: off
    log_rate: float = 10.0
    terrain_mesh: bool = True
    fly_anyway: bool = False  # a mission the vehicle cannot fly: warned and flown, not refused
    command: str = "terrapath replay"  # recorded in the MCAP
    software_version: str = ""

    @property
    def seed(self) -> int:
        return self.config.seed

    @classmethod
    def of(cls, source: str | Mission, **settings: Any) -> ReplayRequest:
        """A request from keyword settings that name its own fields or the config's, e.g.
        ``ReplayRequest.of(path, avoid="fga", sensor="cooperative", margin=30.0, seed=2)``."""
        own, config = _split_settings(settings)
        return cls(source, config=ReplayConfig(**config), **own)

    def but(self, **settings: Any) -> ReplayRequest:
        """This request with some of its own or its config's fields replaced."""
        own, config = _split_settings(settings)
        return replace(self, config=replace(self.config, **config), **own)


def _split_settings(settings: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """(the request's own fields, the config's) of keyword ``settings``; the request's own
    ``terrain_following`` wins (the config's is the resolved one)."""
    own_names = {f.name for f in fields(ReplayRequest)} - {"source", "config"}
    config_names = {f.name for f in fields(ReplayConfig)}
    unknown = sorted(set(settings) - own_names - config_names)
    if unknown:
        raise TypeError(f"unknown replay setting(s): {', '.join(unknown)}")
    own = {k: v for k, v in settings.items() if k in own_names}
    return own, {k: v for k, v in settings.items() if k not in own_names}


@dataclass(frozen=True, eq=False)
class PreparedReplay:
    """Everything a replay needs, validated; ``warnings`` for the user; ``preflight``: what the
    vehicle can do on this mission (its :meth:`~replay.preflight.Preflight.describe` is the
    line printed before take-off)."""

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
    preflight: Preflight


def radar_pairing(sensor: str, avoider: Any, threats: Any) -> tuple[str, ...]:
    """Start-up warnings where the radar cannot serve the avoider (issue 34): the radar sees a
    static sphere by its centre and an intruder by its position (seed 000's points), never their
    radii, unless they are ``solid`` (then it measures them); an avoider that keeps less than a
    threat's radius from such a point will enter it."""
    keep = getattr(avoider, "point_keep_m", lambda: None)()
    if sensor != "radar" or keep is None:
        return ()
    out = []
    for th in threats:
        kind = getattr(th, "kind", "")
        if kind not in ("static", "intruder") or getattr(th, "solid", False):
            continue  # a solid sphere's radius is measured
        kept = keep[0] if kind == "static" else keep[1]
        radius = float(th.radius)
        if radius > kept:
            out.append(
                f"the radar sees {kind} threat {th.id!r} as a point, not its {radius:.0f} m radius; "
                f"{avoider.name} keeps {kept:.0f} m from such a point and may enter it: fly "
                "--sensor cooperative (sizes reported), mark the threat 'solid: true' if the "
                "radar can see its sphere, or widen the avoider's distance (--help-avoider)"
            )
    return tuple(out)


def prepare_replay(request: ReplayRequest) -> PreparedReplay:
    """Read and check everything a replay needs (nothing is written)."""
    r = request
    grid: HeightGrid | None
    if isinstance(r.source, Mission):
        old_run, source = None, f"mission {r.source.name!r}"
        mission, grid, params, vehicle_file = on_its_terrain(
            r.source, r.dem, r.vehicle, source, None
        )
    else:
        # a mission file (terrapath's, or another tool's on --dem) or an earlier run
        source = r.source
        mission, grid, params, vehicle_file, old_run = mission_on_terrain(
            source, r.dem, r.vehicle, r.config.airspeed
        )
    airspace_notes: tuple[str, ...] = ()
    if r.airspace:
        if grid is None:
            raise InputError("--airspace needs the mission's terrain (a DEM): give --dem")
        from terrain.airspace import load_airspace

        # the zones active while the replay may fly (its time limit)
        air = load_airspace(
            r.airspace, grid, start=r.start_time, duration_s=time_limit(mission, r.config)
        )
        mission = replace(mission, danger_zones=(*mission.danger_zones, *air.zones))
        airspace_notes = air.notes
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
        # keep the clearance the mission was planned with (0 turns it off); an imported
        # mission's terrain-frame legs: their lowest height above the ground, everywhere (the
        # autopilot's terrain floor is one clearance for the whole flight)
        following = float(mission.plan.get("clearance", 0.0) or 0.0) or None
        if following is None and mission.terrain_heights:
            following = min(mission.terrain_heights.values())
    elif following == 0:
        following = None
    config = replace(r.config, terrain_following=following)
    speed = config.airspeed or mission.cruise_speed
    params.check_speed(speed, "cruise speed")
    # e.g. FGA's eq 5: the aircraft must turn as tightly as it assumes -- at the fastest ground
    # speed of a turn in the run's wind (the airspeed plus the strongest wind on the way)
    check_wind(config, mission, params.name)  # before the legs: a wind it cannot fly into
    hook_checked(avoider, "check_vehicle", params, float(speed) + strongest_wind(mission, config))
    # e.g. the priority loop: its sensor, a start outside the obstacles
    hook_checked(avoider, "check_setup", config, mission, threats, grid, float(speed))
    # can it fly this? (the waypoints on the map and above the terrain first, as the loop asks)
    check_mission(mission, grid)
    try:
        flight = preflight(
            mission,
            params,
            float(speed),
            config.temperature_offset,
            changes=not config.airspeed,  # --speed flies one speed
            wind=config.wind,
        )
    except InputError as exc:
        if not str(exc).startswith(f"{params.name} cannot trim"):
            raise
        # the speed the mission was planned for is not one this vehicle flies up there
        raise InputError(f"{exc}; fly it at one of those with --speed") from None
    if not r.fly_anyway:
        flight.check()
    flown_anyway = tuple(f"flown anyway (--fly-anyway): {why}" for why in flight.refusals)
    flight = replace(flight, warnings=flight.warnings + flown_anyway) if flown_anyway else flight
    planned = estimated_flight_time(mission.waypoints, speed)
    limit = time_limit(mission, config, avoider)
    warnings = airspace_notes + tuple(threats.warn_after(planned)) + flight.warnings
    warnings += radar_pairing(config.sensor, avoider, threats)
    if following and not params.follows_terrain:
        warnings += (
            f"{params.name} flies the waypoints' altitudes and does not follow the terrain "
            f"({following:g} m of clearance asked)",
        )
    elif (
        not following
        and r.terrain_following is None
        and grid is not None
        and not avoider.passive
        and params.follows_terrain
    ):
        # a mission of another tool names no clearance: its avoidance manoeuvres (an orbit,
        # a held course) are flown at their altitude over whatever terrain lies there
        warnings += (
            "terrain following is off (the mission names no planned clearance): the "
            "avoider's manoeuvres are flown at their altitude whatever the terrain below; "
            "give --terrain-following METRES to keep that much above it",
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
        flight,
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

        # the world the sensors see is the ground the flight is judged on (the measured,
        # conservative heights: sim._Loop.ground); the recorded picture keeps the display grid
        terrain_model = TerrainModel.from_grid(grid.safety(), max_faces=2_000_000)
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
        "sensor": prep.config.sensor,
        "atmosphere": f"ISA{prep.config.temperature_offset:+g} K",
    }
    if prep.config.wind is not None and not prep.config.wind.calm:
        extra["wind"] = json.dumps(
            {**prep.config.wind.to_dict(), "text": prep.config.wind.describe()}
        )
    if prep.config.sensor == "rangefinder":
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
    if r.avoid not in AVOIDERS:  # an installed package's avoider: which package and version
        extra["avoid_package"] = avoider_plugin(r.avoid).origin
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


def _map_origin(mission: Mission, grid: HeightGrid | None) -> tuple[float, float, float]:
    if grid is not None:
        xmin, ymin, xmax, ymax = grid.bounds
        return (round((xmin + xmax) / 2.0), round((ymin + ymax) / 2.0), 0.0)
    w = mission.waypoints
    return (float(w[0, 0]), float(w[0, 1]), 0.0)
