"""Analytic length of 3D segments inside vertical cylinders (danger zones), vectorised.

A danger zone is a vertical cylinder: a horizontal disc of centre (cx, cy) and radius r, extending
from -inf up to an altitude ``top`` (``+inf`` for an unbounded zone).  The ground is not a floor:
whatever lies under the terrain is the terrain checker's business, not this module's.

Method, for a segment p(t) = p0 + t (p1 - p0), t in [0, 1]:

1. horizontal: the set of t where the horizontal distance to the centre is <= r is an interval
   centred on the closest-approach parameter t* = -(w . d) / |d|^2 (w = p0_xy - c, d the horizontal
   direction) of half-width sqrt(r^2 - h^2) / |d|, with h = |w x d| / |d| the perpendicular distance.
   (This form is better conditioned than the roots of the raw quadratic when the segment starts far
   from the centre.)  A segment with no horizontal extent (vertical, or a single point) is inside for
   every t when its (x, y) is within r of the centre, and for no t otherwise;
2. vertical: the set of t where z(t) <= top is a half-line (or everything / nothing when the segment
   is horizontal);
3. the inside length is the width of [0, 1] & (1) & (2) times the 3D segment length.

The cylinder is closed: points on its side wall or its top face count as inside.  That only changes
a result for segments lying *in* the top plane (z0 == z1 == top), which count as inside, or sliding
along the wall, which have zero horizontal-crossing width anyway.  Inside length is a measure, so
touching the cylinder at a single point gives 0.

Everything is numpy broadcasting over (segments, cylinders); there is no Python loop.  NaN inputs give
NaN outputs.  Memory is a handful of float64 arrays of shape (M, K).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import numpy.typing as npt

from terrain.errors import InputError

if TYPE_CHECKING:
    from terrain.zones import DangerZone

FloatArray = npt.NDArray[np.float64]


class ZoneArrays(NamedTuple):
    """Danger zones as arrays: ``centers`` (K, 2), ``radii`` (K,), ``tops`` (K,) with +inf = unbounded."""

    centers: FloatArray
    radii: FloatArray
    tops: FloatArray


def zones_arrays(zones: Iterable[DangerZone]) -> ZoneArrays:
    """The (centers, radii, tops) arrays of some danger zones, in their order (tops None -> +inf)."""
    zs = list(zones)
    centers = np.array([[z.x, z.y] for z in zs], dtype=np.float64).reshape(len(zs), 2)
    radii = np.array([z.radius for z in zs], dtype=np.float64)
    tops = np.array([np.inf if z.top is None else z.top for z in zs], dtype=np.float64)
    return ZoneArrays(centers, radii, tops)


def _check_cylinders(
    centers: npt.ArrayLike, radii: npt.ArrayLike, tops: npt.ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray]:
    c = np.asarray(centers, dtype=np.float64)
    r = np.asarray(radii, dtype=np.float64)
    t = np.asarray(tops, dtype=np.float64)
    if c.ndim != 2 or c.shape[1] != 2:
        raise InputError(f"cylinder centres must have shape (K, 2); got {c.shape}")
    k = c.shape[0]
    if r.shape != (k,) or t.shape != (k,):
        raise InputError(
            f"radii and tops must have shape ({k},) to match the centres; got {r.shape} and {t.shape}"
        )
    return c, r, t


def segment_cylinder_lengths(
    p0: npt.ArrayLike,
    p1: npt.ArrayLike,
    centers: npt.ArrayLike,
    radii: npt.ArrayLike,
    tops: npt.ArrayLike,
) -> FloatArray:
    """Length (m) of each segment p0[m] -> p1[m] inside each cylinder k, shape (M, K).

    ``p0``, ``p1``: (M, 3) map metres (x east, y north, z AMSL); ``centers`` (K, 2); ``radii`` (K,);
    ``tops`` (K,) altitudes AMSL, ``+inf`` for a zone with no top.
    """
    a = np.asarray(p0, dtype=np.float64)
    b = np.asarray(p1, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3 or b.shape != a.shape:
        raise InputError(f"segment ends must both have shape (M, 3); got {a.shape} and {b.shape}")
    c, r, top = _check_cylinders(centers, radii, tops)

    d = b - a  # (M, 3)
    seg_len = np.sqrt(np.einsum("ij,ij->i", d, d))  # (M,)
    dx, dy, dz = d[:, 0:1], d[:, 1:2], d[:, 2:3]  # (M, 1) each, broadcast against (1, K)
    hor2 = dx * dx + dy * dy  # (M, 1)
    moving = hor2 > 0.0
    safe_hor2 = np.where(moving, hor2, 1.0)

    # 1. horizontal interval [h_lo, h_hi] of t where the distance to the centre is <= r.
    wx = a[:, 0:1] - c[None, :, 0]  # (M, K)
    wy = a[:, 1:2] - c[None, :, 1]
    t_mid = -(wx * dx + wy * dy) / safe_hor2
    cross = wx * dy - wy * dx
    perp2 = cross * cross / safe_hor2  # squared perpendicular distance to the centre
    r2 = (r * r)[None, :]
    slack = r2 - perp2
    half = np.sqrt(np.maximum(slack, 0.0) / safe_hor2)
    static_in = wx * wx + wy * wy <= r2  # for segments with no horizontal extent
    hits = np.where(moving, slack > 0.0, static_in)
    h_lo = np.where(moving, t_mid - half, 0.0)
    h_hi = np.where(moving, t_mid + half, 1.0)

    # 2. vertical interval [v_lo, v_hi] of t where z(t) <= top.
    room = top[None, :] - a[:, 2:3]  # top - z0, (M, K); +inf for unbounded zones
    climbing = dz > 0.0
    sinking = dz < 0.0
    safe_dz = np.where(dz != 0.0, dz, 1.0)
    t_top = room / safe_dz
    v_lo = np.where(sinking, t_top, 0.0)
    v_hi = np.where(climbing, t_top, 1.0)
    below = np.where(climbing | sinking, True, room >= 0.0)

    # 3. intersect with [0, 1].
    lo = np.maximum(np.maximum(h_lo, v_lo), 0.0)
    hi = np.minimum(np.minimum(h_hi, v_hi), 1.0)
    width = np.where(hits & below, np.maximum(hi - lo, 0.0), 0.0)
    # NaN anywhere in the inputs must not be hidden by the where/maximum above.
    bad = ~np.isfinite(seg_len)[:, None] | np.isnan(c).any(axis=1)[None, :]
    bad |= np.isnan(r)[None, :] | np.isnan(top)[None, :]
    out = width * seg_len[:, None]
    return np.asarray(np.where(bad, np.nan, out), dtype=np.float64)


def path_inside_lengths(
    paths: npt.ArrayLike,
    centers: npt.ArrayLike,
    radii: npt.ArrayLike,
    tops: npt.ArrayLike,
) -> FloatArray:
    """Total length of each path inside each cylinder, shape (P, K).

    ``paths`` is (P, W, 3): P paths of W waypoints each (a whole swarm in one call); the lengths of
    the W - 1 consecutive segments are summed.  A path of one waypoint has length 0 everywhere.
    """
    p = np.asarray(paths, dtype=np.float64)
    if p.ndim != 3 or p.shape[2] != 3 or p.shape[1] < 1:
        raise InputError(f"paths must have shape (P, W, 3) with W >= 1; got {p.shape}")
    c, r, t = _check_cylinders(centers, radii, tops)
    n_paths, n_points = p.shape[0], p.shape[1]
    seg0 = p[:, :-1, :].reshape(-1, 3)
    seg1 = p[:, 1:, :].reshape(-1, 3)
    per_segment = segment_cylinder_lengths(seg0, seg1, c, r, t)
    total = per_segment.reshape(n_paths, n_points - 1, c.shape[0]).sum(axis=1)
    return np.asarray(total, dtype=np.float64)


def points_in_cylinders(
    points: npt.ArrayLike,
    centers: npt.ArrayLike,
    radii: npt.ArrayLike,
    tops: npt.ArrayLike,
) -> npt.NDArray[np.bool_]:
    """True where point n (of (N, 3)) is inside cylinder k (closed, as above), shape (N, K)."""
    q = np.asarray(points, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != 3:
        raise InputError(f"points must have shape (N, 3); got {q.shape}")
    c, r, t = _check_cylinders(centers, radii, tops)
    wx = q[:, 0:1] - c[None, :, 0]
    wy = q[:, 1:2] - c[None, :, 1]
    inside = (wx * wx + wy * wy <= (r * r)[None, :]) & (q[:, 2:3] <= t[None, :])
    return np.asarray(inside, dtype=np.bool_)
