"""Vehicle parameters: mass properties, stability and control derivatives, propulsion, limits.

One frozen :class:`VehicleParams` holds everything the 6-DOF model (``dynamics.py``), the trim
(``trim.py``) and the autopilot (``replay/autopilot.py``) need. Conventions are those of Beard &
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
    CD(a) = CDp + (CL0 + CLalpha a)^2 / (pi e AR),   AR = b^2 / S

so ``M`` and ``alpha0`` set where the linear lift curve blends into the flat plate (stall).
Air density ``rho`` is the ISA standard atmosphere's at the aircraft's altitude
(:mod:`replay.atmosphere`, optionally on a day ``temperature_offset`` K off standard, given to
:meth:`VehicleParams.pack`): the aerodynamics and the propeller lose force with height.

Propulsion (Beard & McLain eq. 4.18, the 2012 propeller model)::

    T = 1/2 rho S_prop C_prop ((k_motor delta_t)^2 - Va^2),   clamped at T >= 0
    l_prop = -k_Tp (k_Omega delta_t)^2

The clamp is our choice: unclamped, the model brakes with ``1/2 rho S_prop C_prop Va^2`` when the
throttle is closed — for the Aerosonde a drag coefficient of 0.37 on the wing area, ten times any
windmilling propeller — which makes gliding flight meaningless. With the clamp a closed throttle
means no thrust and no braking (a folding propeller).

Angles of the envelope and of the control-surface travel are stored in degrees (field names end in
``_deg``); ``alpha0`` is in radians as in the book. :meth:`VehicleParams.pack` flattens the
parameters into the float64 array the numba kernels take (layout: the ``I_*`` indices below).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.performance import Performance
from replay.atmosphere import check_offset
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
G = 9.81  # m/s^2, the value seed 000 uses (eq. 13)


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
    # propulsion (Beard & McLain 2012 propeller model)
    S_prop: float  # m^2
    C_prop: float
    k_motor: float  # m/s at full throttle
    k_Tp: float
    k_Omega: float
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

    def min_turn_radius(self, speed: float | None = None) -> float:
        """V^2 / (g tan(bank_max)) (seed 000 eq. 13) at ``speed`` (default: cruise)."""
        v = self.cruise_speed if speed is None else speed
        return v * v / (G * math.tan(math.radians(self.bank_max_deg)))

    def performance(self, speed: float | None = None) -> Performance:
        """What the planner needs of this aircraft at ``speed`` (default: cruise), checked
        against the airspeed envelope."""
        v = self.cruise_speed if speed is None else float(speed)
        if not (math.isfinite(v) and self.airspeed_min <= v <= self.airspeed_max):
            raise InputError(
                f"speed {v:g} m/s is outside {self.name}'s airspeed envelope "
                f"{self.airspeed_min:g}–{self.airspeed_max:g} m/s"
            )
        return Performance(
            self.name, v, self.climb_rate_max, self.descent_rate_max, self.bank_max_deg
        )

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
I_SPROP, I_CPROP, I_KMOTOR, I_KTP, I_KOMEGA, I_M, I_ALPHA0 = range(44, 51)
I_DE_MIN, I_DE_MAX, I_DA_MIN, I_DA_MAX, I_DR_MIN, I_DR_MAX = range(51, 57)
I_GRAV, I_WN, I_WE, I_WD = range(57, 61)
N_PACKED = 61

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
    (I_SPROP, "S_prop"),
    (I_CPROP, "C_prop"),
    (I_KMOTOR, "k_motor"),
    (I_KTP, "k_Tp"),
    (I_KOMEGA, "k_Omega"),
    (I_M, "M"),
    (I_ALPHA0, "alpha0"),
)

# ---- validation ------------------------------------------------------------------------------
_POSITIVE = ("mass", "Jx", "Jy", "Jz", "S", "b", "c", "e", "M", "cruise_speed")
_NON_NEGATIVE = ("S_prop", "C_prop", "k_motor", "k_Tp", "k_Omega")


def _bad(field: str, expected: str, found: Any) -> InputError:
    return InputError(f"field {field!r}: expected {expected}, found {found!r}")


def validate(p: VehicleParams) -> None:
    """Refuse impossible values; the message names the field, what was expected and found."""
    if not isinstance(p.name, str) or not p.name:
        raise _bad("name", "a non-empty string", p.name)
    for f in fields(p):
        if f.name in ("name", "source"):
            continue
        v = getattr(p, f.name)
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise _bad(f.name, "a finite number", v)
    for k in _POSITIVE:
        if getattr(p, k) <= 0:
            raise _bad(k, "a number > 0", getattr(p, k))
    for k in _NON_NEGATIVE:
        if getattr(p, k) < 0:
            raise _bad(k, "a number >= 0", getattr(p, k))
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
    if p.k_motor * p.S_prop * p.C_prop <= 0:
        raise _bad("k_motor", "a propeller that can give thrust (k_motor, S_prop, C_prop > 0)", 0)
