"""Analytic length of 3D segments inside vertical cylinders (danger zones), vectorised.

A danger zone is a vertical cylinder: a horizontal disc of centre (cx, cy) and radius r, extending
from an altitude ``floor`` (``-inf``, the default, for a zone unbounded below) up to an altitude
``top`` (``+inf`` for an unbounded zone).  The ground is not a floor: whatever lies under the
terrain is the terrain checker's business, not this module's.

Method, for a segment p(s) from p0 to p1 parametrised by arc length s in [0, L]:

1. horizontal: the set of s where the horizontal distance to the centre is <= r is an interval
   centred on the closest approach (w = p0_xy - c, d the horizontal direction, q = L / |d|:
   s* = -(w . d) / |d| * q) of half-width sqrt(r^2 - h^2) * q, h = (w x d) / |d| the perpendicular
   distance.  This is the quadratic's solution in a form better conditioned than its raw roots when
   the segment starts far from the centre.  A segment with no horizontal extent (vertical, or a
   point) is inside for every s when its (x, y) is within r of the centre, for no s otherwise;
   a segment whose horizontal extent is below 2^-52 of its length counts as vertical at p0's
   (x, y), which keeps L / |d| finite (the drift is below the resolution of the length);
2. vertical: the set of s where z(s) <= top is a half-line (everything / nothing when level), and
   so is the set where z(s) >= floor;
3. the inside length is the width of [0, L] & (1) & (2).  Working in metres rather than in t in
   [0, 1] makes level and vertical axis-aligned cases exact (a level pass through the centre gives
   exactly 2r).

The cylinder is closed: points on its side wall, its top face or its floor face count as inside.
That only changes a result for segments lying *in* the top or floor plane (z0 == z1 == top), which
count as inside, or sliding along the wall, which have zero horizontal-crossing width anyway.  Inside length is a measure, so
touching the cylinder at a single point gives 0.

Each segment is evaluated from its lexicographically smaller end, so the result is bit-identical
when p0 and p1 are swapped.  Near tangency the result is ill-conditioned (the chord grows like
sqrt(r^2 - h^2)), so rounding in the inputs can move it by ~sqrt(r * ulp) times L / |d|.

Two implementations with the same arithmetic: numpy broadcasting over (segments, cylinders) (no
Python loop; memory a handful of float64 arrays of shape (M, K)) and its compiled scalar twin in
``terrain.kernels`` (the default: no temporaries, about 5x faster on a swarm's call); tests compare
them bit for bit.  NaN inputs give NaN outputs.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, Literal, NamedTuple

import numpy as np
import numpy.typing as npt

from terrain import kernels
from terrain.errors import InputError

if TYPE_CHECKING:
    from terrain.zones import DangerZone

FloatArray = npt.NDArray[np.float64]
Backend = Literal["numba", "numpy"]


class ZoneArrays(NamedTuple):
    """Cylinder zones as arrays: ``centers`` (K, 2), ``radii`` (K,), ``tops`` (K,) with +inf =
    unbounded above, ``floors`` (K,) with -inf = unbounded below."""

    centers: FloatArray
    radii: FloatArray
    tops: FloatArray
    floors: FloatArray


def zones_arrays(zones: Iterable[DangerZone]) -> ZoneArrays:
    """The arrays of some cylinder zones, in their order (top None -> +inf, floor None -> -inf).

    Polygon zones have no centre and radius: they are refused here (:class:`terrain.zoneset.ZoneSet`
    packs both kinds).
    """
    zs = list(zones)
    for i, z in enumerate(zs):
        if getattr(z, "kind", "cylinder") != "cylinder":
            raise InputError(
                f"zone {i} ({getattr(z, 'id', None) or 'no id'}) is a {z.kind}, not a cylinder; "
                "use terrain.zoneset.ZoneSet for zones of both kinds"
            )
    centers = np.array([[z.x, z.y] for z in zs], dtype=np.float64).reshape(len(zs), 2)
    radii = np.array([z.radius for z in zs], dtype=np.float64)
    tops = np.array([np.inf if z.top is None else z.top for z in zs], dtype=np.float64)
    floors = np.array(
        [-np.inf if getattr(z, "floor", None) is None else z.floor for z in zs], dtype=np.float64
    )
    return ZoneArrays(centers, radii, tops, floors)


def _check_cylinders(
    centers: npt.ArrayLike,
    radii: npt.ArrayLike,
    tops: npt.ArrayLike,
    floors: npt.ArrayLike | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
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
    if floors is None:
        f = np.full(k, -np.inf)
    else:
        f = np.asarray(floors, dtype=np.float64)
        if f.shape != (k,):
            raise InputError(f"floors must have shape ({k},) to match the centres; got {f.shape}")
    return c, r, t, f


def segment_cylinder_lengths(
    p0: npt.ArrayLike,
    p1: npt.ArrayLike,
    centers: npt.ArrayLike,
    radii: npt.ArrayLike,
    tops: npt.ArrayLike,
    floors: npt.ArrayLike | None = None,
    *,
    backend: Backend = "numba",
) -> FloatArray:
    """Length (m) of each segment p0[m] -> p1[m] inside each cylinder k, shape (M, K).

    ``p0``, ``p1``: (M, 3) map metres (x east, y north, z AMSL); ``centers`` (K, 2); ``radii`` (K,);
    ``tops`` (K,) altitudes AMSL, ``+inf`` for a zone with no top; ``floors`` (K,) altitudes AMSL,
    ``-inf`` (or ``floors=None``, the default) for a zone unbounded below.  ``backend`` "numba"
    (the compiled loop of ``terrain.kernels``, a few times faster on a swarm) or "numpy" (the
    broadcast reference); both give bit-identical results.
    """
    a = np.asarray(p0, dtype=np.float64)
    b = np.asarray(p1, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3 or b.shape != a.shape:
        raise InputError(f"segment ends must both have shape (M, 3); got {a.shape} and {b.shape}")
    c, r, top, floor = _check_cylinders(centers, radii, tops, floors)
    if backend == "numba":
        return np.asarray(
            kernels.cylinder_lengths(
                kernels.read_only(a),
                kernels.read_only(b),
                kernels.read_only(c),
                kernels.read_only(r),
                kernels.read_only(top),
                kernels.read_only(floor),
                bool(np.any(floor != -np.inf)),
            )
        )
    if backend != "numpy":
        raise InputError(f"backend must be 'numba' or 'numpy'; got {backend!r}")
    a, b = orient_segments(a, b)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        return _lengths(a, b, c, r, top, floor)


def orient_segments(a: FloatArray, b: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Swap the ends of (M, 3) segments so that the lexicographically smaller end comes first.

    Every length function evaluates a segment from that end, so that reversing a segment gives a
    bit-identical result (a reversed path costs exactly the same).
    """
    flip = (b[:, 0] < a[:, 0]) | (
        (b[:, 0] == a[:, 0]) & ((b[:, 1] < a[:, 1]) | ((b[:, 1] == a[:, 1]) & (b[:, 2] < a[:, 2])))
    )
    return np.where(flip[:, None], b, a), np.where(flip[:, None], a, b)


def _lengths(
    a: FloatArray, b: FloatArray, c: FloatArray, r: FloatArray, top: FloatArray, floor: FloatArray
) -> FloatArray:
    """The work of :func:`segment_cylinder_lengths`, in arc length s in [0, L].

    Per-segment quantities are (M, 1) columns; only a few (M, K) arrays are made, updated in
    place.  Inf and NaN in the vertical bound are deliberate (see the comments); the caller
    silences numpy's floating-point warnings.
    """
    d = b - a
    length = np.hypot(np.hypot(d[:, 0], d[:, 1]), d[:, 2])[:, None]  # (M, 1); no underflow
    hor = np.hypot(d[:, 0:1], d[:, 1:2])
    # Horizontal extent below 2**-52 of the length counts as vertical (keeps L / hor finite).
    moving = hor > length * 2.0**-52
    safe_hor = np.where(moving, hor, 1.0)
    scale = length / safe_hor  # arc length per metre of horizontal travel (exactly 1 when level)
    ux, uy = d[:, 0:1] / safe_hor, d[:, 1:2] / safe_hor  # horizontal unit direction (0 if static)

    # 1. horizontal interval [lo, hi] of s where the distance to the centre is <= r.
    wx = a[:, 0:1] - c[None, :, 0]  # (M, K)
    wy = a[:, 1:2] - c[None, :, 1]
    perp = wx * uy - wy * ux  # signed perpendicular distance to the centre
    mid = wx * ux
    mid += wy * uy
    mid *= -scale  # arc length to the closest approach
    half = np.square(perp, out=perp)
    np.subtract((r * r)[None, :], half, out=half)  # r^2 - h^2
    np.maximum(half, 0.0, out=half)
    np.sqrt(half, out=half)
    half *= scale
    lo = mid - half
    hi = np.add(mid, half, out=mid)
    static = np.flatnonzero(~moving[:, 0])
    if static.size:  # no horizontal extent: inside everywhere or nowhere
        inside = wx[static] ** 2 + wy[static] ** 2 <= (r * r)[None, :]
        lo[static] = np.where(inside, -np.inf, np.inf)
        hi[static] = np.where(inside, np.inf, -np.inf)
    np.maximum(lo, 0.0, out=lo)
    np.minimum(hi, length, out=hi)

    # 2. vertical bound: z(s) <= top  <=>  s <= s_top when climbing, s >= s_top when sinking,
    # with s_top = (top - z0) * L / dz.  For a level segment L / dz = +inf, so s_top is +inf above
    # the top, -inf below it and NaN exactly at it: fmin ignores the NaN, so a segment lying in
    # the top plane counts as inside.  A huge finite factor stands in for overflow, so that a
    # segment starting exactly at the top and barely climbing still gets s_top = 0.
    dz = d[:, 2:3]
    factor = np.where(dz == 0.0, np.inf, np.clip(length / dz, -1.7e308, 1.7e308))
    s_top = top[None, :] - a[:, 2:3]
    s_top *= factor
    np.fmin(hi, s_top, out=hi, where=dz >= 0.0)
    np.fmax(lo, s_top, out=lo, where=dz < 0.0)
    # The floor is the mirror image: z(s) >= floor  <=>  s >= s_floor when climbing (or level: +inf
    # below the floor, -inf above it, NaN in its plane, which counts as inside), s <= s_floor when
    # sinking.  A floor of -inf leaves both bounds as they are.
    if np.any(floor != -np.inf):
        s_floor = floor[None, :] - a[:, 2:3]
        s_floor *= factor
        np.fmax(lo, s_floor, out=lo, where=dz >= 0.0)
        np.fmin(hi, s_floor, out=hi, where=dz < 0.0)

    # 3. inside length: the width of the intersection, never negative.
    out = np.subtract(hi, lo, out=hi)
    np.maximum(out, 0.0, out=out)
    bad_segment = ~np.isfinite(length[:, 0])
    bad_zone = np.isnan(c).any(axis=1) | np.isnan(r) | np.isnan(top) | np.isnan(floor)
    if bad_segment.any() or bad_zone.any():  # fmin/fmax/maximum must not hide NaN inputs
        out[bad_segment, :] = np.nan
        out[:, bad_zone] = np.nan
    return out


def path_inside_lengths(
    paths: npt.ArrayLike,
    centers: npt.ArrayLike,
    radii: npt.ArrayLike,
    tops: npt.ArrayLike,
    floors: npt.ArrayLike | None = None,
) -> FloatArray:
    """Total length of each path inside each cylinder, shape (P, K).

    ``paths`` is (P, W, 3): P paths of W waypoints each (a whole swarm in one call); the lengths of
    the W - 1 consecutive segments are summed.  A path of one waypoint has length 0 everywhere.
    ``floors`` as in :func:`segment_cylinder_lengths` (default: no floors).
    """
    p = np.asarray(paths, dtype=np.float64)
    if p.ndim != 3 or p.shape[2] != 3 or p.shape[1] < 1:
        raise InputError(f"paths must have shape (P, W, 3) with W >= 1; got {p.shape}")
    c, r, t, f = _check_cylinders(centers, radii, tops, floors)
    n_paths, n_points = p.shape[0], p.shape[1]
    seg0 = p[:, :-1, :].reshape(-1, 3)
    seg1 = p[:, 1:, :].reshape(-1, 3)
    per_segment = segment_cylinder_lengths(seg0, seg1, c, r, t, f)
    total = per_segment.reshape(n_paths, n_points - 1, c.shape[0]).sum(axis=1)
    return np.asarray(total, dtype=np.float64)


def points_in_cylinders(
    points: npt.ArrayLike,
    centers: npt.ArrayLike,
    radii: npt.ArrayLike,
    tops: npt.ArrayLike,
    floors: npt.ArrayLike | None = None,
) -> npt.NDArray[np.bool_]:
    """True where point n (of (N, 3)) is inside cylinder k (closed, as above), shape (N, K)."""
    q = np.asarray(points, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != 3:
        raise InputError(f"points must have shape (N, 3); got {q.shape}")
    c, r, t, f = _check_cylinders(centers, radii, tops, floors)
    wx = q[:, 0:1] - c[None, :, 0]
    wy = q[:, 1:2] - c[None, :, 1]
    z = q[:, 2:3]
    inside = (wx * wx + wy * wy <= (r * r)[None, :]) & (z <= t[None, :]) & (z >= f[None, :])
    return np.asarray(inside, dtype=np.bool_)
