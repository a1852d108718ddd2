"""Compiled kernels (numba) of the multirotor and its controller.

- :func:`derivs` / :func:`rk4` / :func:`step_n`: the 16-state equations of motion of
  :mod:`replay.flight.multirotor.model` (its numpy :func:`~replay.flight.multirotor.model.derivatives` is the
  twin the tests compare against; keep the arithmetic of both identical);
- :func:`mix`: collective thrust and body moments to rotor speed commands (the twin of
  :func:`replay.flight.multirotor.model.mix`);
- :func:`control_law` / :func:`fly`: the cascaded controller of :mod:`replay.flight.multirotor.stack`
  (its docstring has the equations and gains) and the closed loop at 100 Hz.

Parameters come packed (``MultirotorParams.pack``, ``I_*`` layout of ``multirotor.py``); the
controller's arrays (gains ``K_*``, command ``C_*``, loop state and log ``S_*``) have their
layouts below.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from replay.flight.atmosphere import RHO0, density_at
from replay.flight.multirotor.model import (
    I_CDX,
    I_CDY,
    I_CDZ,
    I_DTEMP,
    I_EFF,
    I_GRAV,
    I_JX,
    I_JY,
    I_JZ,
    I_KD,
    I_KF,
    I_KM,
    I_MASS,
    I_MIX,
    I_RX,
    I_RY,
    I_SPIN,
    I_TAU_DN,
    I_TAU_UP,
    I_WD,
    I_WE,
    I_WMAX,
    I_WMIN,
    I_WN,
)
from replay.flight.rigid import attitude, body_to_ned, ned_to_body, record

# ---- gains (replay.flight.multirotor.stack.ControllerDesign.pack) ---------------------------------------
K_POS = 0  # 1/s: velocity command per metre of position error
K_VEL_H, K_VEL_Z = 1, 2  # 1/s: acceleration per m/s of velocity error
K_VEL_I = 3  # 1/s^2: integral of the velocity error
K_ATT, K_YAW = 4, 5  # 1/s: Euler-angle rate per rad of error
K_RATE, K_RATE_YAW = 6, 7  # 1/s: angular acceleration per rad/s of rate error
K_BRAKE = 8  # m/s^2: deceleration of the approach profile
K_TILT = 9  # rad: tilt limit
K_SPEED = 10  # m/s: horizontal speed limit
K_CLIMB, K_DESCENT = 11, 12  # m/s
K_YAW_RATE = 13  # rad/s
K_RATE_MAX = 14  # rad/s: roll and pitch rate command limit
K_ACC_Z = 15  # m/s^2: vertical acceleration command limit
K_I_MAX = 16  # m/s^2: integral term limit
K_I_BAND = 17  # m/s: an integrator runs only while its velocity error is below this
N_GAINS = 18

# ---- command --------------------------------------------------------------------------------------
C_LAT = 0  # 0: hold the point C_T*, 1: fly the leg C_S* -> C_T*, 2: the course C_COURSE, 3: orbit
C_TN, C_TE, C_TD = 1, 2, 3  # target (NED, m)
C_SN, C_SE, C_SD = 4, 5, 6  # leg start (NED, m)
C_SPEED = 7  # m/s: speed along the leg / the course
C_VEND = 8  # m/s: speed at the leg's end (< 0: the final point, approached without overshoot)
C_VERT = 9  # 0: vertical from C_LAT's guidance, 1: hold altitude C_ALT, 2: climb at C_CLIMB
C_ALT, C_CLIMB = 10, 11  # m up, m/s up
C_YAW = 12  # rad, clockwise from north
C_COURSE = 13  # rad
C_EVENT_R = 14  # m: a leg reports its end within this distance (0: never, e.g. a go-to)
C_ORB_N, C_ORB_E, C_ORB_R, C_ORB_LAM = 15, 16, 17, 18  # orbit centre (NED), radius, +1 clockwise
C_ORB_VN, C_ORB_VE = 19, 20  # m/s: velocity of a moving orbit centre (integrated each step)
N_CMD = 21

# ---- loop state and log ---------------------------------------------------------------------------
S_IN, S_IE, S_ID = 0, 1, 2  # velocity-error integrals (as accelerations, m/s^2)
S_YAW_C, S_PHI_C, S_ALT_C, S_CLIMB_C, S_THETA_C, S_SPEED_C = 3, 4, 5, 6, 7, 8
S_XTRACK, S_ALONG, S_DIST = 9, 10, 11  # cross-track (m, + right), along-track, to the target (m)
N_STATE = 12
N_GUIDANCE_LOG = 9  # S_YAW_C .. S_DIST

N_X = 16


@nb.njit(cache=True, nogil=True)
def derivs(x, wc, p, out):  # pragma: no cover - jit
    """xdot = f(x, wc) into ``out`` (the twin of ``multirotor.derivatives``)."""
    sigma = density_at(-x[2], p[I_DTEMP]) / RHO0
    kf = sigma * p[I_KF]
    km = sigma * p[I_KM]
    wmin = p[I_WMIN]
    wmax = p[I_WMAX]
    thrust = 0.0
    ml = 0.0
    mm = 0.0
    mn = 0.0
    wsum = 0.0
    wx = 0.0  # sum of w_i x_i, w_i y_i, w_i (x_i^2 + y_i^2): the H-forces' lever arms
    wy = 0.0
    wl2 = 0.0
    for i in range(4):
        w = x[12 + i]
        w2 = w * w
        f = kf * w2
        rx = p[I_RX + i]
        ry = p[I_RY + i]
        thrust += f
        ml -= ry * f
        mm += rx * f
        mn += p[I_SPIN + i] * km * w2
        wsum += w
        wx += w * rx
        wy += w * ry
        wl2 += w * (rx * rx + ry * ry)
        c = min(max(wc[i], wmin), wmax)
        tau = p[I_TAU_UP] if c > w else p[I_TAU_DN]
        out[12 + i] = (c - w) / tau
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
    wbx, wby, wbz = ned_to_body(r, p[I_WN], p[I_WE], p[I_WD])  # the wind in body axes
    ua = uu - wbx
    va = vv - wby
    wa = ww - wbz
    speed = math.sqrt(ua * ua + va * va + wa * wa)
    kd = sigma * p[I_KD]
    m = p[I_MASS]
    mg = m * p[I_GRAV]
    # H-force of rotor i: -kd w_i (in-plane airspeed at its hub, v_a + omega x r_i)
    fx = -sigma * speed * p[I_CDX] * ua - kd * (wsum * ua - rr * wy) - mg * st
    fy = -sigma * speed * p[I_CDY] * va - kd * (wsum * va + rr * wx) + mg * r[7]
    fz = -sigma * speed * p[I_CDZ] * wa - thrust + mg * r[8]
    mn -= kd * (wx * va - wy * ua + rr * wl2)
    out[0], out[1], out[2] = body_to_ned(r, uu, vv, ww)
    out[3] = rr * vv - qr * ww + fx / m
    out[4] = pr * ww - rr * uu + fy / m
    out[5] = qr * uu - pr * vv + fz / m
    out[6] = pr + (qr * sf + rr * cf) * st / ct
    out[7] = qr * cf - rr * sf
    out[8] = (qr * sf + rr * cf) / ct
    jx = p[I_JX]
    jy = p[I_JY]
    jz = p[I_JZ]
    out[9] = ((jy - jz) * qr * rr + ml) / jx
    out[10] = ((jz - jx) * pr * rr + mm) / jy
    out[11] = ((jx - jy) * pr * qr + mn) / jz


@nb.njit(cache=True, nogil=True)
def _rk4_into(x, wc, dt, p, k1, k2, k3, k4, tmp):  # pragma: no cover - jit
    n = x.shape[0]
    derivs(x, wc, p, k1)
    for i in range(n):
        tmp[i] = x[i] + 0.5 * dt * k1[i]
    derivs(tmp, wc, p, k2)
    for i in range(n):
        tmp[i] = x[i] + 0.5 * dt * k2[i]
    derivs(tmp, wc, p, k3)
    for i in range(n):
        tmp[i] = x[i] + dt * k3[i]
    derivs(tmp, wc, p, k4)
    for i in range(n):
        x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@nb.njit(cache=True, nogil=True)
def rk4(x, wc, dt, p):  # pragma: no cover - jit
    """One RK4 step with the rotor commands held; returns the new state (``x`` untouched)."""
    out = x.copy()
    _rk4_into(
        out, wc, dt, p, np.empty(N_X), np.empty(N_X), np.empty(N_X), np.empty(N_X), np.empty(N_X)
    )
    return out


@nb.njit(cache=True, nogil=True)
def step_n(x, wc, n, dt, p):  # pragma: no cover - jit
    """``n`` RK4 steps with the rotor commands held; returns the new state."""
    out = x.copy()
    k1 = np.empty(N_X)
    k2 = np.empty(N_X)
    k3 = np.empty(N_X)
    k4 = np.empty(N_X)
    tmp = np.empty(N_X)
    for _ in range(n):
        _rk4_into(out, wc, dt, p, k1, k2, k3, k4, tmp)
    return out


@nb.njit(cache=True, nogil=True)
def mix(thrust, ml, mm, mn, sigma, p, wc):  # pragma: no cover - jit
    """Rotor speed commands into ``wc`` for collective ``thrust`` and moments ``ml, mm, mn`` at
    density ratio ``sigma``: roll/pitch first, then the collective, then yaw (``multirotor.py``)."""
    kf = sigma * p[I_KF]
    fmin = kf * p[I_WMIN] * p[I_WMIN]
    fmax = kf * p[I_WMAX] * p[I_WMAX]
    f_rp = np.empty(4)
    f_y = np.empty(4)
    lo = math.inf
    hi = -math.inf
    for i in range(4):
        f_rp[i] = p[I_MIX + 4 * i + 1] * ml + p[I_MIX + 4 * i + 2] * mm
        f_y[i] = p[I_MIX + 4 * i + 3] * mn
        lo = min(lo, f_rp[i])
        hi = max(hi, f_rp[i])
    if hi - lo > fmax - fmin:
        k = (fmax - fmin) / (hi - lo)
        for i in range(4):
            f_rp[i] *= k
        lo *= k
        hi *= k
    base = min(max(0.25 * thrust, fmin - lo), fmax - hi)
    alpha = 1.0
    for i in range(4):
        f_rp[i] += base
        if f_y[i] > 1e-12:
            alpha = min(alpha, (fmax - f_rp[i]) / f_y[i])
        elif f_y[i] < -1e-12:
            alpha = min(alpha, (fmin - f_rp[i]) / f_y[i])
    alpha = max(alpha, 0.0)
    for i in range(4):
        wc[i] = math.sqrt(max(f_rp[i] + alpha * f_y[i], 0.0) / kf)


@nb.njit(cache=True, nogil=True)
def _wrap(a):  # pragma: no cover - jit
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@nb.njit(cache=True, nogil=True)
def leg_event(x, cmd):  # pragma: no cover - jit
    """1 when a leg that reports its end (C_EVENT_R > 0) is within C_EVENT_R of its end point,
    2 when it has passed the end point's perpendicular plane (not on a final leg), else 0."""
    if cmd[C_LAT] != 1.0 or cmd[C_EVENT_R] <= 0.0:
        return 0
    en = cmd[C_TN] - x[0]
    ee = cmd[C_TE] - x[1]
    ed = cmd[C_TD] - x[2]
    if math.sqrt(en * en + ee * ee + ed * ed) <= cmd[C_EVENT_R]:
        return 1
    if cmd[C_VEND] >= 0.0:
        qn = cmd[C_TN] - cmd[C_SN]
        qe = cmd[C_TE] - cmd[C_SE]
        qd = cmd[C_TD] - cmd[C_SD]
        if qn * en + qe * ee + qd * ed < 0.0:
            return 2
    return 0


@nb.njit(cache=True, nogil=True)
def velocity_command(x, gk, cmd, cs, out):  # pragma: no cover - jit
    """The guidance: NED velocity command into ``out[0:3]``, an acceleration feed-forward into
    ``out[3:5]`` (horizontal: an orbit's centripetal acceleration), a yaw command into
    ``out[5]`` (the command's, or along an orbit) and its rate into ``out[6]``."""
    kp = gk[K_POS]
    pn = x[0]
    pe = x[1]
    pd = x[2]
    en = cmd[C_TN] - pn
    ee = cmd[C_TE] - pe
    ed = cmd[C_TD] - pd
    dist = math.sqrt(en * en + ee * ee + ed * ed)
    xtrack = 0.0
    along = 0.0
    out[3] = 0.0
    out[4] = 0.0
    out[5] = cmd[C_YAW]
    out[6] = 0.0
    lat = cmd[C_LAT]
    vn = kp * en
    ve = kp * ee
    vd = kp * ed
    joint = True  # scale the whole vector to the limits (keeps a straight path)
    if lat == 1.0:
        qn = cmd[C_TN] - cmd[C_SN]
        qe = cmd[C_TE] - cmd[C_SE]
        qd = cmd[C_TD] - cmd[C_SD]
        length = math.sqrt(qn * qn + qe * qe + qd * qd)
        if length > 1e-6:
            qn /= length
            qe /= length
            qd /= length
            rn = pn - cmd[C_SN]
            re = pe - cmd[C_SE]
            rd = pd - cmd[C_SD]
            along = rn * qn + re * qe + rd * qd
            d_end = length - along
            ahead = max(d_end, 0.0)
            vend = cmd[C_VEND]
            if vend < 0.0:
                s = min(cmd[C_SPEED], math.sqrt(2.0 * gk[K_BRAKE] * ahead), kp * d_end)
            else:
                s = min(cmd[C_SPEED], math.sqrt(vend * vend + 2.0 * gk[K_BRAKE] * ahead))
            # toward the closest point of the line, and along it
            vn = s * qn + kp * (cmd[C_SN] + along * qn - pn)
            ve = s * qe + kp * (cmd[C_SE] + along * qe - pe)
            vd = s * qd + kp * (cmd[C_SD] + along * qd - pd)
            qh = math.sqrt(qn * qn + qe * qe)
            if qh > 1e-9:
                xtrack = (qn * re - qe * rn) / qh
    elif lat == 2.0:
        c = cmd[C_COURSE]
        vn = cmd[C_SPEED] * math.cos(c)
        ve = cmd[C_SPEED] * math.sin(c)
        vd = 0.0
        joint = False
    elif lat == 3.0:
        # orbit: along the circle at C_SPEED (already within what its radius allows), back
        # onto it radially, with the centre's motion and the centripetal acceleration
        rho = cmd[C_ORB_R]
        lam = cmd[C_ORB_LAM]
        rn = pn - cmd[C_ORB_N]
        re = pe - cmd[C_ORB_E]
        d = math.sqrt(rn * rn + re * re)
        if d > 1e-6:
            en_r = rn / d
            ee_r = re / d
        else:
            en_r = 1.0
            ee_r = 0.0
        s = cmd[C_SPEED]
        tn = -lam * ee_r
        te = lam * en_r
        vn = s * tn + kp * (rho - d) * en_r + cmd[C_ORB_VN]
        ve = s * te + kp * (rho - d) * ee_r + cmd[C_ORB_VE]
        vd = 0.0
        out[3] = -s * s / rho * en_r
        out[4] = -s * s / rho * ee_r
        out[5] = math.atan2(te, tn)
        out[6] = lam * s / rho
        xtrack = lam * (d - rho)  # + right of the direction of travel (outside, clockwise)
        dist = d
        joint = False
    vert = cmd[C_VERT]
    if vert == 1.0:
        vd = kp * (-cmd[C_ALT] - pd)
        joint = False
    elif vert == 2.0:
        vd = -cmd[C_CLIMB]
        joint = False
    elif lat >= 2.0:
        vd = kp * (-cmd[C_ALT] - pd)
    vh = math.sqrt(vn * vn + ve * ve)
    kh = gk[K_SPEED] / vh if vh > gk[K_SPEED] else 1.0
    kz = 1.0
    if vd < -gk[K_CLIMB]:
        kz = -gk[K_CLIMB] / vd
    elif vd > gk[K_DESCENT]:
        kz = gk[K_DESCENT] / vd
    if joint:
        k = min(kh, kz)
        kh = k
        kz = k
    out[0] = vn * kh
    out[1] = ve * kh
    out[2] = vd * kz
    cs[S_ALT_C] = -cmd[C_TD] if vert == 0.0 and lat < 2.0 else cmd[C_ALT]
    cs[S_CLIMB_C] = -out[2]
    cs[S_SPEED_C] = math.sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2])
    cs[S_XTRACK] = xtrack
    cs[S_ALONG] = along
    cs[S_DIST] = dist


@nb.njit(cache=True, nogil=True)
def control_law(x, p, gk, cmd, cs, dt, wc):  # pragma: no cover - jit
    """One step of the cascade (``replay/flight/multirotor/stack.py``): rotor speed commands into
    ``wc``; the loop state and the logged signals in ``cs``."""
    vc = np.empty(7)
    velocity_command(x, gk, cmd, cs, vc)
    if cmd[C_LAT] == 3.0:
        cmd[C_ORB_N] += cmd[C_ORB_VN] * dt
        cmd[C_ORB_E] += cmd[C_ORB_VE] * dt
    sigma = density_at(-x[2], p[I_DTEMP]) / RHO0
    m = p[I_MASS]
    g = p[I_GRAV]
    uu = x[3]
    vv = x[4]
    ww = x[5]
    phi = x[6]
    theta = x[7]
    psi = x[8]
    sf, cf, st, ct, sp, cp, r = attitude(phi, theta, psi)
    vel_n, vel_e, vel_d = body_to_ned(r, uu, vv, ww)
    # ---- velocity loop: PI, plus the model's drag at the present velocity (feed-forward)
    e_n = vc[0] - vel_n
    e_e = vc[1] - vel_e
    e_d = vc[2] - vel_d
    a_n = gk[K_VEL_H] * e_n + cs[S_IN] + vc[3]
    a_e = gk[K_VEL_H] * e_e + cs[S_IE] + vc[4]
    a_d = gk[K_VEL_Z] * e_d + cs[S_ID]
    a_d = min(max(a_d, -gk[K_ACC_Z]), gk[K_ACC_Z])
    speed = math.sqrt(uu * uu + vv * vv + ww * ww)
    wsum = x[12] + x[13] + x[14] + x[15]
    kd = sigma * p[I_KD] * wsum
    db_x = -sigma * speed * p[I_CDX] * uu - kd * uu
    db_y = -sigma * speed * p[I_CDY] * vv - kd * vv
    db_z = -sigma * speed * p[I_CDZ] * ww
    d_n, d_e, d_d = body_to_ned(r, db_x, db_y, db_z)
    # thrust vector wanted (NED): m a = F + m g e_d + D
    f_n = m * a_n - d_n
    f_e = m * a_e - d_e
    f_d = m * a_d - m * g - d_d
    f_d = min(f_d, -0.1 * m * g)
    fh = math.sqrt(f_n * f_n + f_e * f_e)
    fh_max = -f_d * math.tan(gk[K_TILT])
    saturated = fh > fh_max
    if saturated:
        k = fh_max / fh
        f_n *= k
        f_e *= k
    # integrators (anti-windup: they run only near the commanded velocity, the horizontal
    # ones not while the tilt is at its limit and the error would push further; bounded)
    dti = dt * gk[K_VEL_I]
    imax = gk[K_I_MAX]
    band = gk[K_I_BAND]
    if (not saturated or e_n * cs[S_IN] < 0.0) and abs(e_n) < band:
        cs[S_IN] = min(max(cs[S_IN] + dti * e_n, -imax), imax)
    if (not saturated or e_e * cs[S_IE] < 0.0) and abs(e_e) < band:
        cs[S_IE] = min(max(cs[S_IE] + dti * e_e, -imax), imax)
    if abs(e_d) < band:
        cs[S_ID] = min(max(cs[S_ID] + dti * e_d, -imax), imax)
    # ---- attitude wanted: body z along -F, heading psi_c
    fm = math.sqrt(f_n * f_n + f_e * f_e + f_d * f_d)
    zn = -f_n / fm
    ze = -f_e / fm
    zd = -f_d / fm
    psi_c = vc[5]
    # tilt wanted in the present heading's frame (yaw is turned separately, at its own rate)
    a = cp * zn + sp * ze
    b = -sp * zn + cp * ze
    phi_c = -math.asin(min(max(b, -1.0), 1.0))
    theta_c = math.atan2(a, zd)
    # collective: the wanted force along the present thrust axis
    thrust = max(-(f_n * r[2] + f_e * r[5] + f_d * r[8]), 0.0)
    # ---- attitude loop: Euler-angle rates, then body rates
    phi_dot = gk[K_ATT] * (phi_c - phi)
    theta_dot = gk[K_ATT] * (theta_c - theta)
    psi_dot = gk[K_YAW] * _wrap(psi_c - psi) + vc[6]
    psi_dot = min(max(psi_dot, -gk[K_YAW_RATE]), gk[K_YAW_RATE])
    rate_max = gk[K_RATE_MAX]
    p_c = min(max(phi_dot - st * psi_dot, -rate_max), rate_max)
    q_c = min(max(cf * theta_dot + sf * ct * psi_dot, -rate_max), rate_max)
    r_c = -sf * theta_dot + cf * ct * psi_dot
    # ---- rate loop: J (k (w_c - w)) + w x J w
    pr = x[9]
    qr = x[10]
    rr = x[11]
    jx = p[I_JX]
    jy = p[I_JY]
    jz = p[I_JZ]
    ml = jx * gk[K_RATE] * (p_c - pr) + (jz - jy) * qr * rr
    mm = jy * gk[K_RATE] * (q_c - qr) + (jx - jz) * pr * rr
    mn = jz * gk[K_RATE_YAW] * (r_c - rr) + (jy - jx) * pr * qr
    mix(thrust, ml, mm, mn, sigma, p, wc)
    cs[S_YAW_C] = psi_c
    cs[S_PHI_C] = phi_c
    cs[S_THETA_C] = theta_c


@nb.njit(cache=True, nogil=True, inline="always")
def _still(p, wn, we, wd):  # pragma: no cover - jit
    """The wind back to ``(wn, we, wd)`` (the end of :func:`fly`'s turbulence)."""
    p[I_WN] = wn
    p[I_WE] = we
    p[I_WD] = wd


@nb.njit(cache=True, nogil=True)
def drain(x, p):  # pragma: no cover - jit
    """The battery's power (W) of the 16-state ``x``: the rotors' shaft power -- each rotor's
    drag torque times its speed, ``sigma k_m w_i^3`` -- over the motors' and speed controllers'
    efficiency."""
    km = density_at(-x[2], p[I_DTEMP]) / RHO0 * p[I_KM]
    total = 0.0
    for i in range(4):
        w = x[12 + i]
        total += km * w * w * w
    return max(total, 0.0) / p[I_EFF]


@nb.njit(cache=True, nogil=True)
def fly(
    x, n, k0, dt, p, gk, cmd, cs, wc, rec_every, rec_x, rec_u, rec_g, gust, used
):  # pragma: no cover - jit
    """Closed loop: up to ``n`` steps of ``dt`` from global step ``k0``, the control law at every
    step; the 12 rigid-body states, the rotor commands and the logged guidance are recorded every
    ``rec_every`` steps (global index, before the step; 0 = never). ``x`` (16 states), ``cs`` and
    ``wc`` are updated in place. Stops before a step when the leg reports its end
    (:func:`leg_event`). Returns (steps done, event, records written).

    ``gust`` (G, >= 3): the turbulence's velocity (NED) of the steps of this call, added to the
    wind ``p[I_WN:I_WD + 1]`` for its step (the rotational gusts of a fixed wing's span are not
    modelled for a multirotor); ``p``'s wind is the same after the call. ``used[0]`` adds the
    battery's energy (J) each step draws (:func:`drain` at the step's start)."""
    wn = p[I_WN]
    we = p[I_WE]
    wd = p[I_WD]
    ng = gust.shape[0]
    k1 = np.empty(N_X)
    k2 = np.empty(N_X)
    k3 = np.empty(N_X)
    k4 = np.empty(N_X)
    tmp = np.empty(N_X)
    nrec = 0
    to_rec = (rec_every - k0 % rec_every) % rec_every if rec_every > 0 else -1
    for i in range(n):
        if i < ng:
            p[I_WN] = wn + gust[i, 0]
            p[I_WE] = we + gust[i, 1]
            p[I_WD] = wd + gust[i, 2]
        elif i == ng and ng > 0:
            _still(p, wn, we, wd)
        ev = leg_event(x, cmd)
        if ev != 0:
            _still(p, wn, we, wd)
            return i, ev, nrec
        control_law(x, p, gk, cmd, cs, dt, wc)
        if to_rec == 0:
            nrec = record(x, wc, cs, S_YAW_C, N_GUIDANCE_LOG, rec_x, rec_u, rec_g, nrec)
            to_rec = rec_every
        used[0] += drain(x, p) * dt
        _rk4_into(x, wc, dt, p, k1, k2, k3, k4, tmp)
        to_rec -= 1
    _still(p, wn, we, wd)
    return n, 0, nrec
