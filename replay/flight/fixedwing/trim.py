"""Trim: the state and controls of steady flight (Beard & McLain 2012, ch. 5.3).

A trim is a steady climb (flight-path angle ``gamma``) at airspeed ``Va``, straight or in a turn of
radius ``R`` (``R > 0`` turns right, ``R < 0`` left), in still air. The desired derivative is::

    xdot* = [*, *, -Va sin(gamma), 0, 0, 0, 0, 0, Va cos(gamma) / R, 0, 0, 0]

and the trim minimises |f(x, u) - xdot*| (position rates north/east excluded). Unlike the book,
which searches alpha, beta, phi with theta = alpha + gamma and computes the controls in closed form,
we solve for ``z = (alpha, phi, theta, delta_e, delta_a, delta_r, delta_t, beta)`` together with
``scipy.optimize.least_squares`` inside bounds: the surfaces within their travel, the throttle in
[0, 1] and ``alpha`` below the angle of maximum lift (the front side of the lift curve — no stalled
trims). ``theta`` is free because theta = alpha + gamma only holds wings level. The flight is
coordinated in the pilot's sense: no aerodynamic side force (the ball centred), one more
residual ``qbar S CY / m = 0`` -- so a steady turn has the radius V^2 / (g tan(phi)) whatever
the rudder's side force (Beard & McLain's beta = 0 left the rudder's side force in the turn:
1-9 % tighter or wider turns). From z::

    u = Va cos(alpha) cos(beta),  v = Va sin(beta),  w = Va sin(alpha) cos(beta)
    [p, q, r] = psi_dot [-sin(theta), sin(phi) cos(theta), cos(phi) cos(theta)]

with ``psi = 0`` (heading north) and ``pd = -altitude``. A trim is accepted when every residual is
below 1e-6 (m/s^2, rad/s^2, rad/s). If none exists the error names the speed and the speed range in
which the same manoeuvre does trim (a scan of speeds refined by bisection at its ends).
"""

from __future__ import annotations

import math
import pickle
from functools import lru_cache
from pathlib import Path
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares

from replay.flight.atmosphere import density_at
from replay.flight.fixedwing import kernels
from replay.flight.fixedwing.dynamics import drag_coefficient, lift_coefficient
from replay.flight.fixedwing.params import I_DTEMP, VehicleParams
from terrain.errors import InputError
from terrain.memo import DiskMemo

FloatArray = npt.NDArray[np.float64]

TOLERANCE = 1e-6


class Trim(NamedTuple):
    """A trimmed state (12, NED) and its controls (4,); unpacks as ``x, u = trim(...)``."""

    x: FloatArray
    u: FloatArray


@lru_cache(maxsize=64)
def alpha_max_lift(params: VehicleParams) -> float:
    """The angle of attack (rad) of maximum CL (the stall) on the blended lift curve."""
    a = np.linspace(0.0, 0.9, 1801)
    cl = np.array([lift_coefficient(float(v), params) for v in a])
    return float(a[int(np.argmax(cl))])


def _state(z: FloatArray, va: float, altitude: float, psi_dot: float) -> FloatArray:
    alpha, phi, theta, beta = z[0], z[1], z[2], z[7]
    x = np.zeros(12)
    x[2] = -altitude
    x[3] = va * math.cos(alpha) * math.cos(beta)
    x[4] = va * math.sin(beta)
    x[5] = va * math.sin(alpha) * math.cos(beta)
    x[6] = phi
    x[7] = theta
    x[9] = -psi_dot * math.sin(theta)
    x[10] = psi_dot * math.sin(phi) * math.cos(theta)
    x[11] = psi_dot * math.cos(phi) * math.cos(theta)
    return x


def _initial(
    params: VehicleParams,
    packed: FloatArray,
    va: float,
    gamma: float,
    turn_radius: float,
    rho: float,
) -> FloatArray:
    phi = (
        0.0
        if math.isinf(turn_radius)
        else math.atan(va * va * math.cos(gamma) / (9.81 * turn_radius))
    )
    qs = 0.5 * rho * va * va * params.S
    cl = params.weight * math.cos(gamma) / (qs * max(math.cos(phi), 0.2))
    alpha = (cl - params.CL0) / params.CLalpha
    alpha = min(max(alpha, -0.2), alpha_max_lift(params) - 1e-3)
    de = -(params.Cm0 + params.Cmalpha * alpha) / params.Cmde
    drag = qs * drag_coefficient(alpha, params)
    need = max(drag + params.weight * math.sin(gamma), 0.0)
    dt = kernels.throttle_for(need, va, rho, packed)
    z = np.array([alpha, phi, alpha + gamma, de, 0.0, 0.0, dt, 0.0])
    zlo, zhi = _bounds(params)
    return np.asarray(np.clip(z, zlo + 1e-9, zhi - 1e-9))


def _bounds(params: VehicleParams) -> tuple[FloatArray, FloatArray]:
    lo, hi = params.control_limits()
    amax = alpha_max_lift(params)
    zlo = np.array([-0.3, -1.4, -1.4, lo[0], lo[1], lo[2], 0.0, -0.3])
    zhi = np.array([amax, 1.4, 1.4, hi[0], hi[1], hi[2], 1.0, 0.3])
    return zlo, zhi


def _solve(
    params: VehicleParams,
    packed: FloatArray,
    va: float,
    altitude: float,
    gamma: float,
    turn_radius: float,
    z0: FloatArray | None,
) -> tuple[FloatArray, float]:
    """The trim's unknowns ``z`` (8,) and its largest residual.  A pure function of its
    arguments, so it is remembered (:func:`_solved`): the planner, the gains and the envelope
    ask the same trims again and again in one process (a plan, a replay, a campaign's runs, the
    test suite's flights), each a least-squares solve of ~10 ms."""
    key: _SolveKey = (
        params,
        np.asarray(packed, dtype=np.float64).tobytes(),
        float(va),
        float(altitude),
        float(gamma),
        float(turn_radius),
        None if z0 is None else np.asarray(z0, dtype=np.float64).tobytes(),
    )
    z, r = _solved(key)
    return z.copy(), r


_SolveKey = tuple[VehicleParams, bytes, float, float, float, float, bytes | None]


_HERE = Path(__file__).resolve().parent
# the code a solve runs: this module, the dynamics' kernels and what they read
_MEMO = DiskMemo(
    "trim",
    [
        _HERE / name
        for name in (
            "trim.py",
            "kernels.py",
            "dynamics.py",
            "params.py",
            "../atmosphere.py",
            "../rigid.py",
            "../base.py",
            "../energy.py",
            "../../frames.py",
        )
    ],
    max_bytes=64 * 2**20,  # ~16,000 trims (a disk block each)
)


@lru_cache(maxsize=16384)
def _solved(key: _SolveKey) -> tuple[FloatArray, float]:
    """The solve of ``key``: remembered in this process, and on disk between processes
    (:class:`terrain.memo.DiskMemo`, its exact bytes: a campaign's workers, later replays)."""
    params, packed_bytes, va, altitude, gamma, turn_radius, z0_bytes = key
    packed = np.frombuffer(packed_bytes, dtype=np.float64).copy()
    z0 = None if z0_bytes is None else np.frombuffer(z0_bytes, dtype=np.float64).copy()

    def solve() -> FloatArray:
        z, r = _solve_now(params, packed, va, altitude, gamma, turn_radius, z0)
        return np.append(np.asarray(z, dtype=np.float64), r)

    question = pickle.dumps((repr(params), *key[1:]), protocol=4)
    zr = _MEMO.floats(question, solve, 9)
    z = zr[:8].copy()
    z.flags.writeable = False
    return z, float(zr[8])


def _solve_now(
    params: VehicleParams,
    packed: FloatArray,
    va: float,
    altitude: float,
    gamma: float,
    turn_radius: float,
    z0: FloatArray | None,
) -> tuple[FloatArray, float]:
    psi_dot = 0.0 if math.isinf(turn_radius) else va * math.cos(gamma) / turn_radius
    target = np.zeros(10)
    target[0] = -va * math.sin(gamma)
    target[6] = psi_dot
    out = np.empty(12)

    half_b = 0.5 * params.b / va
    side = 0.5 * density_at(float(altitude), float(packed[I_DTEMP])) * va * va * params.S
    side /= params.mass

    def residual(z: FloatArray) -> FloatArray:
        x = _state(z, va, altitude, psi_dot)
        kernels.derivs(x, np.ascontiguousarray(z[3:7]), packed, out)
        # coordinated: no aerodynamic side force (as m/s^2, like the other residuals)
        cy = (
            params.CY0
            + params.CYbeta * z[7]
            + params.CYp * half_b * x[9]
            + params.CYr * half_b * x[11]
            + params.CYda * z[4]
            + params.CYdr * z[5]
        )
        return np.concatenate([out[2:12] - target, [side * cy]])

    zlo, zhi = _bounds(params)
    starts = [] if z0 is None else [np.clip(z0, zlo, zhi)]
    rho = density_at(float(altitude), float(packed[I_DTEMP]))
    starts.append(_initial(params, packed, va, gamma, turn_radius, rho))
    best_z, best_r = starts[0], math.inf
    for s in starts:
        sol = least_squares(
            residual,
            s,
            bounds=(zlo, zhi),
            x_scale="jac",
            xtol=1e-15,
            ftol=1e-15,
            gtol=1e-15,
            max_nfev=400,
        )
        r = float(np.max(np.abs(residual(sol.x))))
        if r < best_r:
            best_z, best_r = sol.x, r
        if best_r < TOLERANCE:
            break
    return best_z, best_r


def trim(
    params: VehicleParams,
    airspeed: float,
    altitude: float = 0.0,
    gamma: float = 0.0,
    turn_radius: float = math.inf,
    temperature_offset: float = 0.0,
    *,
    explain: bool = True,
) -> Trim:
    """Trimmed state and controls at true ``airspeed`` (m/s), ``altitude`` (m AMSL: the standard
    atmosphere's density there, ``temperature_offset`` K off standard), flight-path angle
    ``gamma`` (rad, climb positive) and ``turn_radius`` (m; + right, - left, inf straight).

    Raises :class:`InputError` when the aircraft cannot hold that flight (stall, not enough thrust,
    elevator travel), naming the altitude and the speed range in which it can (``explain``
    False: without that search, for a caller that only asks whether it trims).
    """
    va = float(airspeed)
    if not math.isfinite(va) or va <= 0:
        raise InputError(f"trim airspeed must be a finite speed > 0 m/s, found {airspeed!r}")
    if not -math.pi / 2 < gamma < math.pi / 2:
        raise InputError(f"trim flight-path angle must be in (-pi/2, pi/2) rad, found {gamma!r}")
    if turn_radius == 0 or math.isnan(turn_radius):
        raise InputError(
            f"trim turn radius must be non-zero (inf for straight), found {turn_radius!r}"
        )
    packed = params.pack(temperature_offset=temperature_offset)
    z, r = _solve(params, packed, va, altitude, gamma, turn_radius, None)
    if r >= TOLERANCE:
        raise InputError(
            _cannot_trim(params, va, altitude, gamma, turn_radius, temperature_offset)
            if explain
            else f"{params.name} cannot trim at {va:g} m/s at {altitude:.0f} m"
        )
    psi_dot = 0.0 if math.isinf(turn_radius) else va * math.cos(gamma) / turn_radius
    return Trim(_state(z, va, altitude, psi_dot), np.array(z[3:7], dtype=np.float64))


def trim_range(
    params: VehicleParams,
    altitude: float = 0.0,
    gamma: float = 0.0,
    turn_radius: float = math.inf,
    temperature_offset: float = 0.0,
) -> tuple[float, float] | None:
    """(lowest, highest) true airspeed (m/s, to 0.1 m/s) at which the manoeuvre trims at
    ``altitude``, or None."""
    packed = params.pack(temperature_offset=temperature_offset)
    step = params.cruise_speed / 10.0
    speeds = np.arange(step, 4.0 * params.cruise_speed + step, step)

    def ok(v: float, z0: FloatArray | None) -> tuple[bool, FloatArray]:
        if not math.isinf(turn_radius) and v * v / abs(turn_radius) > 9.81 * math.tan(1.35):
            return False, np.zeros(8)
        z, r = _solve(params, packed, v, altitude, gamma, turn_radius, z0)
        return r < TOLERANCE, z

    good: list[float] = []
    z_prev: FloatArray | None = None
    for v in speeds:
        feasible, z = ok(float(v), z_prev)
        if feasible:
            good.append(float(v))
            z_prev = z
        elif good:
            break
    if not good:
        return None

    def refine(inside: float, outside: float) -> float:
        for _ in range(int(math.ceil(math.log2(step / 0.05)))):
            mid = 0.5 * (inside + outside)
            if ok(mid, None)[0]:
                inside = mid
            else:
                outside = mid
        return inside

    lo = refine(good[0], good[0] - step) if good[0] - step > 0 else good[0]
    hi = refine(good[-1], good[-1] + step)
    return round(lo, 1), round(hi, 1)


def _cannot_trim(
    params: VehicleParams,
    va: float,
    altitude: float,
    gamma: float,
    turn_radius: float,
    temperature_offset: float = 0.0,
) -> str:
    what = "level" if gamma == 0 and math.isinf(turn_radius) else "this"
    cond = []
    if gamma != 0:
        cond.append(f"flight-path angle {math.degrees(gamma):.1f} deg")
    if not math.isinf(turn_radius):
        cond.append(f"turn radius {turn_radius:g} m")
    at = f" ({', '.join(cond)})" if cond else ""
    day = f", ISA{temperature_offset:+g} K" if temperature_offset else ""
    where_ = f" at {altitude:.0f} m{day}"
    rng = trim_range(params, altitude, gamma, turn_radius, temperature_offset)
    if rng is None:
        return (
            f"{params.name} cannot trim at {va:g} m/s{where_}{at}: no airspeed trims {what} "
            "flight there"
        )
    lo, hi = rng
    why = (
        "below its stall speed (or elevator travel)"
        if va < lo
        else "beyond its thrust (or control travel)"
        if va > hi
        else "outside its controls' travel"
    )
    return (
        f"{params.name} cannot trim at {va:g} m/s{where_}{at}, {why}: "
        f"{what} trim exists there for {lo:g}–{hi:g} m/s (true airspeed)"
    )


def best_climb(
    params: VehicleParams,
    airspeed: float,
    altitude: float = 0.0,
    temperature_offset: float = 0.0,
    turn_radius: float = math.inf,
) -> float:
    """The steepest steady climb rate (m/s) at true ``airspeed`` and ``altitude``: the largest
    flight-path angle that still trims (full throttle at most), to 1 mm/s; 0 when not even level
    flight trims there. With a finite ``turn_radius`` (m), in a coordinated helix of that radius:
    the bank's load factor adds induced drag, so the climb in a turn is less."""
    return _steepest(params, airspeed, altitude, temperature_offset, turn_radius, 1.0)


def _steepest(
    params: VehicleParams,
    airspeed: float,
    altitude: float,
    temperature_offset: float,
    turn_radius: float,
    sign: float,
) -> float:
    """The largest vertical speed (m/s, >= 0) up (``sign`` 1) or down (-1) that still trims at
    true ``airspeed`` and ``altitude``: a bisection of the flight-path angle up to 60 deg, to
    1 mm/s; 0 when not even level flight trims there."""
    packed = params.pack(temperature_offset=temperature_offset)
    va = float(airspeed)

    def ok(angle: float) -> bool:
        gamma = sign * angle
        return _solve(params, packed, va, altitude, gamma, turn_radius, None)[1] < TOLERANCE

    if not ok(0.0):
        return 0.0
    lo, hi = 0.0, math.radians(60.0)  # lo trims, hi (steeper) may not
    if ok(hi):
        return va * math.sin(hi)
    while va * (math.sin(hi) - math.sin(lo)) > 1e-3:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return va * math.sin(lo)


def best_descent(
    params: VehicleParams,
    airspeed: float,
    altitude: float = 0.0,
    temperature_offset: float = 0.0,
) -> float:
    """The steepest steady straight descent rate (m/s, a positive number) at true ``airspeed``
    and ``altitude``: the most negative flight-path angle that still trims with the throttle at
    0 at least (the idle glide at that speed; elevator travel may bind first), to 1 mm/s; 0 when
    not even level flight trims there. A clean airframe glides shallow: the solar UAV sinks
    1.17 m/s at 15 m/s at sea level and 1.01 m/s at 3,000 m (the same true airspeed is a lower
    dynamic pressure up there, so less drag), less than its autopilot's 1.5 m/s limit -- a
    plan that asks for that limit is flown above its profile."""
    return _steepest(params, airspeed, altitude, temperature_offset, math.inf, -1.0)


def holds_climb(
    params: VehicleParams,
    airspeed: float,
    altitude: float,
    rate: float,
    temperature_offset: float = 0.0,
) -> bool:
    """Whether a steady straight climb of ``rate`` m/s (negative: a descent) trims at true
    ``airspeed`` and ``altitude`` with the throttle in [0, 1]: one trim solve, where
    :func:`best_climb` takes a bisection of them."""
    va = float(airspeed)
    if not abs(rate) < va:
        return False
    packed = params.pack(temperature_offset=temperature_offset)
    gamma = math.asin(rate / va)
    return _solve(params, packed, va, altitude, gamma, math.inf, None)[1] < TOLERANCE


CEILING_CLIMB = 0.5  # m/s: the service ceiling's climb rate
CEILING_RESOLUTION = 25.0  # m
CEILING_TOP = 20_000.0  # m: the atmosphere model's standard layers end there


@lru_cache(maxsize=128)
def ceiling(
    params: VehicleParams,
    airspeed: float,
    temperature_offset: float = 0.0,
    climb: float = CEILING_CLIMB,
    resolution: float = CEILING_RESOLUTION,
) -> float:
    """The ceiling at true ``airspeed``: the highest altitude (m AMSL, rounded down to
    ``resolution``) at which the aircraft still climbs ``climb`` m/s steadily (full throttle at
    most) -- the service ceiling at that speed. Bisection on the altitude with one trim solve
    a step (about ten), cached per vehicle, speed and day. ``-inf`` when it does not climb that
    fast even at sea level, ``inf`` when it still does at 20 km."""
    v, dt = float(airspeed), float(temperature_offset)
    if not holds_climb(params, v, 0.0, climb, dt):
        return -math.inf
    if holds_climb(params, v, CEILING_TOP, climb, dt):
        return math.inf
    lo, hi = 0.0, CEILING_TOP
    while hi - lo > resolution:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if holds_climb(params, v, mid, climb, dt) else (lo, mid)
    return math.floor(lo / resolution) * resolution
