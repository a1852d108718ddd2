"""The autopilot: waypoint guidance with cross-track correction and successive loop closure.

Structure (Beard & McLain, *Small Unmanned Aircraft*, 2012, ch. 6 "successive loop closure"; the
guidance after Krishnan & Manimala 2020 — seed 000 — §3.5-3.6, eqs 13-20)::

    waypoints --leg--> course command chi_c --course PI--> bank phi_c (<= the bank the excess
              power sustains) --roll PID--> aileron
              --leg--> altitude h_c --P--> climb rate hdot_c (within the energy available)
              --PI--> pitch theta_c --PD--> elevator
    airspeed command Va_c --PI + climb thrust feed-forward--> throttle
    sideslip (PI) + washed-out yaw rate --> rudder

The commands can be overridden (:meth:`Autopilot.set_override`: a course or a bank angle, an
altitude, an airspeed — what an avoider's guidance override or a test needs) and the waypoint list
replaced in flight (:meth:`Autopilot.set_waypoints`).

Everything runs in the compiled kernel ``replay/flight/fixedwing/kernels.py`` (``control_law``) — called
once per control period by :meth:`Autopilot.command`, or inside :meth:`Autopilot.fly` which flies
the vehicle and the autopilot together at 100 Hz in one compiled loop (the fast path for long
missions; both give the same flight).

Guidance (lateral)
------------------
The current leg runs from the previous waypoint W[i-1] to the next one W[i] (map x east, y north,
z up; NED inside). Cross-track error, seed 000 eq. 15::

    DD = (A x + B y + C) / sqrt(A^2 + B^2),  A = Y_fin - Y_st,  B = X_st - X_fin,
    C = X_st (Y_st - Y_fin) + Y_st (X_fin - X_st)

which is the signed distance from the leg's line, positive to the RIGHT of the direction of travel
(the paper's ``AA, BB`` in the denominator are A and B). Seed 000 then feeds DD and its rate
(eq. 20, a difference quotient at 100 Hz) into a leaky-integrator roll command (eq. 19) and a
proportional aileron law (eq. 18). Two things there are ambiguous or wrong geometrically: the sign
(eq. 19 banks *toward* positive DD, i.e. away from the track, unless the paper's aileron sign of
eq. 18 absorbs it), and the law itself: its steady state is ``phi = 0.01 DD + 0.5 DD_rate`` which,
once the bank saturates at 30 deg far from the track, has no bounded approach angle and can circle
(``DD_rate`` cannot exceed the speed). We keep DD (eq. 15) and replace eqs 18-20 by a course
command that is geometrically right for any distance — the straight-line vector field of Beard &
McLain §10.2::

    chi_c = chi_leg - chi_inf (2/pi) atan(k_path DD)

(``chi_inf`` = 60 deg approach angle far from the leg; ``k_path`` = 1 / (2 R_min) with the
minimum turn radius ``R_min = V^2 / (g tan(phi_max))`` of seed 000 eq. 13, so the approach bends
over a couple of turn radii). The cross-track rate of eq. 20 is then implicit:
``dDD/dt = V_g sin(chi - chi_leg)``, which the course loop drives to ``-V_g sin(chi_inf ...)``.
The course loop turns with at most the bank limit, so the turn rate never exceeds
``g tan(phi_max) / V`` (eq. 14).

In a wind the guidance is over the ground: the vector fields (this line's and the orbit's,
Beard & McLain §10.2-10.3) command the course, and the course loop compares it with the ground
track's course, so the heading crabs into the wind by itself (``asin(w_cross / V)``; measured
within 0.11 deg, tests/test_wind.py) and a fillet or orbit is held on the ground, its downwind
side flown at a steeper bank (within 10 % of the radius in 10 m/s). Of the anchors' followers it
is the vector field of the book, not PX4's NPFG nor ArduPilot's L1; like NPFG, and unlike a
heading-based follower, it needs no wind estimate to hold the track, only the ground velocity
(the airspeed loop reads the speed through the air).

Leg change (seed 000 §3.6, eqs 16-17): the paper changes leg when "the difference between Waypoint
Distance and UAV Distance is less than 1 km" — on the track that is the distance still to go. We
use what that means geometrically: the leg ends when the aircraft is within ``switch_distance``
(default 1000 m) of W[i] horizontally, or when it has passed W[i]'s perpendicular plane (the
along-track distance exceeds the leg length — so a missed waypoint never leaves the aircraft flying
away). Horizontal because an altitude lag (climb-rate limit) must not hold a leg. The switching
radius is capped at half the leg's length, so a short inserted leg (an avoider's waypoint) is
flown, not skipped on arrival. The final waypoint uses ``arrival_distance`` (default 100 m); after
it the autopilot holds the last leg's course and the last altitude (:attr:`Autopilot.done`).
While an avoider steers (a course, bank or orbit override) the final leg ends only within the
arrival distance: an aircraft passing the goal's plane mid-manoeuvre has not arrived.

Guidance (vertical)
-------------------
The altitude command follows the leg linearly: ``h_c = z[i-1] + f (z[i] - z[i-1])`` with ``f`` the
along-track fraction clamped to [0, 1] — the straight 3D segment the planner checked against the
terrain (``altitude_mode="direct"`` commands z[i] at once instead). With ``terrain_height`` and a
clearance, ``h_c`` is raised to at least the highest terrain within ``terrain_lookahead`` metres
ahead (along the ground track and along the leg; default 60 s of flight at cruise) plus the
clearance, refreshed every ``terrain_update`` seconds.  In a turn the look-ahead follows the
turn: the rest of its arc (a spiral: of the quarters it has still to fly, at most the whole
circle) and in its last quarter the leg it turns into, not the ground track's tangent -- it
leaves the circle, and 60 s along it looked into the walls of the valley a
spiral climbs in (the aircraft left Big Tujunga's spirals up to 188 m above the plan).

Inner loops (gains from the vehicle's transfer-function coefficients, Beard & McLain §5.4, at the
commanded airspeed — cruise unless given — so the same code flies every preset; the numbers are the
:class:`LoopDesign` defaults)
-----------------------------------------------------------------------------------------------
Roll, ``phi'' = -a_phi1 phi' + a_phi2 delta_a``::

    a_phi1 = -1/4 rho Va S b^2 C_p_p,  a_phi2 = 1/2 rho Va^2 S b C_p_da
    C_p_p = G3 Clp + G4 Cnp,  C_p_da = G3 Clda + G4 Cnda
    wn_phi = sqrt(|a_phi2| da_max / e_phi_max)   (the aileron saturates at e_phi_max = 30 deg of
              roll error), raised to a_phi1 / (2 zeta) for an airframe whose own roll damping
              exceeds 2 zeta wn (it would otherwise need rate feedback of the wrong sign), <= 15
    k_p = wn^2 / a_phi2,  k_d = max(0, (2 zeta wn - a_phi1) / a_phi2),  zeta = 0.9
    k_i = 0.1 wn k_p, integrating only while |phi_c - phi| < 3 deg (no windup in bank steps)
    delta_a = da_ff + k_p (phi_c - phi) + k_i int(phi_c - phi) - k_d p
    da_ff = -(C_p0 + C_p_beta beta + C_p_r b r / (2 Va) + C_p_dr delta_r) / C_p_da

``da_ff`` cancels the rolling moments the book's roll model leaves out (sideslip, yaw rate — large
in tight turns — and rudder, with C_p_x = G3 Cl_x + G4 Cn_x), so the loop sees the plant it was
designed for; the bank command is rate limited to 0.3 wn_phi bank_max per second. Measured bank
overshoot on a 30 deg step: under 0.5 deg for every preset.

Course, ``chi' = (g / V_g) phi``: ``wn_chi = wn_phi / 8`` (bandwidth separation 8), zeta 1::

    k_p = 2 zeta wn_chi V_g / g,  k_i = wn_chi^2 V_g / g,  phi_c = sat(k_p e_chi + k_i int e_chi)

with ``e_chi`` wrapped to [-pi, pi) and ``phi_c`` saturated at the bank limit (default 30 deg).

Pitch, ``theta'' = -a_th1 theta' - a_th2 theta + a_th3 delta_e``::

    a_th1 = -rho Va^2 c S Cmq c / (2 Va) / (2 Jy),  a_th2 = -rho Va^2 c S Cmalpha / (2 Jy),
    a_th3 = rho Va^2 c S Cmde / (2 Jy)
    k_p = sign(a_th3) de_max / e_th_max   (e_th_max = 10 deg, de_max the smaller travel)
    wn_th = sqrt(a_th2 + k_p a_th3),  k_d = (2 zeta wn_th - a_th1) / a_th3,  zeta = 0.8
    delta_e = de_ff + k_p (theta_c - theta) - k_d q

Altitude and climb rate (our replacement of the book's altitude-to-pitch PI, to honour the
climb-rate and pitch limits)::

    hdot_c  = sat(k_h (h_c - h), -0.95 descent_max, 0.95 climb_max),  k_h = 0.25 1/s,
              slewed at 1 m/s^2
    gamma_c = asin(hdot_c / Va),  e_gamma = (hdot_c - hdot) / Va
    theta_c = sat(theta_ff + k_pg e_gamma + k_ig int e_gamma, pitch_min, pitch_max),
              k_pg = 2, k_ig = 0.2 1/s
    theta_ff = theta* + (dtheta/dgamma) gamma_c,  de_ff = delta_e* + (ddelta_e/dgamma) gamma_c

Energy management (after the total energy control of ArduPilot's and PX4's TECS, and Beard &
McLain's climb zone: full throttle, the airspeed first). The loops above split the work the usual
way -- throttle for the airspeed, pitch for the climb -- which fails at the envelope's edge: told
to climb more than the engine gives, the pitch loop keeps pitching up, the throttle saturates and
the airspeed bleeds onto the back of the power curve (a Cessna told to climb from 3,500 m to
4,000 m at 45 m/s sank at full throttle to 2,733 m at 31 m/s). So every control step measures the
climb the aircraft has (``kernels.energy_state``)::

    Edot      = hdot + Va Va' / g                      (specific total-energy rate, m/s; Va'
                                                        filtered with tau = 1 s)
    hdot_up   = Edot + (T(full) - T) Va / (m g)        (T: the last throttle's thrust at this
    hdot_dn   = Edot + (T(idle) - T) Va / (m g)         airspeed and density; filtered, 1 s)

and the climb-rate command is bounded by them less what the airspeed's recovery needs::

    a       = sat(0.2 (Va_c - Va), +-0.5 m/s^2)
    hdot_c <= max(hdot_up - Va a / g, lo),   lo = 0 told to climb (never descends), or the
                                             descent limit when Va < 0.9 Va_c (underspeed: the
                                             airspeed comes first, altitude is traded for it)
    hdot_c >= min(hdot_dn - Va a / g, hi)    (the same for descents and overspeed)

so it climbs at the best rate it has at the commanded airspeed and, at its ceiling, holds the
highest altitude it can. Turns: a coordinated turn at load factor n costs the induced drag
``k_i n^2 W^2 / (q S)`` (``k_i = 1 / (pi e AR)``); the bank is limited to the load factor that
leaves 0.2 m/s of climb (``hdot_up + k_i W Va (n_now^2 - n^2) / (q S) = 0.2``), at least 10 deg,
so a turn at altitude keeps the airspeed with a shallower bank when no throttle is left. Away from
the edge none of this binds (a climb with power to spare is flown as commanded). The numbers are
:class:`LoopDesign`'s ``energy_*``, ``turn_climb_margin`` and ``bank_floor_deg``.

The feed-forward slopes come from the trims at the climb and the descent limits (straight lines
from level trim, one for climbs, one for descents; gamma alone if a trim does not exist, e.g. an
idle descent that would need negative thrust). The climb-rate command stays 5 % inside the
vehicle's limits: the climb-rate loop overshoots its command by up to 3 % at the start of a climb,
and the limit is the vehicle's, not the command's — flown climb rates stay within it.

Airspeed (throttle), ``Va' = -a_V1 Va + a_V2 delta_t``::

    a_V1 = rho Va* S (CD(alpha*) + CDde |de*|) / m - (dT/dVa)* / m,
    a_V2 = (dT/d delta_t)* / m            (slopes of the engine model at the trim, numerically)
    k_i = wn_V^2 / a_V2,  k_p = max(0, (2 zeta wn_V - a_V1) / a_V2),  wn_V = 0.5 rad/s, zeta = 1
    delta_t = delta_t_ff + k_p e_V + k_i int e_V,
    delta_t_ff: the throttle giving T* + m g sin(gamma_c) at the current airspeed and air density
    (the engine model inverted by bisection)

The throttle's lower saturation for anti-windup is the throttle of zero thrust at the current
airspeed (below it the propeller only brakes), not 0.

Yaw (rudder): coordinated flight in the pilot's sense -- no aerodynamic side force, the ball
centred -- by a sideslip hold on the sideslip of zero side force ``beta_ref = -(CY0 + CYp b p /
(2 Va) + CYr b r / (2 Va) + CYda da + CYdr dr) / CYbeta`` (the rudder of the previous step,
beta_ref within +-0.2 rad), plus a yaw damper washed out with tau = 1 s (so steady turns are not
opposed), written as a yawing-moment coefficient and divided by Cndr (no rudder when Cndr = 0)::

    e = sin(beta) - beta_ref
    dCn = Cnbeta e + 0.5 Cnbeta int e - |Cnr| b r_hp / (2 Va),
    delta_r = dCn / Cndr

(the rudder doubles the weathercock stability and the yaw damping and trims the side force
out). A steady turn then has the radius V^2 / (g tan(phi)) (trimmed 30 deg turns at cruise:
+0.9 % aerosonde, +0.3 % solar-uav, +0.1 % cessna172, +0.1 % small-uas). Holding beta = 0
instead (Beard & McLain) leaves the rudder's side force in the turn: 1-9 % off. The rudder in
beta_ref closes a loop through the previous step; with a tail behind the centre of gravity
(CYdr > 0 > Cndr) its gain is below one (the Aerosonde's printed CYdr < 0 made it diverge).

Every saturation (bank, pitch, surfaces, throttle) has anti-windup: an integrator stops while its
loop is saturated and the error would push it further.

Rates: the control law assumes it runs every control period (``dt``, 100 Hz by default, seed 000
eq. 20); ``command`` measures the period from successive ``t``; ``fly`` can run it every
``control_every`` dynamics steps.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt

from planner.flown import Fillets, fillets
from planner.spiral import Spiral
from replay.flight.atmosphere import check_offset
from replay.flight.base import TerrainHeight
from replay.flight.fixedwing import kernels as kern
from replay.flight.fixedwing.dynamics import DT
from replay.flight.fixedwing.gains import Gains, LoopDesign, design_gains
from replay.flight.fixedwing.params import I_WD, I_WE, I_WN, VehicleParams
from replay.flight.log import FlightLog, FlightRecorder, WaypointReached
from replay.frames import N_CONTROLS, N_STATES, map_to_ned
from replay.guidance import Commanded, GuidanceRefused
from terrain.errors import InputError

# a terrain-frame leg keeps this share of the planning climb gradient in reserve-free use: the
# altitude command meets rising ground ahead as if the aircraft climbed only this share of it
# (the altitude loop lags; at the full gradient it arrived 80 m low on a 700 m deep RMNP valley)
FOLLOW_CLIMB_SHARE = 0.5

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class AutopilotConfig:
    """Guidance settings. Distances in metres, times in seconds."""

    dt: float = DT
    control_every: int = 1  # control law every n dynamics steps in ``fly``
    switch_distance: float = 1000.0  # seed 000 §3.6
    turn_radius: float | None = None  # fly turn fillets of this radius instead (None: switch)
    orbit_gain: float = 4.0  # k_orbit of the fillets' orbit following
    arrival_distance: float = 100.0  # the final waypoint
    approach_angle_deg: float = 60.0  # chi_inf
    path_gain: float | None = None  # k_path (1/m); None: 1 / (2 R_min)
    altitude_mode: Literal["linear", "direct"] = "linear"
    terrain_clearance: float = 100.0
    terrain_lookahead: float | None = None  # None: 60 s at the design airspeed
    terrain_samples: int = 24
    terrain_update: float = 1.0
    design: LoopDesign = field(default_factory=LoopDesign)

    def __post_init__(self) -> None:
        checks = {
            "dt": self.dt > 0,
            "control_every": isinstance(self.control_every, int) and self.control_every >= 1,
            "switch_distance": self.switch_distance > 0,
            "turn_radius": self.turn_radius is None
            or (math.isfinite(self.turn_radius) and self.turn_radius > 0),
            "orbit_gain": self.orbit_gain > 0,
            "arrival_distance": self.arrival_distance > 0,
            "approach_angle_deg": 0 < self.approach_angle_deg <= 90,
            "path_gain": self.path_gain is None or self.path_gain > 0,
            "altitude_mode": self.altitude_mode in ("linear", "direct"),
            "terrain_clearance": self.terrain_clearance >= 0,
            "terrain_lookahead": self.terrain_lookahead is None or self.terrain_lookahead >= 0,
            "terrain_samples": self.terrain_samples >= 1,
            "terrain_update": self.terrain_update > 0,
        }
        for name, good in checks.items():
            if not good:
                raise InputError(
                    f"autopilot setting {name!r}: invalid value {getattr(self, name)!r}"
                )


_NO_GUST = np.zeros((0, 6))  # still air beyond the wind


class OrbitRefused(GuidanceRefused):
    """An orbit the aircraft cannot fly (tighter than its minimum turn radius)."""


@dataclass(frozen=True)
class GuidanceState:
    """What the autopilot is doing (for logging). Angles in rad (course clockwise from north),
    altitudes in m up, ``cross_track`` positive right of the leg."""

    mode: str  # "waypoints", "override", "hold" (no waypoints) or "done"
    next_index: int  # index of the waypoint flown to (len(waypoints) when done)
    leg_index: int  # next_index - 1
    cross_track: float
    along_track: float
    distance_to_next: float
    course_cmd: float
    bank_cmd: float
    altitude_cmd: float
    climb_rate_cmd: float
    pitch_cmd: float
    airspeed_cmd: float
    terrain_floor: float | None


# ---- the autopilot ----------------------------------------------------------------------------
class Autopilot:
    """Waypoint-following autopilot of one vehicle.

    ``waypoints`` are map coordinates (W, 3): x east, y north, z altitude (m AMSL); the first leg
    runs from W[0] to W[1]. ``airspeed`` is the commanded true airspeed (default: the vehicle's
    cruise); ``wind`` and ``temperature_offset`` must be those the dynamics use (the autopilot
    reads true air data). The gains are designed in the air at ``design_altitude`` (default: the
    mean altitude of the waypoints, 0 without), where the vehicle's equivalent-airspeed envelope
    gives the true airspeeds it accepts.
    ``terrain_height(x, y)`` (arrays of map coordinates -> heights) turns on terrain following.
    """

    def __init__(
        self,
        params: VehicleParams,
        waypoints: npt.ArrayLike | None = None,
        *,
        airspeed: float | None = None,
        config: AutopilotConfig | None = None,
        wind: npt.ArrayLike = (0.0, 0.0, 0.0),
        terrain_height: TerrainHeight | None = None,
        gains: Gains | None = None,
        temperature_offset: float = 0.0,
        design_altitude: float | None = None,
    ) -> None:
        self.params = params
        self.config = config or AutopilotConfig()
        self.temperature_offset = check_offset(temperature_offset)
        if design_altitude is None:
            wps = None if waypoints is None else np.asarray(waypoints, dtype=np.float64)
            design_altitude = float(wps[:, 2].mean()) if wps is not None and wps.size else 0.0
        self.design_altitude = float(design_altitude)
        self.airspeed = self._check_airspeed(params.cruise_speed if airspeed is None else airspeed)
        self.gains = gains or self._design()
        self.packed = params.pack(wind, self.temperature_offset)
        self.wind = np.asarray(wind, dtype=np.float64)
        self._gust = _NO_GUST
        cfg = self.config
        self.path_gain = (
            cfg.path_gain
            if cfg.path_gain is not None
            else 1.0 / (2.0 * params.min_turn_radius(self.gains.airspeed))
        )
        self._gk = self.gains.pack(
            params, math.radians(cfg.approach_angle_deg), self.path_gain, cfg.orbit_gain
        )
        self._cmd = np.zeros(kern.N_CMD)
        self._cmd[kern.C_AIRSPEED] = self.airspeed
        self._cmd[kern.C_FLOOR] = -math.inf
        self._cmd[kern.C_ALT_DIRECT] = 1.0 if cfg.altitude_mode == "direct" else 0.0
        self._leg = np.zeros(kern.N_LEG)
        self._fillet_at: Fillets | None = None
        self._ap = np.zeros(kern.N_AP)
        self._used = np.zeros(1)  # what the engine drew in fly (kernels.drain): J or kg of fuel
        self._u = np.zeros(N_CONTROLS)
        self.terrain_height = terrain_height
        self.terrain_lookahead = (
            cfg.terrain_lookahead
            if cfg.terrain_lookahead is not None
            else 60.0 * self.gains.airspeed
        )
        self._terrain_next = -math.inf
        self._t_last: float | None = None
        self._x_last: FloatArray | None = None
        self._wp = np.zeros((0, 3))
        self._next = 0
        self._plane_saved: float | None = None
        self._done = False
        self._pending_direct = False
        # (index, map position): the direct-to leg to waypoint index started at that position
        self._origin: tuple[int, FloatArray] | None = None
        self._override_lat: str | None = None  # None, "course", "bank", "orbit"
        self._override_alt: str | None = None  # None, "altitude", "climb"
        self._hold_alt_pending = False  # hold the altitude flown at the next control step
        self._override_speed = False
        self.reached: list[WaypointReached] = []
        # climb and descent spirals (planner.spiral) by waypoint index: (entry altitude, turns,
        # radius, clockwise); the quarter arcs of the one being flown, what comes after it
        self._spirals: dict[int, tuple[float, int, float, bool]] = {}
        self._arcs: list[tuple[float, ...]] = []
        self._after: tuple[str, int, Fillets | None] | None = None
        self._spiral_z0: dict[int, float] = {}  # the altitude a spiral starts at (its T1's)
        self._spiral_z1: dict[int, float] = {}  # and ends at (its fillet's T2's)
        # the altitude the plan leaves each spiral flown so far at (where it touches the path)
        self.spiral_exits: dict[int, float] = {}
        self.land = False  # the final leg is a landing's final approach (no terrain floor)
        self._leg_heights: dict[int, float] = {}  # terrain-frame legs: waypoint index -> metres
        self._leg_speeds: dict[int, float] = {}  # speed changes: from waypoint index on, m/s
        self._follow_gradient = 0.0
        self._hold_pending = waypoints is None
        if waypoints is not None:
            self.set_waypoints(waypoints, 1)
        else:
            self._apply_modes()

    def _check_airspeed(self, airspeed: float) -> float:
        """``airspeed`` (true) if it lies in the vehicle's envelope at the design altitude (the
        envelope is in equivalent airspeed: its true speeds grow with altitude)."""
        p = self.params
        v = float(airspeed)
        h, dt = self.design_altitude, self.temperature_offset
        lo, hi = p.airspeed_range(h, dt)
        if not lo - 1e-9 <= v <= hi + 1e-9:  # also refuses NaN
            at = f" at {h:.0f} m" if abs(h) >= 0.5 else ""
            eas = (
                f" (true airspeed; {p.airspeed_min:g}–{p.airspeed_max:g} m/s equivalent)"
                if abs(h) >= 0.5 or dt
                else " (airspeed_min, airspeed_max)"
            )
            raise InputError(
                f"commanded airspeed {v:g} m/s is outside {p.name}'s envelope{at} "
                f"{round(lo, 1):g}–{round(hi, 1):g} m/s{eas}"
            )
        return v

    def _design(self) -> Gains:
        return design_gains(
            self.params,
            self.airspeed,
            self.config.design,
            self.design_altitude,
            self.temperature_offset,
        )

    # ---- waypoints and overrides --------------------------------------------------------------
    @property
    def waypoints(self) -> FloatArray:
        """The current waypoint list (a copy), map coordinates (W, 3)."""
        return self._wp.copy()

    @property
    def next_index(self) -> int:
        return self._next

    @property
    def done(self) -> bool:
        """True once the final waypoint has been reached."""
        return self._done

    def set_waypoints(
        self, waypoints: npt.ArrayLike, next_index: int = 1, *, direct: bool = False
    ) -> None:
        """Replace the waypoint list mid-flight and fly to ``waypoints[next_index]``.

        The leg starts at ``waypoints[next_index - 1]``; with ``direct=True`` (or
        ``next_index == 0``) it starts at the aircraft's position instead ("direct to": what an
        avoider that planned from the current position wants).
        """
        w = np.array(waypoints, dtype=np.float64)
        if w.ndim != 2 or w.shape[1] != 3 or len(w) < 1 or not np.isfinite(w).all():
            raise InputError(f"waypoints must be a list of finite [x, y, z]; got shape {w.shape}")
        if not 0 <= int(next_index) < len(w):
            raise InputError(
                f"next waypoint index must be in [0, {len(w) - 1}] for {len(w)} waypoints, "
                f"found {next_index!r}"
            )
        self._rekey_spirals(w)
        self._wp = w
        self._next = int(next_index)
        self._origin = None
        self._done = False
        self._hold_pending = False
        self._arcs, self._after = [], None
        direct = direct or self._next == 0
        if direct and self._x_last is None:
            self._pending_direct = True
            self._leg[kern.L_ACTIVE] = 0.0
        else:
            self._start_leg(direct)
        self._apply_modes()

    def set_spirals(self, spirals: Sequence[Spiral]) -> None:
        """Fly a climb or descent spiral at each of ``spirals``' waypoints (objects with ``at``,
        ``entry``, ``turns``, ``radius``, ``clockwise``) as the
        planner built them: the leg into the waypoint ends at ``entry``, then ``turns`` circles
        of ``radius`` tangent to the path where the turn fillet begins (at the start: along the
        first leg; at the goal: along the last), flown as quarter-circle arcs of the turn
        machinery, the altitude linear in the angle turned up (down) to the waypoint's own; then
        the fillet and the next leg as usual. Each spiral's end is a ``WaypointReached`` with
        ``how="spiral"``. Set before the flight starts (a start spiral is flown first)."""
        out: dict[int, tuple[float, int, float, bool]] = {}
        for sp in spirals:
            k = int(sp.at)
            if not 0 <= k < len(self._wp):
                raise InputError(
                    f"spiral at waypoint {k}: no such waypoint (0..{len(self._wp) - 1})"
                )
            radius = float(sp.radius)
            if radius < self.min_orbit_radius() - 1e-6:
                raise OrbitRefused(
                    f"spiral at waypoint {k}: radius {radius:.0f} m is tighter than "
                    f"{self.params.name} can fly at {self.airspeed:g} m/s (at least "
                    f"{self.min_orbit_radius():.0f} m)"
                )
            out[k] = (float(sp.entry), int(sp.turns), radius, bool(sp.clockwise))
        self._spirals = out
        if self._x_last is None and self._wp.shape[0] > 1 and self._next == 1:
            self._start_leg(False)  # the first leg's end altitude may be an entry now
            if 0 in out:
                self._begin_spiral(0, "go", None)
            self._apply_modes()

    @property
    def arrivals(self) -> FloatArray:
        """The altitude each waypoint is arrived at (a spiral's entry, else its own)."""
        z = self._wp[:, 2].copy()
        for k, sp in self._spirals.items():
            z[k] = sp[0]
        return z

    def _arrival(self, i: int) -> float:
        sp = self._spirals.get(i)
        return float(self._wp[i, 2]) if sp is None else sp[0]

    @property
    def leg_heights(self) -> dict[int, float]:
        """The terrain-frame legs of the waypoints flown now (:meth:`set_leg_heights`)."""
        return dict(self._leg_heights)

    def set_gusts(self, gusts: npt.ArrayLike) -> None:
        """The turbulence of the next :meth:`fly` call, step by step: (G, 6) rows of gust
        velocity (NED, m/s, on top of the wind) and rotational gusts (body p, q, r, rad/s) for
        its first G steps (:class:`replay.flight.wind.Dryden`); used by that call only."""
        g = np.ascontiguousarray(gusts, dtype=np.float64)
        if g.ndim != 2 or g.shape[1] != 6 or not np.isfinite(g).all():
            raise InputError(f"gusts must be (steps, 6) finite numbers; got shape {g.shape}")
        self._gust = g

    def set_wind(self, wind: npt.ArrayLike) -> None:
        """The air's velocity (NED, m/s) from now on: the dynamics' air mass and what the
        control law subtracts for the airspeed (:mod:`replay.flight.wind`; the replay sets it
        every tick where the wind changes with height)."""
        w = np.asarray(wind, dtype=np.float64).reshape(-1)
        if w.shape != (3,) or not np.isfinite(w).all():
            raise InputError(f"wind must be three finite numbers (north, east, down); got {wind!r}")
        self.wind = w
        self.packed[I_WN], self.packed[I_WE], self.packed[I_WD] = w

    def set_leg_speeds(self, speeds: Mapping[int, float]) -> None:
        """Speed changes (an imported mission's DO_CHANGE_SPEED): from waypoint ``k`` on the
        true airspeed commanded is ``speeds[k]`` (each checked against the envelope), unless an
        avoider commands one. Kept across a new waypoint list for the waypoints it keeps."""
        self._leg_speeds = {int(k): self._check_airspeed(float(v)) for k, v in speeds.items()}
        if 0 in self._leg_speeds:
            self.airspeed = self._leg_speeds[0]
            self._apply_modes()

    def set_leg_heights(self, heights: Mapping[int, float]) -> None:
        """Terrain-frame legs (an imported mission's MAV_FRAME_GLOBAL_TERRAIN_ALT items): on the
        leg into waypoint ``k`` the altitude command is ``heights[k]`` metres above the highest
        ground within the terrain look-ahead (down into a valley as well as up), not the line
        between the waypoints' altitudes; needs ``terrain_height``. Kept across a new waypoint
        list for the waypoints it keeps (same place), as the spirals."""
        if heights and self.terrain_height is None:
            raise InputError("terrain-frame legs need the terrain (terrain following on)")
        self._leg_heights = {int(k): float(h) for k, h in heights.items()}
        # the climb gradient the planner plans with at this speed (a share of the limit, and
        # of the best climb at the highest waypoint: thinner air, less climb)
        zs = self._wp[:, 2] if len(self._wp) else np.zeros(1)
        try:
            perf = self.params.performance(self.airspeed, (float(zs.min()), float(zs.max())))
        except InputError:
            perf = self.params.performance(self.airspeed)
        self._follow_gradient = FOLLOW_CLIMB_SHARE * perf.climb_gradient

    def _rekey_spirals(self, w: FloatArray) -> None:
        """A new waypoint list keeps the spirals (and terrain-frame legs) of the waypoints it
        keeps (same place)."""
        for book in ("_spirals", "_leg_heights", "_leg_speeds"):
            old = getattr(self, book)
            if not old:
                continue
            out = {}
            for k, v in old.items():
                hit = np.flatnonzero(np.abs(w - self._wp[k]).max(axis=1) < 1.0)
                if hit.size:
                    out[int(hit[0])] = v
            setattr(self, book, out)

    def _begin_spiral(self, k: int, then: str, fillet: Fillets | None) -> None:
        """Start the spiral at waypoint ``k`` (module docstring of planner.spiral): its quarter
        arcs into the leg array and the queue; ``then`` "finish" or "go" (the fillet, or the
        next leg, after it)."""
        entry, turns, radius, clockwise = self._spirals[k]
        w = self._wp
        if k == 0:
            anchor, q = w[0, :2], w[1, :2] - w[0, :2]
            z0 = entry
        elif fillet is not None:
            anchor, q = fillet.t1[0, 0, :2], w[k, :2] - w[k - 1, :2]
            z0 = self._spiral_z0.get(k, entry)
        else:
            anchor, q = w[k, :2], w[k, :2] - w[k - 1, :2]
            z0 = entry
        q = q / max(float(np.hypot(*q)), 1e-12)
        z1 = (
            self._spiral_z1.get(k, z0 + float(w[k, 2]) - entry)
            if fillet is not None
            else (z0 + float(w[k, 2]) - entry)
        )
        self.spiral_exits[k] = z1
        side = -1.0 if clockwise else 1.0  # + counter-clockwise (map)
        cx = float(anchor[0]) - side * radius * float(q[1])
        cy = float(anchor[1]) + side * radius * float(q[0])
        lam = 1.0 if clockwise else -1.0  # NED: +1 clockwise
        g = math.atan2(float(anchor[0]) - cx, float(anchor[1]) - cy)  # east over north
        n = 4 * turns
        arcs: list[tuple[float, ...]] = []
        for j in range(n):
            g0 = g + lam * j * 0.5 * math.pi
            g1 = g0 + lam * 0.5 * math.pi
            arcs.append(
                (
                    cy,
                    cx,
                    radius,
                    lam,
                    g0,
                    0.5 * math.pi,
                    z0 + (z1 - z0) * j / n,
                    z0 + (z1 - z0) * (j + 1) / n,
                    cy + radius * math.cos(g1),
                    cx + radius * math.sin(g1),
                    -lam * math.sin(g1),
                    lam * math.cos(g1),
                )
            )
        kern.set_arc(self._leg, *arcs[0])
        self._arcs = arcs[1:]
        self._after = (then, k, fillet)
        self._fillet_at = None

    def _guard_final_plane(self) -> None:
        """While an avoider steers (a course, bank or orbit override) the final leg ends only
        within the arrival distance: passing the goal's perpendicular plane mid-manoeuvre is
        not arriving (the plane rule is for a waypoint missed while following the leg)."""
        leg = self._leg
        final = (
            self._next == len(self._wp) - 1 and leg[kern.L_ACTIVE] > 0.5 and leg[kern.L_ARC] < 0.5
        )
        if self._override_lat is not None and final:
            if self._plane_saved is None:
                self._plane_saved = float(leg[kern.L_PLANE])
                leg[kern.L_PLANE] = math.inf
        elif self._plane_saved is not None:
            if final:
                leg[kern.L_PLANE] = self._plane_saved
            self._plane_saved = None

    def _start_leg(self, direct: bool) -> None:
        self._plane_saved = None
        i = self._next
        if not direct and (i - 1) in self._leg_speeds:
            # a speed change at the waypoint this leg leaves (DO_CHANGE_SPEED)
            self.airspeed = self._leg_speeds[i - 1]
            if not self._override_speed:
                self._cmd[kern.C_AIRSPEED] = self.airspeed
        end = map_to_ned(self._wp[i])
        if direct:
            assert self._x_last is not None
            start = np.array(self._x_last[0:3], dtype=np.float64)
            self._origin = (i, np.array([start[1], start[0], -start[2]]))
        else:
            start = map_to_ned(self._wp[i - 1])
        length = math.hypot(end[0] - start[0], end[1] - start[1])
        last = i == len(self._wp) - 1
        radius = self.config.arrival_distance if last else self.config.switch_distance
        radius = min(radius, 0.5 * length) if length > 0 else radius
        fillet = None if last else self._fillet(i)
        if fillet is not None:
            radius = 0.0  # the leg ends at its fillet's first tangent point (a plane), not a radius
        if fillet is None and i in self._spirals and not last:
            radius = 0.0  # a spiral on a straight-through waypoint starts on it (its plane)
        # the leg array holds north, east and altitude (up); it ends at the altitude the
        # aircraft arrives with (a spiral's entry)
        kern.set_leg(
            self._leg,
            start[0],
            start[1],
            -start[2],
            end[0],
            end[1],
            self._arrival(i),
            float(radius),
        )
        if fillet is not None:
            self._leg[kern.L_PLANE] = max(0.0, length - float(fillet.distance[0, 0]))
        self._fillet_at = fillet
        self._pending_direct = False

    def _fillet(self, i: int) -> Fillets | None:
        """The turn fillet at interior waypoint ``i`` (fillet mode) exactly as the planner
        computes it (:func:`planner.flown.fillets` over the path being flown: fillets that would
        overlap on a leg shrink in proportion); None when turns are not filleted or the turn is
        under a degree."""
        radius = self.config.turn_radius
        if radius is None or not 0 < i < len(self._wp) - 1:
            return None
        path, k = self._wp, i
        if self._origin is not None:
            # a direct-to leg started where the aircraft was: the path flown begins there
            j, pos = self._origin
            path = np.vstack([pos[None, :], self._wp[j:]])
            k = i - j + 1
        f = fillets(path, radius)
        if k < 1 or f.angle[0, k - 1] < math.radians(1.0):
            return None
        at = f.at(k)
        if not self._spirals:
            return at
        # with spirals a leg runs from the altitude its start is left at to the one its end is
        # arrived at (planner.spiral.flown_path); a spiral here starts at T1
        d = float(at.distance[0, 0])
        a, b, c = path[k - 1], path[k], path[k + 1]
        l1 = math.hypot(b[0] - a[0], b[1] - a[1])
        l2 = math.hypot(c[0] - b[0], c[1] - b[1])
        before = float(
            a[2] + (self._arrival(i) - a[2]) * (max(l1 - d, 0.0) / l1 if l1 > 0 else 1.0)
        )
        t1 = at.t1.copy()
        t2 = at.t2.copy()
        t2[0, 0, 2] = float(
            b[2] + (self._arrival(i + 1) - b[2]) * (min(d / l2, 1.0) if l2 > 0 else 0.0)
        )
        t1[0, 0, 2] = before
        if i in self._spirals:
            # the spiral runs from T1's altitude to T2's, and the turn after it is level
            # (planner.spiral.spiral_ends)
            self._spiral_z0[i] = before
            self._spiral_z1[i] = float(t2[0, 0, 2])
            t1[0, 0, 2] = float(t2[0, 0, 2])
        return dataclasses.replace(at, t1=t1, t2=t2)

    def _start_arc(self, f: Fillets) -> None:
        """Fly the turn fillet ``f`` (map coordinates) into the leg to waypoint ``_next``."""
        c = f.center[0, 0]
        t1 = f.t1[0, 0]
        t2 = f.t2[0, 0]
        nxt = self._wp[self._next]
        qx, qy = nxt[0] - t2[0], nxt[1] - t2[1]
        qn = math.hypot(qx, qy)
        if qn <= 1e-9:  # the fillet ends on the next waypoint: use the turn's exit direction
            qx, qy = t2[0] - c[0], t2[1] - c[1]
            qx, qy = -float(f.side[0, 0]) * qy, float(f.side[0, 0]) * qx
            qn = math.hypot(qx, qy)
        # NED: north = map y, east = map x; a left (counter-clockwise) turn is lam = -1
        kern.set_arc(
            self._leg,
            float(c[1]),
            float(c[0]),
            float(f.radius[0, 0]),
            -float(f.side[0, 0]),
            math.atan2(t1[0] - c[0], t1[1] - c[1]),
            float(f.angle[0, 0]),
            float(t1[2]),
            float(t2[2]),
            float(t2[1]),
            float(t2[0]),
            qy / qn,
            qx / qn,
        )
        self._fillet_at = None

    def set_override(
        self,
        *,
        course: float | None = None,
        bank: float | None = None,
        altitude: float | None = None,
        airspeed: float | None = None,
        climb_rate: float | None = None,
    ) -> None:
        """Hold a course (rad, clockwise from north) or a bank angle (rad), an altitude (m) or a
        climb rate (m/s, + up, within the vehicle's climb and descent limits) and/or an airspeed
        (m/s) instead of the waypoint guidance; ``None`` leaves an axis as it is."""
        if course is not None and bank is not None:
            raise InputError("override either the course or the bank angle, not both")
        if altitude is not None and climb_rate is not None:
            raise InputError("override either the altitude or the climb rate, not both")
        for name, value in (("course", course), ("bank", bank), ("altitude", altitude)):
            if value is not None and not math.isfinite(value):
                raise InputError(f"{name} must be a finite number; got {value!r}")
        if course is not None:
            self._override_lat = "course"
            self._cmd[kern.C_COURSE] = float(course)
        if bank is not None:
            self._override_lat = "bank"
            self._cmd[kern.C_BANK] = float(bank)
        if altitude is not None:
            self._override_alt = "altitude"
            self._cmd[kern.C_ALT] = float(altitude)
        if climb_rate is not None:
            p = self.params
            if not -p.descent_rate_max <= climb_rate <= p.climb_rate_max:  # also refuses NaN
                raise GuidanceRefused(
                    f"climb rate {climb_rate:g} m/s is outside {p.name}'s limits "
                    f"-{p.descent_rate_max:g}..{p.climb_rate_max:g} m/s (descent_rate_max, "
                    "climb_rate_max)"
                )
            self._override_alt = "climb"
            self._cmd[kern.C_CLIMB] = float(climb_rate)
        if airspeed is not None:
            self._override_speed = True
            self._cmd[kern.C_AIRSPEED] = self._check_airspeed(airspeed)
        self._apply_modes()

    def min_orbit_radius(self) -> float:
        """The tightest orbit at the commanded airspeed in the wind flown now: the bank limit at
        the fastest ground speed round it, (V + w)^2 / (g tan(bank_max)) (the downwind side of
        an orbit flown tighter drifts out)."""
        return self.params.min_turn_radius(self.airspeed + math.hypot(self.wind[0], self.wind[1]))

    def set_orbit(
        self,
        center: Sequence[float],
        radius: float,
        *,
        clockwise: bool = True,
        altitude: float | None = None,
        center_velocity: Sequence[float] = (0.0, 0.0),
    ) -> None:
        """Orbit ``center`` (map x, y) at ``radius`` m, clockwise seen from above or not, holding
        ``altitude`` (default: the altitude flown now); a moving centre has ``center_velocity``
        (map m/s east, north). An orbit tighter than the aircraft can fly at its airspeed is
        refused (:class:`OrbitRefused`): it is never silently flown wider."""
        c = [float(v) for v in center]
        cv = [float(v) for v in center_velocity]
        if len(c) != 2 or len(cv) != 2 or not all(math.isfinite(v) for v in (*c, *cv)):
            raise InputError(
                f"orbit centre and its velocity must be two finite numbers each; got {center!r}, "
                f"{center_velocity!r}"
            )
        if not (math.isfinite(radius) and radius > 0):
            raise InputError(f"orbit radius must be a number of metres > 0; got {radius!r}")
        tightest = self.min_orbit_radius()
        if radius < tightest:
            w = math.hypot(self.wind[0], self.wind[1])
            formula = f"(V + w)^2, w = {w:.1f} m/s of wind" if w > 0 else "V^2"
            raise OrbitRefused(
                f"orbit radius {radius:.0f} m is tighter than {self.params.name} can fly at "
                f"{self.airspeed:g} m/s: at least {tightest:.0f} m ({formula} / (g tan "
                f"{self.params.bank_max_deg:g} deg))"
            )
        cmd = self._cmd
        cmd[kern.C_ORB_N], cmd[kern.C_ORB_E] = c[1], c[0]
        cmd[kern.C_ORB_VN], cmd[kern.C_ORB_VE] = cv[1], cv[0]
        cmd[kern.C_ORB_R] = float(radius)
        cmd[kern.C_ORB_LAM] = 1.0 if clockwise else -1.0
        self._override_lat = "orbit"
        if altitude is not None:
            self.set_override(altitude=altitude)
        elif not self._override_alt:
            self._hold_alt_pending = True
        self._apply_modes()

    def clear_override(self) -> None:
        """Return every axis to waypoint guidance (and the commanded airspeed)."""
        self._override_lat = None
        self._override_alt = None
        self._hold_alt_pending = False
        self._override_speed = False
        self._cmd[kern.C_AIRSPEED] = self.airspeed
        self._apply_modes()

    def _apply_modes(self) -> None:
        self._guard_final_plane()
        cmd = self._cmd
        following = self._leg[kern.L_ACTIVE] > 0.5 and not self._done
        if self._override_lat == "bank":
            cmd[kern.C_LAT_MODE] = 2
        elif self._override_lat == "orbit":
            cmd[kern.C_LAT_MODE] = 3
        elif self._override_lat == "course" or not following:
            cmd[kern.C_LAT_MODE] = 1
        else:
            cmd[kern.C_LAT_MODE] = 0
        if self._override_alt == "climb":
            cmd[kern.C_ALT_MODE] = 2
        else:
            cmd[kern.C_ALT_MODE] = 1 if (self._override_alt or not following) else 0
        if not self._override_speed:
            cmd[kern.C_AIRSPEED] = self.airspeed

    def _finish(self) -> None:
        """After the final waypoint: hold the last leg's course and the last altitude."""
        self._done = True
        leg = self._leg
        leg[kern.L_ACTIVE] = 0.0
        if self._override_lat is None:
            self._cmd[kern.C_COURSE] = leg[kern.L_CHI]
        if not self._override_alt:
            self._cmd[kern.C_ALT] = leg[kern.L_H1]
        self._apply_modes()

    def _hold_current(self, x: FloatArray) -> None:
        """No waypoints: hold the present course and altitude."""
        vn, ve = _ground_velocity(x)
        if self._override_lat is None:
            self._cmd[kern.C_COURSE] = math.atan2(ve, vn) if math.hypot(vn, ve) > 0.5 else x[8]
        if not self._override_alt:
            self._cmd[kern.C_ALT] = -x[2]
        self._hold_pending = False
        self._apply_modes()

    def _switch(self, ev: int, t: float, x: FloatArray) -> None:
        if self._leg[kern.L_ARC] > 0.5:
            if self._arcs:  # the next quarter of a spiral
                kern.set_arc(self._leg, *self._arcs.pop(0))
                return
            if self._after is not None:  # a spiral is done: what follows it
                then, k, fillet = self._after
                self._after = None
                _, _, dist = kern.leg_geometry(x, self._leg)
                self.reached.append(WaypointReached(k, float(t), float(dist), "spiral"))
                if then == "finish":
                    self._finish()
                    return
                if fillet is not None:
                    self._start_arc(fillet)
                else:
                    self._start_leg(False)
                self._apply_modes()
                return
            # a turn fillet is done: fly the leg it turned into
            self._start_leg(False)
            self._apply_modes()
            return
        _, _, dist = kern.leg_geometry(x, self._leg)
        fillet = self._fillet_at
        how = "fillet" if fillet is not None else ("radius" if ev == 1 else "plane")
        k = self._next
        self.reached.append(WaypointReached(k, float(t), float(dist), how))
        last = k + 1 >= len(self._wp)
        if k in self._spirals:
            if not last:
                self._next += 1
            self._begin_spiral(k, "finish" if last else "go", fillet)
            self._apply_modes()
            return
        if last:
            self._finish()
            return
        self._next += 1
        if fillet is not None:
            self._start_arc(fillet)
        else:
            self._start_leg(False)
        self._apply_modes()

    def _prepare(self, x: FloatArray, t: float) -> None:
        """Everything that happens between control steps: pending modes, leg changes."""
        self._x_last = x
        if self._pending_direct:
            self._start_leg(True)
            self._apply_modes()
        if self._hold_pending:
            self._hold_current(x)
        if self._hold_alt_pending:
            self._override_alt = "altitude"
            self._cmd[kern.C_ALT] = -x[2]
            self._hold_alt_pending = False
            self._apply_modes()
        while True:
            ev = int(kern.leg_done(x, self._leg))
            if ev == 0:
                break
            self._switch(ev, t, x)

    def _update_terrain(self, x: FloatArray) -> None:
        if self.terrain_height is None:
            return
        if self.land and self._next == len(self._wp) - 1 and not self._done:
            # the final approach of a landing descends to the ground: no terrain floor on it
            # (the plan checked it against an obstacle-clearance surface)
            self._cmd[kern.C_FLOOR] = -math.inf
            return
        vn, ve = _ground_velocity(x)
        vg = math.hypot(vn, ve)
        n_s = self.config.terrain_samples
        s = np.linspace(0.0, self.terrain_lookahead, n_s + 1)
        px, py = [np.array([x[1]])], [np.array([x[0]])]
        in_arc = self._leg[kern.L_ACTIVE] > 0.5 and self._leg[kern.L_ARC] > 0.5
        if vg > 0.5 and not in_arc:
            # ahead on the ground track (not in a turn: the track curves away from its
            # tangent, which would look into terrain the turn never reaches; the arc's own
            # samples below start where the aircraft is)
            px.append(x[1] + s * ve / vg)
            py.append(x[0] + s * vn / vg)
        if in_arc:
            leg = self._leg
            cn, ce, rho, lam = leg[kern.L_CN], leg[kern.L_CE], leg[kern.L_RHO], leg[kern.L_LAM]
            gam = math.atan2(x[1] - ce, x[0] - cn)  # where the aircraft is on the circle
            end = leg[kern.L_GAM0] + lam * leg[kern.L_SWEEP]
            rest = min((lam * (end - gam)) % (2.0 * math.pi), leg[kern.L_SWEEP])
            # the rest of this turn (and of a spiral's quarters queued after it: at most the
            # whole circle); in a turn's last quarter, along the leg it turns into as well (the
            # plan climbs that leg at its gradient: looking along it from the spiral's first
            # turn held the aircraft up to 175 m above the planned spiral)
            rest = min(rest + sum(a[5] for a in self._arcs), 2.0 * math.pi)
            # (a spiral at the goal has no leg after it: the mission ends where it does)
            finishing = self._after is not None and self._after[0] == "finish"
            if not self._arcs and not finishing:
                px.append(leg[kern.L_EE] + s * leg[kern.L_EQE])
                py.append(leg[kern.L_EN] + s * leg[kern.L_EQN])
            ang = gam + lam * np.linspace(0.0, rest, n_s + 1)
            px.append(ce + rho * np.sin(ang))
            py.append(cn + rho * np.cos(ang))
        elif self._leg[kern.L_ACTIVE] > 0.5:
            leg = self._leg
            _, along, _ = kern.leg_geometry(x, leg)
            a = np.clip(along + s, 0.0, leg[kern.L_LEN])
            px.append(leg[kern.L_E0] + a * leg[kern.L_QE])
            py.append(leg[kern.L_N0] + a * leg[kern.L_QN])
        hx = np.concatenate(px)
        hy = np.concatenate(py)
        heights = np.asarray(self.terrain_height(hx, hy), dtype=np.float64)
        top = float(np.nanmax(heights)) if heights.size else -math.inf
        agl = self._leg_heights.get(self._next) if not self._done else None
        if agl is not None and not in_arc and not self._arcs:
            # a terrain-frame leg: ``agl`` above the ground under the aircraft, raised where
            # ground ahead rises faster than the aircraft climbs (the lowest altitude from which
            # it still clears every sample ahead at its planning climb gradient): down into a
            # valley as well as up, as an autopilot following terrain flies it
            if self._leg[kern.L_ACTIVE] > 0.5:
                # every 50 m to the leg's end: a valley deeper than the look-ahead is long
                # must not be entered further than the aircraft can climb out of by the end
                leg = self._leg
                _, along, _ = kern.leg_geometry(x, leg)
                rest = max(float(leg[kern.L_LEN]) - along, 0.0)
                a = along + np.linspace(0.0, rest, max(2, int(rest / 50.0) + 1))
                # and the waypoint itself (a turn fillet ends the leg before it)
                end = self._wp[self._next]  # map x (east), y (north)
                ex = np.append(leg[kern.L_E0] + a * leg[kern.L_QE], end[0])
                ny = np.append(leg[kern.L_N0] + a * leg[kern.L_QN], end[1])
                hx, hy = np.concatenate([hx, ex]), np.concatenate([hy, ny])
                heights = np.concatenate(
                    [heights, np.asarray(self.terrain_height(ex, ny), dtype=np.float64)]
                )
            dist = np.hypot(hx - x[1], hy - x[0])
            need = heights + agl - dist * self._follow_gradient
            self._cmd[kern.C_FOLLOW] = 1.0
            self._cmd[kern.C_FLOOR] = float(np.nanmax(need)) if need.size else -math.inf
            return
        self._cmd[kern.C_FOLLOW] = 0.0
        self._cmd[kern.C_FLOOR] = top + self.config.terrain_clearance

    # ---- running ------------------------------------------------------------------------------
    def command(self, t: float, state: npt.ArrayLike) -> FloatArray:
        """Controls ``[delta_e, delta_a, delta_r, delta_t]`` for ``state`` at time ``t``.

        Call once per control period (``config.dt``, 100 Hz); the integrators use the time since
        the previous call. Leg changes and terrain look-ups happen here.
        """
        x = np.ascontiguousarray(state, dtype=np.float64)
        if x.shape != (N_STATES,):
            raise InputError(f"state must have {N_STATES} elements, found shape {x.shape}")
        t = float(t)
        if self._t_last is None or not 0.0 < t - self._t_last < 1.0:
            dtc = self.config.dt * self.config.control_every
        else:
            dtc = t - self._t_last
        self._prepare(x, t)
        if self.terrain_height is not None and t >= self._terrain_next - 1e-9:
            self._update_terrain(x)
            self._terrain_next = t + self.config.terrain_update
        kern.control_law(x, self.packed, self._gk, self._cmd, self._leg, self._ap, dtc, self._u)
        self._t_last = t
        self._x_last = x.copy()
        return self._u.copy()

    def fly(
        self, state: npt.ArrayLike, t: float, duration: float, *, record_every: int = 0
    ) -> FlightLog:
        """Fly the vehicle with this autopilot for ``duration`` seconds from ``state`` at ``t``
        (compiled RK4 at ``config.dt``, control law every ``config.control_every`` steps).
        ``record_every`` > 0 records every that many steps."""
        cfg = self.config
        dt = cfg.dt
        x = np.array(state, dtype=np.float64)
        if x.shape != (N_STATES,) or not np.isfinite(x).all():
            raise InputError(f"state must be {N_STATES} finite numbers, found shape {x.shape}")
        n_total = int(round(duration / dt))
        if n_total < 0:
            raise InputError(f"duration must be >= 0 s, found {duration!r}")
        k_start = int(round(t / dt))
        t0_grid = t - k_start * dt
        rec = FlightRecorder(n_total, record_every, t0_grid, dt, kern.N_GUIDANCE_LOG)
        first_reached = len(self.reached)
        terrain_steps = max(1, int(round(cfg.terrain_update / dt)))
        decim = cfg.control_every
        gust, self._gust = self._gust, _NO_GUST  # this call's turbulence (set_gusts), used once
        done = 0
        while done < n_total:
            k = k_start + done
            tk = t0_grid + k * dt
            if k % decim == 0:
                self._prepare(x, tk)
            chunk = n_total - done
            if self.terrain_height is not None:
                if k % terrain_steps == 0 or self._terrain_next == -math.inf:
                    self._update_terrain(x)
                    self._terrain_next = tk + cfg.terrain_update
                chunk = min(chunk, terrain_steps - (k % terrain_steps))
            steps, ev, nr = kern.fly(
                x,
                chunk,
                k,
                dt,
                decim,
                self.packed,
                self._gk,
                self._cmd,
                self._leg,
                self._ap,
                self._u,
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
                self._switch(ev, t0_grid + (k + steps) * dt, x)
        self._x_last = x.copy()
        t_end = t0_grid + (k_start + n_total) * dt
        self._t_last = t_end - dt
        return rec.log(x, t_end, self._u.copy(), tuple(self.reached[first_reached:]), n_total)

    @property
    def energy_used(self) -> float:
        """What the engine has drawn in :meth:`fly` so far: the battery's energy (J) of an
        electric aircraft, the fuel (kg) of a piston engine (``kernels.drain``)."""
        return float(self._used[0])

    def reset_integrators(self) -> None:
        self._ap[:] = 0.0

    @property
    def guidance(self) -> GuidanceState:
        ap = self._ap
        if self._done:
            mode = "done"
        elif self._override_lat or self._override_alt or self._override_speed:
            mode = "override"
        elif self._leg[kern.L_ACTIVE] > 0.5:
            mode = "waypoints"
        else:
            mode = "hold"
        floor = float(self._cmd[kern.C_FLOOR])
        return GuidanceState(
            mode=mode,
            next_index=len(self._wp) if self._done else self._next,
            leg_index=(len(self._wp) if self._done else self._next) - 1,
            cross_track=float(ap[kern.A_XTRACK]),
            along_track=float(ap[kern.A_ALONG]),
            distance_to_next=float(ap[kern.A_DIST]),
            course_cmd=float(ap[kern.A_CHI_C]),
            bank_cmd=float(ap[kern.A_PHI_C]),
            altitude_cmd=float(ap[kern.A_H_C]),
            climb_rate_cmd=float(ap[kern.A_HDOT_C]),
            pitch_cmd=float(ap[kern.A_THETA_C]),
            airspeed_cmd=float(ap[kern.A_VA_C]),
            terrain_floor=None if math.isinf(floor) else floor,
        )

    def commanded(self, t: float) -> Commanded:
        """What the autopilot flies at ``t`` beside its legs (see :class:`Commanded`): the
        lateral override (a course, a bank, an orbit; else the leg, ``"path"``) and whether the
        altitude is a command (held, or the leg's profile) or a climb rate."""
        cmd = self._cmd
        lateral = self._override_lat or "path"
        vertical = "climb" if self._override_alt == "climb" else "altitude"
        return Commanded(
            t=float(t),
            lateral=lateral,
            vertical=vertical,
            course=float(cmd[kern.C_COURSE]),
            center=(float(cmd[kern.C_ORB_E]), float(cmd[kern.C_ORB_N])),
            center_velocity=(float(cmd[kern.C_ORB_VE]), float(cmd[kern.C_ORB_VN])),
            radius=float(cmd[kern.C_ORB_R]),
            clockwise=bool(cmd[kern.C_ORB_LAM] > 0.0),
            climb_rate=float(cmd[kern.C_CLIMB]),
        )

    def retune(self, airspeed: float) -> None:
        """Redesign the gains for a new commanded airspeed (and command it)."""
        self.airspeed = self._check_airspeed(airspeed)
        self.gains = self._design()
        self._gk = self.gains.pack(
            self.params,
            math.radians(self.config.approach_angle_deg),
            self.path_gain,
            self.config.orbit_gain,
        )
        self._apply_modes()


def _ground_velocity(x: Sequence[float] | FloatArray) -> tuple[float, float]:
    phi, theta, psi = x[6], x[7], x[8]
    sf, cf = math.sin(phi), math.cos(phi)
    st, ct = math.sin(theta), math.cos(theta)
    sp, cp = math.sin(psi), math.cos(psi)
    u, v, w = x[3], x[4], x[5]
    vn = ct * cp * u + (sf * st * cp - cf * sp) * v + (cf * st * cp + sf * sp) * w
    ve = ct * sp * u + (sf * st * sp + cf * cp) * v + (cf * st * sp - sf * cp) * w
    return float(vn), float(ve)


__all__ = [
    "Autopilot",
    "AutopilotConfig",
    "GuidanceState",
    "OrbitRefused",
]
