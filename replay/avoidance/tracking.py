"""Tracks of moving obstacles: constant-velocity least-squares fits and closest approaches.

:func:`fit_lines` fits ``position = p + v (t - t_last)`` to the last fixes of many histories at
once (vectorised over the histories); :class:`Track` is one moving obstacle's fit as
:mod:`replay.avoidance.perception` lists it; :func:`closest_approaches` gives the closest point of approach
(time and distance) of others to the own aircraft, both at constant velocity.

The fit over n fixes (t_i, p_i), times centred for the arithmetic (``tbar``, ``pbar`` the means):

- ``v = sum (t_i - tbar)(p_i - pbar) / S_tt`` with ``S_tt = sum (t_i - tbar)^2``; with two fixes
  exactly ``(p_2 - p_1) / (t_2 - t_1)`` (computed as that difference, not as the sums);
- ``p = pbar + v (t_last - tbar)``, the fitted position at the last fix (for two fixes the last
  fix itself);
- ``SSR = sum |p_i - pbar - v (t_i - tbar)|^2``; ``residual = sqrt(SSR / n)``, the RMS distance of
  the fixes from the line (0 for two fixes); ``sigma = sqrt(SSR / (3 (n - 2)))``, the per-axis
  noise it implies (unbiased for sigma^2 under independent Gaussian errors of equal variance on
  each axis; NaN for n <= 2).  The standard error of each velocity component is then
  ``sigma / sqrt(S_tt)`` (:attr:`Track.velocity_sigma`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


# -- closest point of approach ---------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Approaches:
    """Closest approach of K others to the own aircraft, both at constant velocity from ``t``:
    ``time_to`` (K,) seconds from ``t`` (0 when they are not closing), ``distance`` (K,) at that
    time, and where each is then (``own_at`` (K, 3), ``other_at`` (K, 3))."""

    t: float
    time_to: FloatArray
    distance: FloatArray
    own_at: FloatArray
    other_at: FloatArray


@dataclass(frozen=True, eq=False)
class ClosestApproach:
    """Closest approach of one track: at ``t`` (absolute), ``time_to`` seconds from now."""

    t: float
    time_to: float
    distance: float
    own_at: FloatArray
    other_at: FloatArray


def closest_approaches(
    own_position: npt.ArrayLike,
    own_velocity: npt.ArrayLike,
    positions: npt.ArrayLike,
    velocities: npt.ArrayLike,
    *,
    t: float = 0.0,
    horizon: float = math.inf,
    horizontal: bool = False,
) -> Approaches:
    """Closest point of approach of others (K, 3) moving at ``velocities`` (K, 3) to the aircraft
    at ``own_position`` moving at ``own_velocity``, all at time ``t``.  With relative position
    ``r`` and velocity ``w``, the distance ``|r + w tau|`` is least at
    ``tau = -r.w / |w|^2``, clipped to ``[0, horizon]`` (0 when ``w = 0`` or the two are already
    separating: the closest approach is now).  ``horizontal``: x, y only (distance and time)."""
    own = _vec3(own_position, "own_position")
    vo = _vec3(own_velocity, "own_velocity")
    p = _rows3(positions, "positions")
    v = _rows3(velocities, "velocities")
    if p.shape != v.shape:
        raise InputError(f"positions and velocities must match; got {p.shape} and {v.shape}")
    if not (horizon >= 0):
        raise InputError(f"horizon must be >= 0 s; got {horizon!r}")
    dims = 2 if horizontal else 3
    r = (p - own)[:, :dims]
    w = (v - vo)[:, :dims]
    ww = np.einsum("kd,kd->k", w, w)
    rw = np.einsum("kd,kd->k", r, w)
    tau = np.where(ww > 0.0, -rw / np.where(ww > 0.0, ww, 1.0), 0.0)
    tau = np.clip(tau, 0.0, horizon)
    dist = np.linalg.norm(r + w * tau[:, None], axis=1)
    return Approaches(float(t), tau, dist, own + vo * tau[:, None], p + v * tau[:, None])


def _vec3(a: npt.ArrayLike, name: str) -> FloatArray:
    out = np.asarray(a, dtype=np.float64)
    if out.shape != (3,) or not np.isfinite(out).all():
        raise InputError(f"{name} must be 3 finite numbers; got {a!r}")
    return out


def _rows3(a: npt.ArrayLike, name: str) -> FloatArray:
    out = np.asarray(a, dtype=np.float64).reshape(-1, 3) if np.size(a) else np.zeros((0, 3))
    if not np.isfinite(out).all():
        raise InputError(f"{name} must be finite")
    return out


@dataclass(frozen=True, eq=False)
class Track:
    """A moving obstacle's constant-velocity fit over its last fixes (module docstring)."""

    id: str
    source: str
    t: float  # time of the last fix
    position: FloatArray  # (3,) fitted at t
    velocity: FloatArray  # (3,)
    residual: float  # RMS distance of the fixes from the fit (m)
    sigma: float  # per-axis noise estimate (m), NaN for n <= 2
    n: int  # fixes used
    since: float  # called moving since
    fitted: bool  # False: one fix, velocity as the sensor reported it
    times: FloatArray  # (n,) fixes, oldest first
    positions: FloatArray  # (n, 3)
    ranges: FloatArray  # (n,)

    @property
    def speed(self) -> float:
        return float(np.linalg.norm(self.velocity))

    @property
    def velocity_sigma(self) -> float:
        """Standard error of each velocity component, ``sigma / sqrt(S_tt)`` (NaN for n <= 2)."""
        tc = self.times - self.times.mean()
        return float(self.sigma / math.sqrt(float(tc @ tc))) if self.n > 2 else math.nan

    def predict(self, t: npt.ArrayLike) -> FloatArray:
        """Position(s) at time(s) t at constant velocity: (3,) or t.shape + (3,)."""
        dt = np.asarray(t, dtype=np.float64) - self.t
        return np.asarray(self.position + dt[..., None] * self.velocity)

    def closest_approach(
        self,
        own_position: npt.ArrayLike,
        own_velocity: npt.ArrayLike,
        t: float,
        *,
        horizon: float = math.inf,
        horizontal: bool = False,
    ) -> ClosestApproach:
        """Closest approach to the aircraft at ``own_position`` / ``own_velocity`` at time t (the
        track predicted to t first); see :func:`closest_approaches`."""
        a = closest_approaches(
            own_position,
            own_velocity,
            self.predict(t)[None, :],
            self.velocity[None, :],
            t=t,
            horizon=horizon,
            horizontal=horizontal,
        )
        tau = float(a.time_to[0])
        return ClosestApproach(t + tau, tau, float(a.distance[0]), a.own_at[0], a.other_at[0])


@dataclass(frozen=True, eq=False)
class LineFit:
    """Constant-velocity least-squares fits of K histories (see :func:`fit_lines`)."""

    position: FloatArray  # (K, 3) at the last fix
    velocity: FloatArray  # (K, 3)
    residual: FloatArray  # (K,)
    sigma: FloatArray  # (K,)


def fit_lines(times: FloatArray, positions: FloatArray, counts: IntArray) -> LineFit:
    """Least-squares lines through the last ``counts[k]`` fixes of each row (histories right
    aligned, (K, N) and (K, N, 3), ``counts`` (K,) in [0, N]); rows with fewer than two fixes
    (or all at one time) get NaN.  See the module docstring for the formulas."""
    times = np.asarray(times, dtype=np.float64)
    positions = np.asarray(positions, dtype=np.float64)
    counts = np.asarray(counts, dtype=np.int64)
    if times.ndim != 2 or positions.shape != (*times.shape, 3) or counts.shape != times.shape[:1]:
        raise InputError(
            f"fit_lines needs times (K, N), positions (K, N, 3) and counts (K,); got "
            f"{times.shape}, {positions.shape}, {counts.shape}"
        )
    n_max = times.shape[1]
    if counts.size and (counts.min() < 0 or counts.max() > n_max):
        raise InputError(f"fit_lines counts must lie in [0, {n_max}]")
    w = (np.arange(n_max)[None, :] >= n_max - counts[:, None]).astype(np.float64)  # (K, N)
    nw = np.maximum(w.sum(axis=1), 1.0)
    t = np.where(w > 0, times, 0.0)
    p = np.where(w[..., None] > 0, positions, 0.0)
    tbar = (w * t).sum(axis=1) / nw
    pbar = (w[..., None] * p).sum(axis=1) / nw[:, None]
    tc = w * (t - tbar[:, None])
    stt = (tc * tc).sum(axis=1)
    ok = (counts >= 2) & (stt > 0)
    safe = np.where(ok, stt, 1.0)
    vel = (tc[..., None] * (p - pbar[:, None, :])).sum(axis=1) / safe[:, None]
    two = ok & (counts == 2)  # exactly the difference of the two fixes
    if two.any():
        dt = times[two, -1] - times[two, -2]
        vel[two] = (positions[two, -1] - positions[two, -2]) / dt[:, None]
    t_last = times[:, -1]
    pos = pbar + vel * (t_last - tbar)[:, None]
    pos[two] = positions[two, -1]
    res = w[..., None] * (p - (pbar[:, None, :] + vel[:, None, :] * (t - tbar[:, None])[..., None]))
    ssr = (res**2).sum(axis=(1, 2))
    ssr[two] = 0.0
    residual = np.sqrt(ssr / nw)
    dof = 3.0 * (counts - 2)
    sigma = np.where(counts > 2, np.sqrt(ssr / np.where(dof > 0, dof, 1.0)), np.nan)
    nan = ~ok
    vel[nan], pos[nan] = np.nan, np.nan
    residual[nan] = np.nan
    sigma[nan] = np.nan
    return LineFit(pos, vel, residual, sigma)
