"""The 6-DOF rigid-body equations of motion of a fixed-wing aircraft, in plain numpy (the reference).

State ``x = [pn, pe, pd, u, v, w, phi, theta, psi, p, q, r]`` (NED position, body velocity,
3-2-1 Euler angles, body rates), controls ``[delta_e, delta_a, delta_r, delta_t]``
(``replay/frames.py``). Equations of Beard & McLain, *Small Unmanned Aircraft* (2012), eqs 3.14-3.17
and ch. 4::

    [pn, pe, pd]' = R_b^n(phi, theta, psi) [u, v, w]
    u' = r v - q w + fx/m,   v' = p w - r u + fy/m,   w' = q u - p v + fz/m
    phi'   = p + (q sin(phi) + r cos(phi)) tan(theta)
    theta' = q cos(phi) - r sin(phi)
    psi'   = (q sin(phi) + r cos(phi)) / cos(theta)
    p' = G1 p q - G2 q r + G3 l + G4 n
    q' = G5 p r - G6 (p^2 - r^2) + m / Jy
    r' = G7 p q - G1 q r + G4 l + G8 n

Forces and moments: gravity ``m g [-sin(theta), cos(theta) sin(phi), cos(theta) cos(phi)]``;
aerodynamics from the air-relative velocity ``[ur, vr, wr] = [u, v, w] - R^T wind`` (constant wind in
NED, default zero): ``Va = |(ur, vr, wr)|``, ``alpha = atan2(wr, ur)``, ``beta = asin(vr / Va)``,
dynamic pressure ``qbar = rho Va^2 / 2`` with ``rho`` the ISA density at the altitude ``-pd``
(:mod:`replay.flight.atmosphere`; ``temperature_offset`` K off standard)::

    lift = qbar S (CL(alpha) + CLq c q / (2 Va) + CLde de)
    drag = qbar S (CD(alpha) + CDq c q / (2 Va) + CDde |de|)   (a deflected surface adds drag)
    fx = -cos(alpha) drag + sin(alpha) lift + T,   fz = -sin(alpha) drag - cos(alpha) lift
    fy = qbar S (CY0 + CYbeta beta + CYp b p / (2 Va) + CYr b r / (2 Va) + CYda da + CYdr dr)
    l  = qbar S b (Cl0 + Clbeta beta + Clp b p/(2Va) + Clr b r/(2Va) + Clda da + Cldr dr) + l_prop
    m  = qbar S c (Cm0 + Cmalpha alpha + Cmq c q / (2 Va) + Cmde de)
    n  = qbar S b (Cn0 + Cnbeta beta + Cnp b p/(2Va) + Cnr b r/(2Va) + Cnda da + Cndr dr)

with CL, CD and the thrust T of ``params.py``. Controls are clipped to the surface travel and
throttle range before use (a surface cannot go past its stop). Below 1e-6 m/s of airspeed the
aerodynamic forces are zero.

:func:`derivatives` is the reference the compiled kernel (``kernels.py``) is tested against step
by step; :class:`Aircraft` is the system object (state, time, ``step``) built on the kernel.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from replay.flight.atmosphere import RHO0, check_offset, density_at
from replay.flight.base import G
from replay.flight.fixedwing import kernels
from replay.flight.fixedwing.params import VehicleParams
from replay.frames import N_STATES, rotation_body_to_ned, translational_rates
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]

DT = 0.01  # s: 100 Hz, seed 000 eq. 20


def stall_blend(alpha: float, p: VehicleParams) -> float:
    """sigma(alpha) of Beard & McLain eq. 4.10, in the overflow-free form of ``params.py``."""
    m, a0 = p.M, p.alpha0
    return 1.0 - 1.0 / (1.0 + math.exp(-m * (a0 - alpha))) / (1.0 + math.exp(-m * (a0 + alpha)))


def lift_coefficient(alpha: float, p: VehicleParams) -> float:
    """CL(alpha): the linear lift curve blended into a flat plate past alpha0 (eq. 4.9)."""
    s = stall_blend(alpha, p)
    sa = math.sin(alpha)
    plate = 2.0 * math.copysign(1.0, alpha) * sa * sa * math.cos(alpha)
    return (1.0 - s) * (p.CL0 + p.CLalpha * alpha) + s * plate


def drag_coefficient(alpha: float, p: VehicleParams) -> float:
    """CD(alpha): the attached flow's induced drag plus the flat plate's past the stall
    (``params.py``; eq. 4.11 below the stall)."""
    s = stall_blend(alpha, p)
    cl = (1.0 - s) * (p.CL0 + p.CLalpha * alpha)
    sa = abs(math.sin(alpha))
    return p.CDp + cl * cl / (math.pi * p.e * p.aspect_ratio) + s * 2.0 * sa * sa * sa


def propeller(
    airspeed: float, throttle: float, p: VehicleParams, rho: float = RHO0
) -> tuple[float, float]:
    """(thrust N, torque N m) of the engine and propeller (``params.py``) at true ``airspeed``,
    ``throttle`` (0..1) and air density ``rho`` -- the compiled function itself."""
    t, q = kernels.propeller(float(airspeed), float(throttle), float(rho), p.pack())
    return float(t), float(q)


def thrust(airspeed: float, throttle: float, p: VehicleParams, rho: float = RHO0) -> float:
    """Propeller thrust (N): see :func:`propeller`."""
    return propeller(airspeed, throttle, p, rho)[0]


def air_data(x: npt.ArrayLike, wind: npt.ArrayLike = (0.0, 0.0, 0.0)) -> tuple[float, float, float]:
    """(Va, alpha, beta) of state ``x`` in a constant NED ``wind``."""
    s = np.asarray(x, dtype=np.float64)
    rot = rotation_body_to_ned(s[6], s[7], s[8])
    vr = s[3:6] - rot.T @ np.asarray(wind, dtype=np.float64)
    va = float(np.sqrt(vr @ vr))
    if va < 1e-6:
        return va, 0.0, 0.0
    return va, math.atan2(vr[2], vr[0]), math.asin(max(-1.0, min(1.0, vr[1] / va)))


def clip_controls(u: npt.ArrayLike, p: VehicleParams) -> FloatArray:
    lo, hi = p.control_limits()
    return np.clip(np.asarray(u, dtype=np.float64), lo, hi)


def forces_moments(
    x: npt.ArrayLike,
    u: npt.ArrayLike,
    p: VehicleParams,
    wind: npt.ArrayLike = (0.0, 0.0, 0.0),
    temperature_offset: float = 0.0,
) -> tuple[FloatArray, FloatArray]:
    """Body-frame force (N) and moment (N m) on the aircraft, gravity included, in the standard
    atmosphere at its altitude (``temperature_offset`` K off standard)."""
    s = np.asarray(x, dtype=np.float64)
    rho = density_at(-float(s[2]), check_offset(temperature_offset))
    de, da, dr, dt = clip_controls(u, p)
    phi, theta = s[6], s[7]
    pr, qr, rr = s[9], s[10], s[11]
    m = p.mass
    f = (
        m
        * G
        * np.array(
            [-math.sin(theta), math.cos(theta) * math.sin(phi), math.cos(theta) * math.cos(phi)]
        )
    )
    mom = np.zeros(3)
    va, alpha, beta = air_data(s, wind)
    if va >= 1e-6:
        qbar = 0.5 * rho * va * va
        cq = p.c / (2.0 * va)
        bv = p.b / (2.0 * va)
        lift = qbar * p.S * (lift_coefficient(alpha, p) + p.CLq * cq * qr + p.CLde * de)
        drag = qbar * p.S * (drag_coefficient(alpha, p) + p.CDq * cq * qr + p.CDde * abs(de))
        ca, sa = math.cos(alpha), math.sin(alpha)
        f[0] += -ca * drag + sa * lift
        f[2] += -sa * drag - ca * lift
        f[1] += (
            qbar
            * p.S
            * (
                p.CY0
                + p.CYbeta * beta
                + p.CYp * bv * pr
                + p.CYr * bv * rr
                + p.CYda * da
                + p.CYdr * dr
            )
        )
        mom[0] = (
            qbar
            * p.S
            * p.b
            * (
                p.Cl0
                + p.Clbeta * beta
                + p.Clp * bv * pr
                + p.Clr * bv * rr
                + p.Clda * da
                + p.Cldr * dr
            )
        )
        mom[1] = qbar * p.S * p.c * (p.Cm0 + p.Cmalpha * alpha + p.Cmq * cq * qr + p.Cmde * de)
        mom[2] = (
            qbar
            * p.S
            * p.b
            * (
                p.Cn0
                + p.Cnbeta * beta
                + p.Cnp * bv * pr
                + p.Cnr * bv * rr
                + p.Cnda * da
                + p.Cndr * dr
            )
        )
    t_prop, q_prop = propeller(va, dt, p, rho)
    f[0] += t_prop
    mom[0] -= q_prop
    if va >= 1e-6 and (p.CLadot or p.Cmadot):  # qbar, cq, alpha of the aerodynamics above
        kad = qbar * p.S * p.CLadot * cq
        rel = s[3:6] - rotation_body_to_ned(s[6], s[7], s[8]).T @ np.asarray(wind, dtype=float)
        uu, vv, ww = (float(c) for c in s[3:6])
        ur, vr, wr = (float(c) for c in rel)
        adot = float(
            kernels.alpha_rate(
                uu, vv, ww, ur, vr, wr, float(pr), float(qr), float(rr), f[0] / m, f[2] / m, kad / m
            )
        )
        f[0] += math.sin(alpha) * kad * adot
        f[2] -= math.cos(alpha) * kad * adot
        mom[1] += qbar * p.S * p.c * p.Cmadot * cq * adot
    return f, mom


def derivatives(
    x: npt.ArrayLike,
    u: npt.ArrayLike,
    params: VehicleParams,
    wind: npt.ArrayLike = (0.0, 0.0, 0.0),
    temperature_offset: float = 0.0,
) -> FloatArray:
    """xdot = f(x, u) of the 12-state model (numpy reference of the compiled kernel)."""
    s = np.asarray(x, dtype=np.float64)
    if s.shape != (N_STATES,):
        raise InputError(f"state must have {N_STATES} elements, found shape {s.shape}")
    f, mom = forces_moments(s, u, params, wind, temperature_offset)
    phi, theta, pr, qr, rr = s[6], s[7], s[9], s[10], s[11]
    _, g1, g2, g3, g4, g5, g6, g7, g8 = params.gammas()
    out = np.empty(N_STATES)
    out[0:6] = translational_rates(s, f, params.mass)
    sf, cf = math.sin(phi), math.cos(phi)
    ct = math.cos(theta)
    tt = math.sin(theta) / ct
    out[6] = pr + (qr * sf + rr * cf) * tt
    out[7] = qr * cf - rr * sf
    out[8] = (qr * sf + rr * cf) / ct
    ell, mm, nn = mom
    out[9] = g1 * pr * qr - g2 * qr * rr + g3 * ell + g4 * nn
    out[10] = g5 * pr * rr - g6 * (pr * pr - rr * rr) + mm / params.Jy
    out[11] = g7 * pr * qr - g1 * qr * rr + g4 * ell + g8 * nn
    return out


def rk4_step(
    x: npt.ArrayLike,
    u: npt.ArrayLike,
    dt: float,
    params: VehicleParams,
    wind: npt.ArrayLike = (0.0, 0.0, 0.0),
) -> FloatArray:
    """One classical Runge-Kutta step of :func:`derivatives` with the controls held (numpy)."""
    s = np.asarray(x, dtype=np.float64)
    k1 = derivatives(s, u, params, wind)
    k2 = derivatives(s + 0.5 * dt * k1, u, params, wind)
    k3 = derivatives(s + 0.5 * dt * k2, u, params, wind)
    k4 = derivatives(s + dt * k3, u, params, wind)
    return np.asarray(s + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4))


class Aircraft:
    """The vehicle as a system object: state, time, ``step`` (compiled RK4 at ``dt``).

    ``wind`` is the constant velocity of the air mass (NED, m/s); ``temperature_offset`` the day's
    offset from the standard atmosphere (K).
    """

    def __init__(
        self,
        params: VehicleParams,
        x0: npt.ArrayLike,
        *,
        wind: npt.ArrayLike = (0.0, 0.0, 0.0),
        temperature_offset: float = 0.0,
        dt: float = DT,
        t0: float = 0.0,
    ) -> None:
        x = np.array(x0, dtype=np.float64)
        if x.shape != (N_STATES,) or not np.isfinite(x).all():
            raise InputError(f"initial state must be {N_STATES} finite numbers, found {x0!r}")
        if not dt > 0:
            raise InputError(f"time step must be > 0 s, found {dt!r}")
        self.params = params
        self.wind = np.asarray(wind, dtype=np.float64)
        self.packed = params.pack(self.wind, temperature_offset)
        self.dt = float(dt)
        self.x = x
        self.t = float(t0)
        self._steps = 0
        self._t0 = float(t0)

    def fun(self, x: npt.ArrayLike, u: npt.ArrayLike) -> FloatArray:
        """xdot at state ``x`` with controls ``u`` (compiled)."""
        out = np.empty(N_STATES)
        kernels.derivs(
            np.asarray(x, dtype=np.float64), np.asarray(u, dtype=np.float64), self.packed, out
        )
        return out

    def step(self, u: npt.ArrayLike, n: int = 1) -> FloatArray:
        """Advance ``n`` steps with the controls held; returns the new state."""
        self.x = kernels.step_n(
            self.x, np.asarray(u, dtype=np.float64), int(n), self.dt, self.packed
        )
        self._steps += int(n)
        self.t = self._t0 + self._steps * self.dt
        return self.x

    def air_data(self) -> tuple[float, float, float]:
        return air_data(self.x, self.wind)
