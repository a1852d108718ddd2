"""Vehicle parameters: mass properties, stability and control derivatives, propulsion, limits.

One frozen :class:`VehicleParams` holds everything the 6-DOF model (``dynamics.py``), the trim
(``trim.py``) and the autopilot (``replay/flight/fixedwing/autopilot.py``) need. Conventions are those of Beard &
McLain, *Small Unmanned Aircraft: Theory and Practice* (Princeton, 2012), ch. 3-4:

- body axes x forward, y right wing, z down; all derivatives per radian; the rate derivatives
  multiply the non-dimensional rates ``c q / (2 Va)`` and ``b p / (2 Va)``, ``b r / (2 Va)``;
- controls ``[delta_e, delta_a, delta_r, delta_t]`` (rad, rad, rad, throttle 0..1); positive elevator
  is trailing edge down (nose-down moment, ``Cmde < 0``), positive aileron gives a positive
  (right-wing-down) rolling moment, positive rudder gives a nose-left moment (``Cndr < 0``).

Aerodynamic model (Beard & McLain eqs 4.9-4.11, the "nonlinear" lift and drag)::

    CL(a) = (1 - s(a)) (CL0 + CLalpha a) + s(a) 2 sign(a) sin(a)^2 cos(a)
    s(a)  = (1 + e^-M(a-a0) + e^M(a+a0)) / ((1 + e^-M(a-a0)) (1 + e^M(a+a0)))
          = 1 - L(M (a0 - a)) L(M (a0 + a)),    L(z) = 1 / (1 + e^-z)   (same value, no overflow)
    CD(a) = CDp + ((1 - s(a)) (CL0 + CLalpha a))^2 / (pi e AR) + s(a) 2 |sin(a)|^3,  AR = b^2 / S

so ``M`` and ``alpha0`` set where the linear lift curve blends into the flat plate (stall). The
drag is eq. 4.11 where the flow is attached (s ~ 0: unchanged for every UAV preset in flight)
but not near and past the stall: eq. 4.11 squares the *linear* lift coefficient, so as the lift
curve bends the induced drag keeps growing as if it did not (the Cessna at 12 deg: 0.21 against
JSBSim's c172p table's 0.157). Here the induced drag is that of the attached-flow part of the
lift, and the flat plate's part brings its own drag (its normal force 2 sin^2 a, times sin a).
Air density ``rho`` is the ISA standard atmosphere's at the aircraft's altitude
(:mod:`replay.flight.atmosphere`, optionally on a day ``temperature_offset`` K off standard, given to
:meth:`VehicleParams.pack`): the aerodynamics and the propeller lose force with height.

Propulsion: ``engine`` is one of two power-limited models (the 2012 book's propeller,
``T = 1/2 rho S_prop C_prop ((k_motor delta_t)^2 - Va^2)``, had no power limit: 6.2 times the
Aerosonde's weight of static thrust, a Cessna climbing 5.3 m/s; it is gone).

``electric`` -- the motor and propeller of Beard & McLain's second edition (2021, §4.3): the
throttle sets the motor voltage ``V_in = delta_t battery_voltage``; the propeller speed Omega
balances motor and propeller torque::

    rho D^5 CQ0 / (4 pi^2) Omega^2 + (rho D^4 CQ1 Va / (2 pi) + KQ^2 / R) Omega
        + (rho D^3 CQ2 Va^2 - KQ V_in / R + KQ i0) = 0          (positive root; 0 if none)
    J = 2 pi Va / (Omega D),   CT = CT2 J^2 + CT1 J + CT0,   CQ = CQ2 J^2 + CQ1 J + CQ0
    T = rho (Omega / (2 pi))^2 D^4 CT,   Q = rho (Omega / (2 pi))^2 D^5 CQ,   l_prop = -Q

so the thrust falls with airspeed and with the air's density.  The motor controller draws no
negative current (no regenerative braking, our choice): when the propeller would turn faster than
the voltage drives it (``KV Omega > V_in``, e.g. at closed throttle) it freewheels -- the same
balance with the motor's no-load friction ``KQ i0`` alone -- and its thrust is the small
windmilling drag of the propeller.

``piston`` -- a fixed-pitch propeller on a piston engine: the engine's torque is taken constant
with rpm (shaft power ``P_e = delta_t phi(sigma) power_max n / n_r`` at propeller speed n rev/s,
``n_r = rated_rpm / 60``) with the Gagg-Ferrar lapse ``phi = (sigma - 0.117) / 0.883``
(sigma = rho / rho0, a normally aspirated engine); the propeller absorbs
``P_p = CP(J) rho n^3 D^5`` and gives ``T = CT(J) rho n^2 D^4`` (``J = Va / (n D)``, CT and CP
quadratics in J).  P_e = P_p is a quadratic in n::

    CP0 rho D^5 n^2 + CP1 rho D^4 Va n + CP2 rho D^3 Va^2 - delta_t phi power_max / n_r = 0

(positive root).  Above the rated rpm the throttle is held back to keep n = n_r, as the pilot
of a fixed-pitch propeller does (and as JSBSim's c172p is held in the validation).  At closed
throttle the propeller windmills where CP(J) = 0, its (negative) thrust the windmilling drag.
No engine torque on the airframe.

Angles of the envelope and of the control-surface travel are stored in degrees (field names end in
``_deg``); ``alpha0`` is in radians as in the book. :meth:`VehicleParams.pack` flattens the
parameters into the float64 array the numba kernels take (layout: the ``I_*`` indices below).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from planner.performance import Performance
from replay.flight.atmosphere import check_offset, true_airspeed
from replay.flight.base import G, TerrainHeight, check_numbers
from replay.flight.energy import ESC_EFFICIENCY
from terrain.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Sequence

    from planner.spiral import Spiral
    from replay.flight.fixedwing.stack import FixedWingStack

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class VehicleParams:
    """A fixed-wing aircraft. Units: SI (kg, m, s, rad) unless the name ends in ``_deg``."""

    name: str
    # mass properties
    mass: float  # kg
    Jx: float  # kg m^2
    Jy: float
    Jz: float
    Jxz: float
    # geometry and air
    S: float  # wing area, m^2
    b: float  # span, m
    c: float  # mean aerodynamic chord, m
    e: float  # Oswald efficiency of the drag polar
    # longitudinal derivatives
    CL0: float
    CLalpha: float
    CLq: float
    CLde: float
    CDp: float  # parasitic drag (the polar adds the induced part)
    CDq: float
    CDde: float
    Cm0: float
    Cmalpha: float
    Cmq: float
    Cmde: float
    # lateral derivatives
    CY0: float
    CYbeta: float
    CYp: float
    CYr: float
    CYda: float
    CYdr: float
    Cl0: float
    Clbeta: float
    Clp: float
    Clr: float
    Clda: float
    Cldr: float
    Cn0: float
    Cnbeta: float
    Cnp: float
    Cnr: float
    Cnda: float
    Cndr: float
    # stall blending
    M: float  # sharpness of the blend
    alpha0: float  # rad, centre of the blend
    # control-surface travel (degrees; the elevator may be asymmetric)
    elevator_min_deg: float
    elevator_max_deg: float
    aileron_max_deg: float
    rudder_max_deg: float
    # flight envelope used by the autopilot
    cruise_speed: float  # m/s
    airspeed_min: float  # m/s
    airspeed_max: float  # m/s
    bank_max_deg: float = 30.0  # seed 000 §2.3.2.4, seed 001 §4.1
    pitch_max_deg: float = 20.0  # seed 001 §4.1
    pitch_min_deg: float = -20.0
    climb_rate_max: float = 3.0  # m/s (seed 000 §2.3: 3 m/s for its solar UAV)
    descent_rate_max: float = 3.0  # m/s, positive number
    # propulsion (module docstring)
    engine: str = "electric"  # "electric" or "piston"
    prop_diameter: float = 0.0  # m
    battery_voltage: float = 0.0  # electric: V at full throttle
    motor_kv: float = 0.0  # electric: back-EMF constant, V s/rad
    motor_kq: float = 0.0  # electric: torque constant, N m/A
    motor_resistance: float = 0.0  # electric: ohm
    motor_no_load_current: float = 0.0  # electric: A
    CT0: float = 0.0  # thrust coefficient CT(J) = CT2 J^2 + CT1 J + CT0
    CT1: float = 0.0
    CT2: float = 0.0
    CQ0: float = 0.0  # electric: torque coefficient CQ(J) = CQ2 J^2 + CQ1 J + CQ0
    CQ1: float = 0.0
    CQ2: float = 0.0
    power_max: float = 0.0  # piston: shaft power at sea level, full throttle, rated rpm, W
    rated_rpm: float = 0.0  # piston: rev/min
    CP0: float = 0.0  # piston: power coefficient CP(J) = CP2 J^2 + CP1 J + CP0 (CT as above)
    CP1: float = 0.0
    CP2: float = 0.0
    # energy (module docstring, "Energy"): what the engine draws and what it carries
    esc_efficiency: float = ESC_EFFICIENCY  # electric: battery power = motor input power / this
    bsfc_g_per_kwh: float = 0.0  # piston: fuel per shaft energy, g/kWh
    battery_wh: float = 0.0  # electric: usable battery energy, Wh (0: not given)
    fuel_kg: float = 0.0  # piston: usable fuel, kg (0: not given)
    # alpha-dot derivatives (per rad of alpha-dot c / (2 Va)): the tail meets the downwash the
    # wing shed a moment ago (Beard & McLain leave them out: zero for their airframes)
    CLadot: float = 0.0
    Cmadot: float = 0.0
    source: str = ""  # where the numbers come from (free text)

    def __post_init__(self) -> None:
        validate(self)

    # ---- derived quantities -------------------------------------------------------------------
    @property
    def aspect_ratio(self) -> float:
        return self.b * self.b / self.S

    @property
    def weight(self) -> float:
        return self.mass * G

    def gammas(self) -> tuple[float, ...]:
        """Beard & McLain eq. 3.13: Gamma, Gamma_1 .. Gamma_8 of the rotational equations."""
        jx, jy, jz, jxz = self.Jx, self.Jy, self.Jz, self.Jxz
        g = jx * jz - jxz * jxz
        return (
            g,
            jxz * (jx - jy + jz) / g,
            (jz * (jz - jy) + jxz * jxz) / g,
            jz / g,
            jxz / g,
            (jz - jx) / jy,
            jxz / jy,
            ((jx - jy) * jx + jxz * jxz) / g,
            jx / g,
        )

    def control_limits(self) -> tuple[FloatArray, FloatArray]:
        """(lower, upper) bounds of ``[delta_e, delta_a, delta_r, delta_t]`` in rad / throttle."""
        d = math.radians
        lo = np.array(
            [d(self.elevator_min_deg), -d(self.aileron_max_deg), -d(self.rudder_max_deg), 0.0]
        )
        hi = np.array(
            [d(self.elevator_max_deg), d(self.aileron_max_deg), d(self.rudder_max_deg), 1.0]
        )
        return lo, hi

    def airspeed_range(
        self, altitude: float = 0.0, temperature_offset: float = 0.0
    ) -> tuple[float, float]:
        """The envelope (airspeed_min, airspeed_max: equivalent airspeeds) as true airspeeds
        at ``altitude`` (m AMSL) on a day ``temperature_offset`` K off standard."""
        lo, hi = np.asarray(
            true_airspeed([self.airspeed_min, self.airspeed_max], altitude, temperature_offset)
        )
        return float(lo), float(hi)

    @property
    def follows_terrain(self) -> bool:
        """The fixed-wing stack follows the terrain when asked (its autopilot's floor)."""
        return True

    def check_speed(self, speed: float, what: str = "speed") -> float:
        """``speed`` as a float: the fixed wing's trim at the start of a flight refuses a speed it
        cannot fly, naming those it can."""
        return float(speed)

    def flight_stack(
        self,
        waypoints: npt.ArrayLike,
        *,
        speed: float,
        turn_radius: float | None = None,
        switch_distance: float = 1000.0,
        terrain_height: TerrainHeight | None = None,
        terrain_clearance: float = 0.0,
        temperature_offset: float = 0.0,
        spirals: Sequence[Spiral] = (),
        land: bool = False,
        leg_heights: Mapping[int, float] | None = None,
        leg_speeds: Mapping[int, float] | None = None,
    ) -> FixedWingStack:
        """The aircraft under its autopilot flying ``waypoints`` at ``speed``: turn fillets of
        ``turn_radius`` (else the leg switch ``switch_distance`` before a waypoint), the climb
        and descent ``spirals`` of the plan, terrain following when ``terrain_height`` is
        given (not on a landing's final approach, ``land``); on the terrain-frame legs
        ``leg_heights`` (waypoint index -> metres: the leg into it) the altitude flown is that
        height above the highest ground ahead (:meth:`Autopilot.set_leg_heights`)."""
        from replay.flight.fixedwing.stack import FixedWingStack

        return FixedWingStack(
            self,
            waypoints,
            airspeed=speed,
            turn_radius=turn_radius,
            switch_distance=switch_distance,
            terrain_height=terrain_height,
            terrain_clearance=terrain_clearance,
            temperature_offset=temperature_offset,
            spirals=spirals,
            land=land,
            leg_heights=leg_heights,
            leg_speeds=leg_speeds,
        )

    def min_turn_radius(self, speed: float | None = None) -> float:
        """V^2 / (g tan(bank_max)) (seed 000 eq. 13) at ``speed`` (default: cruise)."""
        v = self.cruise_speed if speed is None else speed
        return v * v / (G * math.tan(math.radians(self.bank_max_deg)))

    def performance(
        self,
        speed: float | None = None,
        altitudes: tuple[float, float] | None = None,
        temperature_offset: float = 0.0,
    ) -> Performance:
        """What the planner needs of this aircraft at true airspeed ``speed`` (default: cruise).

        Without ``altitudes`` the speed is checked against the envelope at sea level, where
        equivalent and true airspeed agree, and the climb rate is the autopilot's limit. With
        ``altitudes`` = (lowest, highest) m AMSL the plan may fly: the speed must lie in the
        true-airspeed envelope at both ends (the envelope is equivalent airspeed: its true speeds
        grow with height, so the highest altitude sets the slowest speed and the lowest the
        fastest), and the climb rate is the smaller of the autopilot's limit and the best
        steady climb the aircraft makes at that speed at the highest altitude (thinner air, less
        power: the Cessna's 3 m/s limit is 1.3 m/s at 3,000 m); the ceiling at that speed
        (:meth:`ceiling`) goes with it. The descent rate likewise is the smaller of the
        autopilot's limit and the steepest idle descent at that speed at the highest altitude
        (:func:`~replay.flight.fixedwing.trim.best_descent`: the same true airspeed sinks less in
        thinner air, so the top is the conservative end): the solar UAV's 1.5 m/s limit is a
        1.0 m/s glide at 3,000 m, and a plan made with the limit was flown 50-94 m above its
        profile."""
        v = self.cruise_speed if speed is None else float(speed)
        if altitudes is None:
            if not (math.isfinite(v) and self.airspeed_min <= v <= self.airspeed_max):
                raise InputError(
                    f"speed {v:g} m/s is outside {self.name}'s airspeed envelope "
                    f"{self.airspeed_min:g}–{self.airspeed_max:g} m/s"
                )
            climb, descent = self.climb_rate_max, self.descent_rate_max
            return Performance(self.name, v, climb, descent, self.bank_max_deg)
        from replay.flight.fixedwing.trim import best_climb, best_descent

        climb = self._climb_over(v, altitudes, temperature_offset)
        ceiling = self.ceiling(v, temperature_offset)
        top = float(altitudes[1])
        descent = min(self.descent_rate_max, best_descent(self, v, top, temperature_offset))
        perf = Performance(self.name, v, climb, descent, self.bank_max_deg, ceiling=ceiling)
        # the climb in a spiral of the planned turn radius, at the highest altitude
        turn = best_climb(self, v, top, temperature_offset, perf.turn_radius)
        return replace(perf, turn_climb_rate=min(self.climb_rate_max, turn))

    def _climb_over(
        self, v: float, altitudes: tuple[float, float], temperature_offset: float
    ) -> float:
        from replay.flight.fixedwing.trim import best_climb  # trim imports this module

        low, high = (float(a) for a in altitudes)
        eas = f"{self.airspeed_min:g}–{self.airspeed_max:g} m/s equivalent"
        for h, bad in ((high, lambda lo, hi: v < lo), (low, lambda lo, hi: v > hi)):
            lo, hi = self.airspeed_range(h, temperature_offset)
            if not math.isfinite(v) or bad(lo, hi):
                where = "highest" if h == high else "lowest"
                raise InputError(
                    f"speed {v:g} m/s (true airspeed) is outside {self.name}'s envelope at "
                    f"{h:,.0f} m, the {where} altitude the plan may fly: it can fly "
                    f"{lo:.1f}–{hi:.1f} m/s true there ({eas}); choose a speed in it "
                    "(--speed) or a narrower altitude band (--zmin/--zmax)"
                )
        best = best_climb(self, v, high, temperature_offset)
        if best <= 0.0:
            raise InputError(
                f"{self.name} cannot hold level flight at {v:g} m/s (true airspeed) at "
                f"{high:,.0f} m, the highest altitude the plan may fly; choose another speed "
                "(--speed) or a lower band (--zmax)"
            )
        return min(self.climb_rate_max, best)

    def ceiling(self, speed: float | None = None, temperature_offset: float = 0.0) -> float:
        """The ceiling (m AMSL, to 25 m) at true airspeed ``speed`` (default: cruise) on a day
        ``temperature_offset`` K off standard: the lower of the altitude where its best steady
        climb falls below 0.5 m/s (:func:`replay.flight.fixedwing.trim.ceiling`) and
        :meth:`envelope_ceiling`. Cached: a bisection of trim solves, a few tenths of a second."""
        from replay.flight.fixedwing.trim import ceiling  # trim imports this module

        v = self.cruise_speed if speed is None else float(speed)
        return min(
            ceiling(self, v, float(temperature_offset)),
            self.envelope_ceiling(v, temperature_offset),
        )

    def envelope_ceiling(
        self, speed: float | None = None, temperature_offset: float = 0.0
    ) -> float:
        """The highest altitude (m AMSL, rounded down to 25 m) at which true airspeed ``speed``
        is still inside the envelope: ``airspeed_min`` is an equivalent airspeed, its true speed
        grows with height, and above this altitude ``speed`` is slower than it. ``inf`` for a
        speed already below ``airspeed_min`` at sea level: the replay flies such a speed as asked
        (it refuses only what does not trim), so the envelope sets it no ceiling."""
        from replay.flight.fixedwing.trim import CEILING_RESOLUTION, CEILING_TOP

        v = self.cruise_speed if speed is None else float(speed)
        if v < self.airspeed_min or self.airspeed_range(CEILING_TOP, temperature_offset)[0] <= v:
            return math.inf
        lo, hi = 0.0, CEILING_TOP
        while hi - lo > CEILING_RESOLUTION:
            mid = 0.5 * (lo + hi)
            lo, hi = (
                (mid, hi) if self.airspeed_range(mid, temperature_offset)[0] <= v else (lo, mid)
            )
        return math.floor(lo / CEILING_RESOLUTION) * CEILING_RESOLUTION

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def pack(
        self, wind: npt.ArrayLike = (0.0, 0.0, 0.0), temperature_offset: float = 0.0
    ) -> FloatArray:
        """The flat float64 array the compiled kernels take (``I_*`` layout), with a constant
        wind vector (NED, m/s: the velocity of the air mass) and the day's temperature offset
        from the standard atmosphere (K, within +-50)."""
        dtemp = check_offset(temperature_offset)
        w = np.asarray(wind, dtype=np.float64).reshape(-1)
        if w.shape != (3,) or not np.isfinite(w).all():
            raise InputError(f"wind must be three finite numbers (north, east, down); got {wind!r}")
        gm = self.gammas()
        lo, hi = self.control_limits()
        p = np.zeros(N_PACKED)
        p[I_MASS] = self.mass
        p[I_JY] = self.Jy
        p[I_G1 : I_G8 + 1] = gm[1:]
        p[I_S] = self.S
        p[I_B] = self.b
        p[I_C] = self.c
        p[I_DTEMP] = dtemp
        p[I_KIND] = 1.0 / (math.pi * self.e * self.aspect_ratio)
        for i, name in _PACKED_DERIVS:
            p[i] = getattr(self, name)
        p[I_DE_MIN], p[I_DA_MIN], p[I_DR_MIN] = lo[0], lo[1], lo[2]
        p[I_DE_MAX], p[I_DA_MAX], p[I_DR_MAX] = hi[0], hi[1], hi[2]
        p[I_GRAV] = G
        p[I_WN], p[I_WE], p[I_WD] = w
        p[I_ENGINE] = ENGINES.index(self.engine)
        p[I_ESC] = self.esc_efficiency
        p[I_BSFC] = self.bsfc_g_per_kwh * 1e-3 / 3.6e6  # kg/J
        return p


FIELD_NAMES: tuple[str, ...] = tuple(f.name for f in fields(VehicleParams))

# ---- packed layout (shared with _kernels.py; numba reads these module globals as constants) ----
I_MASS, I_JY = 0, 1
I_G1, I_G2, I_G3, I_G4, I_G5, I_G6, I_G7, I_G8 = range(2, 10)
I_S, I_B, I_C, I_DTEMP, I_KIND = range(10, 15)
I_CL0, I_CLA, I_CLQ, I_CLDE, I_CDP, I_CDQ, I_CDDE = range(15, 22)
I_CM0, I_CMA, I_CMQ, I_CMDE = range(22, 26)
I_CY0, I_CYB, I_CYP, I_CYR, I_CYDA, I_CYDR = range(26, 32)
I_CL_0, I_CL_B, I_CL_P, I_CL_R, I_CL_DA, I_CL_DR = range(32, 38)  # rolling moment (C_ell)
I_CN0, I_CNB, I_CNP, I_CNR, I_CNDA, I_CNDR = range(38, 44)
I_M, I_ALPHA0 = 44, 45
I_DE_MIN, I_DE_MAX, I_DA_MIN, I_DA_MAX, I_DR_MIN, I_DR_MAX = range(46, 52)
I_GRAV, I_WN, I_WE, I_WD = range(52, 56)
# propulsion: I_ENGINE is 0 (electric) or 1 (piston)
I_ENGINE, I_DPROP, I_VBAT, I_KV, I_KQ, I_RMOT, I_I0 = range(56, 63)
I_CT0, I_CT1, I_CT2, I_CQ0, I_CQ1, I_CQ2 = range(63, 69)
I_PMAX, I_RPM, I_CP0, I_CP1, I_CP2 = range(69, 74)
I_CLAD, I_CMAD = 74, 75
# the turbulence's rotational gusts (body axes, rad/s) of the step flown: the kernel's ``fly``
# sets them with the gusts' velocities (added to the wind above) and clears them after
I_GP, I_GQ, I_GR = 76, 77, 78
# what the engine draws (kernels.drain): the speed controller's efficiency, the fuel per joule
I_ESC, I_BSFC = 79, 80
N_PACKED = 81
ENGINES = ("electric", "piston")

_PACKED_DERIVS: tuple[tuple[int, str], ...] = (
    (I_CL0, "CL0"),
    (I_CLA, "CLalpha"),
    (I_CLQ, "CLq"),
    (I_CLDE, "CLde"),
    (I_CDP, "CDp"),
    (I_CDQ, "CDq"),
    (I_CDDE, "CDde"),
    (I_CM0, "Cm0"),
    (I_CMA, "Cmalpha"),
    (I_CMQ, "Cmq"),
    (I_CLAD, "CLadot"),
    (I_CMAD, "Cmadot"),
    (I_CMDE, "Cmde"),
    (I_CY0, "CY0"),
    (I_CYB, "CYbeta"),
    (I_CYP, "CYp"),
    (I_CYR, "CYr"),
    (I_CYDA, "CYda"),
    (I_CYDR, "CYdr"),
    (I_CL_0, "Cl0"),
    (I_CL_B, "Clbeta"),
    (I_CL_P, "Clp"),
    (I_CL_R, "Clr"),
    (I_CL_DA, "Clda"),
    (I_CL_DR, "Cldr"),
    (I_CN0, "Cn0"),
    (I_CNB, "Cnbeta"),
    (I_CNP, "Cnp"),
    (I_CNR, "Cnr"),
    (I_CNDA, "Cnda"),
    (I_CNDR, "Cndr"),
    (I_M, "M"),
    (I_ALPHA0, "alpha0"),
    (I_DPROP, "prop_diameter"),
    (I_VBAT, "battery_voltage"),
    (I_KV, "motor_kv"),
    (I_KQ, "motor_kq"),
    (I_RMOT, "motor_resistance"),
    (I_I0, "motor_no_load_current"),
    (I_CT0, "CT0"),
    (I_CT1, "CT1"),
    (I_CT2, "CT2"),
    (I_CQ0, "CQ0"),
    (I_CQ1, "CQ1"),
    (I_CQ2, "CQ2"),
    (I_PMAX, "power_max"),
    (I_RPM, "rated_rpm"),
    (I_CP0, "CP0"),
    (I_CP1, "CP1"),
    (I_CP2, "CP2"),
)

# ---- validation ------------------------------------------------------------------------------
_POSITIVE = ("mass", "Jx", "Jy", "Jz", "S", "b", "c", "e", "M", "cruise_speed")
# every parameter of each engine model (the module docstring); all must be > 0 but the slopes
# of the coefficient curves (either sign) and the no-load current (>= 0)
ENGINE_PARAMETERS: dict[str, tuple[str, ...]] = {
    "electric": (
        "prop_diameter",
        "battery_voltage",
        "motor_kv",
        "motor_kq",
        "motor_resistance",
        "motor_no_load_current",
        "CT0",
        "CT1",
        "CT2",
        "CQ0",
        "CQ1",
        "CQ2",
    ),
    "piston": ("prop_diameter", "power_max", "rated_rpm", "CT0", "CT1", "CT2", "CP0", "CP1", "CP2"),
}
_ANY_SIGN = ("CT1", "CT2", "CQ1", "CQ2", "CP1", "CP2")
_NON_NEGATIVE = ("motor_no_load_current", "battery_wh", "fuel_kg", "bsfc_g_per_kwh")


def _bad(field: str, expected: str, found: Any) -> InputError:
    return InputError(f"field {field!r}: expected {expected}, found {found!r}")


def validate(p: VehicleParams) -> None:
    """Refuse impossible values; the message names the field, what was expected and found."""
    if not isinstance(p.name, str) or not p.name:
        raise _bad("name", "a non-empty string", p.name)
    if p.engine not in ENGINES:
        raise _bad("engine", f"one of {', '.join(ENGINES)}", p.engine)
    check_numbers(p, ("name", "source", "engine"), _POSITIVE, _NON_NEGATIVE, _bad)
    if p.e > 1.5:
        raise _bad("e", "an Oswald efficiency in (0, 1.5]", p.e)
    inertia = np.array([[p.Jx, 0.0, -p.Jxz], [0.0, p.Jy, 0.0], [-p.Jxz, 0.0, p.Jz]])
    eig = np.linalg.eigvalsh(inertia)
    if eig[0] <= 0:
        raise _bad(
            "Jxz",
            f"a positive-definite inertia (Jx Jz > Jxz^2 = {p.Jxz**2:g})",
            f"Jx Jz = {p.Jx * p.Jz:g}",
        )
    e1, e2, e3 = eig
    if e1 + e2 < e3 * (1 - 1e-9):
        raise _bad(
            "Jz",
            "principal moments obeying the triangle inequality (a rigid body)",
            f"principal moments {e1:g}, {e2:g}, {e3:g}",
        )
    if not 0 < p.alpha0 < math.pi / 2:
        raise _bad("alpha0", "a stall blending angle in (0, pi/2) rad", p.alpha0)
    if not p.elevator_min_deg < 0 < p.elevator_max_deg:
        raise _bad(
            "elevator_min_deg/elevator_max_deg",
            "min < 0 < max",
            (p.elevator_min_deg, p.elevator_max_deg),
        )
    if max(-p.elevator_min_deg, p.elevator_max_deg) > 60:
        raise _bad("elevator_max_deg", "travel within +-60 deg", p.elevator_max_deg)
    for k in ("aileron_max_deg", "rudder_max_deg"):
        if not 0 < getattr(p, k) <= 60:
            raise _bad(k, "travel in (0, 60] deg", getattr(p, k))
    if not 0 < p.bank_max_deg < 80:
        raise _bad("bank_max_deg", "a bank limit in (0, 80) deg", p.bank_max_deg)
    if not 0 < p.pitch_max_deg < 80:
        raise _bad("pitch_max_deg", "a pitch limit in (0, 80) deg", p.pitch_max_deg)
    if not -80 < p.pitch_min_deg < 0:
        raise _bad("pitch_min_deg", "a pitch limit in (-80, 0) deg", p.pitch_min_deg)
    if p.climb_rate_max <= 0:
        raise _bad("climb_rate_max", "a climb rate > 0 m/s", p.climb_rate_max)
    if p.descent_rate_max <= 0:
        raise _bad(
            "descent_rate_max", "a descent rate > 0 m/s (a positive number)", p.descent_rate_max
        )
    if not 0 < p.airspeed_min < p.airspeed_max:
        raise _bad("airspeed_min/airspeed_max", "0 < min < max", (p.airspeed_min, p.airspeed_max))
    if not p.airspeed_min <= p.cruise_speed <= p.airspeed_max:
        raise _bad(
            "cruise_speed",
            f"a speed inside [airspeed_min, airspeed_max] = [{p.airspeed_min:g}, {p.airspeed_max:g}]",
            p.cruise_speed,
        )
    if p.Cmalpha >= 0:
        raise _bad("Cmalpha", "a statically stable aircraft (Cmalpha < 0)", p.Cmalpha)
    if p.Cmde == 0:
        raise _bad("Cmde", "a working elevator (Cmde != 0)", p.Cmde)
    if p.Clda == 0:
        raise _bad("Clda", "working ailerons (Clda != 0)", p.Clda)
    for k in ENGINE_PARAMETERS[p.engine]:
        if k not in _ANY_SIGN + _NON_NEGATIVE and getattr(p, k) <= 0:
            raise _bad(k, f"a number > 0 (the {p.engine} engine needs it)", getattr(p, k))
    if not 0.0 < p.esc_efficiency <= 1.0:
        raise _bad("esc_efficiency", "an efficiency in (0, 1]", p.esc_efficiency)
    if p.engine == "electric" and p.fuel_kg > 0:
        raise _bad("fuel_kg", "0 for an electric aircraft (its capacity is battery_wh)", p.fuel_kg)
    if p.engine == "piston" and p.battery_wh > 0:
        raise _bad("battery_wh", "0 for a piston engine (its capacity is fuel_kg)", p.battery_wh)
    if p.engine == "piston" and p.fuel_kg > 0 and p.bsfc_g_per_kwh <= 0:
        raise _bad(
            "bsfc_g_per_kwh", "a fuel consumption > 0 g/kWh (the fuel_kg is burnt by it)", 0.0
        )
