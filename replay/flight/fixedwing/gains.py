"""The fixed wing autopilot's gain design: successive loop closure (Beard & McLain, *Small
Unmanned Aircraft*, 2012, §5.4 and ch. 6) from the transfer-function coefficients at the trim;
the loops' natural frequencies, damping and separations (:class:`LoopDesign`) and the designed
gains (:class:`Gains`). The loops themselves are described in :mod:`replay.flight.fixedwing.autopilot`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from replay.flight.atmosphere import density
from replay.flight.base import G
from replay.flight.fixedwing import kernels as kern
from replay.flight.fixedwing.dynamics import drag_coefficient
from replay.flight.fixedwing.params import VehicleParams
from replay.flight.fixedwing.trim import trim
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]


# ---- design choices ---------------------------------------------------------------------------
@dataclass(frozen=True)
class LoopDesign:
    """Natural frequencies, damping and separations of the loops (see the module docstring)."""

    roll_error_max_deg: float = 30.0  # roll error that just saturates the ailerons (sets wn_phi)
    roll_wn_max: float = 15.0  # rad/s
    roll_zeta: float = 0.9
    roll_integral_fraction: float = 0.1  # k_i = fraction * wn_phi * k_p
    roll_integral_band_deg: float = 3.0  # the roll integrator runs inside this error only
    roll_slew: float = 0.3  # bank-command rate limit, in wn_phi * bank_max per second
    course_separation: float = 8.0  # wn_chi = wn_phi / separation
    course_zeta: float = 1.0
    pitch_error_max_deg: float = 10.0  # pitch error that just saturates the elevator
    pitch_zeta: float = 0.8
    altitude_gain: float = 0.25  # k_h, climb-rate command per metre of altitude error (1/s)
    climb_slew: float = 1.0  # m/s^2, rate limit of the climb-rate command
    climb_margin: float = 0.05  # the climb-rate command stays this fraction inside the limits
    climb_kp: float = 2.0  # pitch (rad) per flight-path-angle error (rad)
    climb_ki: float = 0.2  # 1/s
    airspeed_wn: float = 0.5  # rad/s
    airspeed_zeta: float = 1.0
    yaw_beta: float = 1.0  # rudder sideslip gain, in units of Cnbeta
    yaw_beta_integral: float = 0.5  # 1/s, in units of Cnbeta
    yaw_rate: float = 1.0  # yaw damper gain, in units of |Cnr|
    washout_tau: float = 1.0  # s
    # energy management (kernels.energy_state, kernels.climb_loop)
    energy_tau: float = 1.0  # s, filter of the measured energy rates
    energy_speed_tau: float = 3.0  # s, filter of the airspeed energy management judges by
    energy_recovery: float = 0.2  # 1/s, acceleration asked per m/s of airspeed error
    energy_acceleration_max: float = 0.5  # m/s^2
    energy_speed_band: float = 0.1  # of the commanded airspeed: beyond it the airspeed comes first
    turn_climb_margin: float = 0.2  # m/s of climb a turn must leave (else a shallower bank)
    bank_floor_deg: float = 10.0  # the bank limit never falls below this


@dataclass(frozen=True)
class Gains:
    """The designed gains and feed-forwards (rad, m, s units; see the module docstring).
    ``pitch_dc`` is the book's DC gain of the pitch loop, K_DC (for information)."""

    airspeed: float
    roll_p: float
    roll_i: float
    roll_d: float
    roll_band: float
    roll_slew: float
    course_p: float
    course_i: float
    pitch_p: float
    pitch_d: float
    pitch_dc: float
    altitude_p: float
    climb_p: float
    climb_i: float
    climb_slew: float
    climb_margin: float
    speed_p: float
    speed_i: float
    yaw_beta: float
    yaw_beta_i: float
    yaw_r: float
    washout_tau: float
    theta_trim: float
    elevator_trim: float
    thrust_trim: float
    theta_per_gamma_up: float
    theta_per_gamma_down: float
    elevator_per_gamma_up: float
    elevator_per_gamma_down: float
    roll_wn: float
    course_wn: float
    pitch_wn: float
    altitude: float = 0.0  # m AMSL, where the gains were designed (the air's density there)
    airspeed_min: float = 0.0  # the true-airspeed envelope there (the vehicle's EAS envelope)
    airspeed_max: float = math.inf
    design: LoopDesign = LoopDesign()

    def pack(
        self, params: VehicleParams, chi_inf: float, path_gain: float, orbit_gain: float = 4.0
    ) -> FloatArray:
        gk = np.zeros(kern.N_GAINS)
        gk[kern.K_ORBIT] = orbit_gain
        gk[kern.K_ROLL_P] = self.roll_p
        gk[kern.K_ROLL_I] = self.roll_i
        gk[kern.K_ROLL_D] = self.roll_d
        gk[kern.K_ROLL_BAND] = self.roll_band
        gk[kern.K_ROLL_SLEW] = self.roll_slew
        _, _, _, g3, g4, _, _, _, _ = params.gammas()
        gk[kern.K_CP0] = g3 * params.Cl0 + g4 * params.Cn0
        gk[kern.K_CPB] = g3 * params.Clbeta + g4 * params.Cnbeta
        gk[kern.K_CPR] = g3 * params.Clr + g4 * params.Cnr
        gk[kern.K_CPDR] = g3 * params.Cldr + g4 * params.Cndr
        gk[kern.K_CPDA] = g3 * params.Clda + g4 * params.Cnda
        gk[kern.K_COURSE_P] = self.course_p
        gk[kern.K_COURSE_I] = self.course_i
        gk[kern.K_PITCH_P] = self.pitch_p
        gk[kern.K_PITCH_D] = self.pitch_d
        gk[kern.K_ALT_P] = self.altitude_p
        gk[kern.K_CLIMB_P] = self.climb_p
        gk[kern.K_CLIMB_I] = self.climb_i
        gk[kern.K_SPEED_P] = self.speed_p
        gk[kern.K_SPEED_I] = self.speed_i
        gk[kern.K_YAW_BETA] = self.yaw_beta
        gk[kern.K_YAW_BETA_I] = self.yaw_beta_i
        gk[kern.K_YAW_R] = self.yaw_r
        gk[kern.K_WASHOUT_TAU] = self.washout_tau
        gk[kern.K_THETA0] = self.theta_trim
        gk[kern.K_DE0] = self.elevator_trim
        gk[kern.K_THRUST0] = self.thrust_trim
        gk[kern.K_BANK_MAX] = math.radians(params.bank_max_deg)
        gk[kern.K_THETA_MIN] = math.radians(params.pitch_min_deg)
        gk[kern.K_THETA_MAX] = math.radians(params.pitch_max_deg)
        gk[kern.K_CLIMB_MAX] = (1.0 - self.climb_margin) * params.climb_rate_max
        gk[kern.K_DESCENT_MAX] = (1.0 - self.climb_margin) * params.descent_rate_max
        gk[kern.K_VA_MIN] = self.airspeed_min
        gk[kern.K_VA_MAX] = self.airspeed_max
        gk[kern.K_CHI_INF] = chi_inf
        gk[kern.K_PATH] = path_gain
        gk[kern.K_VACC_MAX] = self.climb_slew
        gk[kern.K_THETA_UP] = self.theta_per_gamma_up
        gk[kern.K_THETA_DN] = self.theta_per_gamma_down
        gk[kern.K_DE_UP] = self.elevator_per_gamma_up
        gk[kern.K_DE_DN] = self.elevator_per_gamma_down
        d = self.design
        gk[kern.K_E_TAU] = d.energy_tau
        gk[kern.K_E_VA_TAU] = d.energy_speed_tau
        gk[kern.K_E_ACC] = d.energy_recovery
        gk[kern.K_E_ACC_MAX] = d.energy_acceleration_max
        gk[kern.K_E_SPEED_BAND] = d.energy_speed_band
        gk[kern.K_E_TURN_MARGIN] = d.turn_climb_margin
        gk[kern.K_E_BANK_MIN] = min(math.radians(d.bank_floor_deg), gk[kern.K_BANK_MAX])
        return gk


def design_gains(
    params: VehicleParams,
    airspeed: float | None = None,
    design: LoopDesign | None = None,
    altitude: float = 0.0,
    temperature_offset: float = 0.0,
) -> Gains:
    """Gains of every loop from the transfer-function coefficients at true ``airspeed`` (default
    cruise) and the level trim there (Beard & McLain §5.4 and ch. 6), in the standard
    atmosphere's air at ``altitude`` (m AMSL; ``temperature_offset`` K off standard)."""
    d = design or LoopDesign()
    p = params
    va = p.cruise_speed if airspeed is None else float(airspeed)
    x_t, u_t = trim(p, va, altitude, temperature_offset=temperature_offset)
    alpha_t = math.atan2(x_t[5], x_t[3])
    de_t, dt_t = float(u_t[0]), float(u_t[3])
    rho = float(density(altitude, temperature_offset))
    lo, hi = p.control_limits()

    roll_p, roll_i, roll_d, wn_phi = _roll_gains(p, d, rho, va, hi[1])

    # course
    wn_chi = wn_phi / d.course_separation
    course_p = 2.0 * d.course_zeta * wn_chi * va / G
    course_i = wn_chi * wn_chi * va / G

    pitch_p, pitch_d, k_dc, wn_th = _pitch_gains(p, d, rho, va, lo, hi)

    speed_p, speed_i, thrust_t = _airspeed_gains(
        p, d, rho, va, alpha_t, de_t, dt_t, temperature_offset
    )

    slopes = _feed_forwards(p, va, altitude, temperature_offset, x_t, de_t)

    envelope = p.airspeed_range(altitude, temperature_offset)
    return Gains(
        airspeed=va,
        roll_p=roll_p,
        roll_i=roll_i,
        roll_d=roll_d,
        roll_band=math.radians(d.roll_integral_band_deg),
        roll_slew=d.roll_slew * wn_phi * math.radians(p.bank_max_deg),
        course_p=course_p,
        course_i=course_i,
        pitch_p=pitch_p,
        pitch_d=pitch_d,
        pitch_dc=k_dc,
        altitude_p=d.altitude_gain,
        climb_p=d.climb_kp,
        climb_i=d.climb_ki,
        climb_slew=d.climb_slew,
        climb_margin=d.climb_margin,
        speed_p=speed_p,
        speed_i=speed_i,
        yaw_beta=d.yaw_beta * max(p.Cnbeta, 0.05),
        yaw_beta_i=d.yaw_beta_integral * max(p.Cnbeta, 0.05),
        yaw_r=d.yaw_rate * abs(p.Cnr),
        washout_tau=d.washout_tau,
        theta_trim=float(x_t[7]),
        elevator_trim=de_t,
        thrust_trim=thrust_t,
        theta_per_gamma_up=slopes[0][0],
        theta_per_gamma_down=slopes[1][0],
        elevator_per_gamma_up=slopes[0][1],
        elevator_per_gamma_down=slopes[1][1],
        roll_wn=wn_phi,
        course_wn=wn_chi,
        pitch_wn=wn_th,
        altitude=float(altitude),
        airspeed_min=envelope[0],
        airspeed_max=envelope[1],
        design=d,
    )


def _roll_gains(
    p: VehicleParams, d: LoopDesign, rho: float, va: float, da_max: float
) -> tuple[float, float, float, float]:
    """(k_p, k_i, k_d, wn_phi) of the roll loop (Beard & McLain §6.1.1)."""
    _, _, _, g3, g4, _, _, _, _ = p.gammas()
    s, b = p.S, p.b
    # roll
    c_pp = g3 * p.Clp + g4 * p.Cnp
    c_pda = g3 * p.Clda + g4 * p.Cnda
    a_phi1 = -0.25 * rho * va * s * b * b * c_pp
    a_phi2 = 0.5 * rho * va * va * s * b * c_pda
    wn_phi = min(
        math.sqrt(abs(a_phi2) * da_max / math.radians(d.roll_error_max_deg)), d.roll_wn_max
    )
    # a heavily roll-damped airframe (a_phi1 > 2 zeta wn) would need rate feedback of the wrong
    # sign: raise wn until its own damping gives zeta (with k_d = 0)
    wn_phi = min(max(wn_phi, a_phi1 / (2.0 * d.roll_zeta)), d.roll_wn_max)
    roll_p = wn_phi * wn_phi / a_phi2
    roll_d = (2.0 * d.roll_zeta * wn_phi - a_phi1) / a_phi2
    if roll_d * roll_p < 0:  # the airframe's own roll damping is already enough
        roll_d = 0.0
    roll_i = d.roll_integral_fraction * wn_phi * roll_p
    return roll_p, roll_i, roll_d, wn_phi


def _pitch_gains(
    p: VehicleParams, d: LoopDesign, rho: float, va: float, lo: FloatArray, hi: FloatArray
) -> tuple[float, float, float, float]:
    """(k_p, k_d, K_DC, wn_theta) of the pitch loop (Beard & McLain §6.1.2)."""
    s, c = p.S, p.c
    # pitch
    k = rho * va * va * c * s / (2.0 * p.Jy)
    a_th1 = -k * p.Cmq * c / (2.0 * va)
    a_th2 = -k * p.Cmalpha
    a_th3 = k * p.Cmde
    de_max = min(-lo[0], hi[0])
    pitch_p = math.copysign(de_max / math.radians(d.pitch_error_max_deg), a_th3)
    wn_th = math.sqrt(a_th2 + pitch_p * a_th3)
    pitch_d = (2.0 * d.pitch_zeta * wn_th - a_th1) / a_th3
    if pitch_d * pitch_p < 0:
        pitch_d = 0.0
    k_dc = pitch_p * a_th3 / (a_th2 + pitch_p * a_th3)
    return pitch_p, pitch_d, k_dc, wn_th


def _airspeed_gains(
    p: VehicleParams,
    d: LoopDesign,
    rho: float,
    va: float,
    alpha_t: float,
    de_t: float,
    dt_t: float,
    temperature_offset: float,
) -> tuple[float, float, float]:
    """(k_p, k_i, the trim thrust) of the airspeed-by-throttle loop."""
    s = p.S
    # airspeed: the thrust's slopes in airspeed and throttle at the trim, numerically from the
    # engine model (params.py)
    packed = p.pack(temperature_offset=temperature_offset)

    def thrust_at(v: float, throttle: float) -> float:
        return float(kern.propeller(v, min(max(throttle, 0.0), 1.0), rho, packed)[0])

    dv, ddt = 0.01 * va, 0.01
    t_dv = (thrust_at(va + dv, dt_t) - thrust_at(va - dv, dt_t)) / (2.0 * dv)
    lo_t, hi_t = max(dt_t - ddt, 0.0), min(dt_t + ddt, 1.0)
    t_ddt = (thrust_at(va, hi_t) - thrust_at(va, lo_t)) / (hi_t - lo_t)
    cd_t = drag_coefficient(alpha_t, p) + p.CDde * abs(de_t)
    a_v1 = rho * va * s * cd_t / p.mass - t_dv / p.mass
    a_v2 = max(t_ddt / p.mass, 1e-6)
    speed_i = d.airspeed_wn**2 / a_v2
    speed_p = max(0.0, (2.0 * d.airspeed_zeta * d.airspeed_wn - a_v1) / a_v2)
    thrust_t = thrust_at(va, dt_t)
    return speed_p, speed_i, thrust_t


def _feed_forwards(
    p: VehicleParams,
    va: float,
    altitude: float,
    temperature_offset: float,
    x_t: FloatArray,
    de_t: float,
) -> list[tuple[float, float]]:
    """[(pitch, elevator) per radian of flight-path angle] for climbs and for descents."""
    # pitch and elevator feed-forwards from the climb and descent trims at the limits
    slopes = []
    for rate in (p.climb_rate_max, -p.descent_rate_max):
        gam = math.asin(max(-0.9, min(0.9, rate / va)))
        try:
            x_g, u_g = trim(
                p, va, altitude, gam, temperature_offset=temperature_offset, explain=False
            )
            slopes.append(((x_g[7] - x_t[7]) / gam, (u_g[0] - de_t) / gam))
        except InputError:  # e.g. an idle descent that needs negative thrust: gamma alone
            slopes.append((1.0, 0.0))
    return slopes


__all__ = ["Gains", "LoopDesign", "design_gains"]
