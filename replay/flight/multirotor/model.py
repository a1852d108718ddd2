"""A multirotor: parameters, presets and the 6-DOF rigid body driven by its rotors (numpy reference).

State (16 floats): the 12 of :mod:`replay.frames` ``[pn, pe, pd, u, v, w, phi, theta, psi, p, q,
r]`` (NED position, body velocity FRD, 3-2-1 Euler angles, body rates) followed by the four rotor
speeds ``w_0 .. w_3`` (rad/s). Input: the four commanded rotor speeds (rad/s). The compiled twin
is :mod:`replay.flight.multirotor.kernels` (keep the arithmetic of both identical).

Rotors (body axes x forward, y right, z down; ``arm`` from the centre of mass to each hub)::

    "+":  rotor i at angle a_i = i 90 deg      (front, right, back, left)
    "x":  rotor i at angle a_i = 45 + i 90 deg (front-right, back-right, back-left, front-left)
    position (arm cos a_i, arm sin a_i, 0);  spin s_i = -1, +1, -1, +1

(angles clockwise from the nose seen from above; rotor 0 turns clockwise seen from above and its
drag torque yaws the body to the left, s = -1; the others alternate.)

Equations (Newton-Euler in body axes; sigma = rho(h) / rho0 the ISA density ratio at the altitude,
:mod:`replay.flight.atmosphere`: ``k_f`` and ``k_m`` are sea-level values and a rotor's thrust and torque
scale with the air's density)::

    T_i = sigma k_f w_i^2                            thrust of rotor i, along -z
    Q_i = sigma k_m w_i^2                            drag torque of rotor i
    w_i' = (clip(wc_i, w_min, w_max) - w_i) / tau    tau = tau_up when speeding up, else tau_down
    F = [0, 0, -sum T_i] + D + m g [-sin(theta), cos(theta) sin(phi), cos(theta) cos(phi)]
    D = -sigma |v_a| [c_x u_a, c_y v_a, c_z w_a] + sum H_i
    H_i = -sigma k_d w_i [u_a - r y_i, v_a + r x_i, 0]     (in-plane airspeed at hub i)
    L = -sum y_i T_i,   M = sum x_i T_i,   N = sum s_i Q_i + sum (x_i H_iy - y_i H_ix)
    [pn, pe, pd]' = R_b^n [u, v, w]
    u' = r v - q w + Fx / m,   v' = p w - r u + Fy / m,   w' = q u - p v + Fz / m
    phi'   = p + (q sin(phi) + r cos(phi)) tan(theta)
    theta' = q cos(phi) - r sin(phi)
    psi'   = (q sin(phi) + r cos(phi)) / cos(theta)
    p' = ((Jy - Jz) q r + L) / Jx,  q' = ((Jz - Jx) p r + M) / Jy,  r' = ((Jx - Jy) p q + N) / Jz

``v_a = [u_a, v_a, w_a]`` is the air-relative body velocity (a constant wind in NED, default none).
``D`` is the airframe's parasitic drag (quadratic, per body axis) plus the rotors' H-force (blade
flapping and induced drag: linear in the in-plane airspeed at each hub and in the rotor speed,
the form of RotorS and rotorpy; acting at the hubs, in the rotor plane through the centre of
mass, it yaws the body and damps its yaw rate). Modelled: rigid body with a diagonal inertia,
rotor lag and speed limits, thrust and torque with the density at altitude, both drags, constant
wind. Not modelled: rotor gyroscopic moments and the reaction torque of a rotor's acceleration,
the vertical (induced-inflow) part of the rotor drag, blade flapping moments, ground effect,
translational lift, vortex ring state, battery sag, sensor noise (the controller reads the true
state). Euler angles are singular at 90 deg of
pitch: the controller's tilt limit keeps far from it.

Mixer (:func:`mix`): the collective thrust T and body moments (L, M, N) become rotor thrusts
``f = A^-1 [T, L, M, N]`` and speeds ``sqrt(f / (sigma k_f))``, with the rotor limits honoured in
order of priority: roll and pitch first (their spread scaled down if it exceeds the thrust range,
then the collective shifted to fit), then the collective, then yaw (scaled down to what is left).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from replay.flight.atmosphere import RHO0, check_offset, density_at
from replay.flight.base import G, check_numbers, file_overrides
from replay.flight.energy import ESC_EFFICIENCY, MOTOR_EFFICIENCY, battery_wh
from replay.frames import rotation_body_to_ned, translational_rates
from terrain.errors import InputError

if TYPE_CHECKING:
    from replay.flight.base import TerrainHeight
    from replay.flight.multirotor.stack import MultirotorStack

FloatArray = npt.NDArray[np.float64]

N_ROTORS = 4
N_MR_STATES = 16  # the 12 of replay.frames + 4 rotor speeds
CONFIGURATIONS = ("x", "+")
SPIN = (-1.0, 1.0, -1.0, 1.0)
DT = 0.01  # s, 100 Hz
TAU_MIN = 0.4 * DT  # RK4 at DT is stable on a lag down to tau = DT / 2.785


@dataclass(frozen=True)
class MultirotorParams:
    """A multirotor with four rotors. Units SI (kg, m, s, rad/s) unless a name ends in ``_deg``."""

    name: str
    mass: float  # kg
    Jx: float  # kg m^2 (principal axes: body x, y, z)
    Jy: float
    Jz: float
    arm: float  # m, centre of mass to each rotor hub
    configuration: str  # "x" or "+"
    k_f: float  # N / (rad/s)^2, thrust coefficient at sea level (ISA)
    k_m: float  # N m / (rad/s)^2, rotor drag-torque coefficient at sea level
    rotor_speed_min: float  # rad/s
    rotor_speed_max: float  # rad/s
    rotor_tau_up: float  # s, rotor time constant when speeding up
    rotor_tau_down: float  # s, when slowing down
    rotor_drag: float  # k_d, N / (m/s) / (rad/s): the rotors' H-force per rotor speed
    drag_x: float  # N / (m/s)^2, parasitic drag of the airframe along body x
    drag_y: float
    drag_z: float
    # envelope the controller keeps to (commands beyond it are refused)
    cruise_speed: float  # m/s, horizontal speed along waypoint legs by default
    speed_max: float  # m/s, horizontal
    climb_rate_max: float  # m/s
    descent_rate_max: float  # m/s, positive number
    tilt_max_deg: float  # deg, of the thrust axis from the vertical
    yaw_rate_max_deg: float  # deg/s
    # energy: the battery's power is the rotors' shaft power sum(sigma k_m w_i^3) over this
    # (motors and speed controllers together); the usable battery energy (0: not given)
    power_efficiency: float = MOTOR_EFFICIENCY * ESC_EFFICIENCY
    battery_wh: float = 0.0
    source: str = ""

    def __post_init__(self) -> None:
        validate(self)

    # ---- derived ------------------------------------------------------------------------------
    @property
    def weight(self) -> float:
        return self.mass * G

    @property
    def bank_max_deg(self) -> float:
        """The tilt limit (what an avoider that asks for a bank limit reads)."""
        return self.tilt_max_deg

    @property
    def pitch_max_deg(self) -> float:
        return self.tilt_max_deg

    def rotor_positions(self) -> FloatArray:
        """(4, 2) hub positions (x forward, y right) in body axes, m."""
        a0 = 0.25 * math.pi if self.configuration == "x" else 0.0
        a = a0 + 0.5 * math.pi * np.arange(N_ROTORS)
        return self.arm * np.column_stack([np.cos(a), np.sin(a)])

    def allocation(self) -> FloatArray:
        """A, with [T, L, M, N] = A f for rotor thrusts f (density-free: N uses k_m / k_f)."""
        r = self.rotor_positions()
        return np.vstack(
            [np.ones(N_ROTORS), -r[:, 1], r[:, 0], np.asarray(SPIN) * self.k_m / self.k_f]
        )

    def thrust_max(self, altitude: float = 0.0, temperature_offset: float = 0.0) -> float:
        """All four rotors at full speed (N) at ``altitude`` (m AMSL)."""
        sigma = density_at(float(altitude), check_offset(temperature_offset)) / RHO0
        return N_ROTORS * sigma * self.k_f * self.rotor_speed_max**2

    def hover_rotor_speed(self, altitude: float = 0.0, temperature_offset: float = 0.0) -> float:
        """Rotor speed (rad/s) at which the four rotors carry the weight: sqrt(m g / (4 sigma
        k_f))."""
        sigma = density_at(float(altitude), check_offset(temperature_offset)) / RHO0
        return math.sqrt(self.weight / (N_ROTORS * sigma * self.k_f))

    def min_turn_radius(self, speed: float | None = None) -> float:
        """V^2 / (g tan(tilt_max)): the tightest level turn at ``speed`` (default cruise)."""
        v = self.cruise_speed if speed is None else float(speed)
        return v * v / (G * math.tan(math.radians(self.tilt_max_deg)))

    def check_speed(self, speed: float, what: str = "speed") -> float:
        """``speed`` if the controller may command it, else an InputError naming the limit."""
        v = float(speed)
        if not (math.isfinite(v) and 0.0 < v <= self.speed_max):
            raise InputError(
                f"{what} {speed!r} m/s is beyond {self.name}'s horizontal speed envelope "
                f"(0, {self.speed_max:g}] m/s"
            )
        return v

    @property
    def follows_terrain(self) -> bool:
        """The multirotor flies the waypoints' altitudes: it does not follow the terrain."""
        return False

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
        spirals: Sequence[Any] = (),
        land: bool = False,
        leg_heights: Mapping[int, float] | None = None,
        leg_speeds: Mapping[int, float] | None = None,
    ) -> MultirotorStack:
        """The multirotor under its controller flying ``waypoints`` at ``speed`` in the day's air
        (turn radius, leg switch and terrain following do not apply: it turns on the spot and
        flies the waypoints' altitudes, terrain-frame legs ``leg_heights`` included), changing
        speed from the waypoints ``leg_speeds`` names."""
        if spirals:
            raise InputError(
                f"{self.name} is a multirotor: it climbs on the spot and flies no spirals "
                "(a spiral is a fixed-wing plan's)"
            )
        from replay.flight.multirotor.stack import MultirotorStack

        stack = MultirotorStack(self, waypoints, speed=speed, temperature_offset=temperature_offset)
        if leg_speeds:
            stack.set_leg_speeds(leg_speeds)
        return stack

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    def pack(
        self, wind: npt.ArrayLike = (0.0, 0.0, 0.0), temperature_offset: float = 0.0
    ) -> FloatArray:
        """The flat float64 array the compiled kernels take (``I_*`` layout), with a constant
        wind (NED, m/s) and the day's temperature offset from the standard atmosphere (K)."""
        dtemp = check_offset(temperature_offset)
        w = np.asarray(wind, dtype=np.float64).reshape(-1)
        if w.shape != (3,) or not np.isfinite(w).all():
            raise InputError(f"wind must be three finite numbers (north, east, down); got {wind!r}")
        out = np.zeros(N_PACKED)
        out[I_MASS], out[I_JX], out[I_JY], out[I_JZ] = self.mass, self.Jx, self.Jy, self.Jz
        out[I_KF], out[I_KM] = self.k_f, self.k_m
        out[I_WMIN], out[I_WMAX] = self.rotor_speed_min, self.rotor_speed_max
        out[I_TAU_UP], out[I_TAU_DN] = self.rotor_tau_up, self.rotor_tau_down
        out[I_KD] = self.rotor_drag
        out[I_CDX], out[I_CDY], out[I_CDZ] = self.drag_x, self.drag_y, self.drag_z
        out[I_GRAV] = G
        out[I_WN], out[I_WE], out[I_WD] = w
        out[I_DTEMP] = dtemp
        r = self.rotor_positions()
        out[I_RX : I_RX + 4] = r[:, 0]
        out[I_RY : I_RY + 4] = r[:, 1]
        out[I_SPIN : I_SPIN + 4] = SPIN
        out[I_MIX : I_MIX + 16] = np.linalg.inv(self.allocation()).reshape(-1)
        out[I_EFF] = self.power_efficiency
        return out


# ---- packed layout -----------------------------------------------------------------------------
I_MASS, I_JX, I_JY, I_JZ, I_KF, I_KM, I_WMIN, I_WMAX = range(8)
I_TAU_UP, I_TAU_DN, I_KD, I_CDX, I_CDY, I_CDZ, I_GRAV = range(8, 15)
I_WN, I_WE, I_WD, I_DTEMP = range(15, 19)
I_RX = 19  # 4 hub x positions
I_RY = 23  # 4 hub y positions
I_SPIN = 27  # 4 spin signs
I_MIX = 31  # 16: A^-1, row-major (rotor i, column [T, L, M, N])
I_EFF = 47  # the motors' and speed controllers' efficiency (kernels.drain)
N_PACKED = 48


# ---- validation --------------------------------------------------------------------------------
_POSITIVE = (
    "mass",
    "Jx",
    "Jy",
    "Jz",
    "arm",
    "k_f",
    "k_m",
    "rotor_speed_max",
    "cruise_speed",
    "speed_max",
    "climb_rate_max",
    "descent_rate_max",
    "yaw_rate_max_deg",
)
_NON_NEGATIVE = ("rotor_speed_min", "rotor_drag", "drag_x", "drag_y", "drag_z", "battery_wh")


def _bad(field: str, expected: str, found: Any) -> InputError:
    return InputError(f"multirotor field {field!r}: expected {expected}, found {found!r}")


def validate(p: MultirotorParams) -> None:
    """Refuse impossible values; the message names the field, what was expected and found."""
    if not isinstance(p.name, str) or not p.name:
        raise _bad("name", "a non-empty string", p.name)
    if p.configuration not in CONFIGURATIONS:
        raise _bad(
            "configuration", f"one of {', '.join(map(repr, CONFIGURATIONS))}", p.configuration
        )
    check_numbers(p, ("name", "source", "configuration"), _POSITIVE, _NON_NEGATIVE, _bad)
    moments = sorted((p.Jx, p.Jy, p.Jz))
    if moments[0] + moments[1] < moments[2] * (1 - 1e-9):
        raise _bad(
            "Jz", "principal moments obeying the triangle inequality (a rigid body)", moments
        )
    if p.rotor_speed_min >= p.rotor_speed_max:
        raise _bad(
            "rotor_speed_min",
            f"less than rotor_speed_max ({p.rotor_speed_max:g})",
            p.rotor_speed_min,
        )
    for k in ("rotor_tau_up", "rotor_tau_down"):
        if getattr(p, k) < TAU_MIN:
            raise _bad(
                k, f"a time constant >= {TAU_MIN:g} s (the 100 Hz integration)", getattr(p, k)
            )
    if not 0.0 < p.power_efficiency <= 1.0:
        raise _bad("power_efficiency", "an efficiency in (0, 1]", p.power_efficiency)
    if not 0 < p.tilt_max_deg < 80:
        raise _bad("tilt_max_deg", "a tilt limit in (0, 80) degrees", p.tilt_max_deg)
    if p.cruise_speed > p.speed_max:
        raise _bad("cruise_speed", f"at most speed_max ({p.speed_max:g} m/s)", p.cruise_speed)
    hover = 0.25 * p.weight / p.k_f
    if p.rotor_speed_max**2 <= hover * 1.2:
        raise _bad(
            "rotor_speed_max",
            f"more than 1.1 x the hover speed {math.sqrt(hover):.0f} rad/s (room to manoeuvre)",
            p.rotor_speed_max,
        )
    if p.rotor_speed_min**2 >= hover:
        raise _bad(
            "rotor_speed_min",
            f"below the hover speed {math.sqrt(hover):.0f} rad/s",
            p.rotor_speed_min,
        )


# ---- presets -------------------------------------------------------------------------------------
QUADROTOR = MultirotorParams(
    name="quadrotor",
    mass=0.68,
    Jx=0.007,
    Jy=0.007,
    Jz=0.012,
    arm=0.17,
    configuration="+",
    k_f=8.54858e-06,
    k_m=0.016 * 8.54858e-06,
    rotor_speed_min=0.0,
    rotor_speed_max=838.0,
    rotor_tau_up=0.0125,
    rotor_tau_down=0.025,
    rotor_drag=8.06428e-05,
    drag_x=0.5e-2,
    drag_y=0.5e-2,
    drag_z=1.0e-2,
    cruise_speed=5.0,
    speed_max=12.0,
    climb_rate_max=3.0,
    descent_rate_max=1.0,
    tilt_max_deg=45.0,
    yaw_rate_max_deg=45.0,
    battery_wh=battery_wh(0.68),
    source=(
        "AscTec Hummingbird as in RotorS (Furrer et al. 2016, rotors_description hummingbird.xacro, "
        "after Wang et al.): 0.68 kg, J = diag(0.007, 0.007, 0.012) kg m^2, '+' with 0.17 m arms, "
        "k_f = 8.54858e-6 N/(rad/s)^2, k_m = 0.016 m x k_f, 838 rad/s, rotor time constants "
        "12.5 ms up / 25 ms down, rotor drag 8.06428e-5; airframe drag 0.005/0.005/0.01 N/(m/s)^2 "
        "of rotorpy's Hummingbird set; envelope of PX4's multicopter position-controller defaults "
        "as its mc_pos_control_params.c defines them (MPC_XY_VEL_MAX 12 m/s, MPC_Z_VEL_MAX_UP 3, "
        "MPC_Z_VEL_MAX_DN 1, MPC_TILTMAX_AIR 45 deg, MPC_XY_CRUISE 5 m/s, MPC_YAWRAUTO_MAX "
        "45 deg/s; PX4's 2023 split of the file, multicopter_position_control_limits_params.c, "
        "raises MPC_Z_VEL_MAX_DN to 1.5 m/s and keeps the others)"
    ),
)

MULTIROTOR_PRESETS: dict[str, MultirotorParams] = {p.name: p for p in (QUADROTOR,)}
MR_FILE_KEYS: tuple[str, ...] = (
    "terrapath",
    "base",
    *(f.name for f in dataclasses.fields(MultirotorParams)),
)
_TEXT_FIELDS = ("name", "source", "configuration")


def multirotor_from_dict(data: Any, path: str | None = None) -> MultirotorParams:
    """A multirotor vehicle document: ``terrapath: 1``, ``base:`` a multirotor preset
    (``quadrotor``), ``name:``, and any :class:`MultirotorParams` field to change (SI units);
    one-line errors naming the file and the field (``path`` only names the source)."""
    from terrain.errors import where

    if not isinstance(data, dict):
        raise InputError(f"{where(path)}expected a mapping (terrapath: 1, name: ..., base: ...)")
    unknown = sorted(str(k) for k in data if k not in MR_FILE_KEYS)
    if unknown:
        raise InputError(
            f"{where(path)}unknown key(s) {', '.join(map(repr, unknown))} for a multirotor "
            f"(base {data.get('base')!r}); allowed: {', '.join(MR_FILE_KEYS)}"
        )
    if data.get("terrapath") != 1:
        raise InputError(
            f"{where(path, 'terrapath')}expected format version 1, found {data.get('terrapath')!r}"
        )
    base = data.get("base")
    if base not in MULTIROTOR_PRESETS:
        raise InputError(
            f"{where(path, 'base')}expected a multirotor preset "
            f"({', '.join(MULTIROTOR_PRESETS)}), found {base!r}"
        )
    overrides = file_overrides(data, path, _TEXT_FIELDS)
    overrides.setdefault("source", f"{path or 'vehicle document'} (base {base})")
    try:
        return dataclasses.replace(MULTIROTOR_PRESETS[base], **overrides)
    except InputError as exc:
        raise InputError(f"{where(path)}{exc}") from None


def multirotor_preset(name: str) -> MultirotorParams:
    """A multirotor preset by name (``quadrotor``)."""
    try:
        return MULTIROTOR_PRESETS[name]
    except KeyError:
        raise InputError(
            f"unknown multirotor {name!r}: expected one of {', '.join(MULTIROTOR_PRESETS)}"
        ) from None


# ---- the numpy reference -------------------------------------------------------------------------
def mix(
    thrust: float, moments: npt.ArrayLike, params: MultirotorParams, sigma: float = 1.0
) -> FloatArray:
    """Rotor speed commands (rad/s) for collective ``thrust`` (N) and body ``moments`` (L, M, N)
    at density ratio ``sigma``, within the rotor limits by priority (module docstring)."""
    inv = np.linalg.inv(params.allocation())
    m = np.asarray(moments, dtype=np.float64)
    kf = sigma * params.k_f
    fmin, fmax = kf * params.rotor_speed_min**2, kf * params.rotor_speed_max**2
    f_rp = inv[:, 1] * m[0] + inv[:, 2] * m[1]
    f_y = inv[:, 3] * m[2]
    lo, hi = float(f_rp.min()), float(f_rp.max())
    if hi - lo > fmax - fmin:
        k = (fmax - fmin) / (hi - lo)
        f_rp, lo, hi = f_rp * k, lo * k, hi * k
    base = min(max(0.25 * float(thrust), fmin - lo), fmax - hi)
    f = base + f_rp
    alpha = 1.0
    for i in range(N_ROTORS):
        if f_y[i] > 1e-12:
            alpha = min(alpha, (fmax - f[i]) / f_y[i])
        elif f_y[i] < -1e-12:
            alpha = min(alpha, (fmin - f[i]) / f_y[i])
    f = f + max(alpha, 0.0) * f_y
    return np.asarray(np.sqrt(np.maximum(f, 0.0) / kf))


def forces_moments(
    x: npt.ArrayLike,
    params: MultirotorParams,
    wind: npt.ArrayLike = (0.0, 0.0, 0.0),
    temperature_offset: float = 0.0,
) -> tuple[FloatArray, FloatArray]:
    """Body force (N, gravity included) and moment (N m) at the 16-state ``x``."""
    s = np.asarray(x, dtype=np.float64)
    sigma = density_at(-float(s[2]), check_offset(temperature_offset)) / RHO0
    w = s[12:16]
    thrusts = sigma * params.k_f * w * w
    torques = sigma * params.k_m * w * w
    r = params.rotor_positions()
    rot = rotation_body_to_ned(s[6], s[7], s[8])
    va = s[3:6] - rot.T @ np.asarray(wind, dtype=np.float64)
    speed = math.sqrt(float(va @ va))
    cd = np.array([params.drag_x, params.drag_y, params.drag_z])
    f = -sigma * speed * cd * va
    f[2] -= thrusts.sum()
    phi, theta = s[6], s[7]
    f += (
        params.mass
        * G
        * np.array(
            [-math.sin(theta), math.cos(theta) * math.sin(phi), math.cos(theta) * math.cos(phi)]
        )
    )
    mom = np.array(
        [-(r[:, 1] * thrusts).sum(), (r[:, 0] * thrusts).sum(), (np.asarray(SPIN) * torques).sum()]
    )
    # H-forces at the hubs: -k_d w_i times the in-plane airspeed there (v_a + omega x r_i)
    hub = np.column_stack([va[0] - s[11] * r[:, 1], va[1] + s[11] * r[:, 0]])
    h = -sigma * params.rotor_drag * w[:, None] * hub
    f[0:2] += h.sum(axis=0)
    mom[2] += float((r[:, 0] * h[:, 1] - r[:, 1] * h[:, 0]).sum())
    return f, mom


def derivatives(
    x: npt.ArrayLike,
    rotor_cmd: npt.ArrayLike,
    params: MultirotorParams,
    wind: npt.ArrayLike = (0.0, 0.0, 0.0),
    temperature_offset: float = 0.0,
) -> FloatArray:
    """xdot of the 16-state model with rotor speed commands ``rotor_cmd`` (numpy reference)."""
    s = np.asarray(x, dtype=np.float64)
    if s.shape != (N_MR_STATES,):
        raise InputError(f"multirotor state must have {N_MR_STATES} elements, found {s.shape}")
    f, mom = forces_moments(s, params, wind, temperature_offset)
    phi, theta, pr, qr, rr = s[6], s[7], s[9], s[10], s[11]
    out = np.empty(N_MR_STATES)
    out[0:6] = translational_rates(s, f, params.mass)
    sf, cf = math.sin(phi), math.cos(phi)
    ct = math.cos(theta)
    out[6] = pr + (qr * sf + rr * cf) * math.sin(theta) / ct
    out[7] = qr * cf - rr * sf
    out[8] = (qr * sf + rr * cf) / ct
    jx, jy, jz = params.Jx, params.Jy, params.Jz
    out[9] = ((jy - jz) * qr * rr + mom[0]) / jx
    out[10] = ((jz - jx) * pr * rr + mom[1]) / jy
    out[11] = ((jx - jy) * pr * qr + mom[2]) / jz
    cmd = np.clip(
        np.asarray(rotor_cmd, dtype=np.float64), params.rotor_speed_min, params.rotor_speed_max
    )
    w = s[12:16]
    tau = np.where(cmd > w, params.rotor_tau_up, params.rotor_tau_down)
    out[12:16] = (cmd - w) / tau
    return out


def rk4_step(
    x: npt.ArrayLike,
    rotor_cmd: npt.ArrayLike,
    dt: float,
    params: MultirotorParams,
    wind: npt.ArrayLike = (0.0, 0.0, 0.0),
    temperature_offset: float = 0.0,
) -> FloatArray:
    """One classical Runge-Kutta step with the rotor commands held (numpy)."""
    s = np.asarray(x, dtype=np.float64)
    a = (rotor_cmd, params, wind, temperature_offset)
    k1 = derivatives(s, *a)
    k2 = derivatives(s + 0.5 * dt * k1, *a)
    k3 = derivatives(s + 0.5 * dt * k2, *a)
    k4 = derivatives(s + dt * k3, *a)
    return np.asarray(s + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4))


def hover_state(
    params: MultirotorParams,
    position: npt.ArrayLike,
    yaw: float = 0.0,
    temperature_offset: float = 0.0,
) -> FloatArray:
    """The 16-state of a hover at map ``position`` (x east, y north, z up) facing ``yaw``."""
    p = np.asarray(position, dtype=np.float64)
    x = np.zeros(N_MR_STATES)
    x[0], x[1], x[2], x[8] = p[1], p[0], -p[2], float(yaw)
    x[12:16] = params.hover_rotor_speed(float(p[2]), temperature_offset)
    return x


def top_speed(
    params: MultirotorParams,
    altitude: float = 0.0,
    tilt_deg: float | None = None,
    temperature_offset: float = 0.0,
) -> float:
    """Level speed (m/s) of steady flight at ``tilt_deg`` (default the tilt limit): the rotors
    carry the weight (and the vertical drag), the tilted thrust balances the drag. Solved by
    bisection on the speed, the rotor speed found for each speed by bisection too."""
    tilt = math.radians(params.tilt_max_deg if tilt_deg is None else tilt_deg)
    dtemp = check_offset(temperature_offset)

    def forces(v: float, w: float) -> FloatArray:
        x = np.zeros(N_MR_STATES)
        x[2], x[7] = -altitude, -tilt  # nose down, flying north
        rot = rotation_body_to_ned(0.0, -tilt, 0.0)
        x[3:6] = rot.T @ np.array([v, 0.0, 0.0])
        x[12:16] = w
        f, _ = forces_moments(x, params, temperature_offset=dtemp)
        return rot @ f  # NED

    return level_speed(forces, params.rotor_speed_max)


def level_speed(force_ned: Callable[[float, float], FloatArray], rotor_speed_max: float) -> float:
    """The bisections of :func:`top_speed` for any model of the forces: ``force_ned(v, w)`` is
    the net force (NED) flying north at ``v`` m/s with every rotor at ``w`` rad/s; the speed in
    [0, 200] m/s where the rotor speed that zeroes the vertical force (in [0, 4 x
    ``rotor_speed_max``]) also zeroes the forward one."""

    def rotor_for(v: float) -> float:
        lo, hi = 0.0, 4.0 * rotor_speed_max
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if force_ned(v, mid)[2] > 0.0 else (lo, mid)
        return 0.5 * (lo + hi)

    lo, hi = 0.0, 200.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if force_ned(mid, rotor_for(mid))[0] > 0.0 else (lo, mid)
    return 0.5 * (lo + hi)


__all__ = [
    "CONFIGURATIONS",
    "MR_FILE_KEYS",
    "MULTIROTOR_PRESETS",
    "N_MR_STATES",
    "N_ROTORS",
    "QUADROTOR",
    "MultirotorParams",
    "derivatives",
    "forces_moments",
    "hover_state",
    "level_speed",
    "mix",
    "multirotor_from_dict",
    "multirotor_preset",
    "rk4_step",
    "top_speed",
]
