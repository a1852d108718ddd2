"""Compiled kernels (numba) of the vehicle and its autopilot inner loops.

- :func:`derivs` / :func:`rk4` / :func:`step_n`: the 12-state equations of motion of
  ``dynamics.py`` (its numpy :func:`~replay.flight.fixedwing.dynamics.derivatives` is the twin the tests
  compare against; keep the arithmetic of both identical) and a classical RK4 step at ``dt`` with
  the controls held; ``step_n`` advances n steps in one call.
- :func:`control_law` / :func:`fly`: the autopilot of ``replay/flight/fixedwing/autopilot.py``
  (the equations and every gain are documented there). ``control_law`` is called from Python by
  ``Autopilot.command`` and from :func:`fly` at every control step, so the slow path and the fast
  path are the same code. It runs, in this order: :func:`flight_data`, the lateral guidance
  (:func:`course_command`), :func:`course_loop`, :func:`roll_loop`, the longitudinal guidance
  (:func:`altitude_command`), :func:`climb_loop`, :func:`pitch_loop`, :func:`airspeed_loop` and
  :func:`yaw_loop`.

Parameters come packed in one float64 array (``VehicleParams.pack``, ``I_*`` layout) so each kernel
compiles once for every vehicle and caches on disk (``NUMBA_CACHE_DIR``). The autopilot's arrays
(gains ``K_*``, commands ``C_*``, leg ``L_*``, loop state ``A_*``) have their layouts below.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from replay.flight.atmosphere import RHO0, density_at
from replay.flight.fixedwing.params import (
    I_ALPHA0,
    I_B,
    I_BSFC,
    I_C,
    I_CDDE,
    I_CDP,
    I_CDQ,
    I_CL0,
    I_CL_0,
    I_CL_B,
    I_CL_DA,
    I_CL_DR,
    I_CL_P,
    I_CL_R,
    I_CLA,
    I_CLAD,
    I_CLDE,
    I_CLQ,
    I_CM0,
    I_CMA,
    I_CMAD,
    I_CMDE,
    I_CMQ,
    I_CN0,
    I_CNB,
    I_CNDA,
    I_CNDR,
    I_CNP,
    I_CNR,
    I_CP0,
    I_CP1,
    I_CP2,
    I_CQ0,
    I_CQ1,
    I_CQ2,
    I_CT0,
    I_CT1,
    I_CT2,
    I_CY0,
    I_CYB,
    I_CYDA,
    I_CYDR,
    I_CYP,
    I_CYR,
    I_DA_MAX,
    I_DA_MIN,
    I_DE_MAX,
    I_DE_MIN,
    I_DPROP,
    I_DR_MAX,
    I_DR_MIN,
    I_DTEMP,
    I_ENGINE,
    I_ESC,
    I_G1,
    I_G2,
    I_G3,
    I_G4,
    I_G5,
    I_G6,
    I_G7,
    I_G8,
    I_GP,
    I_GQ,
    I_GR,
    I_GRAV,
    I_I0,
    I_JY,
    I_KIND,
    I_KQ,
    I_KV,
    I_M,
    I_MASS,
    I_PMAX,
    I_RMOT,
    I_RPM,
    I_S,
    I_VBAT,
    I_WD,
    I_WE,
    I_WN,
)
from replay.flight.rigid import attitude, body_to_ned, ned_to_body, record

# ---- autopilot gains (filled by replay.flight.fixedwing.gains.design_gains) ----------------------
K_ROLL_P, K_ROLL_I, K_ROLL_D = 0, 1, 2
K_COURSE_P, K_COURSE_I = 3, 4
K_PITCH_P, K_PITCH_D = 5, 6
K_ALT_P = 7  # climb-rate command per metre of altitude error (1/s)
K_CLIMB_P, K_CLIMB_I = 8, 9  # pitch per flight-path-angle error (rad/rad, 1/s)
K_SPEED_P, K_SPEED_I = 10, 11
K_YAW_BETA, K_YAW_BETA_I, K_YAW_R = 12, 13, 14  # Cn per rad of sideslip, per rad s, per b r/(2Va)
K_WASHOUT_TAU = 15
K_THETA0, K_DE0, K_THRUST0 = 16, 17, 18  # design-trim pitch, elevator, thrust (feed-forwards)
K_BANK_MAX, K_THETA_MIN, K_THETA_MAX = 19, 20, 21
K_CLIMB_MAX, K_DESCENT_MAX = 22, 23
K_VA_MIN, K_VA_MAX = 24, 25
K_CHI_INF, K_PATH = 26, 27  # vector-field approach angle (rad), gain (1/m)
K_VACC_MAX = 28  # m/s^2: slew limit of the climb-rate command
K_THETA_UP, K_THETA_DN, K_DE_UP, K_DE_DN = 29, 30, 31, 32  # d(theta, delta_e)/d(gamma) trims
K_ROLL_BAND = 33  # rad: the roll integrator runs only for roll errors below this
K_ROLL_SLEW = 34  # rad/s: rate limit of the bank command
K_CP0, K_CPB, K_CPR, K_CPDR, K_CPDA = 35, 36, 37, 38, 39  # C_p coefficients (G3 Cl + G4 Cn)
K_ORBIT = 40  # orbit-following gain k_orbit (Beard & McLain eq. 10.13)
# energy management (see energy_state and climb_loop)
K_E_TAU = 41  # s: time constant of the filtered energy rates
K_E_ACC = 42  # 1/s: airspeed recovery, acceleration asked per m/s of airspeed error
K_E_ACC_MAX = 43  # m/s^2: at most this acceleration (or deceleration) is asked
K_E_SPEED_BAND = 44  # fraction of the commanded airspeed: under/overspeed beyond it
K_E_TURN_MARGIN = 45  # m/s: the climb a turn leaves (the bank limit keeps this much)
K_E_BANK_MIN = 46  # rad: the bank limit never falls below this (the aircraft can still turn)
K_E_VA_TAU = 47  # s: the airspeed energy management judges by is filtered with this
N_GAINS = 48

# ---- commands ---------------------------------------------------------------------------------
C_LAT_MODE = 0  # 0: follow the leg, 1: hold course, 2: hold bank, 3: orbit
C_COURSE, C_BANK = 1, 2  # rad
C_ALT_MODE = 3  # 0: altitude from the leg, 1: hold C_ALT, 2: climb at C_CLIMB
C_ALT = 4  # m (up)
C_AIRSPEED = 5  # m/s
C_FLOOR = 6  # m: terrain floor (altitude command is at least this); -inf when off
C_ALT_DIRECT = 7  # 1: on a leg, command the next waypoint's altitude at once (else linear)
C_CLIMB = 8  # m/s: the climb rate of altitude mode 2 (+ up)
C_ORB_N, C_ORB_E, C_ORB_R, C_ORB_LAM = 9, 10, 11, 12  # orbit centre (N, E), radius, +1 clockwise
C_ORB_VN, C_ORB_VE = 13, 14  # m/s: velocity of a moving orbit centre (integrated each step)
C_FOLLOW = 15  # 1: on this leg the altitude command is the terrain floor (a terrain-frame leg)
N_CMD = 16

# ---- the current leg (NED horizontal, altitude up) --------------------------------------------
L_N0, L_E0, L_H0, L_N1, L_E1, L_H1 = 0, 1, 2, 3, 4, 5
L_SWITCH = 6  # m: switch when closer than this to the leg's end
L_ACTIVE = 7  # 1 when a leg is being followed (switch checks on)
L_QN, L_QE, L_LEN, L_CHI = 8, 9, 10, 11  # unit direction, length (m), course (rad): set_leg
L_PLANE = 12  # m: a line leg ends when its along-track distance reaches this (L_LEN by default)
L_ARC = 13  # 1: the leg is a turn fillet (an arc; set_arc), 0: a straight line
L_CN, L_CE, L_RHO, L_LAM = 14, 15, 16, 17  # arc centre (N, E), radius (m), +1 clockwise / -1
L_GAM0, L_SWEEP = 18, 19  # arc: angle of its start seen from the centre, angle to turn (rad)
L_EN, L_EE, L_EQN, L_EQE = 20, 21, 22, 23  # arc: end point and the next leg's unit direction
N_LEG = 24

# ---- autopilot loop state and logged signals --------------------------------------------------
A_I_COURSE, A_I_ROLL, A_I_CLIMB, A_I_SPEED, A_I_BETA, A_R_LOW = 0, 1, 2, 3, 4, 5
A_CHI_C, A_PHI_C, A_H_C, A_HDOT_C, A_THETA_C, A_VA_C = 6, 7, 8, 9, 10, 11
A_XTRACK, A_ALONG, A_DIST = 12, 13, 14  # cross-track (m, + right), along-track (m), to leg end (m)
A_INIT = 15  # 0 until the first control step (the washout filter starts at the current r)
A_VA_LAST, A_VDOT = 16, 17  # airspeed at the last control step; its filtered rate (m/s^2)
A_HDOT_UP, A_HDOT_DN = 18, 19  # m/s: climb rate available at full / idle throttle (filtered)
A_BANK_LIM = 20  # rad: the bank the aircraft can sustain with K_E_TURN_MARGIN of climb left
A_VA_F = 21  # m/s: the airspeed filtered with K_E_VA_TAU (what energy management judges by)
N_AP = 22

N_GUIDANCE_LOG = 9  # rec_g columns: A_CHI_C .. A_DIST


@nb.njit(cache=True, nogil=True, inline="always")
def atan2f(y, x):  # pragma: no cover - jit
    """atan2 through atan (about 4x faster in glibc; equal to within an ulp or two)."""
    if x > 0.0:
        return math.atan(y / x)
    if x < 0.0:
        if y >= 0.0:
            return math.atan(y / x) + math.pi
        return math.atan(y / x) - math.pi
    if y > 0.0:
        return 0.5 * math.pi
    if y < 0.0:
        return -0.5 * math.pi
    return 0.0


@nb.njit(cache=True, nogil=True)
def _positive_root(a, b, c):  # pragma: no cover - jit
    """The larger root of a x^2 + b x + c = 0 if it is positive, else 0."""
    if a > 0.0:
        disc = b * b - 4.0 * a * c
        return max((-b + math.sqrt(disc)) / (2.0 * a), 0.0) if disc >= 0.0 else 0.0
    return max(-c / b, 0.0) if b > 0.0 else 0.0


@nb.njit(cache=True, nogil=True)
def piston_lapse(rho):  # pragma: no cover - jit
    """A piston engine's full-throttle power over its sea-level power at density ``rho``:
    Gagg and Ferrar's (sigma - 0.117) / 0.883, sigma = rho / rho0 (normally aspirated)."""
    return max((rho / RHO0 - 0.117) / 0.883, 0.0)


@nb.njit(cache=True, nogil=True)
def shaft_speed(va, dt, rho, p):  # pragma: no cover - jit
    """The propeller's speed (rev/s) at true airspeed ``va``, throttle ``dt`` (0..1) and air
    density ``rho``, and whether the engine drives it (1.0) or it freewheels / windmills (0.0):
    the torque balance of ``params.py`` (electric: motor and propeller; piston: engine power and
    propeller power, held at the rated rpm)."""
    d = p[I_DPROP]
    d3 = d * d * d
    if p[I_ENGINE] == 0.0:  # electric: Beard & McLain 2nd ed. §4.3
        kq = p[I_KQ]
        r = p[I_RMOT]
        vin = dt * p[I_VBAT]
        a = rho * d3 * d * d * p[I_CQ0] / (4.0 * math.pi * math.pi)
        b0 = rho * d3 * d * p[I_CQ1] * va / (2.0 * math.pi)
        c0 = rho * d3 * p[I_CQ2] * va * va + kq * p[I_I0]
        om = _positive_root(a, b0 + kq * p[I_KV] / r, c0 - kq * vin / r)
        if p[I_KV] * om > vin:
            # the propeller turns faster than the voltage drives it: the controller draws no
            # current (no regenerative braking) and it freewheels against the motor's friction
            return _positive_root(a, b0, c0) / (2.0 * math.pi), 0.0
        return om / (2.0 * math.pi), 1.0
    # piston: fixed-pitch propeller on a constant-torque engine, Gagg-Ferrar power lapse
    d4 = d3 * d
    n_r = p[I_RPM] / 60.0
    phi = piston_lapse(rho)
    n = _positive_root(
        p[I_CP0] * rho * d4 * d,
        p[I_CP1] * rho * d4 * va,
        p[I_CP2] * rho * d3 * va * va - dt * phi * p[I_PMAX] / n_r,
    )
    return min(n, n_r), 1.0 if dt > 0.0 else 0.0  # the throttle held back at the rated rpm


@nb.njit(cache=True, nogil=True)
def drain(va, dt, rho, p):  # pragma: no cover - jit
    """What the engine draws from its source at true airspeed ``va``, throttle ``dt`` and
    density ``rho``: electric, the battery's power (W) -- the motor's electrical input
    ``V_in i`` with ``i = (V_in - KV Omega) / R`` (its copper and no-load losses are in the
    motor model) over the speed controller's efficiency; none while it freewheels (no current
    is drawn); piston, the fuel flow (kg/s) -- the shaft power ``CP(J) rho n^3 D^5`` the
    propeller absorbs times the brake-specific fuel consumption (none at closed throttle: the
    idle's own burn is not modelled)."""
    dt = min(max(dt, 0.0), 1.0)
    n, driven = shaft_speed(va, dt, rho, p)
    if driven == 0.0 or n <= 0.0:
        return 0.0
    d = p[I_DPROP]
    if p[I_ENGINE] == 0.0:
        vin = dt * p[I_VBAT]
        i = (vin - p[I_KV] * 2.0 * math.pi * n) / p[I_RMOT]
        return vin * max(i, 0.0) / p[I_ESC]
    j = va / (n * d)
    cp = (p[I_CP2] * j + p[I_CP1]) * j + p[I_CP0]
    return p[I_BSFC] * max(cp, 0.0) * rho * n * n * n * d * d * d * d * d


@nb.njit(cache=True, nogil=True)
def propeller(va, dt, rho, p):  # pragma: no cover - jit
    """(thrust N, torque N m) of the engine and propeller at true airspeed ``va``, throttle
    ``dt`` and air density ``rho`` (``params.py``: electric, or piston)."""
    dt = min(max(dt, 0.0), 1.0)
    d = p[I_DPROP]
    n = shaft_speed(va, dt, rho, p)[0]
    if n <= 0.0:
        return 0.0, 0.0
    j = va / (n * d)
    ct = (p[I_CT2] * j + p[I_CT1]) * j + p[I_CT0]
    nn = rho * n * n
    d3 = d * d * d
    if p[I_ENGINE] == 0.0:  # electric (Beard & McLain 2nd ed. §4.3): the motor feels the torque
        cq = (p[I_CQ2] * j + p[I_CQ1]) * j + p[I_CQ0]
        k = nn * d3 * d
        return k * ct, k * d * cq
    return nn * (d3 * d) * ct, 0.0  # piston: no engine torque on the airframe


@nb.njit(cache=True, nogil=True)
def throttle_for(thrust, va, rho, p):  # pragma: no cover - jit
    """The throttle (0..1) giving ``thrust`` at ``va`` and ``rho`` (thrust grows with the
    throttle); 0 or 1 when it lies outside what the engine gives.  Regula falsi with the Illinois
    step on the bracket [0, 1] (a few evaluations for 1e-4 N on these smooth curves)."""
    fhi = propeller(va, 1.0, rho, p)[0] - thrust
    if fhi <= 0.0:
        return 1.0
    flo = propeller(va, 0.0, rho, p)[0] - thrust
    if flo >= 0.0:
        return 0.0
    lo = 0.0
    hi = 1.0
    x = 0.5
    side = 0
    for _ in range(30):
        x = (lo * fhi - hi * flo) / (fhi - flo)
        fx = propeller(va, x, rho, p)[0] - thrust
        if abs(fx) < 1e-4 or hi - lo < 1e-9:
            break
        if fx > 0.0:
            hi = x
            fhi = fx
            if side == -1:
                flo *= 0.5
            side = -1
        else:
            lo = x
            flo = fx
            if side == 1:
                fhi *= 0.5
            side = 1
    return x


@nb.njit(cache=True, nogil=True)
def alpha_rate(uu, vv, ww, ur, vr, wr, pr, qr, rr, ax, az, kad_m):  # pragma: no cover - jit
    """d(alpha)/dt (rad/s) with the alpha-dot lift included: ``ax``, ``az`` the body force per
    unit mass without it, ``kad_m`` its lift per rad/s of alpha-dot per unit mass.

    alpha = atan(wr / ur) with (ur, wr) the air-relative velocity; a constant wind's body
    components turn with the body (d(w_b)/dt = -omega x w_b). The alpha-dot lift L = k alpha_dot
    (acting at alpha) changes alpha_dot by -L / (m sqrt(ur^2 + wr^2)), so alpha_dot is the root
    of a linear equation: alpha_dot0 / (1 + k / (m sqrt(ur^2 + wr^2)))."""
    h2 = ur * ur + wr * wr
    if h2 <= 0.0:
        return 0.0
    wbx = uu - ur  # the wind in body axes
    wby = vv - vr
    wbz = ww - wr
    udot = rr * vv - qr * ww + ax + (qr * wbz - rr * wby)
    wdot = qr * uu - pr * vv + az + (pr * wby - qr * wbx)
    return (ur * wdot - wr * udot) / h2 / (1.0 + kad_m / math.sqrt(h2))


@nb.njit(cache=True, nogil=True)
def derivs(x, u, p, out):  # pragma: no cover - jit
    """xdot = f(x, u) into ``out`` (the twin of ``dynamics.derivatives``).

    Written for speed with the same arithmetic: alpha by :func:`atan2f`, sin/cos(alpha) from the
    air velocity (no trigonometry), the stall blend with a single division.
    """
    de = min(max(u[0], p[I_DE_MIN]), p[I_DE_MAX])
    da = min(max(u[1], p[I_DA_MIN]), p[I_DA_MAX])
    dr = min(max(u[2], p[I_DR_MIN]), p[I_DR_MAX])
    dt = min(max(u[3], 0.0), 1.0)
    uu = x[3]
    vv = x[4]
    ww = x[5]
    phi = x[6]
    theta = x[7]
    psi = x[8]
    pr = x[9]
    qr = x[10]
    rr = x[11]
    sf, cf, st, ct, _, _, r = attitude(phi, theta, psi)
    # the body's rates through the air: the turbulence's rotational gusts taken off (the
    # damping derivatives act on them; the kinematics keep the body's own rates)
    pa = pr - p[I_GP]
    qa = qr - p[I_GQ]
    ra = rr - p[I_GR]
    m = p[I_MASS]
    mg = m * p[I_GRAV]
    fx = -mg * st
    fy = mg * r[7]
    fz = mg * r[8]
    ml = 0.0
    mm = 0.0
    mn = 0.0
    wbx, wby, wbz = ned_to_body(r, p[I_WN], p[I_WE], p[I_WD])  # the wind in body axes
    ur = uu - wbx
    vr = vv - wby
    wr = ww - wbz
    h2 = ur * ur + wr * wr
    va2 = h2 + vr * vr
    va = math.sqrt(va2)
    rho = density_at(-x[2], p[I_DTEMP])  # the standard atmosphere at the aircraft's altitude
    kad = 0.0  # N per rad/s of alpha-dot (lift), N m per rad/s (pitch): set with the air data
    mad = 0.0
    ca = 1.0
    sa = 0.0
    if va >= 1e-6:
        alpha = atan2f(wr, ur)
        if h2 > 0.0:
            ih = 1.0 / math.sqrt(h2)
            ca = ur * ih
            sa = wr * ih
        else:
            ca = 1.0
            sa = 0.0
        sb = vr / va
        sb = min(max(sb, -1.0), 1.0)
        beta = math.asin(sb)
        qs = 0.5 * rho * va2 * p[I_S]
        inv2va = 0.5 / va
        cq = p[I_C] * inv2va
        bv = p[I_B] * inv2va
        mb = p[I_M]
        a0 = p[I_ALPHA0]
        e1 = math.exp(-mb * (a0 - alpha))
        e2 = math.exp(-mb * (a0 + alpha))
        sig = 1.0 - 1.0 / ((1.0 + e1) * (1.0 + e2))
        plate = 2.0 * sa * sa * ca
        if alpha < 0.0:
            plate = -plate
        cl_att = (1.0 - sig) * (p[I_CL0] + p[I_CLA] * alpha)  # the attached flow's lift
        cl = cl_att + sig * plate
        cd = p[I_CDP] + cl_att * cl_att * p[I_KIND] + sig * 2.0 * abs(sa) * sa * sa
        lift = qs * (cl + p[I_CLQ] * cq * qa + p[I_CLDE] * de)
        drag = qs * (cd + p[I_CDQ] * cq * qa + p[I_CDDE] * abs(de))
        fx += -ca * drag + sa * lift
        fz += -sa * drag - ca * lift
        bp = bv * pa
        br = bv * ra
        fy += qs * (
            p[I_CY0]
            + p[I_CYB] * beta
            + p[I_CYP] * bp
            + p[I_CYR] * br
            + p[I_CYDA] * da
            + p[I_CYDR] * dr
        )
        qsb = qs * p[I_B]
        ml = qsb * (
            p[I_CL_0]
            + p[I_CL_B] * beta
            + p[I_CL_P] * bp
            + p[I_CL_R] * br
            + p[I_CL_DA] * da
            + p[I_CL_DR] * dr
        )
        mm = qs * p[I_C] * (p[I_CM0] + p[I_CMA] * alpha + p[I_CMQ] * cq * qa + p[I_CMDE] * de)
        if h2 > 0.0:
            kad = qs * p[I_CLAD] * cq
            mad = qs * p[I_C] * p[I_CMAD] * cq
        mn = qsb * (
            p[I_CN0]
            + p[I_CNB] * beta
            + p[I_CNP] * bp
            + p[I_CNR] * br
            + p[I_CNDA] * da
            + p[I_CNDR] * dr
        )
    thrust, torque = propeller(va, dt, rho, p)
    fx += thrust
    ml -= torque
    if kad != 0.0 or mad != 0.0:
        adot = alpha_rate(uu, vv, ww, ur, vr, wr, pr, qr, rr, fx / m, fz / m, kad / m)
        fx += sa * kad * adot
        fz -= ca * kad * adot
        mm += mad * adot
    out[0], out[1], out[2] = body_to_ned(r, uu, vv, ww)
    inv_m = 1.0 / m
    out[3] = rr * vv - qr * ww + fx * inv_m
    out[4] = pr * ww - rr * uu + fy * inv_m
    out[5] = qr * uu - pr * vv + fz * inv_m
    qsf_rcf = (qr * sf + rr * cf) / ct
    out[6] = pr + qsf_rcf * st
    out[7] = qr * cf - rr * sf
    out[8] = qsf_rcf
    g1 = p[I_G1]
    g4 = p[I_G4]
    out[9] = g1 * pr * qr - p[I_G2] * qr * rr + p[I_G3] * ml + g4 * mn
    out[10] = p[I_G5] * pr * rr - p[I_G6] * (pr * pr - rr * rr) + mm / p[I_JY]
    out[11] = p[I_G7] * pr * qr - g1 * qr * rr + g4 * ml + p[I_G8] * mn


@nb.njit(cache=True, nogil=True)
def _rk4_into(x, u, dt, p, k1, k2, k3, k4, tmp):  # pragma: no cover - jit
    derivs(x, u, p, k1)
    for i in range(12):
        tmp[i] = x[i] + 0.5 * dt * k1[i]
    derivs(tmp, u, p, k2)
    for i in range(12):
        tmp[i] = x[i] + 0.5 * dt * k2[i]
    derivs(tmp, u, p, k3)
    for i in range(12):
        tmp[i] = x[i] + dt * k3[i]
    derivs(tmp, u, p, k4)
    h6 = dt / 6.0
    for i in range(12):
        x[i] = x[i] + h6 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@nb.njit(cache=True, nogil=True)
def rk4(x, u, dt, p):  # pragma: no cover - jit
    """One RK4 step; returns the new state (``x`` is not modified)."""
    y = x.copy()
    k1 = np.empty(12)
    k2 = np.empty(12)
    k3 = np.empty(12)
    k4 = np.empty(12)
    tmp = np.empty(12)
    _rk4_into(y, u, dt, p, k1, k2, k3, k4, tmp)
    return y


@nb.njit(cache=True, nogil=True)
def step_n(x, u, n, dt, p):  # pragma: no cover - jit
    """``n`` RK4 steps of ``dt`` with the controls ``u`` held; returns the new state."""
    y = x.copy()
    k1 = np.empty(12)
    k2 = np.empty(12)
    k3 = np.empty(12)
    k4 = np.empty(12)
    tmp = np.empty(12)
    for _ in range(n):
        _rk4_into(y, u, dt, p, k1, k2, k3, k4, tmp)
    return y


# ---- autopilot --------------------------------------------------------------------------------


@nb.njit(cache=True, nogil=True)
def wrap(a):  # pragma: no cover - jit
    """Angle wrapped to [-pi, pi)."""
    while a >= math.pi:
        a -= 2.0 * math.pi
    while a < -math.pi:
        a += 2.0 * math.pi
    return a


@nb.njit(cache=True, nogil=True, inline="always")
def orbit_course(pn, pe, cn, ce, rho, lam, k_orbit):  # pragma: no cover - jit
    """Course command of the orbit-following vector field (Beard & McLain eq. 10.13):
    chi_c = gamma + lam (pi/2 + atan(k_orbit (d - rho) / rho)), gamma the angle of the position
    seen from the centre (clockwise from north), lam +1 for a clockwise orbit."""
    dn = pn - cn
    de = pe - ce
    d = math.sqrt(dn * dn + de * de)
    gam = atan2f(de, dn)
    return gam + lam * (0.5 * math.pi + math.atan(k_orbit * (d - rho) / rho))


@nb.njit(cache=True, nogil=True)
def set_leg(leg, n0, e0, h0, n1, e1, h1, switch):  # pragma: no cover - jit
    """Fill ``leg`` for the leg (n0, e0, h0) -> (n1, e1, h1) (NED horizontal, altitude up)."""
    leg[L_N0] = n0
    leg[L_E0] = e0
    leg[L_H0] = h0
    leg[L_N1] = n1
    leg[L_E1] = e1
    leg[L_H1] = h1
    dn = n1 - n0
    de = e1 - e0
    length = math.sqrt(dn * dn + de * de)
    leg[L_LEN] = length
    if length > 1e-9:
        leg[L_QN] = dn / length
        leg[L_QE] = de / length
    else:
        leg[L_QN] = 1.0
        leg[L_QE] = 0.0
    leg[L_CHI] = math.atan2(leg[L_QE], leg[L_QN])
    leg[L_SWITCH] = switch
    leg[L_ACTIVE] = 1.0
    leg[L_PLANE] = length
    leg[L_ARC] = 0.0


@nb.njit(cache=True, nogil=True)
def set_arc(leg, cn, ce, rho, lam, gam0, sweep, h0, h1, en, ee, eqn, eqe):  # pragma: no cover - jit
    """Fill ``leg`` for a turn fillet: centre (cn, ce), radius ``rho``, ``lam`` +1 clockwise
    (a right turn) or -1, starting at the angle ``gam0`` seen from the centre and turning through
    ``sweep`` rad, altitude ``h0`` -> ``h1`` linear in the angle turned; it ends when the
    aircraft passes the plane through (en, ee) normal to the next leg's direction (eqn, eqe)."""
    leg[L_ARC] = 1.0
    leg[L_CN] = cn
    leg[L_CE] = ce
    leg[L_RHO] = rho
    leg[L_LAM] = lam
    leg[L_GAM0] = gam0
    leg[L_SWEEP] = sweep
    leg[L_H0] = h0
    leg[L_H1] = h1
    leg[L_EN] = en
    leg[L_EE] = ee
    leg[L_EQN] = eqn
    leg[L_EQE] = eqe
    leg[L_N1] = en
    leg[L_E1] = ee
    leg[L_LEN] = rho * sweep
    leg[L_PLANE] = rho * sweep
    # course at the end of the turn (what the autopilot holds if the mission ends here)
    leg[L_QN] = eqn
    leg[L_QE] = eqe
    leg[L_CHI] = math.atan2(eqe, eqn)
    leg[L_SWITCH] = 0.0
    leg[L_ACTIVE] = 1.0


@nb.njit(cache=True, nogil=True)
def arc_progress(x, leg):  # pragma: no cover - jit
    """(distance from the centre, angle seen from the centre, fraction of the turn done)."""
    dn = x[0] - leg[L_CN]
    de = x[1] - leg[L_CE]
    d = math.sqrt(dn * dn + de * de)
    gam = atan2f(de, dn)
    frac = leg[L_LAM] * wrap(gam - leg[L_GAM0]) / leg[L_SWEEP] if leg[L_SWEEP] > 0.0 else 1.0
    return d, gam, min(max(frac, 0.0), 1.0)


@nb.njit(cache=True, nogil=True)
def leg_geometry(x, leg):  # pragma: no cover - jit
    """(cross-track + right of the leg, along-track from its start, horizontal distance to its
    end) of the position in ``x`` (seed 000 eq. 15 for the cross-track)."""
    en = x[0] - leg[L_N1]
    ee = x[1] - leg[L_E1]
    if leg[L_ARC] > 0.5:
        # cross-track: + right of the direction of travel; along: arc length turned so far
        d, _, frac = arc_progress(x, leg)
        return leg[L_LAM] * (leg[L_RHO] - d), frac * leg[L_LEN], math.sqrt(en * en + ee * ee)
    qn = leg[L_QN]
    qe = leg[L_QE]
    pn = x[0] - leg[L_N0]
    pe = x[1] - leg[L_E0]
    return -qe * pn + qn * pe, qn * pn + qe * pe, math.sqrt(en * en + ee * ee)


@nb.njit(cache=True, nogil=True)
def leg_done(x, leg):  # pragma: no cover - jit
    """0: keep flying the leg; 1: within the switching distance of its end; 2: its end plane
    has been passed (a line: the plane normal to it at ``L_PLANE`` along it; an arc: the plane
    through its end normal to the next leg)."""
    if leg[L_ACTIVE] < 0.5:
        return 0
    if leg[L_ARC] > 0.5:
        # a turn ends at the plane through its end normal to the next leg
        if (x[0] - leg[L_EN]) * leg[L_EQN] + (x[1] - leg[L_EE]) * leg[L_EQE] >= 0.0:
            return 2
        return 0
    _, along, dist = leg_geometry(x, leg)
    if dist < leg[L_SWITCH]:
        return 1
    if along >= leg[L_PLANE]:
        return 2
    return 0


@nb.njit(cache=True, nogil=True, inline="always")
def flight_data(x, p):  # pragma: no cover - jit
    """``(vn, ve, vd, va, inv_va, sbeta, vg2, chi)`` of the state ``x`` for the control law: the
    ground velocity (NED), the airspeed (at least 1 m/s) and its inverse, the sine of the
    sideslip, the squared ground speed and the course (the heading below 0.5 m/s ground speed)."""
    phi = x[6]
    theta = x[7]
    psi = x[8]
    r = attitude(phi, theta, psi)[6]
    uu = x[3]
    vv = x[4]
    ww = x[5]
    vn, ve, vd = body_to_ned(r, uu, vv, ww)
    wn = p[I_WN]
    we = p[I_WE]
    wd = p[I_WD]
    an = vn - wn
    ae = ve - we
    adn = vd - wd
    va = math.sqrt(an * an + ae * ae + adn * adn)
    va = max(va, 1.0)
    # sine of the sideslip: body-y air velocity over airspeed
    inv_va = 1.0 / va
    sbeta = (vv - ned_to_body(r, wn, we, wd)[1]) * inv_va
    vg2 = vn * vn + ve * ve
    chi = atan2f(ve, vn) if vg2 > 0.25 else psi
    return vn, ve, vd, va, inv_va, sbeta, vg2, chi


@nb.njit(cache=True, nogil=True, inline="always")
def energy_state(x, p, gk, ap, va, hdot, u, dtc):  # pragma: no cover - jit
    """Energy management's measurements (the total-energy view of TECS): the climb rate the
    aircraft has available at full and at idle throttle, ``A_HDOT_UP`` / ``A_HDOT_DN``, and the
    bank it can sustain, ``A_BANK_LIM``; each filtered with ``K_E_TAU``.

    The specific total-energy rate ``Edot = hdot + Va Va' / g`` (m/s) is what the aircraft does
    now with the last throttle's thrust ``T``; moving the throttle to full (idle) adds
    ``(T_max - T) Va / (m g)`` (``(T_idle - T) Va / (m g)``), from the engine model at this
    airspeed and air density. Measured, not modelled: the drag of the moment (a turn's induced
    drag, a climb's angle of attack, the thin air at altitude) is in ``Edot``.

    The bank limit: a coordinated turn at load factor ``n = 1 / cos(phi)`` costs the induced drag
    ``k_i n^2 W^2 / (q S)`` (``k_i = 1 / (pi e AR)``), so the climb available at load factor
    ``n`` is ``hdot_up + k_i W Va (n_now^2 - n^2) / (q S)``; the limit is the ``n`` that leaves
    ``K_E_TURN_MARGIN`` of climb, at least ``K_E_BANK_MIN``."""
    g = p[I_GRAV]
    w = p[I_MASS] * g
    rho = density_at(-x[2], p[I_DTEMP])
    if ap[A_INIT] < 0.5:
        ap[A_VA_LAST] = va
        ap[A_VDOT] = 0.0
        ap[A_VA_F] = va
    ap[A_VA_F] += dtc / (gk[K_E_VA_TAU] + dtc) * (va - ap[A_VA_F])
    vdot_raw = (va - ap[A_VA_LAST]) / dtc
    ap[A_VA_LAST] = va
    k = dtc / (gk[K_E_TAU] + dtc)
    ap[A_VDOT] += k * (vdot_raw - ap[A_VDOT])
    thrust = propeller(va, u[3], rho, p)[0]
    # through the air: the air's own rise (a gust, a steady vertical wind) is not the aircraft's
    e_dot = hdot + p[I_WD] + va * ap[A_VDOT] / g
    up = e_dot + (propeller(va, 1.0, rho, p)[0] - thrust) * va / w
    dn = e_dot + (propeller(va, 0.0, rho, p)[0] - thrust) * va / w
    # the bank the excess power sustains
    cphi = max(math.cos(x[6]), 0.17)
    qs = 0.5 * rho * va * va * p[I_S]
    per_n2 = p[I_KIND] * w * va / qs  # m/s of climb per unit of n^2
    n2 = 1.0 / (cphi * cphi) + (up - gk[K_E_TURN_MARGIN]) / per_n2
    bank = math.acos(1.0 / math.sqrt(n2)) if n2 > 1.0 else 0.0
    bank = min(max(bank, gk[K_E_BANK_MIN]), gk[K_BANK_MAX])
    if ap[A_INIT] < 0.5:
        ap[A_HDOT_UP] = up
        ap[A_HDOT_DN] = dn
        ap[A_BANK_LIM] = bank
    else:
        ap[A_HDOT_UP] += k * (up - ap[A_HDOT_UP])
        ap[A_HDOT_DN] += k * (dn - ap[A_HDOT_DN])
        ap[A_BANK_LIM] += k * (bank - ap[A_BANK_LIM])


@nb.njit(cache=True, nogil=True, inline="always")
def course_command(
    x, p, gk, cmd, leg, mode, on_arc, xtrack, vn, ve, va, vg2, dtc
):  # pragma: no cover - jit
    """Lateral guidance: ``(chi_c, phi_ff)``, the course command and the bank feed-forward of
    lateral mode ``mode`` (``C_LAT_MODE``): on a line leg the vector field on the cross-track
    error ``xtrack``, on a turn fillet (``on_arc``) or around an orbit the orbit-following
    vector field; a moving orbit's centre in ``cmd`` advances by ``dtc``."""
    # ---- lateral guidance: course command (vector field on the cross-track error)
    phi_ff = 0.0
    if mode == 0 and on_arc:
        # a turn fillet: orbit following with the steady bank of the turn as feed-forward
        rho = leg[L_RHO]
        lam = leg[L_LAM]
        chi_c = orbit_course(x[0], x[1], leg[L_CN], leg[L_CE], rho, lam, gk[K_ORBIT])
        phi_ff = lam * math.atan(vg2 / (p[I_GRAV] * rho))
    elif mode == 3:
        # orbit a (possibly moving) centre: the vector field gives the direction u of the
        # velocity relative to the centre; the commanded course is the one whose ground velocity
        # (of magnitude va) less the centre's points along u: va u(chi) = s u + v_c, s > 0 (the
        # root of a quadratic). When no course does (the centre outruns the aircraft across u),
        # the course is u itself, which gains most along it.
        rho = cmd[C_ORB_R]
        lam = cmd[C_ORB_LAM]
        cvn = cmd[C_ORB_VN]
        cve = cmd[C_ORB_VE]
        chi_r = orbit_course(x[0], x[1], cmd[C_ORB_N], cmd[C_ORB_E], rho, lam, gk[K_ORBIT])
        un = math.cos(chi_r)
        ue = math.sin(chi_r)
        dot = cvn * un + cve * ue
        disc = va * va - (cvn * cvn + cve * cve - dot * dot)
        srel = -dot + math.sqrt(disc) if disc > 0.0 else -1.0
        if srel > 0.0:
            chi_c = atan2f(srel * ue + cve, srel * un + cvn)
        else:
            chi_c = chi_r
        rvn = vn - cvn
        rve = ve - cve
        phi_ff = lam * math.atan((rvn * rvn + rve * rve) / (p[I_GRAV] * rho))
        cmd[C_ORB_N] += cvn * dtc
        cmd[C_ORB_E] += cve * dtc
    elif mode == 0:
        chi_c = leg[L_CHI] - gk[K_CHI_INF] * (2.0 / math.pi) * math.atan(gk[K_PATH] * xtrack)
    else:
        chi_c = cmd[C_COURSE]
    return chi_c, phi_ff


@nb.njit(cache=True, nogil=True, inline="always")
def course_loop(gk, cmd, ap, mode, chi_c, chi, phi_ff, dtc):  # pragma: no cover - jit
    """The course loop: ``(chi_c, phi_c)``, the course command as flown (``chi`` plus the wrapped
    error) and the bank command (PI on the course error plus ``phi_ff``, limited to the maximum
    bank or to the bank the aircraft sustains, ``A_BANK_LIM``, when less; the bank command
    ``C_BANK`` itself in mode 2). Integrates ``A_I_COURSE``."""
    bank_max = min(gk[K_BANK_MAX], ap[A_BANK_LIM])
    if mode == 2:
        phi_c = min(max(cmd[C_BANK], -bank_max), bank_max)
        ap[A_I_COURSE] = 0.0
    else:
        e_chi = wrap(chi_c - chi)
        raw = phi_ff + gk[K_COURSE_P] * e_chi + gk[K_COURSE_I] * ap[A_I_COURSE]
        phi_c = min(max(raw, -bank_max), bank_max)
        # anti-windup: integrate unless saturated and the error pushes further into saturation
        if phi_c == raw or (raw > bank_max and e_chi < 0.0) or (raw < -bank_max and e_chi > 0.0):
            ap[A_I_COURSE] += dtc * e_chi
        chi_c = chi + e_chi
    return chi_c, phi_c


@nb.njit(cache=True, nogil=True, inline="always")
def roll_loop(x, p, gk, ap, phi_c, sbeta, bv, u, dtc):  # pragma: no cover - jit
    """The roll loop: ``(phi_c, da)``, the bank command after its rate limit and the aileron
    (PID on the bank error with a feed-forward; ``bv`` = b / (2 Va), ``u[2]`` the last rudder).
    Integrates ``A_I_ROLL``."""
    phi = x[6]
    pr = x[9]
    rr = x[11]
    # ---- roll loop (aileron); the bank command is rate limited (A_PHI_C holds the last one)
    slew = gk[K_ROLL_SLEW] * dtc
    phi_c = min(max(phi_c, ap[A_PHI_C] - slew), ap[A_PHI_C] + slew)
    e_phi = phi_c - phi
    da_lo = p[I_DA_MIN]
    da_hi = p[I_DA_MAX]
    kp = gk[K_ROLL_P]
    # feed-forward cancelling the rolling moments of sideslip, yaw rate and rudder
    # (Beard & McLain's roll model keeps only roll damping and aileron)
    da_ff = -(gk[K_CP0] + gk[K_CPB] * sbeta + gk[K_CPR] * bv * rr + gk[K_CPDR] * u[2]) / gk[K_CPDA]
    raw = da_ff + kp * e_phi + gk[K_ROLL_I] * ap[A_I_ROLL] - gk[K_ROLL_D] * pr
    da = min(max(raw, da_lo), da_hi)
    if abs(e_phi) < gk[K_ROLL_BAND] and (
        da == raw or (raw > da_hi and e_phi * kp < 0.0) or (raw < da_lo and e_phi * kp > 0.0)
    ):
        ap[A_I_ROLL] += dtc * e_phi
    return phi_c, da


@nb.njit(cache=True, nogil=True, inline="always")
def altitude_command(x, cmd, leg, on_arc, along, h, vn, ve):  # pragma: no cover - jit
    """Longitudinal guidance: ``(h_c, hdot_ff)``, the altitude command of altitude mode
    ``C_ALT_MODE`` (on a leg: its end's altitude, or linear in the progress ``along`` it or round
    the turn fillet) at least the terrain floor, and the climb rate fed forward."""
    # ---- longitudinal guidance: altitude command
    # the climb rate the profile asks for is fed forward (no lag on a climbing leg)
    hdot_ff = 0.0
    if int(cmd[C_ALT_MODE] + 0.5) == 0:
        length = leg[L_LEN]
        if cmd[C_ALT_DIRECT] > 0.5 or length < 1e-9:
            h_c = leg[L_H1]
        elif on_arc:
            _, gam_a, f = arc_progress(x, leg)
            h_c = leg[L_H0] + f * (leg[L_H1] - leg[L_H0])
            if 0.0 < f < 1.0:
                v_tan = leg[L_LAM] * (-math.sin(gam_a) * vn + math.cos(gam_a) * ve)
                hdot_ff = (leg[L_H1] - leg[L_H0]) / length * v_tan
        else:
            f = min(max(along / length, 0.0), 1.0)
            h_c = leg[L_H0] + f * (leg[L_H1] - leg[L_H0])
            if 0.0 < f < 1.0:
                hdot_ff = (leg[L_H1] - leg[L_H0]) / length * (leg[L_QN] * vn + leg[L_QE] * ve)
    elif int(cmd[C_ALT_MODE] + 0.5) == 2:
        # climb-rate mode: the altitude command runs with the aircraft (no altitude error term)
        h_c = h
        hdot_ff = cmd[C_CLIMB]
    else:
        h_c = cmd[C_ALT]
    if cmd[C_FLOOR] > h_c or (
        cmd[C_FOLLOW] > 0.5 and int(cmd[C_ALT_MODE] + 0.5) == 0 and cmd[C_FLOOR] > -1e300
    ):
        # at least the floor; on a terrain-frame leg followed, the floor itself (its height
        # above the highest ground ahead), down into a valley as well as up
        h_c = cmd[C_FLOOR]
        hdot_ff = 0.0
    return h_c, hdot_ff


@nb.njit(cache=True, nogil=True, inline="always")
def climb_loop(gk, cmd, ap, h_c, hdot_ff, h, hdot, va, inv_va, g, dtc):  # pragma: no cover - jit
    """The altitude and climb-rate loops: ``(hdot_c, sgam, theta_c, de_ff)``, the climb-rate
    command (``hdot_ff`` plus P on the altitude error, limited, energy managed, slew limited:
    ``A_HDOT_C`` holds the last one), the sine of its flight-path angle, the pitch command (PI
    on the flight-path angle error with the trim pitch of the commanded climb as feed-forward,
    limited) and the elevator trim of that climb. Integrates ``A_I_CLIMB``.

    Energy management (the throttle holds the airspeed, the pitch the climb, so the climb asked
    must be one the engine can give): the climb-rate command is at most the climb available at
    full throttle less what the airspeed's recovery needs, ``A_HDOT_UP - (Va / g) a``, and at
    least the climb at idle less the same, ``A_HDOT_DN - (Va / g) a``, where ``a`` is the
    acceleration asked, ``K_E_ACC (Va_c - Va)`` within ``K_E_ACC_MAX``. Told to climb it never
    descends (told to descend, never climbs) unless the airspeed is more than ``K_E_SPEED_BAND``
    of its command below (above) it: then the airspeed comes first, and the aircraft trades
    altitude for it rather than fly on towards the stall."""
    want = hdot_ff + gk[K_ALT_P] * (h_c - h)
    want = min(max(want, -gk[K_DESCENT_MAX]), gk[K_CLIMB_MAX])
    va_c = min(max(cmd[C_AIRSPEED], gk[K_VA_MIN]), gk[K_VA_MAX])
    e_v = va_c - ap[A_VA_F]  # a gust's moment of airspeed is not a trend to trade height for
    acc = min(max(gk[K_E_ACC] * e_v, -gk[K_E_ACC_MAX]), gk[K_E_ACC_MAX])
    band = gk[K_E_SPEED_BAND] * va_c
    lo = -gk[K_DESCENT_MAX] if e_v > band else min(want, 0.0)
    hi = gk[K_CLIMB_MAX] if -e_v > band else max(want, 0.0)
    hdot_c = min(want, max(ap[A_HDOT_UP] - va * acc / g, lo))
    hdot_c = max(hdot_c, min(ap[A_HDOT_DN] - va * acc / g, hi))
    slew = gk[K_VACC_MAX] * dtc
    hdot_c = min(max(hdot_c, ap[A_HDOT_C] - slew), ap[A_HDOT_C] + slew)
    sgam = min(max(hdot_c * inv_va, -0.9), 0.9)
    gam_c = math.asin(sgam)
    e_gam = (hdot_c - hdot) * inv_va
    th_lo = gk[K_THETA_MIN]
    th_hi = gk[K_THETA_MAX]
    if gam_c >= 0.0:
        th_ff = gk[K_THETA0] + gk[K_THETA_UP] * gam_c
        de_ff = gk[K_DE0] + gk[K_DE_UP] * gam_c
    else:
        th_ff = gk[K_THETA0] + gk[K_THETA_DN] * gam_c
        de_ff = gk[K_DE0] + gk[K_DE_DN] * gam_c
    raw = th_ff + gk[K_CLIMB_P] * e_gam + gk[K_CLIMB_I] * ap[A_I_CLIMB]
    theta_c = min(max(raw, th_lo), th_hi)
    if theta_c == raw or (raw > th_hi and e_gam < 0.0) or (raw < th_lo and e_gam > 0.0):
        ap[A_I_CLIMB] += dtc * e_gam
    return hdot_c, sgam, theta_c, de_ff


@nb.njit(cache=True, nogil=True, inline="always")
def pitch_loop(x, p, gk, theta_c, de_ff):  # pragma: no cover - jit
    """The pitch loop: the elevator (PD on the pitch error with ``de_ff`` as feed-forward)."""
    theta = x[7]
    qr = x[10]
    # ---- pitch loop (elevator)
    raw = de_ff + gk[K_PITCH_P] * (theta_c - theta) - gk[K_PITCH_D] * qr
    return min(max(raw, p[I_DE_MIN]), p[I_DE_MAX])


@nb.njit(cache=True, nogil=True, inline="always")
def airspeed_loop(x, p, gk, cmd, ap, va, sgam, dtc):  # pragma: no cover - jit
    """The airspeed loop: ``(va_c, thr)``, the airspeed command (limited) and the throttle (PI on
    the airspeed error with the throttle of the commanded climb's thrust, ``sgam`` the sine of
    its flight-path angle, as feed-forward). Integrates ``A_I_SPEED``."""
    # ---- airspeed loop (throttle) with the thrust for the commanded climb as feed-forward
    va_c = min(max(cmd[C_AIRSPEED], gk[K_VA_MIN]), gk[K_VA_MAX])
    e_v = va_c - va
    t_ff = gk[K_THRUST0] + p[I_MASS] * p[I_GRAV] * sgam
    rho_here = density_at(-x[2], p[I_DTEMP])
    dt_ff = throttle_for(t_ff, va, rho_here, p)
    raw = dt_ff + gk[K_SPEED_P] * e_v + gk[K_SPEED_I] * ap[A_I_SPEED]
    thr = min(max(raw, 0.0), 1.0)
    # below the throttle of zero thrust the propeller only brakes: the lower saturation (the
    # thrust grows with the throttle, so a command above the feed-forward of a non-negative
    # thrust is above it: no need to find it then)
    thr_idle = 0.0 if (t_ff >= 0.0 and raw >= dt_ff) else throttle_for(0.0, va, rho_here, p)
    if (thr_idle <= raw <= 1.0) or (raw > 1.0 and e_v < 0.0) or (raw < thr_idle and e_v > 0.0):
        ap[A_I_SPEED] += dtc * e_v
    return va_c, thr


@nb.njit(cache=True, nogil=True, inline="always")
def yaw_loop(x, p, gk, ap, sbeta, bv, da, u, dtc):  # pragma: no cover - jit
    """The yaw loop: the rudder (PI on the sideslip error plus the washed-out yaw damper;
    ``bv`` = b / (2 Va), ``da`` this step's aileron, ``u[2]`` the last rudder). Runs the
    washout filter ``A_R_LOW`` and integrates ``A_I_BETA``."""
    pr = x[9]
    rr = x[11]
    # ---- yaw: coordinated flight (no aerodynamic side force: the ball centred) by a sideslip
    # hold on the sideslip of zero side force, and a washed-out yaw damper (rudder)
    ap[A_R_LOW] += (dtc / (gk[K_WASHOUT_TAU] + dtc)) * (rr - ap[A_R_LOW])
    r_hp = rr - ap[A_R_LOW]
    beta_ref = 0.0
    if p[I_CYB] < -1e-9:
        cy_rest = (
            p[I_CY0] + p[I_CYP] * bv * pr + p[I_CYR] * bv * rr + p[I_CYDA] * da + p[I_CYDR] * u[2]
        )
        beta_ref = min(max(-cy_rest / p[I_CYB], -0.2), 0.2)
    e_beta = sbeta - beta_ref
    cndr = p[I_CNDR]
    dr = 0.0
    if abs(cndr) > 1e-9:
        dcn = gk[K_YAW_BETA] * e_beta + gk[K_YAW_BETA_I] * ap[A_I_BETA] - gk[K_YAW_R] * bv * r_hp
        raw = dcn / cndr
        dr = min(max(raw, p[I_DR_MIN]), p[I_DR_MAX])
        if (
            dr == raw
            or (raw > p[I_DR_MAX] and e_beta * cndr > 0.0)
            or (raw < p[I_DR_MIN] and e_beta * cndr < 0.0)
        ):
            ap[A_I_BETA] += dtc * e_beta
    return dr


@nb.njit(cache=True, nogil=True)
def control_law(x, p, gk, cmd, leg, ap, dtc, u):  # pragma: no cover - jit
    """Guidance and the inner loops for one control period ``dtc``: writes ``u`` and updates the
    integrators and logged signals in ``ap``. The loops are kernels of their own, inlined here
    (``inline="always"``): one compiled function as before, without a call per loop."""
    rr = x[11]
    vn, ve, vd, va, inv_va, sbeta, vg2, chi = flight_data(x, p)
    h = -x[2]
    hdot = -vd
    energy_state(x, p, gk, ap, va, hdot, u, dtc)  # before A_INIT is set: it starts its filters
    if ap[A_INIT] < 0.5:
        ap[A_R_LOW] = rr
        ap[A_INIT] = 1.0

    xtrack, along, dist = leg_geometry(x, leg)
    mode = int(cmd[C_LAT_MODE] + 0.5)
    on_arc = leg[L_ARC] > 0.5 and leg[L_ACTIVE] > 0.5
    chi_c, phi_ff = course_command(x, p, gk, cmd, leg, mode, on_arc, xtrack, vn, ve, va, vg2, dtc)
    chi_c, phi_c = course_loop(gk, cmd, ap, mode, chi_c, chi, phi_ff, dtc)
    bv = 0.5 * p[I_B] * inv_va  # b / (2 Va): the roll feed-forward's and the yaw loop's rate scale
    phi_c, da = roll_loop(x, p, gk, ap, phi_c, sbeta, bv, u, dtc)

    h_c, hdot_ff = altitude_command(x, cmd, leg, on_arc, along, h, vn, ve)
    hdot_c, sgam, theta_c, de_ff = climb_loop(
        gk, cmd, ap, h_c, hdot_ff, h, hdot, va, inv_va, p[I_GRAV], dtc
    )
    de = pitch_loop(x, p, gk, theta_c, de_ff)

    va_c, thr = airspeed_loop(x, p, gk, cmd, ap, va, sgam, dtc)

    dr = yaw_loop(x, p, gk, ap, sbeta, bv, da, u, dtc)

    u[0] = de
    u[1] = da
    u[2] = dr
    u[3] = thr
    ap[A_CHI_C] = chi_c
    ap[A_PHI_C] = phi_c
    ap[A_H_C] = h_c
    ap[A_HDOT_C] = hdot_c
    ap[A_THETA_C] = theta_c
    ap[A_VA_C] = va_c
    ap[A_XTRACK] = xtrack
    ap[A_ALONG] = along
    ap[A_DIST] = dist


@nb.njit(cache=True, nogil=True, inline="always")
def _still(p, wn, we, wd):  # pragma: no cover - jit
    """The wind back to ``(wn, we, wd)`` without gusts (the end of :func:`fly`'s turbulence)."""
    p[I_WN] = wn
    p[I_WE] = we
    p[I_WD] = wd
    p[I_GP] = 0.0
    p[I_GQ] = 0.0
    p[I_GR] = 0.0


@nb.njit(cache=True, nogil=True)
def fly(
    x, n, k0, dt, decim, p, gk, cmd, leg, ap, u, rec_every, rec_x, rec_u, rec_g, gust, used
):  # pragma: no cover - jit
    """Closed-loop flight: up to ``n`` steps of ``dt`` from global step ``k0``; the control law
    runs every ``decim`` steps (global index), states are recorded every ``rec_every`` steps
    (global index, before the step; 0 = never) into ``rec_x``/``rec_u``/``rec_g``.

    ``gust`` (G, 6): the turbulence of the steps of this call, row ``i`` for step ``i`` --
    velocity NED (added to the wind ``p[I_WN:I_WD + 1]`` for the step) and rotational gusts
    (body p, q, r); none (G = 0) or past its end: still air beyond the wind.  ``p``'s wind is
    the same after the call.

    ``used[0]`` adds what the engine draws (:func:`drain`: J of the battery, kg of fuel) over
    each control period, at the throttle and the airspeed of its control step.

    ``x``, ``ap`` and ``u`` are updated in place. Stops early, before the step, when the current
    leg is done (``leg_done``). Returns (steps done, leg_done code, records written).
    """
    wn = p[I_WN]
    we = p[I_WE]
    wd = p[I_WD]
    ng = gust.shape[0]
    k1 = np.empty(12)
    k2 = np.empty(12)
    k3 = np.empty(12)
    k4 = np.empty(12)
    tmp = np.empty(12)
    nrec = 0
    dtc = dt * decim
    # countdowns to the next control and record step (no integer division in the loop)
    to_ctrl = (decim - k0 % decim) % decim
    to_rec = (rec_every - k0 % rec_every) % rec_every if rec_every > 0 else -1
    for i in range(n):
        if i < ng:  # this step's turbulence on top of the wind
            p[I_WN] = wn + gust[i, 0]
            p[I_WE] = we + gust[i, 1]
            p[I_WD] = wd + gust[i, 2]
            p[I_GP] = gust[i, 3]
            p[I_GQ] = gust[i, 4]
            p[I_GR] = gust[i, 5]
        elif i == ng and ng > 0:
            _still(p, wn, we, wd)
        if to_ctrl == 0:
            ev = leg_done(x, leg)
            if ev != 0:
                _still(p, wn, we, wd)
                return i, ev, nrec
            control_law(x, p, gk, cmd, leg, ap, dtc, u)
            # at the airspeed of this control step (energy_state keeps it in A_VA_LAST)
            used[0] += drain(ap[A_VA_LAST], u[3], density_at(-x[2], p[I_DTEMP]), p) * dtc
            to_ctrl = decim
        if to_rec == 0:
            nrec = record(x, u, ap, A_CHI_C, N_GUIDANCE_LOG, rec_x, rec_u, rec_g, nrec)
            to_rec = rec_every
        _rk4_into(x, u, dt, p, k1, k2, k3, k4, tmp)
        to_ctrl -= 1
        to_rec -= 1
    _still(p, wn, we, wd)
    return n, 0, nrec
