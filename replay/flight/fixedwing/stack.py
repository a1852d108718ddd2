"""The fixed-wing flight stack (:class:`replay.flight.base.FlightStack`): the 6-DOF aircraft and
its autopilot, driven by guidance commands.

:class:`FixedWingStack` is the fixed-wing aircraft under :class:`replay.flight.fixedwing.autopilot.Autopilot`:
waypoint legs (turn fillets of the mission's radius, or seed 000's switch 1 km before a
waypoint), hold course, orbit (refused when tighter than V^2 / (g tan(bank_max))), climb rate,
flight-path angle and hold altitude. It cannot hover: go-to, hold-position and yaw-to commands are
refused. The multirotor's stack is :class:`replay.flight.multirotor.stack.MultirotorStack` (go-to,
hold position, yaw-to, waypoints, hold course, orbits at the speed their radius allows).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.spiral import Spiral
from replay.flight.base import G, TerrainHeight
from replay.flight.fixedwing.autopilot import Autopilot, AutopilotConfig
from replay.flight.fixedwing.params import VehicleParams
from replay.flight.fixedwing.trim import trim
from replay.flight.log import FlightLog
from replay.frames import PD, PE, PHI, PN, PSI, THETA, U, W, rotation_body_to_ned
from replay.guidance import (
    HOVER_COMMANDS,
    ClimbRate,
    Commanded,
    FlightPathAngle,
    FollowWaypoints,
    GuidanceCommand,
    GuidanceRefused,
    HoldAltitude,
    HoldCourse,
    Orbit,
    check_command,
)
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
SEED000_SWITCH_M = 1000.0  # seed 000 §3.6: the next leg is taken 1 km before a waypoint
ARRIVAL_M = 100.0
LAND_ARRIVAL_M = 20.0  # a landing: the run ends this close to the touchdown point


class FixedWingStack:
    """A fixed-wing aircraft (``params``) under its autopilot, flying ``waypoints`` at ``airspeed``.

    ``turn_radius``: corners are flown as fillets of that radius (what the planner checked); None:
    seed 000's rule, the next leg 1 km (``switch_distance``) before a waypoint. ``terrain_height``
    and ``terrain_clearance`` > 0 turn on terrain following.
    """

    hover_capable = False

    def __init__(
        self,
        params: VehicleParams,
        waypoints: npt.ArrayLike,
        *,
        airspeed: float | None = None,
        turn_radius: float | None = None,
        switch_distance: float = SEED000_SWITCH_M,
        arrival_distance: float = ARRIVAL_M,
        terrain_height: TerrainHeight | None = None,
        terrain_clearance: float = 0.0,
        temperature_offset: float = 0.0,
        spirals: Sequence[Spiral] = (),
        land: bool = False,
        leg_heights: Mapping[int, float] | None = None,
        leg_speeds: Mapping[int, float] | None = None,
    ) -> None:
        self.params = params
        if land:  # a landing ends at the flare, over the touchdown point, not 100 m short
            arrival_distance = min(arrival_distance, LAND_ARRIVAL_M)
        self.temperature_offset = float(temperature_offset)
        self.name = params.name
        self.airspeed = float(params.cruise_speed if airspeed is None else airspeed)
        self.config = AutopilotConfig(
            switch_distance=switch_distance,
            turn_radius=turn_radius,
            arrival_distance=arrival_distance,
            terrain_clearance=terrain_clearance,
        )
        wp = np.array(waypoints, dtype=np.float64)
        self._wp0 = wp
        # a climb spiral at the first waypoint (a launch spiralling up) starts at its entry
        self._z0 = next((float(sp.entry) for sp in spirals if sp.at == 0), float(wp[0, 2]))
        # trim first: "cannot trim" names the speeds the aircraft can fly, more than the envelope
        self._x0 = self._trimmed_start()
        self.autopilot = Autopilot(
            params,
            wp,
            airspeed=self.airspeed,
            config=self.config,
            terrain_height=terrain_height if terrain_clearance > 0 else None,
            temperature_offset=self.temperature_offset,
        )
        self.autopilot.land = bool(land)
        if leg_heights:
            self.autopilot.set_leg_heights(leg_heights)
        if leg_speeds:
            self.autopilot.set_leg_speeds(leg_speeds)
        if spirals:
            if turn_radius is None:
                raise InputError(
                    "a mission with spirals needs its turn radius (cruise.turn_radius): the "
                    "spirals are tangent to its turn fillets"
                )
            self.autopilot.set_spirals(spirals)
        self.arrival_distance = float(arrival_distance)
        self.switch_distance = 0.0 if turn_radius is not None else float(switch_distance)
        # how far before a waypoint the flown path leaves the leg: the switch distance, or with
        # fillets the tangent distance of a right-angle turn (R tan 45 deg = R)
        self.corner_distance = (
            float(turn_radius) if turn_radius is not None else float(switch_distance)
        )

    # -- state ----------------------------------------------------------------------------------
    @property
    def leg_heights(self) -> dict[int, float]:
        """The terrain-frame legs of the waypoints flown now (index of the waypoint a leg goes
        to -> metres above the ground): :meth:`Autopilot.set_leg_heights`."""
        return self.autopilot.leg_heights

    @property
    def waypoints(self) -> FloatArray:
        return self.autopilot.waypoints

    @property
    def next_index(self) -> int:
        return self.autopilot.next_index

    @property
    def done(self) -> bool:
        return self.autopilot.done

    @property
    def dt(self) -> float:
        return float(self.config.dt)

    def initial_state(self) -> FloatArray:
        """Trimmed level flight at the airspeed over the first waypoint (at a spiral's entry
        when one starts there), its course for the second: in a wind (:meth:`set_wind`) crabbed
        into it, the trim's velocity through the air plus the wind's."""
        x = self._x0.copy()
        w = self.autopilot.wind
        if not w.any():
            return x
        start, nxt = self._wp0[0], self._wp0[min(1, len(self._wp0) - 1)]
        chi = math.atan2(nxt[0] - start[0], nxt[1] - start[1])
        across = -w[0] * math.sin(chi) + w[1] * math.cos(chi)  # the wind across the course
        va = float(np.linalg.norm(x[U : W + 1]))
        x[PSI] = chi - math.asin(max(-1.0, min(1.0, across / va)))
        x[U : W + 1] += rotation_body_to_ned(x[PHI], x[THETA], x[PSI]).T @ w
        return x

    def set_wind(self, wind: npt.ArrayLike) -> None:
        """The air's velocity (NED, m/s) from now on (:meth:`Autopilot.set_wind`)."""
        self.autopilot.set_wind(wind)

    def set_gusts(self, gusts: npt.ArrayLike) -> None:
        """The turbulence of the next :meth:`fly` (:meth:`Autopilot.set_gusts`)."""
        self.autopilot.set_gusts(gusts)

    def _trimmed_start(self) -> FloatArray:
        """The start state; first the level trim at the mission's highest waypoint, where the
        air is thinnest: a mission the aircraft cannot fly up there is refused before take-off,
        naming the altitude and the speeds it can fly there."""
        dtemp = self.temperature_offset
        top = float(self._wp0[:, 2].max())
        trim(self.params, self.airspeed, altitude=top, temperature_offset=dtemp)
        start, nxt = self._wp0[0], self._wp0[min(1, len(self._wp0) - 1)]
        tr = trim(self.params, self.airspeed, altitude=self._z0, temperature_offset=dtemp)
        x = np.array(tr.x, dtype=np.float64)
        x[PN], x[PE], x[PD] = start[1], start[0], -self._z0
        x[PSI] = math.atan2(nxt[0] - start[0], nxt[1] - start[1])
        return x

    # -- commands -------------------------------------------------------------------------------
    def apply(self, command: GuidanceCommand) -> None:
        """Fly ``command`` from now on, or raise :class:`GuidanceRefused` saying why not."""
        cmd = check_command(command)
        ap = self.autopilot
        if isinstance(cmd, HOVER_COMMANDS):
            raise GuidanceRefused(
                f"{type(cmd).__name__} needs a vehicle that can hover; {self.name} is a "
                "fixed-wing aircraft"
            )
        if isinstance(cmd, FollowWaypoints):
            ap.set_waypoints(cmd.waypoints, cmd.next_index, direct=cmd.direct)
            ap.clear_override()
        elif isinstance(cmd, HoldCourse):
            ap.clear_override()
            ap.set_override(course=cmd.course, altitude=cmd.altitude, climb_rate=cmd.climb_rate)
        elif isinstance(cmd, Orbit):
            ap.set_orbit(
                cmd.center,
                cmd.radius,
                clockwise=cmd.clockwise,
                altitude=cmd.altitude,
                center_velocity=cmd.center_velocity,
            )
        elif isinstance(cmd, ClimbRate):
            ap.set_override(climb_rate=cmd.rate)
        elif isinstance(cmd, FlightPathAngle):
            ap.set_override(climb_rate=ap.airspeed * math.sin(cmd.gamma))
        elif isinstance(cmd, HoldAltitude):
            ap.set_override(altitude=cmd.altitude)

    @property
    def spiral_exits(self) -> dict[int, float]:
        """The altitude the plan leaves each spiral flown so far at, by waypoint."""
        return dict(self.autopilot.spiral_exits)

    @property
    def arrivals(self) -> FloatArray:
        """The altitude each waypoint is arrived at (a climb or descent spiral's entry)."""
        return self.autopilot.arrivals

    def commanded(self, t: float) -> Commanded:
        """What the autopilot flies at ``t`` beside its legs (:meth:`Autopilot.commanded`)."""
        return self.autopilot.commanded(t)

    @property
    def energy_used(self) -> float:
        """The battery's energy (J) or the fuel (kg) drawn so far (:attr:`Autopilot.energy_used`)."""
        return self.autopilot.energy_used

    # -- flying ---------------------------------------------------------------------------------
    def fly(self, state: FloatArray, t: float, duration: float, *, record_every: int) -> FlightLog:
        return self.autopilot.fly(state, t, duration, record_every=record_every)


__all__ = ["ARRIVAL_M", "SEED000_SWITCH_M", "FixedWingStack", "measure_turn"]


def measure_turn(
    vehicle: str = "seed004-uas",
    airspeed: float = 15.0,
    steps_deg: tuple[float, ...] = (30, 60, 90, 135, 170),
) -> dict[str, Any]:
    """Fly the 6-DOF aircraft through a 180 deg course step and measure its response: the time
    each course change in ``steps_deg`` takes beyond an ideal vehicle turning at ``psi_dot_max``
    from the start (``t_res`` of eq 8), and the steady turn's ground radius (eq 7's ``rho``)."""
    from replay.flight.fixedwing.presets import preset
    from replay.frames import rotation_body_to_ned

    params = preset(vehicle)
    stack = FixedWingStack(
        params, np.array([[0.0, 0.0, 100.0], [0.0, 10_000.0, 100.0]]), airspeed=airspeed
    )
    log = stack.fly(stack.initial_state(), 0.0, 10.0, record_every=1)
    stack.apply(HoldCourse(math.pi, altitude=100.0))
    t0 = log.t
    log = stack.fly(log.x, log.t, 30.0, record_every=1)
    v = np.array([rotation_body_to_ned(*s[6:9]) @ s[3:6] for s in log.states])
    course = np.unwrap(np.arctan2(v[:, 1], v[:, 0]))
    turned = np.abs(course - course[0])
    rate = np.abs(np.gradient(course, log.times))
    ideal_rate = G * math.tan(math.radians(params.bank_max_deg)) / airspeed
    t_res = {}
    for deg in steps_deg:
        i = int(np.argmax(turned >= math.radians(deg)))
        t_res[float(deg)] = float(log.times[i] - t0 - math.radians(deg) / ideal_rate)
    steady = rate > 0.97 * rate.max()
    ground = np.hypot(v[:, 0], v[:, 1])
    radius = float(np.mean(ground[steady] / rate[steady]))
    return {
        "vehicle": vehicle,
        "airspeed": airspeed,
        "t_res": t_res,
        "radius_m": radius,
        "radius_eq3_m": params.min_turn_radius(airspeed),
        "max_rate_deg_s": math.degrees(float(rate.max())),
        "ideal_rate_deg_s": math.degrees(ideal_rate),
    }
