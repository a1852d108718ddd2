"""The multirotor flight stack: the 6-DOF multirotor (:mod:`replay.flight.multirotor.model`) under a
cascaded controller, driven by guidance commands (:mod:`replay.guidance`).

Everything below runs in compiled code (:mod:`replay.flight.multirotor.kernels`), controller and
dynamics together at 100 Hz (RK4, the rotor speeds integrated with the rigid body).

Cascade (one step every 10 ms; NED, positions p, velocities v)::

    guidance          -> velocity command v_c
    velocity PI + drag feed-forward -> thrust vector F (tilt limit, vertical first)
    F, yaw command    -> attitude command (phi_c, theta_c) and collective thrust T
    attitude P        -> body-rate command (p_c, q_c, r_c)
    rate P + w x J w  -> body moments (L, M, N)
    mixer             -> rotor speed commands (priority roll/pitch > collective > yaw)

Guidance. Holding a point P: ``v_c = k_p (P - p)``. A leg from S to E (a go-to, a waypoint leg),
unit direction q, length l, along-track a = (p - S).q, distance to its end d = l - a::

    s   = min(V, sqrt(2 a_b max(d, 0)), k_p d)          at the final point (no overshoot)
    s   = min(V, sqrt(v_end^2 + 2 a_b max(d, 0)))        at an intermediate waypoint
    v_c = s q + k_p (S + a q - p)                         (along the leg, and back onto it)

with V the commanded speed and a_b the braking deceleration; v_end = V max(0, cos(turn)) slows
down for the turn at the waypoint (a right angle stops there). Near the end point both terms
become ``k_p (E - p)``: a first-order approach in position. The vector is scaled to the speed
limits as a whole (horizontal ``speed_max``, climb and descent rates), so the path stays
straight. A course: ``v_c = V (cos chi, sin chi)`` horizontally, the altitude held.

Velocity loop: ``a = K_v (v_c - v) + K_i int (v_c - v)``, ``|a_z| <= a_z,max``, the integral
running only while ``|v_c - v| < 0.5 m/s`` on its axis (what the accelerations of a step leave
in it would otherwise creep back out through the position loop), and the thrust
vector ``F = m a - m g e_d - D(v)`` with ``D`` the model's drag at the present velocity (the
controller knows its airframe; wind and the rest go to the integrator). Its horizontal part is
limited to ``|F_z| tan(tilt_max)``; the horizontal integrators stop while it is (anti-windup).
The attitude wanted puts the body z axis along ``-F`` at heading ``psi_c`` (exact for 3-2-1
angles: with z = -F/|F| turned by -psi_c to (a, b, c), ``phi_c = -asin(b)``, ``theta_c =
atan2(a, c)``); the collective is F's component along the present thrust axis. Attitude:
Euler-angle rates ``k_att (angle_c - angle)`` (yaw ``k_yaw wrap(psi_c - psi)``, limited to the
yaw-rate limit) turned into body rates by the kinematics; roll and pitch rates limited to
``rate_max``. Rates: ``M = J k_rate (w_c - w) + w x J w``.

Gains (:class:`ControllerDesign`): k_p 1.0 1/s, K_v 3.0 1/s (vertical 3.0), K_i 0.4 1/s^2,
k_att 6.5 1/s, k_yaw 2.8 1/s, k_rate 20 1/s (yaw 10), a_b 3 m/s^2, a_z,max 4 m/s^2, rate_max
220 deg/s (PX4's MPC_XY_P, MPC_XY_VEL_P_ACC, MPC_XY_VEL_I_ACC, MC_ROLL_P, MC_YAW_P,
MPC_ACC_HOR, MPC_ACC_UP_MAX, MC_ROLLRATE_MAX are of that size), chosen by a sweep of 20 m
steps at 5 and 12 m/s, with and without wind, for the shortest settling without overshoot.
Measured on the ``quadrotor`` preset: ``tests/test_multirotor.py``.

Commands. ``FollowWaypoints``: each waypoint a leg at the cruise speed, facing along the leg; a
waypoint is reached within ``arrival_distance`` (2 m) or when its perpendicular plane is passed;
after the last one the stack holds it (``done``). ``GoTo(point, yaw)``: a leg from where the
vehicle is, approached without overshoot, yaw as given (else kept). ``HoldPosition(point)``: hold
that point, or without one the point where the vehicle comes to rest (braking at a_b).
``YawTo(yaw)``: turn in place (holding the point it holds, or where it comes to rest).
``HoldCourse(course, altitude | climb_rate)``: fly horizontally at that course at the cruise
speed, facing it, holding the altitude given (or the present one) or climbing at the rate given.
``Orbit(center, radius, clockwise, altitude, center_velocity)``: circle the (moving) centre at
the cruise speed, or slower where the radius needs it (centripetal acceleration at most 70 % of
g tan(tilt_max), turn rate at most 0.5 rad/s: 1 m/s on a 2 m circle, 5 m/s from 10 m), facing
along the circle, at the altitude given (or
the present one); the velocity command is tangential plus ``k_p (radius - distance)`` radially
plus the centre's velocity, with the centripetal acceleration fed forward.
``HoldAltitude`` / ``ClimbRate``: the vertical axis only. ``FlightPathAngle`` (a fixed wing's
flight-path angle) is refused (:class:`GuidanceRefused`), as is a climb or descent rate beyond
the limits and an orbit about a centre faster than the speed limit. Not supported: terrain
following (a multirotor mission flies its waypoints' altitudes).

Logged (:class:`replay.flight.log.FlightLog`): ``states`` the 12 rigid-body states (the rotor
speeds are the stack's own state between calls: :attr:`MultirotorStack.rotor_speeds`);
``controls`` the four rotor speed commands (rad/s, rotors 0-3 of ``multirotor.py``) -- the
recorder's columns are named for a fixed wing's surfaces; ``guidance`` the nine columns of
:data:`replay.flight.log.GUIDANCE_COLUMNS` read as: yaw command (course_cmd), roll command
(bank_cmd), altitude command, climb-rate command, pitch command, speed command (airspeed_cmd:
the magnitude of v_c), cross-track (m, + right of the leg), along-track (m), distance to the
target point (m, 3D).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from replay.flight.base import G
from replay.flight.log import FlightLog, FlightRecorder, WaypointReached
from replay.flight.multirotor import kernels as kern
from replay.flight.multirotor.model import (
    DT,
    I_WD,
    I_WE,
    I_WN,
    N_MR_STATES,
    MultirotorParams,
    hover_state,
)
from replay.frames import N_STATES, map_to_ned, ned_to_map, rotation_body_to_ned
from replay.guidance import (
    ClimbRate,
    Commanded,
    FlightPathAngle,
    FollowWaypoints,
    GoTo,
    GuidanceCommand,
    GuidanceRefused,
    HoldAltitude,
    HoldCourse,
    HoldPosition,
    Orbit,
    YawTo,
    check_command,
)
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
ARRIVAL_M = 2.0
ORBIT_TILT_SHARE = 0.7  # an orbit's centripetal acceleration: at most this of g tan(tilt_max)
ORBIT_RATE = 0.5  # rad/s: an orbit's turn rate at most (the velocity loop's K_v / 6)


@dataclass(frozen=True)
class ControllerDesign:
    """Gains and limits of the cascade (module docstring); the envelope comes from the vehicle."""

    position_gain: float = 1.0  # 1/s
    velocity_gain: float = 3.0  # 1/s, horizontal
    velocity_gain_z: float = 3.0  # 1/s
    velocity_integral: float = 0.4  # 1/s^2
    attitude_gain: float = 6.5  # 1/s
    yaw_gain: float = 2.8  # 1/s
    rate_gain: float = 20.0  # 1/s
    yaw_rate_gain: float = 10.0  # 1/s
    brake: float = 3.0  # m/s^2
    acc_z_max: float = 4.0  # m/s^2
    integral_max: float = 3.0  # m/s^2
    integral_band: float = 0.5  # m/s
    rate_max_deg: float = 220.0  # deg/s

    def __post_init__(self) -> None:
        for name in self.__dataclass_fields__:
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not v > 0:
                raise InputError(
                    f"multirotor controller setting {name!r}: expected > 0, found {v!r}"
                )

    def pack(self, params: MultirotorParams) -> FloatArray:
        gk = np.zeros(kern.N_GAINS)
        gk[kern.K_POS] = self.position_gain
        gk[kern.K_VEL_H] = self.velocity_gain
        gk[kern.K_VEL_Z] = self.velocity_gain_z
        gk[kern.K_VEL_I] = self.velocity_integral
        gk[kern.K_ATT] = self.attitude_gain
        gk[kern.K_YAW] = self.yaw_gain
        gk[kern.K_RATE] = self.rate_gain
        gk[kern.K_RATE_YAW] = self.yaw_rate_gain
        gk[kern.K_BRAKE] = self.brake
        gk[kern.K_TILT] = math.radians(params.tilt_max_deg)
        gk[kern.K_SPEED] = params.speed_max
        gk[kern.K_CLIMB] = params.climb_rate_max
        gk[kern.K_DESCENT] = params.descent_rate_max
        gk[kern.K_YAW_RATE] = math.radians(params.yaw_rate_max_deg)
        gk[kern.K_RATE_MAX] = math.radians(self.rate_max_deg)
        gk[kern.K_ACC_Z] = self.acc_z_max
        gk[kern.K_I_MAX] = self.integral_max
        gk[kern.K_I_BAND] = self.integral_band
        return gk


class MultirotorStack:
    """A multirotor (``params``) under its controller, flying ``waypoints`` (map, (W, 3)) at
    ``speed`` (default the vehicle's cruise speed). ``wind`` (NED, m/s) and
    ``temperature_offset`` (K off ISA) are the air it flies in."""

    hover_capable = True

    def __init__(
        self,
        params: MultirotorParams,
        waypoints: npt.ArrayLike,
        *,
        speed: float | None = None,
        arrival_distance: float = ARRIVAL_M,
        wind: npt.ArrayLike = (0.0, 0.0, 0.0),
        temperature_offset: float = 0.0,
        design: ControllerDesign | None = None,
    ) -> None:
        self.params = params
        self.name = params.name
        self.speed = params.check_speed(
            params.cruise_speed if speed is None else speed, "cruise speed"
        )
        if not (math.isfinite(arrival_distance) and arrival_distance > 0):
            raise InputError(f"arrival distance must be > 0 m; got {arrival_distance!r}")
        self.arrival_distance = float(arrival_distance)
        self.switch_distance = self.arrival_distance
        self.corner_distance = self.arrival_distance
        self.temperature_offset = float(temperature_offset)
        self.design = design or ControllerDesign()
        self.packed = params.pack(wind, temperature_offset)
        self._gk = self.design.pack(params)
        self._cmd = np.zeros(kern.N_CMD)
        self._cs = np.zeros(kern.N_STATE)
        self._used = np.zeros(1)  # the battery energy drawn in fly (J; kernels.drain)
        self._wc = np.zeros(4)
        self.reached: list[WaypointReached] = []
        wp = _waypoints(waypoints)
        nxt = wp[min(1, len(wp) - 1)]
        yaw = math.atan2(nxt[0] - wp[0, 0], nxt[1] - wp[0, 1]) if len(wp) > 1 else 0.0
        self._x0 = hover_state(params, wp[0], yaw, temperature_offset)
        self._x = self._x0.copy()
        self._wc[:] = self._x0[12:]
        self._cmd[kern.C_YAW] = yaw
        self._wp = wp
        self._next = 0
        self._done = False
        self._leg_speeds: dict[int, float] = {}  # speed changes: from waypoint index on, m/s
        self._gust = np.zeros((0, 6))
        if len(wp) > 1:
            self._next = 1
            self._start_leg(direct=False)
        else:
            self._hold(wp[0])

    # -- state ----------------------------------------------------------------------------------
    @property
    def dt(self) -> float:
        return DT

    @property
    def waypoints(self) -> FloatArray:
        return self._wp.copy()

    @property
    def next_index(self) -> int:
        return self._next

    @property
    def done(self) -> bool:
        return self._done

    @property
    def rotor_speeds(self) -> FloatArray:
        """The four rotor speeds (rad/s) at the end of the last flight."""
        return np.asarray(self._x[12:16].copy())

    @property
    def mode(self) -> str:
        """``"hold"``, ``"leg"``, ``"course"`` or ``"orbit"``."""
        return ("hold", "leg", "course", "orbit")[int(self._cmd[kern.C_LAT])]

    def commanded(self, t: float) -> Commanded:
        """What the stack flies at ``t`` beside a leg (see :class:`Commanded`): a held point, a
        course or an orbit, and whether the altitude is a command or a climb rate."""
        c = self._cmd
        lateral = ("point", "path", "course", "orbit")[int(c[kern.C_LAT])]
        return Commanded(
            t=float(t),
            lateral=lateral,
            vertical="climb" if c[kern.C_VERT] == 2.0 else "altitude",
            course=float(c[kern.C_COURSE]),
            center=(float(c[kern.C_ORB_E]), float(c[kern.C_ORB_N])),
            center_velocity=(float(c[kern.C_ORB_VE]), float(c[kern.C_ORB_VN])),
            radius=float(c[kern.C_ORB_R]),
            clockwise=bool(c[kern.C_ORB_LAM] > 0.0),
            point=(float(c[kern.C_TE]), float(c[kern.C_TN])),
            climb_rate=float(c[kern.C_CLIMB]),
        )

    def initial_state(self) -> FloatArray:
        """Hover over the first waypoint facing the second (rotors at hover speed)."""
        self._x = self._x0.copy()
        return np.asarray(self._x0[:N_STATES].copy())

    # -- commands -------------------------------------------------------------------------------
    def apply(self, command: GuidanceCommand) -> None:
        """Fly ``command`` from now on, or raise :class:`GuidanceRefused` saying why not."""
        cmd = check_command(command)
        c = self._cmd
        if isinstance(cmd, FlightPathAngle):
            raise GuidanceRefused(
                f"FlightPathAngle is a fixed-wing command; {self.name} is a multirotor (it flies "
                "FollowWaypoints, GoTo, HoldPosition, YawTo, HoldCourse, Orbit, HoldAltitude, "
                "ClimbRate)"
            )
        if isinstance(cmd, ClimbRate):
            self._check_climb(cmd.rate)
            c[kern.C_VERT], c[kern.C_CLIMB] = 2.0, cmd.rate
        elif isinstance(cmd, HoldAltitude):
            c[kern.C_VERT], c[kern.C_ALT] = 1.0, cmd.altitude
        elif isinstance(cmd, FollowWaypoints):
            new = np.array(cmd.waypoints, dtype=np.float64)
            self._rekey_speeds(new)
            self._wp = new
            self._next = cmd.next_index
            self._done = False
            self._start_leg(direct=cmd.direct or cmd.next_index == 0)
        elif isinstance(cmd, GoTo):
            self._leg(self.position, np.asarray(cmd.point), events=False)
            if cmd.yaw is not None:
                c[kern.C_YAW] = cmd.yaw
        elif isinstance(cmd, HoldPosition):
            self._hold(self.stopping_point() if cmd.point is None else np.asarray(cmd.point))
        elif isinstance(cmd, YawTo):
            if c[kern.C_LAT] != 0.0:
                self._hold(self.stopping_point())
            c[kern.C_VERT] = 0.0
            c[kern.C_YAW] = cmd.yaw
        elif isinstance(cmd, Orbit):
            self._orbit(cmd)
        elif isinstance(cmd, HoldCourse):
            if cmd.climb_rate is not None:
                self._check_climb(cmd.climb_rate)
            c[kern.C_LAT], c[kern.C_COURSE], c[kern.C_SPEED] = 2.0, cmd.course, self.speed
            c[kern.C_YAW] = cmd.course
            c[kern.C_EVENT_R] = 0.0
            if cmd.climb_rate is not None:
                c[kern.C_VERT], c[kern.C_CLIMB] = 2.0, cmd.climb_rate
            else:
                c[kern.C_VERT] = 1.0
                c[kern.C_ALT] = self.position[2] if cmd.altitude is None else cmd.altitude

    def set_wind(self, wind: npt.ArrayLike) -> None:
        """The air's velocity (NED, m/s) from now on: the rotor and body drag act on the
        velocity through the air; the controller holds position and track over the ground."""
        w = np.asarray(wind, dtype=np.float64).reshape(-1)
        if w.shape != (3,) or not np.isfinite(w).all():
            raise InputError(f"wind must be three finite numbers (north, east, down); got {wind!r}")
        self.packed[I_WN], self.packed[I_WE], self.packed[I_WD] = w

    def set_gusts(self, gusts: npt.ArrayLike) -> None:
        """The turbulence of the next :meth:`fly` call, step by step: (G, 6) rows of gust
        velocity (NED, m/s, on top of the wind) and rotational gusts (unused: a multirotor's
        response to them is not modelled); used by that call only."""
        g = np.ascontiguousarray(gusts, dtype=np.float64)
        if g.ndim != 2 or g.shape[1] != 6 or not np.isfinite(g).all():
            raise InputError(f"gusts must be (steps, 6) finite numbers; got shape {g.shape}")
        self._gust = g

    def set_leg_speeds(self, speeds: Mapping[int, float]) -> None:
        """Speed changes (an imported mission's DO_CHANGE_SPEED): from waypoint ``k`` on the
        speed flown is ``speeds[k]`` (each within the vehicle's limits), as the fixed wing's
        :meth:`~replay.flight.fixedwing.autopilot.Autopilot.set_leg_speeds`; kept across a new
        waypoint list for the waypoints it keeps (same place)."""
        p = self.params
        self._leg_speeds = {
            int(k): p.check_speed(float(v), f"speed from waypoint {k}") for k, v in speeds.items()
        }
        first = self._leg_speeds.get(0)
        if first is not None:
            self.speed = first
        if not self._done and len(self._wp) > 1 and self._next >= 1:
            self._start_leg(direct=False)  # the leg flown now at its speed

    def _rekey_speeds(self, w: FloatArray) -> None:
        if not self._leg_speeds:
            return
        out = {}
        for k, v in self._leg_speeds.items():
            hit = np.flatnonzero(np.abs(w - self._wp[k]).max(axis=1) < 1.0)
            if hit.size:
                out[int(hit[0])] = v
        self._leg_speeds = out

    def orbit_speed(self, radius: float) -> float:
        """The speed flown on an orbit of ``radius`` m: the cruise speed, or less where its
        centripetal acceleration would need more than ``ORBIT_TILT_SHARE`` of the tilt limit's
        g tan(tilt_max) or its turn rate more than ``ORBIT_RATE`` (what the velocity loop
        follows)."""
        a = ORBIT_TILT_SHARE * G * math.tan(math.radians(self.params.tilt_max_deg))
        return min(self.speed, math.sqrt(a * radius), ORBIT_RATE * radius)

    def _orbit(self, cmd: Orbit) -> None:
        cv = math.hypot(*cmd.center_velocity)
        speed = min(self.orbit_speed(cmd.radius), self.params.speed_max - cv)
        if speed <= 0.0:
            raise GuidanceRefused(
                f"an orbit about a centre moving at {cv:.1f} m/s is beyond {self.name}'s "
                f"{self.params.speed_max:g} m/s"
            )
        c = self._cmd
        c[kern.C_LAT], c[kern.C_SPEED], c[kern.C_EVENT_R] = 3.0, speed, 0.0
        c[kern.C_ORB_N], c[kern.C_ORB_E] = cmd.center[1], cmd.center[0]
        c[kern.C_ORB_VN], c[kern.C_ORB_VE] = cmd.center_velocity[1], cmd.center_velocity[0]
        c[kern.C_ORB_R] = cmd.radius
        c[kern.C_ORB_LAM] = 1.0 if cmd.clockwise else -1.0
        c[kern.C_VERT] = 1.0
        c[kern.C_ALT] = self.position[2] if cmd.altitude is None else cmd.altitude

    def _check_climb(self, rate: float) -> None:
        p = self.params
        if not -p.descent_rate_max <= rate <= p.climb_rate_max:
            raise GuidanceRefused(
                f"climb rate {rate:g} m/s is beyond {self.name}'s limits (descent "
                f"{p.descent_rate_max:g} m/s, climb {p.climb_rate_max:g} m/s)"
            )

    @property
    def position(self) -> FloatArray:
        """Map position (x east, y north, z up) at the end of the last flight."""
        return np.asarray(ned_to_map(self._x[0:3]))

    def stopping_point(self) -> FloatArray:
        """Where the vehicle comes to rest braking at the design deceleration (map)."""
        x = self._x
        v = rotation_body_to_ned(x[6], x[7], x[8]) @ x[3:6]
        stop = x[0:3] + v * float(np.linalg.norm(v)) / (2.0 * self.design.brake)
        return np.asarray(ned_to_map(stop))

    def _hold(self, point: FloatArray) -> None:
        c = self._cmd
        c[kern.C_LAT] = 0.0
        c[kern.C_TN], c[kern.C_TE], c[kern.C_TD] = map_to_ned(point)
        c[kern.C_VERT] = 0.0
        c[kern.C_EVENT_R] = 0.0

    def _leg(self, start: FloatArray, end: FloatArray, *, events: bool) -> None:
        c = self._cmd
        c[kern.C_LAT] = 1.0
        c[kern.C_SN], c[kern.C_SE], c[kern.C_SD] = map_to_ned(start)
        c[kern.C_TN], c[kern.C_TE], c[kern.C_TD] = map_to_ned(end)
        c[kern.C_SPEED] = self.speed
        c[kern.C_VEND] = -1.0
        c[kern.C_VERT] = 0.0
        c[kern.C_EVENT_R] = self.arrival_distance if events else 0.0

    def _start_leg(self, *, direct: bool) -> None:
        i = self._next
        wp = self._wp
        if not direct:  # the speed set at the waypoint this leg leaves, or the last one before
            at = [k for k in self._leg_speeds if k <= i - 1]
            if at:
                self.speed = self._leg_speeds[max(at)]
        start = self.position if direct else wp[i - 1]
        end = wp[i]
        final = i == len(wp) - 1
        self._leg(start, end, events=True)
        d = end - start
        if math.hypot(d[0], d[1]) > 1.0:
            self._cmd[kern.C_YAW] = math.atan2(d[0], d[1])
        if not final:
            d2 = wp[i + 1] - end
            n1, n2 = float(np.linalg.norm(d)), float(np.linalg.norm(d2))
            cos = float(d @ d2) / (n1 * n2) if n1 > 0 and n2 > 0 else 0.0
            self._cmd[kern.C_VEND] = self.speed * max(0.0, cos)

    def _switch(self, ev: int, t: float, x: FloatArray) -> None:
        end = self._wp[self._next]
        dist = float(np.linalg.norm(ned_to_map(x[0:3]) - end))
        self.reached.append(WaypointReached(self._next, t, dist, "radius" if ev == 1 else "plane"))
        if self._next + 1 >= len(self._wp):
            self._done = True
            self._hold(end)
            return
        self._next += 1
        self._x = x.copy()
        self._start_leg(direct=False)

    @property
    def energy_used(self) -> float:
        """The battery's energy (J) drawn in :meth:`fly` so far (``kernels.drain``)."""
        return float(self._used[0])

    # -- flying ---------------------------------------------------------------------------------
    def fly(
        self, state: npt.ArrayLike, t: float, duration: float, *, record_every: int = 0
    ) -> FlightLog:
        """Fly for ``duration`` seconds from ``state`` (12 states, the rotors as they were; or
        16 with the rotor speeds) at time ``t``; record every ``record_every`` steps."""
        s = np.asarray(state, dtype=np.float64)
        if s.shape not in ((N_STATES,), (N_MR_STATES,)) or not np.isfinite(s).all():
            raise InputError(
                f"state must be {N_STATES} (or {N_MR_STATES}) finite numbers, found shape {s.shape}"
            )
        x = np.empty(N_MR_STATES)
        x[:N_STATES] = s[:N_STATES]
        x[N_STATES:] = s[N_STATES:] if s.shape == (N_MR_STATES,) else self._x[N_STATES:]
        self._x = x.copy()
        n_total = int(round(duration / DT))
        if n_total < 0:
            raise InputError(f"duration must be >= 0 s, found {duration!r}")
        k_start = int(round(t / DT))
        t0_grid = t - k_start * DT
        rec = FlightRecorder(n_total, record_every, t0_grid, DT, kern.N_GUIDANCE_LOG)
        first = len(self.reached)
        gust, self._gust = self._gust, np.zeros((0, 6))  # this call's turbulence, used once
        done = 0
        while done < n_total:
            k = k_start + done
            steps, ev, nr = kern.fly(
                x,
                n_total - done,
                k,
                DT,
                self.packed,
                self._gk,
                self._cmd,
                self._cs,
                self._wc,
                rec.every,
                rec.x[rec.n :],
                rec.u[rec.n :],
                rec.g[rec.n :],
                gust[done:],
                self._used,
            )
            rec.add(k, steps, nr, self._next)
            done += steps
            if ev != 0:
                self._switch(int(ev), t0_grid + (k + steps) * DT, x)
        self._x = x.copy()
        return rec.log(
            x[:N_STATES].copy(),
            t0_grid + (k_start + n_total) * DT,
            self._wc.copy(),
            tuple(self.reached[first:]),
            n_total,
        )

    def control(self, state: npt.ArrayLike) -> FloatArray:
        """The rotor speed commands for the 16-state ``state`` (one control step, advancing the
        controller's integrators): what :meth:`fly` does at every step, callable from Python to
        drive another model of the vehicle."""
        x = np.ascontiguousarray(state, dtype=np.float64)
        if x.shape != (N_MR_STATES,):
            raise InputError(f"state must have {N_MR_STATES} elements, found shape {x.shape}")
        kern.control_law(x, self.packed, self._gk, self._cmd, self._cs, DT, self._wc)
        return np.asarray(self._wc.copy())


def _waypoints(waypoints: npt.ArrayLike) -> FloatArray:
    w = np.array(waypoints, dtype=np.float64)
    if w.ndim != 2 or w.shape[1] != 3 or len(w) < 1 or not np.isfinite(w).all():
        raise InputError(f"waypoints must be a list of finite [x, y, z]; got shape {w.shape}")
    return w


__all__ = ["ARRIVAL_M", "ControllerDesign", "MultirotorStack"]
