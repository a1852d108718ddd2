"""The simulation loop: a flight stack, threats, a sensor and an avoider, wired together.

Per tick (the shorter of the sensor's period, 1 s by default, and the avoider's) the loop

1. flies the vehicle for one tick in one compiled call of its flight stack
   (:class:`replay.flight.fixedwing.stack.FixedWingStack`: the 6-DOF aircraft under its autopilot, RK4 at
   100 Hz), sampling the state at ``sample_hz``;
2. advances the threats (intruders move on their own schedule) and measures, at every sample, the
   separation to each active threat's safety volume and to each of the mission's danger zones,
   the clearance above the terrain (the measured, conservative heights: the bilinear surface
   through the highest source value of each grid cell, the ground the sensors see), whether the aircraft is over the map and over measured terrain, its equivalent
   airspeed against its stall speed and its track against the autopilot's guidance
   (:mod:`replay.judge`);
3. records the samples (the recorder keeps its own log rate), leg changes and threat changes;
4. scans with the sensor when it is due (``radar``, the ADS-B-like ``cooperative``, or the
   ``rangefinder`` beams of :mod:`replay.sensors.rangefinder`, given the vehicle's state), and asks
   the avoider when it is due; its command goes to the flight stack at once (a command the stack
   refuses is recorded with the reason), and every decision is recorded with its compute time.

The run ends when the final waypoint is reached (``goal``), the aircraft touches the terrain
(``terrain contact``), the avoider ends it with an outcome (e.g. ``target unreachable``) or the
time limit passes (``time limit``).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from planner.mission import Mission
from replay.avoidance.base import AvoidanceContext, Avoider
from replay.avoidance.registry import SENSORS, decide_checked, hook_checked
from replay.flight.atmosphere import check_offset
from replay.flight.base import FlightStack, Vehicle
from replay.flight.energy import source_of
from replay.flight.log import GUIDANCE_COLUMNS, FlightLog
from replay.flight.wind import Dryden, Wind, dryden_scales
from replay.frames import U, V, W, ned_to_map, rotation_body_to_ned, velocities_ned
from replay.guidance import (
    AvoidanceDecision,
    Commanded,
    FollowWaypoints,
    GuidanceRefused,
    command_record,
)
from replay.judge import (
    ORBIT_GAIN,
    RETURN_TIME_S,
    SETTLE_S,
    Conformance,
    StallJudge,
    Tolerances,
    gust_altitude_error,
    stall_eas,
)
from replay.metrics import MetricsTracker, RunMetrics
from replay.record.base import Recorder
from replay.record.separation import SHOWN
from replay.sensors.base import Sensor
from replay.threats.book import SeparationBook
from replay.threats.kinds import ThreatSet
from replay.threats.table import ThreatTable
from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrain.validity import ValidityChecker

if TYPE_CHECKING:
    from terrain.model import TerrainModel
    from terrain.zones import Zone

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class ReplayConfig:
    """Settings of one replay. Times in seconds, distances in metres."""

    seed: int = 0
    duration: float | None = None  # None: 1.5 x the mission's flight time at cruise + 10 min
    sample_hz: float = 10.0  # trajectory samples for metrics, recording and the result
    radar_range: float = 10_000.0
    radar_period: float = 1.0
    radar_noise_range: float = 0.0
    radar_noise_bearing: float = 0.0
    terrain_returns: bool = True
    terrain_clearance: float | None = (
        None  # radar: terrain above own altitude - this (None: radar default)
    )
    terrain_following: float | None = None  # autopilot: keep at least this clearance (None: off)
    switch_distance: float = 1000.0  # fixed wing without turn fillets (seed 000 §3.6)
    airspeed: float | None = None  # None: the mission's cruise speed
    avoid_period: float | None = None  # s between avoider calls (None: avoider's, else sensor's)
    sensor: str = "radar"  # "radar" (seed 000), "cooperative" (ADS-B-like) or "rangefinder"
    margin: float = 0.0  # success needs every separation >= this (m; 0: outside the surfaces)
    coop_noise_position: float = 0.0  # cooperative sensor: 1-sigma position noise (m)
    coop_noise_velocity: float = 0.0  # cooperative sensor: 1-sigma velocity noise (m/s)
    coop_latency: float = 0.0  # cooperative sensor: age of the reports (s)
    rangefinder_range: float = 20.0  # rangefinders (replay.sensors.rangefinder): range R (m)
    rangefinder_period: float = 0.1  # s between scans (10 Hz)
    rangefinder_beams: int = 4  # evenly spaced from the front
    rangefinder_mount: str = "gimballed"  # or "body" (fixed in the body, tilting with it)
    rangefinder_noise: float = 0.0  # 1-sigma range noise (m)
    # each beam a cone of this half-angle (deg; None: the avoider's choice, else a line)
    rangefinder_spread: float | None = None
    temperature_offset: float = 0.0  # K off the ISA standard day (hot day > 0), within +-50
    wind: Wind | None = None  # the air mass (replay.flight.wind); None: still air
    # success: time over terrain the DEM did not measure is accepted (else a failure)
    allow_unknown_terrain: bool = False
    # conformance (replay.judge): the track within these of the plan (m; None: the larger of
    # 30 m and half the planned clearance / of 50 m and a quarter of the turn radius), and back
    # within them this long (s) after an avoider's manoeuvre, a new plan or a leg change that is
    # not a fillet (None: the longer of 60 s and two corner distances of flight)
    vertical_tolerance: float | None = None
    lateral_tolerance: float | None = None
    return_time: float | None = None

    def __post_init__(self) -> None:
        if self.avoid_period is not None and not (
            isinstance(self.avoid_period, int | float)
            and math.isfinite(self.avoid_period)
            and self.avoid_period > 0
        ):
            raise InputError(
                f"replay setting 'avoid_period' must be a positive number; got {self.avoid_period!r}"
            )
        check_offset(self.temperature_offset, "replay setting 'temperature_offset'")
        if self.wind is not None and not isinstance(self.wind, Wind):
            raise InputError(
                f"replay setting 'wind' must be a Wind (replay.flight.wind); got {self.wind!r}"
            )
        if self.sensor not in SENSORS:
            raise InputError(f"unknown sensor {self.sensor!r}; choose one of {', '.join(SENSORS)}")
        beams = self.rangefinder_beams
        if isinstance(beams, bool) or not isinstance(beams, int) or beams < 1:
            raise InputError(
                f"replay setting 'rangefinder_beams' must be an integer >= 1; got {beams!r}"
            )
        if self.rangefinder_mount not in ("gimballed", "body"):
            mount = self.rangefinder_mount
            raise InputError(
                f"replay setting 'rangefinder_mount' must be gimballed or body; got {mount!r}"
            )
        spread = self.rangefinder_spread
        if spread is not None and not (
            isinstance(spread, int | float) and math.isfinite(spread) and 0 <= spread < 45
        ):
            raise InputError(
                f"replay setting 'rangefinder_spread' must be a number of degrees in [0, 45); "
                f"got {spread!r}"
            )
        for name in (
            "coop_noise_position",
            "coop_noise_velocity",
            "coop_latency",
            "margin",
            "rangefinder_noise",
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise InputError(f"replay setting {name!r} must be a number >= 0; got {v!r}")
        for name in ("vertical_tolerance", "lateral_tolerance", "return_time"):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise InputError(f"replay setting {name!r} must be a positive number; got {v!r}")
        for name in (
            "sample_hz",
            "radar_range",
            "radar_period",
            "switch_distance",
            "rangefinder_range",
            "rangefinder_period",
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise InputError(f"replay setting {name!r} must be a positive number; got {v!r}")
        if self.duration is not None and not (math.isfinite(self.duration) and self.duration > 0):
            raise InputError(
                f"duration must be a positive number of seconds; got {self.duration!r}"
            )

    def make_sensor(self, rng: np.random.Generator, spread_deg: float = 0.0) -> Sensor:
        """The configured sensor, drawing its noise from ``rng`` (the run's generator):
        ``radar`` (seed 000), ``cooperative`` (ADS-B-like reports) or ``rangefinder`` (beams by
        ray casting, each a cone of ``spread_deg``; seed 003's world of fixed obstacles: the
        avoiders act on stationary returns only)."""
        if self.sensor == "cooperative":
            from replay.sensors.cooperative import CooperativeSensor

            return CooperativeSensor(
                range_m=self.radar_range,
                period_s=self.radar_period,
                noise_position_m=self.coop_noise_position,
                noise_velocity_mps=self.coop_noise_velocity,
                latency_s=self.coop_latency,
                seed=rng,
            )
        if self.sensor == "rangefinder":
            from replay.sensors.rangefinder import Rangefinders

            return Rangefinders(
                range_m=self.rangefinder_range,
                period_s=self.rangefinder_period,
                beams=self.rangefinder_beams,
                mount=self.rangefinder_mount,
                noise_m=self.rangefinder_noise,
                seed=rng,
                assume_static=True,
                spread_deg=spread_deg,
            )
        from replay.sensors.radar import Radar

        return Radar(
            range_m=self.radar_range,
            period_s=self.radar_period,
            noise_range_m=self.radar_noise_range,
            noise_bearing_rad=self.radar_noise_bearing,
            seed=rng,
        )


@dataclass(frozen=True, eq=False)
class ReplayResult:
    """What a replay produced: metrics, the sampled trajectory, the final waypoint list."""

    metrics: RunMetrics
    times: FloatArray
    states: FloatArray  # (K, 12) NED
    positions: FloatArray  # (K, 3) map
    waypoints: FloatArray  # final list (map)
    initial_waypoints: FloatArray
    decisions: tuple[dict[str, Any], ...]
    seed: int
    wall_s: float
    extra: dict[str, Any] = field(default_factory=dict)


def estimated_flight_time(waypoints: FloatArray, speed: float) -> float:
    return float(np.linalg.norm(np.diff(waypoints, axis=0), axis=1).sum() / speed)


def strongest_wind(mission: Mission, cfg: ReplayConfig) -> float:
    """The fastest horizontal wind (m/s) of the run between the mission's lowest and highest
    waypoints (0 in still air)."""
    if cfg.wind is None or cfg.wind.calm:
        return 0.0
    z = np.asarray(mission.waypoints, dtype=np.float64)[:, 2]
    return float(cfg.wind.strongest(float(z.min()), float(z.max())))


def time_limit(mission: Mission, cfg: ReplayConfig, avoider: Any = None) -> float:
    """How long a replay may fly (s): the configured duration, else 1.5 x the mission's flight
    time at its airspeed (into the strongest wind on the way: less its speed; its spirals'
    circles counted) + 10 minutes, or longer where the
    avoider bounds its own flight (``time_limit_s``: an explorer such as the priority loop, which
    ends itself with its own outcome)."""
    if cfg.duration:
        return float(cfg.duration)
    speed = float(cfg.airspeed or mission.cruise_speed)
    # the ground speed into the strongest wind on the way (at least a fifth of the airspeed)
    speed = max(speed - strongest_wind(mission, cfg), 0.2 * speed)
    loops = sum(2.0 * math.pi * sp.radius * sp.turns for sp in mission.spirals)  # climb spirals
    flight = estimated_flight_time(np.asarray(mission.waypoints, np.float64), speed)
    own = getattr(avoider, "time_limit_s", None)
    return max(1.5 * (flight + loops / speed) + 600.0, float(own or 0.0))


def check_mission(mission: Mission, grid: HeightGrid | None) -> None:
    """Waypoints must lie inside the map and above the terrain (flat ground at 0 m without one)."""
    w = mission.waypoints
    where = f"{mission.source!r}: " if mission.source else ""
    if grid is None:
        low = np.flatnonzero(w[:, 2] <= 0.0)
        if low.size:
            i = int(low[0])
            raise InputError(
                f"{where}waypoint {i} at {w[i, 2]:.1f} m is not above the ground (0 m, no terrain)"
            )
        return
    inside = grid.contains(w[:, 0], w[:, 1])
    if not inside.all():
        i = int(np.flatnonzero(~inside)[0])
        raise InputError(
            f"{where}waypoint {i} ({w[i, 0]:.1f}, {w[i, 1]:.1f}) lies outside the map {tuple(round(b, 1) for b in grid.bounds)}"
        )
    ground = grid.height_at(w[:, 0], w[:, 1])
    below = np.flatnonzero(w[:, 2] <= ground)
    if below.size:
        i = int(below[0])
        raise InputError(
            f"{where}waypoint {i} at {w[i, 2]:.1f} m AMSL is below the terrain there ({ground[i]:.1f} m)"
        )


def rangefinder_spread(cfg: ReplayConfig, avoider: Avoider) -> float:
    """The half-angle of the rangefinders' beams (deg): the setting, else the avoider's
    (``rangefinder_spread_deg(R)``: the priority loop's sees tau round a beam's axis at R - tau),
    else 0 (a line)."""
    if cfg.rangefinder_spread is not None:
        return float(cfg.rangefinder_spread)
    return float(hook_checked(avoider, "rangefinder_spread_deg", cfg.rangefinder_range))


def simulate(
    mission: Mission,
    threats: ThreatSet,
    avoider: Avoider,
    vehicle: Vehicle,
    *,
    grid: HeightGrid | None = None,
    terrain_model: TerrainModel | None = None,
    config: ReplayConfig | None = None,
    recorder: Recorder | None = None,
    progress: Callable[[float, float], None] | None = None,
    sensor: Sensor | None = None,
    stack: FlightStack | None = None,
) -> ReplayResult:
    """Fly ``mission`` with ``vehicle`` among ``threats``, letting ``avoider`` react to what the
    sensor sees at its own period.

    The flight stack is the vehicle's own (:meth:`replay.flight.base.Vehicle.flight_stack`: the
    mission's waypoints at its cruise speed or the configured one, its turn radius, terrain
    following when configured) unless ``stack`` is given; the sensor is the configured one
    (:meth:`ReplayConfig.make_sensor`, seeded with the run's generator, which the avoider shares)
    unless ``sensor`` is given. ``recorder`` (:class:`replay.record.base.Recorder`) records the
    run; ``progress(t, limit)`` is called after every tick."""
    cfg = config or ReplayConfig()
    wall0 = time.perf_counter()
    check_mission(mission, grid)
    rng = np.random.default_rng(cfg.seed)
    if stack is None:
        stack = _vehicle_stack(mission, vehicle, grid, cfg)
    wind = check_wind(cfg, mission, stack.name)
    if wind is not None:  # the start crabbed into the wind where it starts
        stack.set_wind(_wind_at(wind, mission.waypoints[0], grid.safety() if grid else None))
    x = stack.initial_state()  # first: "cannot trim" names the speeds it can fly
    if sensor is None:
        sensor = cfg.make_sensor(rng, rangefinder_spread(cfg, avoider))
    loop = _Loop(mission, threats, avoider, stack, sensor, grid, terrain_model, cfg, recorder)
    hook_checked(avoider, "reset", loop.wp0, rng)  # a plugin's crash: one line
    loop.fly(x, progress)
    metrics = loop.finish()
    tt = np.concatenate(loop.times) if loop.times else np.zeros(0)
    xx = np.concatenate(loop.states) if loop.states else np.zeros((0, 12))
    return ReplayResult(
        metrics=metrics,
        times=tt,
        states=xx,
        positions=ned_to_map(xx[:, :3]) if len(xx) else np.zeros((0, 3)),
        waypoints=stack.waypoints,
        initial_waypoints=loop.wp0,
        decisions=tuple(loop.decisions),
        seed=cfg.seed,
        wall_s=time.perf_counter() - wall0,
        # the air's velocity (K, 3) NED at every sample, gusts included (a run with wind)
        extra={
            **({"wind": np.concatenate(loop.air)} if loop.air else {}),
            # what the source had given at every sample (Wh of battery, kg of fuel)
            "energy": np.concatenate(loop.energy) if loop.energy else np.zeros(0),
        },
    )


def _vehicle_stack(
    mission: Mission, vehicle: Vehicle, grid: HeightGrid | None, cfg: ReplayConfig
) -> FlightStack:
    """The vehicle's flight stack for the mission: its waypoints at its cruise speed (or the
    configured one), its turn fillets when it records a turn radius (else seed 000's 1 km leg
    switch), terrain following when configured (above the grid's conservative heights), in the
    configured day's air."""
    return vehicle.flight_stack(
        np.array(mission.waypoints, dtype=np.float64),
        speed=float(cfg.airspeed or mission.cruise_speed),
        turn_radius=mission.turn_radius,
        switch_distance=cfg.switch_distance,
        # the conservative heights the planner's clearance was checked on (bilinear: smooth
        # enough for the controller's look-ahead)
        terrain_height=(
            grid.safety().height_at if (grid is not None and cfg.terrain_following) else None
        ),
        terrain_clearance=cfg.terrain_following or 0.0,
        temperature_offset=cfg.temperature_offset,
        spirals=mission.spirals,
        land=isinstance(mission.plan, dict) and "landing" in mission.plan,
        leg_heights=mission.terrain_heights if cfg.terrain_following else None,
        # the mission's speed changes, unless the run names its own speed
        leg_speeds=mission.speeds if not cfg.airspeed else None,
    )


def check_wind(cfg: ReplayConfig, mission: Mission, vehicle: str) -> Wind | None:
    """The run's wind (None in still air); a wind as fast as the airspeed anywhere between the
    mission's lowest and highest waypoints is refused: the aircraft could not make headway."""
    wind = cfg.wind
    if wind is None or wind.calm:
        return None
    speed = float(cfg.airspeed or mission.cruise_speed)
    fastest = strongest_wind(mission, cfg)
    if fastest >= speed:
        raise InputError(
            f"wind {fastest:.1f} m/s ({wind.describe()}) is not slower than {vehicle}'s "
            f"{speed:g} m/s airspeed: it could not make headway; fly faster (--speed) or in "
            "less wind"
        )
    return wind


def _wind_at(wind: Wind, position: npt.ArrayLike, grid: HeightGrid | None) -> FloatArray:
    """The air's velocity (3,) NED at a map ``position`` (for a profile, its height over
    ``grid``: the measured heights, ``HeightGrid.safety``, the ground the gusts' scales and the
    judge use too)."""
    p = np.asarray(position, dtype=np.float64)
    ground = float(grid.height_at(p[0], p[1])) if grid is not None else 0.0
    return np.asarray(wind.velocity(float(p[2]), float(p[2]) - ground), dtype=np.float64)


class _Loop:
    """One replay while it flies: the stack, sensor and avoider, what is judged (threats, zones,
    terrain, map) and what is kept (samples, decisions, the end)."""

    def __init__(
        self,
        mission: Mission,
        threats: ThreatSet,
        avoider: Avoider,
        stack: FlightStack,
        sensor: Sensor,
        grid: HeightGrid | None,
        terrain_model: TerrainModel | None,
        cfg: ReplayConfig,
        recorder: Recorder | None,
    ) -> None:
        self.mission, self.threats, self.avoider = mission, threats, avoider
        self.stack, self.sensor, self.grid, self.cfg = stack, sensor, grid, cfg
        self.wind = None if cfg.wind is None or cfg.wind.calm else cfg.wind
        self.wind_varies = self.wind is not None and (
            bool(self.wind.layers) or self.wind.profile != "uniform"
        )
        # terrain is judged on the measured, conservative heights (the display heights are for
        # the picture): the surface the sensors see and terrain following keeps clear of; the
        # height over the ground of a wind profile and of the gusts' scales too
        self.safety = grid.safety() if grid is not None else None
        self.wind_now = (
            _wind_at(self.wind, mission.waypoints[0], self.safety)
            if self.wind is not None
            else np.zeros(3)
        )
        # Dryden turbulence on its own seeded stream (the same gusts for the same seed, whatever
        # the sensor and the avoider draw); the tick's gusts, step by step
        self.dryden = None
        if self.wind is not None and self.wind.turbulence is not None:
            # the span of the rotational gusts: a fixed wing's; a multirotor's rotor disc
            # (its rotational gusts are not flown: replay.flight.multirotor.kernels.fly)
            span = getattr(stack.params, "b", None) or 2.0 * float(
                getattr(stack.params, "arm", 0.25)
            )
            self.dryden = Dryden(self.wind.turbulence, float(span), [cfg.seed, 36])
        self.gust_now = np.zeros((0, 6))
        self.tick_t0 = 0.0
        # what the source gave (replay.flight.energy): at the tick's start and end
        self.source = source_of(stack.params)
        self.used0 = self.used = 0.0
        self.energy: list[FloatArray] = []  # what was used at the kept samples (Wh or kg)
        self.air: list[FloatArray] = []  # the air's velocity at the kept samples
        self.terrain_model, self.recorder = terrain_model, recorder
        self.wp0 = np.array(mission.waypoints, dtype=np.float64)
        self.duration = time_limit(mission, cfg, avoider)
        scan_period = float(sensor.period_s)
        self.avoid_period = float(cfg.avoid_period or avoider.period or scan_period)
        self.tick = min(scan_period, self.avoid_period)
        self.next_decision = 0.0
        self.zones = tuple(f"zone:{z.id or k}" for k, z in enumerate(mission.danger_zones))
        self.tracker = MetricsTracker(
            [*threats.ids, *self.zones],
            self.wp0[0],
            self.wp0[-1],
            cfg.margin,
            allow_unknown=cfg.allow_unknown_terrain,
        )
        self.contact_at: tuple[float, float, float] | None = None
        self.tolerances = tolerances(mission, stack, cfg)
        params = stack.params
        climb = climb_rate(
            params,
            float(cfg.airspeed or mission.cruise_speed),
            float(self.wp0[:, 2].max()),
            cfg.temperature_offset,
        )
        speed = float(cfg.airspeed or mission.cruise_speed)
        tightest = getattr(params, "min_turn_radius", None)
        autopilot = getattr(stack, "autopilot", None)
        self.conformance = Conformance(
            self.tolerances,
            climb,
            float(getattr(params, "descent_rate_max", climb)),
            speed=speed,
            turn_rate=math.inf if tightest is None else speed / float(tightest(speed)),
            orbit_gain=float(getattr(autopilot.config, "orbit_gain", ORBIT_GAIN))
            if autopilot is not None
            else ORBIT_GAIN,
        )
        eas = stall_eas(stack.params)
        self.stall = None if eas is None else StallJudge(eas, cfg.temperature_offset)
        self.record_every = max(1, int(round(1.0 / (cfg.sample_hz * stack.dt))))
        self.times: list[FloatArray] = []
        self.states: list[FloatArray] = []
        self.decisions: list[dict[str, Any]] = []
        self.spiral_exits: list[dict[str, Any]] = []
        self.t = 0.0
        self.end_reason = "time limit"
        self.contact = False
        self.table = ThreatTable(threats.threats)  # activity and separations of every threat
        # what the metrics judge the flight by: the map, its measured terrain, the mission's
        # danger zones (no-fly volumes) and the threats' safety volumes -- those measured where
        # they can matter (replay.threats.book)
        self.validity = ValidityChecker(grid=grid, zones=mission.danger_zones)
        self.book = SeparationBook(self.table, cfg.margin)
        # what an avoider's new waypoints and legs must pass: the same without the threats,
        # which the avoider knows only through its sensor
        self.candidates = ValidityChecker(grid=grid, zones=mission.danger_zones)
        self.shown = np.zeros(len(self.table), dtype=bool)  # the active threats last recorded
        self.pending: list[tuple[FloatArray, FloatArray, FloatArray]] = []
        self.picture: Any = None
        if recorder is not None:
            recorder.write_waypoints(0.0, self.wp0, "initial", 1)

    def ground(self, x: FloatArray, y: FloatArray) -> FloatArray:
        """The terrain the flight is judged against, from the measured heights: the bilinear
        surface through the grid's safety heights (on a resampled grid, ``upper``: the highest
        source value in each cell, the heights the planner checks clearance with; else the
        source cells themselves) -- the surface terrain following keeps clear of and the one the
        sensors see (``run.run_replay`` builds the ray-casting mesh from it); 0 m without a map.

        Not the cell's highest value held over the whole cell: that value lies somewhere in the
        cell, and on a coarse grid (Jacksboro's 75 m) a block of it stands up to 12 m above the
        surface through the same values -- an aircraft the sensors keep 2 m above the measured
        ground would be "in contact" with a block edge they cannot see. The summit the display
        grid smooths away (RMNP: 4,261 m measured, 4,192 m displayed) is contact either way."""
        g = self.safety
        if g is None:
            return np.zeros_like(np.asarray(x, dtype=np.float64))
        return g.height_at(x, y)

    def fly(self, x: FloatArray, progress: Callable[[float, float], None] | None) -> None:
        """Tick by tick until the goal, terrain contact, the avoider's end or the time limit."""
        t = 0.0
        stack = self.stack
        while t < self.duration - 1e-9:
            period = min(self.tick, self.duration - t)
            if period < 0.5 * stack.dt:
                break  # the limit falls between two steps of the integrator: nothing left to fly
            if self.wind is not None and self.wind_varies:
                # the wind where the aircraft is, held for the tick (a profile or layers)
                self.wind_now = _wind_at(self.wind, ned_to_map(x[:3]), self.safety)
                stack.set_wind(self.wind_now)
            self.conformance.wind = (float(self.wind_now[0]), float(self.wind_now[1]))
            if self.dryden is not None:
                self._gusts(x, t, period)
            following = follows_plan(stack)
            commanded = None if following else stack.commanded(t)
            self.tick_t0 = t
            log = stack.fly(x, t, period, record_every=self.record_every)
            x, t = log.x, log.t
            self.used0, self.used = self.used, float(getattr(stack, "energy_used", 0.0))
            contact_t = self._samples(log, following, commanded)
            if contact_t is not None:
                t = contact_t
                break
            if self.source.exhausted(self.used):
                t = self._exhausted(t)
                break
            self._events(log, t)
            if progress is not None:
                progress(t, self.duration)
            if stack.done:
                self.end_reason = _arrival(stack, ned_to_map(x[:3]))
                break
            if self.sensor.due(t):
                self._scan(t, x)
            if self._decide(t, x):
                break
        self.t = t

    def _gusts(self, x: FloatArray, t: float, period: float) -> None:
        """The turbulence of the tick, step by step, handed to the stack (and kept for the
        judge and the recording): at the airspeed flown and the height over the ground here."""
        assert self.dryden is not None
        stack = self.stack
        pos = ned_to_map(x[:3])
        height = float(pos[2] - self.ground(np.array([pos[0]]), np.array([pos[1]]))[0])
        speed = getattr(stack, "airspeed", None) or self.cfg.airspeed or self.mission.cruise_speed
        n = int(round(period / stack.dt)) + 1
        self.gust_now = self.dryden.gusts(n, stack.dt, float(speed), height, float(x[8]))
        stack.set_gusts(self.gust_now)

    def winds(self, ts: FloatArray) -> FloatArray:
        """The air's velocity (K, 3) NED at the tick's sample times: the wind, and the gusts of
        the steps they fall on."""
        out = np.broadcast_to(self.wind_now, (len(ts), 3)).copy()
        g = self.gust_now
        if len(g):
            k = np.round((np.asarray(ts) - self.tick_t0) / self.stack.dt).astype(np.int64)
            out += g[np.clip(k, 0, len(g) - 1), :3]
        return out

    def _exhausted(self, t1: float) -> float:
        """The source ran out in the tick from ``tick_t0`` to ``t1``: when (linear in the
        tick), the run's end."""
        t0 = self.tick_t0
        src = self.source
        a, b = src.amount(self.used0), src.amount(self.used)
        f = (src.capacity - a) / (b - a) if b > a else 1.0
        t = t0 + min(max(f, 0.0), 1.0) * (t1 - t0)
        self.end_reason = (
            f"energy exhausted: the {src.kind} ({src.capacity:g} {src.unit}) ran out at "
            f"t = {t:.0f} s"
        )
        self.used = src.capacity * src.per_unit  # all of it
        if self.recorder is not None:
            self.recorder.write_log(t, "error", self.end_reason)
        return t

    def _energy_at(self, ts: FloatArray, t1: float) -> FloatArray:
        """What the source had given at the sample times ``ts`` of the tick from ``tick_t0``
        to ``t1`` (linear in the tick), in its unit."""
        t0 = self.tick_t0
        src = self.source
        a, b = src.amount(self.used0), src.amount(self.used)
        f = np.clip((np.asarray(ts) - t0) / max(t1 - t0, 1e-9), 0.0, 1.0)
        used = a + f * (b - a)
        if src.capacity > 0:  # none beyond what it carries (the tick it ran out in)
            used = np.minimum(used, src.capacity)
        return np.asarray(used, dtype=np.float64)

    def _samples(
        self, log: FlightLog, following: bool = True, commanded: Commanded | None = None
    ) -> float | None:
        """Keep the tick's samples (up to terrain contact) for the metrics and the recording,
        and judge them (stall, conformance: ``following`` whether the stack followed its legs,
        else the avoider's command it flew, ``commanded``); the time of terrain contact, else
        None."""
        ts, xs = log.times, log.states
        if not len(ts):
            return None
        pos = ned_to_map(xs[:, :3])
        clearance = pos[:, 2] - self.ground(pos[:, 0], pos[:, 1])
        hit = np.flatnonzero(clearance < 0.0)
        keep = int(hit[0]) + 1 if hit.size else len(ts)
        self.pending.append((ts[:keep], pos[:keep], clearance[:keep]))
        self.times.append(ts[:keep])
        self.states.append(xs[:keep])
        air = self.winds(ts) if self.wind is not None else None  # the air's velocity (K, 3)
        if air is not None:
            self.air.append(air[:keep])
        used = self._energy_at(ts, log.t)
        self.energy.append(used[:keep])
        self._judge(log, pos, keep, following, commanded, air)
        rec = self.recorder
        if rec is not None:
            _record_samples(rec, log, pos, air, used, self.source.capacity)
        if ts[keep - 1] - self.pending[0][0][0] >= _METRICS_BATCH_S:
            _flush(self.pending, self.validity, self.tracker, self.zones, rec, self.book)
        if not hit.size:
            return None
        self.contact = True
        self.end_reason = "terrain contact"
        h = int(hit[0])
        self.contact_at = (float(pos[h, 0]), float(pos[h, 1]), float(clearance[h]))
        if rec is not None:
            where = f"x={pos[hit[0], 0]:.0f}, y={pos[hit[0], 1]:.0f}"
            rec.write_log(float(ts[hit[0]]), "error", f"terrain contact at {where}")
        return float(ts[hit[0]])

    def _judge(
        self,
        log: FlightLog,
        pos: FloatArray,
        keep: int,
        following: bool,
        commanded: Commanded | None = None,
        air: FloatArray | None = None,
    ) -> None:
        """Stall and conformance of the first ``keep`` samples of the tick (``air``: the air's
        velocity at each sample, None in still air)."""
        ts, g = log.times[:keep], log.guidance[:keep]
        if self.stall is not None:
            # the speed through the air: the ground velocity less the wind's
            v = velocities_ned(log.states[:keep])
            airspeed = np.linalg.norm(v if air is None else v - air[:keep], axis=1)
            self.stall.update(ts, pos[:keep], airspeed)
        # a leg change that is not a fillet turns the aircraft onto a leg it is not yet on
        turns = [r.t for r in log.reached if r.how not in ("fillet", "spiral")]
        self.conformance.update(
            ts,
            pos[:keep],
            g[:, _CROSS_TRACK],
            g[:, _ALTITUDE_CMD],
            following,
            converge_from=turns,
            commanded=commanded,
        )
        # where a leg ends, the altitude against the plan's (Conformance.waypoint): the leg's
        # profile to the altitude its end is arrived at (a spiral's entry); where a spiral ends,
        # the waypoint's own altitude
        if following and len(ts):
            wps = np.asarray(self.stack.waypoints, dtype=np.float64)
            arrivals = getattr(self.stack, "arrivals", wps[:, 2])
            heights = getattr(self.stack, "leg_heights", {})
            for r in log.reached:
                if not (1 <= r.index < len(wps) or (r.how == "spiral" and r.index == 0)):
                    continue
                k = min(int(np.searchsorted(ts, r.t)), len(ts) - 1)
                if r.how == "spiral":
                    # the plan's altitude where the helix touches the path again
                    planned = getattr(self.stack, "spiral_exits", {}).get(r.index, wps[r.index, 2])
                    leg = np.array([[*pos[k, :2], planned], [*pos[k, :2], planned]])
                    self.spiral_exits.append(
                        {
                            "waypoint": int(r.index),
                            "t": round(float(r.t), 2),
                            "altitude": round(float(pos[k, 2]), 2),
                            "planned": round(float(planned), 2),
                        }
                    )
                elif r.index in heights and self.safety is not None:
                    # a terrain-frame leg: its height above the ground the autopilot follows
                    ground = float(np.asarray(self.safety.height_at(pos[k, 0], pos[k, 1])))
                    planned = ground + heights[r.index]
                    leg = np.array([[*pos[k, :2], planned], [*pos[k, :2], planned]])
                else:
                    leg = wps[r.index - 1 : r.index + 1].copy()
                    leg[1, 2] = arrivals[r.index]
                self.conformance.waypoint(
                    r.index,
                    r.t,
                    pos[k],
                    leg,
                    g[k, _ALTITUDE_CMD],
                    bool(self.cfg.terrain_following),
                )

    def _events(self, log: FlightLog, t: float) -> None:
        """Record the tick's leg changes and the threats when they changed."""
        rec = self.recorder
        if rec is None:
            return
        for r in log.reached:
            rec.write_log(r.t, "info", f"waypoint {r.index} reached ({r.how}, {r.distance:.0f} m)")
        table = self.table
        active = table.active(t)
        if not np.array_equal(active, self.shown) or bool((active & table.moving).any()):
            rec.write_threats(t, self.threats.shapes(t))
            self.shown = active

    def _scan(self, t: float, x: FloatArray) -> None:
        cfg = self.cfg
        self.picture = picture = self.sensor.scan(
            t,
            ned_to_map(x[:3]),
            self.threats.threats,
            terrain_model=self.terrain_model if cfg.terrain_returns else None,
            min_clearance=cfg.terrain_clearance,
            state=x,
        )
        if self.recorder is not None:
            _record_picture(self.recorder, t, picture)

    def _decide(self, t: float, x: FloatArray) -> bool:
        """Ask the avoider when it is due; True when its decision ends the run."""
        avoider = self.avoider
        if avoider.passive or self.picture is None or t < self.next_decision - 1e-9:
            return False  # "none" never changes the mission: skip building its context
        self.next_decision = t + self.avoid_period
        ctx = _context(
            t,
            x,
            self.picture,
            self.stack,
            self.terrain_model,
            self.cfg,
            self.mission.danger_zones,
            self.candidates,
            self.wind_now,
        )
        t0 = time.perf_counter()
        decision = decide_checked(avoider, ctx)  # a wrong type, a plugin's crash: one line
        compute = time.perf_counter() - t0
        self.tracker.call(compute)
        if decision is None:
            return False
        record = _apply(decision, self.stack, t, compute, avoider, self.tracker, self.recorder)
        self.decisions.append(record)
        if decision.command is not None and "refused" not in record:
            self.conformance.settle(t)  # a new plan or a manoeuvre: time to converge
        if decision.end is None:
            return False
        self.end_reason = decision.end
        if self.recorder is not None:
            self.recorder.write_log(t, "error", f"{avoider.name}: {decision.end}")
        return True

    def _position_at(self, t: float) -> tuple[float, float]:
        """Map (x, y) of the sample at (or just after) time ``t`` (of the samples kept so far)."""
        if not self.times:
            return (math.nan, math.nan)
        if len(self.times) > 1:  # once: the run has ended when this is asked
            self.times, self.states = [np.concatenate(self.times)], [np.concatenate(self.states)]
        times, states = self.times[0], self.states[0]
        k = min(int(np.searchsorted(times, t)), len(times) - 1)
        p = ned_to_map(states[k, :3])
        return (float(p[0]), float(p[1]))

    def finish(self) -> RunMetrics:
        _flush(self.pending, self.validity, self.tracker, self.zones, self.recorder, self.book)
        for tid, (value, t) in self.book.lowest().items():
            self.tracker.lowest(tid, value, t)
        judged = list(self.conformance.failures(self.t))
        if self.stall is not None:
            judged += self.stall.failures(self.t)
        tol = self.tolerances
        metrics = self.tracker.finish(
            self.t,
            reached_goal=self.end_reason == "goal",
            terrain_contact=self.contact,
            end_reason=self.end_reason,
            contact_at=self.contact_at,
            position_at=self._position_at,
            failures=judged,
            off_plan_s=self.conformance.off_plan_s,
            spirals=self.spiral_exits,
            energy=self.source.as_dict(self.used),
            judged_by={
                "terrain": "flat ground at 0 m"
                if self.grid is None
                else "the measured heights: bilinear through each cell's highest source value"
                if self.grid.upper is not None
                else "the measured heights (bilinear)",
                "vertical_tolerance_m": tol.vertical,
                "lateral_tolerance_m": tol.lateral,
                "return_time_s": tol.return_time,
                "stall_eas_mps": None if self.stall is None else self.stall.eas,
                "stall_min_s": None if self.stall is None else self.stall.min_s,
                "allow_unknown_terrain": self.cfg.allow_unknown_terrain,
            },
        )
        if self.recorder is not None:
            self.recorder.write_metrics(metrics.as_dict())
        return metrics


_CROSS_TRACK = GUIDANCE_COLUMNS.index("cross_track")
_ALTITUDE_CMD = GUIDANCE_COLUMNS.index("altitude_cmd")


def follows_plan(stack: FlightStack) -> bool:
    """Whether the stack follows its waypoint legs (or a go-to leg an avoider gave it), rather
    than flying an avoider's commands (a course, an orbit, a climb rate, a held position): the
    fixed wing's autopilot in its ``waypoints`` mode, the multirotor in its ``leg`` mode."""
    autopilot = getattr(stack, "autopilot", None)
    if autopilot is not None:
        return bool(autopilot.guidance.mode == "waypoints")
    mode = getattr(stack, "mode", None)
    return mode is None or mode == "leg"


@functools.lru_cache(maxsize=64)
def climb_rate(params: Any, speed: float, altitude: float, temperature_offset: float) -> float:
    """The climb rate (m/s) the vehicle can keep at ``speed`` up to ``altitude``: its limit, or
    for a fixed wing the best steady climb there when that is less (thin air, little power);
    what the vertical conformance expects of it."""
    limit = float(getattr(params, "climb_rate_max", math.inf))
    if not hasattr(params, "CLalpha"):
        return limit
    from replay.flight.fixedwing.trim import best_climb

    try:
        best = best_climb(params, speed, altitude, temperature_offset)
    except (InputError, ValueError, ArithmeticError):
        return limit
    return min(limit, best) if best > 0.0 else limit


def tolerances(mission: Mission, stack: FlightStack, cfg: ReplayConfig) -> Tolerances:
    """The conformance tolerances of a run: the configured ones, else the defaults from the
    mission's planned clearance and turn radius (else the vehicle's tightest turn at the
    airspeed), and a return time of 60 s, two corner distances of flight (seed 000's switch
    1 km before a waypoint leaves a slow aircraft up to 1 km off its next leg) or one full turn
    of that radius and the settling after it (an avoider's new route may need the aircraft to
    turn round: the Cessna at 50 m/s, turning 441 m at its bank limit, takes 55 s for the circle),
    the longest -- in a wind, flown at the slowest ground speed, into the strongest wind on the
    way (a 15 m/s aircraft into 10 m/s takes three times as long over the ground)."""
    speed = float(cfg.airspeed or mission.cruise_speed)
    over_ground = max(speed - strongest_wind(mission, cfg), 0.2 * speed)
    radius = mission.turn_radius
    if radius is None and hasattr(stack.params, "min_turn_radius"):
        radius = stack.params.min_turn_radius(speed)
    back = cfg.return_time
    if back is None:
        back = max(RETURN_TIME_S, 2.0 * float(stack.corner_distance) / over_ground)
        if radius:
            back = max(back, 2.0 * math.pi * float(radius) / over_ground + SETTLE_S)
    clearance = mission.plan.get("clearance") if isinstance(mission.plan, dict) else None
    tol = Tolerances.of(
        cfg.vertical_tolerance,
        cfg.lateral_tolerance,
        back,
        planned_clearance=clearance if isinstance(clearance, int | float) else None,
        turn_radius=radius,
    )
    turbulence = None if cfg.wind is None else cfg.wind.turbulence
    if turbulence is None or cfg.vertical_tolerance is not None:
        return tol
    # in turbulence the altitude hold keeps the plan only so well: three standard deviations
    # of its error in the vertical gusts (judge.gust_altitude_error), at the height above the
    # ground where they are strongest (MIL-F-8785C's Dryden scales), on top
    gain = _altitude_gain(stack)
    spread = max(
        gust_altitude_error(s[5], s[2], speed, gain)
        for s in (dryden_scales(turbulence, h) for h in GUST_HEIGHTS_M)
    )
    return dataclasses.replace(tol, vertical=round(tol.vertical + GUST_SIGMAS * spread, 1))


GUST_HEIGHTS_M = (30.0, 100.0, 300.0, 600.0, 1000.0, 2000.0, 3000.0)
GUST_SIGMAS = 3.0


def _altitude_gain(stack: FlightStack) -> float:
    """The stack's altitude hold bandwidth (1/s): a fixed wing's altitude gain, a multirotor's
    position gain."""
    autopilot = getattr(stack, "autopilot", None)
    if autopilot is not None:
        return float(autopilot.config.design.altitude_gain)
    return float(getattr(getattr(stack, "design", None), "position_gain", 1.0))


GOAL_MISS_FACTOR = 2.0  # passing the goal's plane farther than this x the arrival distance


def _arrival(stack: FlightStack, position: FloatArray) -> str:
    """The end of the waypoints: "goal" within ``GOAL_MISS_FACTOR`` arrival distances of the
    final waypoint; an aircraft that passed the final waypoint's perpendicular plane farther
    away (the leg ends there too, so that a missed waypoint is not chased) missed the goal."""
    goal = np.asarray(stack.waypoints, dtype=np.float64)[-1]
    miss = float(np.hypot(position[0] - goal[0], position[1] - goal[1]))
    if miss <= GOAL_MISS_FACTOR * stack.arrival_distance:
        return "goal"
    return f"missed the goal (passed it {miss:.0f} m away)"


_METRICS_BATCH_S = 60.0  # separations and metrics are computed over this much flight at once


def _flush(
    pending: list[tuple[FloatArray, FloatArray, FloatArray]],
    validity: ValidityChecker,
    tracker: MetricsTracker,
    zones: tuple[str, ...],
    recorder: Recorder | None = None,
    book: SeparationBook | None = None,
) -> None:
    """Separation to every active threat and to every danger zone of the mission, time off the
    map and over unknown terrain (``validity``; the threats from ``validity``'s volumes, or
    from ``book``: those that can change what is judged or recorded, the smallest separation
    from the others when the run ends, ``SeparationBook.lowest``), and the metrics update, for
    the buffered samples; the separations are recorded (``/vehicle/separation``) too."""
    if not pending:
        return
    ts = np.concatenate([p[0] for p in pending])
    pos = np.concatenate([p[1] for p in pending])
    clearance = np.concatenate([p[2] for p in pending])
    pending.clear()
    pv = validity.points(pos, ts)
    volume_ids, volumes = list(pv.volume_ids), pv.volumes
    if book is not None:
        nearest = SHOWN if recorder is not None else 0  # the threats a record names
        volume_ids, volumes = book.batch(ts, pos, tracker.inside, nearest)
    ids = [*volume_ids, *zones]  # the mission's danger zones after the threats
    seps = np.column_stack([volumes, pv.zones])
    off_map = unknown = None
    grid = validity.grid
    if grid is not None:
        off_map = ~pv.on_map
        if grid.known is not None and grid.has_unknown:
            unknown = ~pv.known & pv.on_map
    tracker.update_columns(ts, pos, ids, seps, clearance, off_map, unknown)
    if recorder is not None:
        recorder.write_separations(ts, ids, seps, margin_m=tracker.margin)


def _record_samples(
    recorder: Recorder,
    log: FlightLog,
    pos: FloatArray,
    wind: FloatArray | None = None,
    used: FloatArray | None = None,
    capacity: float = 0.0,
) -> None:
    """The tick's states (the recorder keeps those at its rate), with the guidance and the
    air's velocity at each (``wind`` (K, 3): ``wind_n``, ``wind_e``, ``wind_d`` m/s NED, gusts
    included, when the run has wind), and what the source has given (``used`` (K,):
    ``energy_used`` in Wh of battery or kg of fuel; with a ``capacity``, ``energy_left`` the
    share left, 0..1): one call, as columns."""
    extras: dict[str, npt.NDArray[Any]] = {
        name: log.guidance[:, j] for j, name in enumerate(GUIDANCE_COLUMNS)
    }
    extras["next_index"] = log.next_index
    if wind is not None:
        extras["wind_n"], extras["wind_e"], extras["wind_d"] = wind[:, 0], wind[:, 1], wind[:, 2]
    if used is not None:
        extras["energy_used"] = used
        if capacity > 0:
            extras["energy_left"] = 1.0 - used / capacity
    recorder.write_states(log.times, log.states, log.controls, extras)


RECORDED_TERRAIN_RETURNS = 48  # the nearest terrain returns of a scan that go into the MCAP


def _record_picture(recorder: Recorder, t: float, picture: Any) -> None:
    """Every threat return of a scan, and its nearest terrain returns (a mountain scan can hold
    hundreds; recording them all would dominate the run's time and file size); and the
    rangefinders' beams (every scan: they show what the beams saw, hits or not). A scan with no
    return and no beams records nothing."""
    if getattr(picture, "beam_ranges", None) is not None:
        recorder.write_beams(t, picture.own_position, picture.beam_ends, picture.beam_hits)
    if not len(picture):
        return
    n = picture.n_threat
    if len(picture) == n:  # threat returns only: all of them, as they are
        terrain = np.zeros(n, dtype=bool)
        recorder.write_detection_arrays(
            t,
            picture.threat_ids,
            picture.positions,
            picture.ranges,
            terrain,
            picture.moving_code == 1,
        )
        return
    near = np.argsort(picture.ranges[n:], kind="stable")[:RECORDED_TERRAIN_RETURNS] + n
    rows = np.concatenate([np.arange(n), near])
    recorder.write_detection_arrays(
        t,
        picture.ids_of(rows),
        picture.positions[rows],
        picture.ranges[rows],
        rows >= n,
        picture.moving_code[rows] == 1,
    )


def _context(
    t: float,
    x: FloatArray,
    picture: Any,
    stack: FlightStack,
    terrain: TerrainModel | None,
    cfg: ReplayConfig,
    zones: tuple[Zone, ...] = (),
    validity: ValidityChecker | None = None,
    wind: FloatArray | None = None,
) -> AvoidanceContext:
    rot = rotation_body_to_ned(x[6], x[7], x[8])
    v_ned = rot @ x[[U, V, W]]
    vel = np.array([v_ned[1], v_ned[0], -v_ned[2]])
    w_ned = np.zeros(3) if wind is None else np.asarray(wind, dtype=np.float64)
    return AvoidanceContext(
        t=t,
        state=x.copy(),
        position=ned_to_map(x[:3]),
        velocity=vel,
        airspeed=float(np.linalg.norm(v_ned - w_ned)),  # through the air
        wind=np.array([w_ned[1], w_ned[0], -w_ned[2]]),
        course=math.atan2(vel[0], vel[1]),
        picture=picture,
        waypoints=stack.waypoints,
        next_index=stack.next_index,
        vehicle=stack.params,
        terrain=terrain,
        terrain_clearance=float(cfg.terrain_following or 0.0),
        switch_distance=float(stack.corner_distance),
        fillets=getattr(stack, "switch_distance", 1.0) == 0.0,
        zones=tuple(zones),
        validity=validity,
    )


def _apply(
    decision: AvoidanceDecision,
    stack: FlightStack,
    t: float,
    compute: float,
    avoider: Avoider,
    tracker: MetricsTracker,
    recorder: Recorder | None,
) -> dict[str, Any]:
    """Hand the decision's command to the flight stack (a refusal is recorded, not raised)."""
    added = 0
    refused = None
    cmd = decision.command
    if cmd is not None:
        before = len(stack.waypoints)
        try:
            stack.apply(cmd)
        except GuidanceRefused as exc:
            refused = str(exc)
        else:
            if isinstance(cmd, FollowWaypoints):
                added = max(0, len(cmd.waypoints) - before)
                if recorder is not None:
                    recorder.write_waypoints(
                        t,
                        cmd.waypoints,
                        f"avoidance: {avoider.name} {decision.reason}".strip(),
                        cmd.next_index,
                    )
    gave_up = None
    if refused is not None:
        gave_up = f"refused by the flight stack: {refused}"
    elif decision.end is not None:
        gave_up = f"ended the run: {decision.end}"
    elif decision.reason.startswith("failed"):
        gave_up = decision.reason
    tracker.decision(compute, added, t=t, gave_up=gave_up)
    record: dict[str, Any] = {
        "t": t,
        "algorithm": avoider.name,
        "reason": decision.reason,
        "compute_s": compute,
        "waypoints_added": added,
        **decision.info,
    }
    if isinstance(cmd, FollowWaypoints):  # its list goes to the waypoint topics
        record["command"] = {
            "command": "FollowWaypoints",
            "next_index": cmd.next_index,
            "direct": cmd.direct,
        }
    elif cmd is not None:
        record["command"] = command_record(cmd)
    if refused is not None:
        record["refused"] = refused
    if decision.end is not None:
        record["end"] = decision.end
    if recorder is not None:
        recorder.write_decision(t, record)
    return record
