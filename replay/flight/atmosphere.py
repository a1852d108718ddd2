"""The ISA standard atmosphere (ISO 2533:1975 / ICAO / U.S. Standard Atmosphere 1976 below 20 km):
temperature, pressure, density and the speed of sound with altitude, and the airspeed conversions.

Altitudes are geometric metres above mean sea level (what a DEM and a mission give); the standard
is written in geopotential altitude ``H = r0 z / (r0 + z)`` (r0 = 6,356,766 m), converted here.
Two layers::

    troposphere  (H <= 11 km):  T = T0 - L H,  p = p0 (T / T0)^(g0 / (R L))
    tropopause   (11-20 km):    T = T11,       p = p11 exp(-g0 (H - 11 km) / (R T11))

with T0 = 288.15 K, p0 = 101,325 Pa, L = 0.0065 K/m, g0 = 9.80665 m/s^2, R = 287.05287 J/(kg K),
gamma = 1.4.  Above 20 km the tropopause formulas are continued (no aircraft here flies there).
Density ``rho = p / (R T)``, speed of sound ``a = sqrt(gamma R T)``.

**Hot and cold days.**  ``dT`` (K, within +-50) offsets the temperature at every altitude while the
pressure keeps its standard value at that altitude -- the usual "ISA + dT" of performance charts --
so a hot day has a thinner air: rho = p_ISA / (R (T_ISA + dT)).

**Airspeeds.**  The 6-DOF model flies true airspeed (TAS).  Equivalent airspeed EAS = TAS
sqrt(rho / rho0) carries the same dynamic pressure as at sea level, so stall and structural
speeds are constant in EAS: an envelope given at sea level is an EAS envelope, and its true
speeds grow with altitude as sqrt(rho0 / rho).  :func:`true_airspeed` and
:func:`equivalent_airspeed` convert; at the low Mach numbers of these aircraft calibrated and
equivalent airspeed differ by well under 1 %.

The scalar functions are compiled with numba so the flight dynamics call them every step.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np
import numpy.typing as npt

from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]

T0 = 288.15  # K
P0 = 101_325.0  # Pa
RHO0 = 1.225  # kg/m^3, p0 / (R T0)
LAPSE = 0.0065  # K/m
G0 = 9.80665  # m/s^2
R_AIR = 287.05287  # J/(kg K)
GAMMA_AIR = 1.4
R_EARTH = 6_356_766.0  # m, the standard's radius for geopotential altitude
H_TROPOPAUSE = 11_000.0  # m geopotential
T11 = T0 - LAPSE * H_TROPOPAUSE  # 216.65 K
P11 = P0 * (T11 / T0) ** (G0 / (R_AIR * LAPSE))  # 22,632.06 Pa
MAX_TEMPERATURE_OFFSET = 50.0  # K


class Air(NamedTuple):
    """The air at an altitude: temperature (K), pressure (Pa), density (kg/m^3), speed of sound
    (m/s); arrays when the altitude is an array."""

    temperature: FloatArray | float
    pressure: FloatArray | float
    density: FloatArray | float
    speed_of_sound: FloatArray | float


@nb.njit(cache=True, nogil=True)
def _temperature_pressure(z: float) -> tuple[float, float]:  # pragma: no cover - jit
    h = R_EARTH * z / (R_EARTH + z)
    if h <= H_TROPOPAUSE:
        t = T0 - LAPSE * h
        return t, P0 * (t / T0) ** (G0 / (R_AIR * LAPSE))
    return T11, P11 * math.exp(-G0 * (h - H_TROPOPAUSE) / (R_AIR * T11))


@nb.njit(cache=True, nogil=True)
def density_at(z: float, dt: float) -> float:  # pragma: no cover - jit
    """Density (kg/m^3) at geometric altitude ``z`` (m AMSL) on a day ``dt`` K off standard."""
    t, p = _temperature_pressure(z)
    return p / (R_AIR * (t + dt))


@nb.njit(cache=True, nogil=True)
def _layers(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - jit
    """:func:`_temperature_pressure` of every altitude of a flat array (compiled: the judge asks
    for a tick's few samples each tick, where ``np.vectorize`` cost 80 us a call)."""
    t = np.empty(z.shape[0])
    p = np.empty(z.shape[0])
    for i in range(z.shape[0]):
        t[i], p[i] = _temperature_pressure(z[i])
    return t, p


def _layers_of(z: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The standard's temperature and pressure at altitudes ``z`` (any shape)."""
    flat = np.ascontiguousarray(z, dtype=np.float64).reshape(-1)
    t, p = _layers(flat)
    return t.reshape(np.shape(z)), p.reshape(np.shape(z))


def check_offset(dt: float, what: str = "temperature offset") -> float:
    """``dt`` as a float, refused unless a finite number of kelvin within +-50."""
    if (
        isinstance(dt, bool)
        or not isinstance(dt, int | float | np.floating)
        or not math.isfinite(dt)
        or abs(dt) > MAX_TEMPERATURE_OFFSET
    ):
        raise InputError(
            f"{what} must be a number of kelvin within ±{MAX_TEMPERATURE_OFFSET:g} K; got {dt!r}"
        )
    return float(dt)


def air(altitude: npt.ArrayLike, dt: float = 0.0) -> Air:
    """Temperature, pressure, density and speed of sound at geometric ``altitude`` (m AMSL,
    scalar or array; from -1 km) on a day ``dt`` K off standard."""
    dt = check_offset(dt)
    z = np.asarray(altitude, dtype=np.float64)
    if not np.isfinite(z).all() or (z < -1000.0).any():
        raise InputError(f"altitude must be finite metres above -1000 m; got {altitude!r}")
    # the standard's layers once, in the compiled function the dynamics call
    t_std, p = _layers_of(z)
    t = t_std + dt
    rho = p / (R_AIR * t)
    a = np.sqrt(GAMMA_AIR * R_AIR * t)
    if z.ndim == 0:
        return Air(float(t), float(p), float(rho), float(a))
    return Air(t, p, rho, a)


def density(altitude: npt.ArrayLike, dt: float = 0.0) -> FloatArray | float:
    """Air density (kg/m^3) at geometric ``altitude`` (m AMSL) on a day ``dt`` K off standard."""
    return air(altitude, dt).density


def _scalar_sigma(altitude: object, dt: float) -> float | None:
    """sigma of one altitude given as a number, by the compiled :func:`density_at` (the same
    arithmetic as :func:`air`, without its arrays: the flight asks once a step); None for arrays."""
    if isinstance(altitude, bool) or not isinstance(altitude, float | int | np.floating):
        return None
    z = float(altitude)
    if not math.isfinite(z) or z < -1000.0:
        raise InputError(f"altitude must be finite metres above -1000 m; got {altitude!r}")
    return float(density_at(z, check_offset(dt))) / RHO0


@nb.njit(cache=True, nogil=True)
def _sigmas(z: np.ndarray, dt: float) -> tuple[np.ndarray, bool]:  # pragma: no cover - jit
    """sigma at every altitude of a flat array, the arithmetic of :func:`air` (then / RHO0), and
    whether every altitude was valid (finite, from -1 km)."""
    out = np.empty(z.shape[0])
    ok = True
    for i in range(z.shape[0]):
        if not (np.isfinite(z[i]) and z[i] >= -1000.0):
            ok = False
            out[i] = np.nan
            continue
        t_std, p = _temperature_pressure(z[i])
        t = t_std + dt
        out[i] = p / (R_AIR * t) / RHO0
    return out, ok


def density_ratio(altitude: npt.ArrayLike, dt: float = 0.0) -> FloatArray | float:
    """sigma = rho / rho0 (compiled for arrays: the judge asks for each tick's samples)."""
    scalar = _scalar_sigma(altitude, dt)
    if scalar is not None:
        return scalar
    z = np.asarray(altitude, dtype=np.float64)
    sigma, ok = _sigmas(np.ascontiguousarray(z).reshape(-1), check_offset(dt))
    if not ok:
        raise InputError(f"altitude must be finite metres above -1000 m; got {altitude!r}")
    return float(sigma[0]) if z.ndim == 0 else sigma.reshape(z.shape)


def true_airspeed(
    eas: npt.ArrayLike, altitude: npt.ArrayLike, dt: float = 0.0
) -> FloatArray | float:
    """TAS (m/s) of an equivalent airspeed ``eas`` at ``altitude``: EAS sqrt(rho0 / rho)."""
    sigma = density_ratio(altitude, dt)
    if isinstance(sigma, float) and isinstance(eas, float | int):  # one number: no arrays
        return float(eas) / math.sqrt(sigma)
    out = np.asarray(eas, dtype=np.float64) / np.sqrt(sigma)
    return float(out) if out.ndim == 0 else out


def equivalent_airspeed(
    tas: npt.ArrayLike, altitude: npt.ArrayLike, dt: float = 0.0
) -> FloatArray | float:
    """EAS (m/s) of a true airspeed ``tas`` at ``altitude``: TAS sqrt(rho / rho0)."""
    sigma = density_ratio(altitude, dt)
    if isinstance(sigma, float) and isinstance(tas, float | int):  # one number: no arrays
        return float(tas) * math.sqrt(sigma)
    out = np.asarray(tas, dtype=np.float64) * np.sqrt(sigma)
    return float(out) if out.ndim == 0 else out


__all__ = [
    "RHO0",
    "Air",
    "air",
    "check_offset",
    "density",
    "density_at",
    "density_ratio",
    "equivalent_airspeed",
    "true_airspeed",
]
