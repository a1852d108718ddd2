"""The simulation loop: a flight stack, threats, a sensor and an avoider, wired together.

Per tick (the shorter of the sensor's period, 1 s by default, and the avoider's) the loop

1. flies the vehicle for one tick in one compiled call of its flight stack
   (:class:`replay.flight.fixedwing.stack.FixedWingStack`: the 6-DOF aircraft under its autopilot, RK4 at
   100 Hz), sampling the state at ``sample_hz``;
2. advances the threats (intruders move on their own schedule) and measures, at every sample, the
   separation to each active threat's safety volume and to each of the mission's danger zones,
   the clearance above the terrain, and whether the aircraft is over the map;
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

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.mission import Mission
from replay.avoidance.base import AvoidanceContext, Avoider, NoAvoidance
from replay.flight.atmosphere import check_offset
from replay.flight.base import FlightStack
from replay.flight.fixedwing.params import VehicleParams
from replay.flight.fixedwing.stack import FixedWingStack
from replay.flight.log import GUIDANCE_COLUMNS
from replay.flight.multirotor.model import MultirotorParams
from replay.flight.multirotor.stack import MultirotorStack
from replay.frames import U, V, W, ned_to_map, rotation_body_to_ned
from replay.guidance import AvoidanceDecision, FollowWaypoints, GuidanceRefused, command_record
from replay.metrics import MetricsTracker, RunMetrics
from replay.sensors.radar import Radar
from replay.threats.kinds import ThreatSet
from replay.threats.table import ThreatTable
from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrain.validity import ValidityChecker

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


def time_limit(mission: Mission, cfg: ReplayConfig) -> float:
    """How long a replay may fly (s): the configured duration, else 1.5 x the mission's flight
    time at its airspeed + 10 minutes."""
    if cfg.duration:
        return float(cfg.duration)
    speed = float(cfg.airspeed or mission.cruise_speed)
    return 1.5 * estimated_flight_time(np.asarray(mission.waypoints, np.float64), speed) + 600.0


def fixed_wing_stack(
    mission: Mission, params: VehicleParams, grid: HeightGrid | None, cfg: ReplayConfig
) -> FixedWingStack:
    """The fixed-wing stack a mission is flown with: its waypoints at its cruise speed (or the
    configured one), its turn fillets when it records a turn radius (else seed 000's 1 km leg
    switch), terrain following when configured."""
    return FixedWingStack(
        params,
        np.array(mission.waypoints, dtype=np.float64),
        airspeed=float(cfg.airspeed or mission.cruise_speed),
        turn_radius=mission.turn_radius,
        switch_distance=cfg.switch_distance,
        terrain_height=grid.height_at if (grid is not None and cfg.terrain_following) else None,
        terrain_clearance=cfg.terrain_following or 0.0,
        temperature_offset=cfg.temperature_offset,
    )


def multirotor_stack(
    mission: Mission, params: MultirotorParams, cfg: ReplayConfig
) -> MultirotorStack:
    """The multirotor stack a mission is flown with: its waypoints at its cruise speed (or the
    configured one), in the day's air (no terrain following: it flies the waypoints' altitudes)."""
    return MultirotorStack(
        params,
        np.array(mission.waypoints, dtype=np.float64),
        speed=float(cfg.airspeed or mission.cruise_speed),
        temperature_offset=cfg.temperature_offset,
    )


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


def rangefinder_spread(cfg: ReplayConfig, avoider: Any) -> float:
    """The half-angle of the rangefinders' beams (deg): the setting, else the avoider's
    (``rangefinder_spread_deg(R)``: the priority loop's sees tau round a beam's axis at R - tau),
    else 0 (a line)."""
    if cfg.rangefinder_spread is not None:
        return float(cfg.rangefinder_spread)
    hook = getattr(avoider, "rangefinder_spread_deg", None)
    return float(hook(cfg.rangefinder_range)) if hook is not None else 0.0


def simulate(
    mission: Mission,
    threats: ThreatSet,
    avoider: Avoider,
    vehicle: VehicleParams | MultirotorParams | FlightStack,
    *,
    grid: HeightGrid | None = None,
    terrain_model: Any = None,
    config: ReplayConfig | None = None,
    recorder: Any = None,
    progress: Callable[[float, float], None] | None = None,
) -> ReplayResult:
    """Fly ``mission`` with ``vehicle`` (a flight stack, or fixed-wing parameters: then
    :func:`fixed_wing_stack`, or multirotor parameters: :func:`multirotor_stack`) among
    ``threats``, letting ``avoider`` react to the radar at its own period."""
    cfg = config or ReplayConfig()
    wall0 = time.perf_counter()
    check_mission(mission, grid)
    wp0 = np.array(mission.waypoints, dtype=np.float64)
    duration = time_limit(mission, cfg)
    rng = np.random.default_rng(cfg.seed)
    ground: Callable[[FloatArray, FloatArray], FloatArray]
    if grid is not None:
        ground = grid.height_at
    else:

        def ground(x: FloatArray, y: FloatArray) -> FloatArray:
            return np.zeros_like(np.asarray(x, dtype=np.float64))

    stack: FlightStack
    if isinstance(vehicle, VehicleParams):
        stack = fixed_wing_stack(mission, vehicle, grid, cfg)
    elif isinstance(vehicle, MultirotorParams):
        stack = multirotor_stack(mission, vehicle, cfg)
    else:
        stack = vehicle
    x = stack.initial_state()  # first: "cannot trim" names the speeds it can fly
    radar: Any
    if cfg.sensor == "cooperative":
        from replay.sensors.cooperative import CooperativeSensor

        radar = CooperativeSensor(
            range_m=cfg.radar_range,
            period_s=cfg.radar_period,
            noise_position_m=cfg.coop_noise_position,
            noise_velocity_mps=cfg.coop_noise_velocity,
            latency_s=cfg.coop_latency,
            seed=rng,
        )
    elif cfg.sensor == "rangefinder":
        from replay.sensors.rangefinder import Rangefinders

        # seed 003's world of fixed obstacles: the avoiders act on stationary returns only
        radar = Rangefinders(
            range_m=cfg.rangefinder_range,
            period_s=cfg.rangefinder_period,
            beams=cfg.rangefinder_beams,
            mount=cfg.rangefinder_mount,
            noise_m=cfg.rangefinder_noise,
            seed=rng,
            assume_static=True,
            spread_deg=rangefinder_spread(cfg, avoider),
        )
    else:
        radar = Radar(
            range_m=cfg.radar_range,
            period_s=cfg.radar_period,
            noise_range_m=cfg.radar_noise_range,
            noise_bearing_rad=cfg.radar_noise_bearing,
            seed=rng,
        )
    avoider.reset(wp0, rng)
    passive = isinstance(avoider, NoAvoidance)
    scan_period = float(radar.period_s)
    avoid_period = float(cfg.avoid_period or getattr(avoider, "period", None) or scan_period)
    tick = min(scan_period, avoid_period)
    attitude = cfg.sensor == "rangefinder"  # the sensors that take the vehicle's state
    next_decision = 0.0
    zones = tuple(f"zone:{z.id or k}" for k, z in enumerate(mission.danger_zones))
    tracker = MetricsTracker([*threats.ids, *zones], wp0[0], wp0[-1], cfg.margin)
    record_every = max(1, int(round(1.0 / (cfg.sample_hz * stack.dt))))
    if recorder is not None:
        recorder.write_waypoints(0.0, wp0, "initial", 1)

    times: list[FloatArray] = []
    states: list[FloatArray] = []
    decisions: list[dict[str, Any]] = []
    t = 0.0
    end_reason = "time limit"
    contact = False
    table = ThreatTable(threats.threats)  # activity and separations of every threat at once
    # what the metrics judge the flight by: the map, its measured terrain, the mission's danger
    # zones (no-fly volumes) and the threats' safety volumes
    validity = ValidityChecker(grid=grid, zones=mission.danger_zones, volumes=table)
    # what an avoider's new waypoints and legs must pass: the same without the threats, which
    # the avoider knows only through its sensor
    candidates = ValidityChecker(grid=grid, zones=mission.danger_zones)
    shown = np.zeros(len(table), dtype=bool)  # the active threats last recorded
    pending: list[tuple[FloatArray, FloatArray, FloatArray]] = []
    picture: Any = None
    while t < duration - 1e-9:
        period = min(tick, duration - t)
        if period < 0.5 * stack.dt:
            break  # the limit falls between two steps of the integrator: nothing left to fly
        log = stack.fly(x, t, period, record_every=record_every)
        x, t = log.x, log.t
        ts, xs = log.times, log.states
        if len(ts):
            pos = ned_to_map(xs[:, :3])
            clearance = pos[:, 2] - ground(pos[:, 0], pos[:, 1])
            hit = np.flatnonzero(clearance < 0.0)
            keep = int(hit[0]) + 1 if hit.size else len(ts)
            pending.append((ts[:keep], pos[:keep], clearance[:keep]))
            times.append(ts[:keep])
            states.append(xs[:keep])
            if recorder is not None:
                _record_samples(recorder, log, pos)
            if ts[keep - 1] - pending[0][0][0] >= _METRICS_BATCH_S:
                _flush(pending, validity, tracker, zones, recorder)
            if hit.size:
                contact = True
                end_reason = "terrain contact"
                t = float(ts[hit[0]])
                if recorder is not None:
                    recorder.write_log(
                        t,
                        "error",
                        f"terrain contact at x={pos[hit[0], 0]:.0f}, y={pos[hit[0], 1]:.0f}",
                    )
                break
        if recorder is not None:
            for r in log.reached:
                recorder.write_log(
                    r.t, "info", f"waypoint {r.index} reached ({r.how}, {r.distance:.0f} m)"
                )
            active = table.active(t)
            if not np.array_equal(active, shown) or bool((active & table.moving).any()):
                recorder.write_threats(t, threats.shapes(t))
                shown = active
        if progress is not None:
            progress(t, duration)
        if stack.done:
            end_reason = _arrival(stack, ned_to_map(x[:3]))
            break
        if radar.due(t):
            own = ned_to_map(x[:3])
            picture = radar.scan(
                t,
                own,
                threats.threats,
                terrain_model=terrain_model if cfg.terrain_returns else None,
                min_clearance=cfg.terrain_clearance,
                **({"state": x} if attitude else {}),
            )
            if recorder is not None and (len(picture) or attitude):
                _record_picture(recorder, t, picture)
        if passive or picture is None or t < next_decision - 1e-9:
            continue  # "none" never changes the mission: skip building its context
        next_decision = t + avoid_period
        ctx = _context(t, x, picture, stack, terrain_model, cfg, mission.danger_zones, candidates)
        t0 = time.perf_counter()
        decision = avoider.decide(ctx)
        compute = time.perf_counter() - t0
        tracker.call(compute)
        if decision is not None:
            decisions.append(_apply(decision, stack, t, compute, avoider, tracker, recorder))
            if decision.end is not None:
                end_reason = decision.end
                if recorder is not None:
                    recorder.write_log(t, "error", f"{avoider.name}: {decision.end}")
                break
    _flush(pending, validity, tracker, zones, recorder)
    metrics = tracker.finish(
        t, reached_goal=end_reason == "goal", terrain_contact=contact, end_reason=end_reason
    )
    if recorder is not None:
        recorder.write_metrics(metrics.as_dict())
    tt = np.concatenate(times) if times else np.zeros(0)
    xx = np.concatenate(states) if states else np.zeros((0, 12))
    return ReplayResult(
        metrics=metrics,
        times=tt,
        states=xx,
        positions=ned_to_map(xx[:, :3]) if len(xx) else np.zeros((0, 3)),
        waypoints=stack.waypoints,
        initial_waypoints=wp0,
        decisions=tuple(decisions),
        seed=cfg.seed,
        wall_s=time.perf_counter() - wall0,
    )


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


SENSORS = ("radar", "cooperative", "rangefinder")
_METRICS_BATCH_S = 60.0  # separations and metrics are computed over this much flight at once


def _flush(
    pending: list[tuple[FloatArray, FloatArray, FloatArray]],
    validity: ValidityChecker,
    tracker: MetricsTracker,
    zones: tuple[str, ...],
    recorder: Any = None,
) -> None:
    """Separation to every active threat and to every danger zone of the mission, time off the
    map and over unknown terrain (all from ``validity``), and the metrics update, for the
    buffered samples; the separations are recorded (``/vehicle/separation``) too."""
    if not pending:
        return
    ts = np.concatenate([p[0] for p in pending])
    pos = np.concatenate([p[1] for p in pending])
    clearance = np.concatenate([p[2] for p in pending])
    pending.clear()
    pv = validity.points(pos, ts)
    ids = [*pv.volume_ids, *zones]  # the mission's danger zones after the threats
    seps = np.column_stack([pv.volumes, pv.zones])
    off_map = unknown = None
    grid = validity.grid
    if grid is not None:
        off_map = ~pv.on_map
        if grid.known is not None and grid.has_unknown:
            unknown = ~pv.known & pv.on_map
    tracker.update_columns(ts, pos, ids, seps, clearance, off_map, unknown)
    if recorder is not None:
        recorder.write_separations(ts, ids, seps, margin_m=tracker.margin)


def _record_samples(recorder: Any, log: Any, pos: FloatArray) -> None:
    for i, tk in enumerate(log.times):
        if not recorder.state_due(float(tk)):
            continue
        extras = {name: float(log.guidance[i, j]) for j, name in enumerate(GUIDANCE_COLUMNS)}
        extras["next_index"] = float(log.next_index[i])
        recorder.write_state(float(tk), log.states[i], log.controls[i], extras)


RECORDED_TERRAIN_RETURNS = 48  # the nearest terrain returns of a scan that go into the MCAP


def _record_picture(recorder: Any, t: float, picture: Any) -> None:
    """Every threat return of a scan, and its nearest terrain returns (a mountain scan can hold
    hundreds; recording them all would dominate the run's time and file size); and the
    rangefinders' beams."""
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
        [picture.ids[i] for i in rows.tolist()],
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
    terrain: Any,
    cfg: ReplayConfig,
    zones: tuple[Any, ...] = (),
    validity: ValidityChecker | None = None,
) -> AvoidanceContext:
    rot = rotation_body_to_ned(x[6], x[7], x[8])
    v_ned = rot @ x[[U, V, W]]
    vel = np.array([v_ned[1], v_ned[0], -v_ned[2]])
    return AvoidanceContext(
        t=t,
        state=x.copy(),
        position=ned_to_map(x[:3]),
        velocity=vel,
        airspeed=float(np.linalg.norm(x[[U, V, W]])),
        course=math.atan2(vel[0], vel[1]),
        picture=picture,
        waypoints=stack.waypoints,
        next_index=stack.next_index,
        vehicle=stack.params,
        terrain=terrain,
        terrain_clearance=float(cfg.terrain_following or 0.0),
        switch_distance=float(stack.corner_distance),
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
    recorder: Any,
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
    tracker.decision(compute, added)
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
