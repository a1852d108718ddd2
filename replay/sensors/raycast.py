"""First-hit distances of rays against the threat shapes (the rangefinders' geometry).

Every function takes rays from one origin -- the origin of the coordinates, so callers pass the
shapes *relative to the sensor* (map metres minus the sensor's position: small numbers, no
cancellation at UTM magnitudes) -- as unit directions ``dirs`` (B, 3) (x east, y north, z up),
and returns the distance along each ray to the first point of each closed solid, ``inf`` where
the ray (s >= 0) never meets it and ``0`` where the origin is inside or on it.  Vectorised over
rays and shapes: the result is (B, K) for K shapes of a kind.

- :func:`ray_spheres` -- spheres (static threats, hill points, intruders at the scan's time):
  with ``p = d.c`` and ``cc = |c|^2 - r^2``, the first root ``p - sqrt(p^2 - cc)`` when
  ``cc > 0``, ``p > 0`` and ``p^2 >= cc``; 0 when ``cc <= 0``.
- :func:`ray_cylinders` -- solid vertical cylinders (side, top and bottom caps): the ray's
  interval inside the infinite cylinder (a quadratic in the horizontal components; all or
  nothing for a vertical ray) intersected with its interval in the slab ``[bottom, top]`` (all
  or nothing for a horizontal ray) and with ``s >= 0``; the hit is the interval's start.
- :func:`ray_prisms` -- solid vertical polygon prisms (buildings; any simple footprint, convex
  or not): within the slab interval ``[s0, s1]`` (as for the cylinder, ``s0 >= 0``) the hit is
  ``s0`` when the footprint contains the ray's horizontal point there (even-odd rule, every
  edge of the prism), else the first crossing of the ray's horizontal projection with an edge
  at ``s`` in ``[s0, s1]`` (2-D ray/segment intersection: ``s = (A x e) / (h x e)``, ``u = (A x
  h) / (h x e)`` for the edge ``A + u e``, ``u`` in [0, 1] with a 1e-12 tolerance so that a
  ray through a vertex is never lost).  A ray running along a wall meets the wall's ends through
  the neighbouring edges.  Between crossings the projection is wholly inside or wholly outside,
  so the first crossing is the entry into a concave footprint's notch as well as into its hull.
- :func:`ray_superellipsoid` -- seed 001's convex body ``Gamma(x) = sum |x_i / a_i|^(2 p_i) <=
  1``.  Along a ray Gamma is a sum of convex functions of s (every exponent 2 p_i >= 1), hence
  convex: ``{s : Gamma <= 1}`` is one interval.  The search works on ``log Gamma`` (log-sum-exp
  of ``2 p_i log |x_i / a_i|``: no overflow with exponents up to 100), which orders points as
  Gamma does: Gamma(0) <= 1 gives 0; else golden-section search for Gamma's minimum on
  ``[0, max_range]`` (45 iterations: the bracket shrinks to 4e-10 of the range; exact for a
  convex function, whose only plateau is its minimum), no hit when that minimum is > 1, else
  bisection of ``Gamma = 1`` on ``[0, s_min]``, where Gamma decreases (40 iterations: 1e-12 of
  the range).  Only rays that meet the body's bounding sphere (radius ``|axes|``) are searched.
  A ray that only grazes the surface (its minimum within the search's tolerance of 1) can be
  reported either way.
- :func:`ray_separation` -- any shape with a conservative signed distance (never more than the
  true one): sphere tracing, ``s += max(separation, step_min)`` until the separation is below
  ``tolerance`` (a hit) or s passes ``max_range``; a ray still marching after ``max_steps``
  (grazing a surface) is reported hit where it stands, the conservative answer.
- :func:`ray_flat_ground` -- the plane ``z = ground`` (0 m AMSL: the replay's ground without a
  terrain model).

The rays against the terrain mesh are :meth:`terrain.model.TerrainModel.raycast`'s.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numba as nb
import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

_EDGE_TOL = 1e-12  # edge parameter slack: a ray through a vertex meets one of its two edges
_GOLDEN_STEPS = 45  # 0.618^45 = 4e-10: the minimum's bracket as a fraction of the range
_BISECT_STEPS = 40  # 2^-40 = 9e-13: the root's bracket as a fraction of the range
_INV_PHI = (math.sqrt(5.0) - 1.0) / 2.0


def ray_spheres(dirs: FloatArray, centers: FloatArray, radii: FloatArray) -> FloatArray:
    """(B, K) first-hit distances of the rays against spheres (centres (K, 3) relative to the
    origin, radii (K,))."""
    c = np.asarray(centers, dtype=np.float64).reshape(-1, 3)
    r = np.asarray(radii, dtype=np.float64).reshape(-1)
    p = dirs @ c.T  # (B, K) projection of each centre on each ray
    cc = np.einsum("ij,ij->i", c, c) - r * r  # (K,) > 0 outside
    disc = p * p - cc
    with np.errstate(invalid="ignore"):
        s = p - np.sqrt(disc)
    hit = (p > 0.0) & (disc >= 0.0)
    return np.asarray(np.where(cc <= 0.0, 0.0, np.where(hit, s, np.inf)))


def slab_interval(
    dz: FloatArray, bottoms: FloatArray, tops: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """(s0, s1) (B, K): where the rays (vertical components ``dz`` (B,)) lie in the slabs
    ``bottoms <= z <= tops`` (K,) (relative; bottom -inf allowed); empty (s0 > s1) for a
    horizontal ray outside a slab.  Not clipped to s >= 0."""
    dzc = dz[:, None]
    flat = dzc == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        a = bottoms / np.where(flat, 1.0, dzc)
        b = tops / np.where(flat, 1.0, dzc)
    inside = (bottoms <= 0.0) & (0.0 <= tops)  # (K,) the origin's altitude within the slab
    s0 = np.where(flat, np.where(inside, -np.inf, np.inf), np.minimum(a, b))
    s1 = np.where(flat, np.where(inside, np.inf, -np.inf), np.maximum(a, b))
    return np.asarray(s0), np.asarray(s1)


def ray_cylinders(
    dirs: FloatArray,
    centers: FloatArray,
    radii: FloatArray,
    bottoms: FloatArray,
    tops: FloatArray,
) -> FloatArray:
    """(B, K) first-hit distances against solid vertical cylinders (centres (K, 2), radii,
    bottoms (-inf allowed) and tops (K,), relative to the origin)."""
    c = np.asarray(centers, dtype=np.float64).reshape(-1, 2)
    r = np.asarray(radii, dtype=np.float64).reshape(-1)
    h = dirs[:, :2]
    a = np.einsum("ij,ij->i", h, h)[:, None]  # (B, 1) squared horizontal speed
    p = h @ c.T  # (B, K)
    cc = np.einsum("ij,ij->i", c, c) - r * r  # (K,)
    disc = p * p - a * cc
    vertical = a == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        root = np.sqrt(disc)
        lo = (p - root) / np.where(vertical, 1.0, a)
        hi = (p + root) / np.where(vertical, 1.0, a)
    inside_axis = cc <= 0.0  # (K,) the origin's vertical line within the disc
    lo = np.where(vertical, np.where(inside_axis, -np.inf, np.inf), np.where(disc >= 0, lo, np.inf))
    hi = np.where(
        vertical, np.where(inside_axis, np.inf, -np.inf), np.where(disc >= 0, hi, -np.inf)
    )
    z0, z1 = slab_interval(dirs[:, 2], np.asarray(bottoms, float), np.asarray(tops, float))
    s0 = np.maximum(np.maximum(lo, z0), 0.0)
    s1 = np.minimum(hi, z1)
    return np.asarray(np.where(s0 <= s1, s0, np.inf))


def ray_prisms(
    dirs: FloatArray,
    edges: FloatArray,
    offsets: IntArray,
    bottoms: FloatArray,
    tops: FloatArray,
) -> FloatArray:
    """(B, K) first-hit distances against solid vertical prisms: the edges of every prism's
    footprint one after the other (E, 4) ``[x0, y0, x1, y1]`` (:func:`terrain.prisms.
    ring_edges`), prism k's edges ``offsets[k]:offsets[k + 1]`` (K + 1,), bottoms (-inf allowed)
    and tops (K,), all relative to the origin.  A compiled loop over beams, prisms and edges
    (:func:`_prisms_kernel`) with the arithmetic of :func:`ray_prisms_numpy`, which built
    (B, E) arrays of every beam against every edge."""
    e = np.ascontiguousarray(np.asarray(edges, dtype=np.float64).reshape(-1, 4))
    off = np.ascontiguousarray(offsets, dtype=np.int64)
    if len(off) - 1 <= 0:
        return np.zeros((len(dirs), 0))
    z0, z1 = slab_interval(dirs[:, 2], np.asarray(bottoms, float), np.asarray(tops, float))
    return _prisms_kernel(np.ascontiguousarray(dirs, dtype=np.float64), e, off, z0, z1)


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _prisms_kernel(dirs, e, off, z0, z1):  # pragma: no cover - jit
    """:func:`ray_prisms` given the slab intervals (B, K): per beam and prism, the first edge
    crossing in [s0, s1] (min over the prism's edges) unless the point at s0 is inside the
    footprint (even-odd count); inf for an empty slab."""
    nb_ = dirs.shape[0]
    k = off.shape[0] - 1
    out = np.empty((nb_, k))
    for b in range(nb_):
        hx, hy = dirs[b, 0], dirs[b, 1]
        for p in range(k):
            z = z0[b, p]
            s0 = z if (z >= 0.0 or z != z) else 0.0  # np.maximum(z0, 0.0)
            s1 = z1[b, p]
            empty = s0 > s1
            s_in = 0.0 if empty else s0
            qx, qy = s_in * hx, s_in * hy
            crossing = np.inf
            count = 0
            slack = s0 - 1e-9 * (1.0 + abs(s0))
            for j in range(off[p], off[p + 1]):
                ax, ay, bx, by = e[j, 0], e[j, 1], e[j, 2], e[j, 3]
                ex, ey = bx - ax, by - ay
                denom = hx * ey - hy * ex
                s = (ax * ey - ay * ex) / denom
                u = (ax * hy - ay * hx) / denom
                if (
                    denom != 0.0
                    and u >= -_EDGE_TOL
                    and u <= 1.0 + _EDGE_TOL
                    and s >= slack
                    and s <= s1
                ):
                    v = s if s >= s0 else s0  # np.maximum(s, s0) (s is a number here)
                    if not crossing <= v:  # np.minimum's fold
                        crossing = v
                if (ay > qy) != (by > qy):
                    xint = ax + (qy - ay) * (bx - ax) / (by - ay)
                    if qx < xint:
                        count += 1
            if empty:
                out[b, p] = np.inf
            elif count % 2 == 1:
                out[b, p] = s0
            else:
                out[b, p] = crossing
    return out


def ray_prisms_numpy(
    dirs: FloatArray,
    edges: FloatArray,
    offsets: IntArray,
    bottoms: FloatArray,
    tops: FloatArray,
) -> FloatArray:
    """:func:`ray_prisms` by numpy's (B, E) arrays: the tests' twin of the compiled loop."""
    e = np.asarray(edges, dtype=np.float64).reshape(-1, 4)
    off = np.asarray(offsets, dtype=np.int64)
    k = len(off) - 1
    if k <= 0:
        return np.zeros((len(dirs), 0))
    owner = np.repeat(np.arange(k), np.diff(off))  # (E,) the prism of each edge
    z0, z1 = slab_interval(dirs[:, 2], np.asarray(bottoms, float), np.asarray(tops, float))
    s0 = np.maximum(z0, 0.0)  # (B, K)
    empty = s0 > z1
    hx, hy = dirs[:, 0:1], dirs[:, 1:2]  # (B, 1)
    ax, ay = e[:, 0], e[:, 1]
    ex, ey = e[:, 2] - ax, e[:, 3] - ay
    # first crossing of the horizontal projection with an edge, at s in [s0, s1]
    denom = hx * ey - hy * ex  # (B, E): h x e
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        s = (ax * ey - ay * ex) / denom
        u = (ax * hy - ay * hx) / denom
    lo_e, hi_e = s0[:, owner], z1[:, owner]
    ok = (denom != 0.0) & (u >= -_EDGE_TOL) & (u <= 1.0 + _EDGE_TOL)
    with np.errstate(invalid="ignore"):  # an empty slab's s0 is inf
        ok &= (s >= lo_e - 1e-9 * (1.0 + np.abs(lo_e))) & (s <= hi_e)
    crossing = np.minimum.reduceat(np.where(ok, np.maximum(s, lo_e), np.inf), off[:-1], axis=1)
    # is the horizontal point at s0 inside the footprint? (even-odd over the prism's edges)
    s_in = np.where(empty, 0.0, s0)
    qx = (s_in * hx)[:, owner]  # (B, E) the point tested against each edge
    qy = (s_in * hy)[:, owner]
    x0, y0, x1, y1 = (e[:, j] for j in range(4))
    straddle = (y0 > qy) != (y1 > qy)
    with np.errstate(divide="ignore", invalid="ignore"):
        xint = x0 + (qy - y0) * (x1 - x0) / (y1 - y0)
    count = np.add.reduceat((straddle & (qx < xint)).astype(np.int64), off[:-1], axis=1)
    inside = count % 2 == 1
    out = np.where(inside, s0, crossing)
    return np.asarray(np.where(empty, np.inf, out))


def _log_gamma(x: FloatArray, axes: FloatArray, powers: FloatArray) -> FloatArray:
    """log Gamma at points x (..., 3) relative to the body's centre (-inf at the centre)."""
    with np.errstate(divide="ignore"):
        terms = powers * np.log(np.abs(x) / axes)
    top = terms.max(axis=-1)
    finite = np.isfinite(top)
    safe = np.where(finite, top, 0.0)
    with np.errstate(invalid="ignore"):
        total = np.exp(terms - safe[..., None]).sum(axis=-1)
    return np.asarray(np.where(finite, safe + np.log(total), top))


def ray_superellipsoid(
    dirs: FloatArray,
    center: FloatArray,
    axes: FloatArray,
    powers: FloatArray,
    max_range: float,
) -> FloatArray:
    """(B,) first-hit distances (within ``max_range``; inf beyond) against one convex
    superellipsoid: centre (3,) relative to the origin, semi-axes (3,), powers (3,) = 2 x the
    exponents (each >= 1).  Method in the module docstring."""
    c = np.asarray(center, dtype=np.float64)
    ax = np.asarray(axes, dtype=np.float64)
    pw = np.asarray(powers, dtype=np.float64)
    out = np.full(len(dirs), np.inf)
    bound = ray_spheres(dirs, c[None, :], np.array([float(np.linalg.norm(ax))]))[:, 0]
    rows = np.flatnonzero(bound <= max_range)
    if not rows.size:
        return out
    d = dirs[rows]

    def f(s: FloatArray) -> FloatArray:
        return _log_gamma(s[:, None] * d - c, ax, pw)

    zero = np.zeros(len(rows))
    inside = f(zero) <= 0.0
    lo, hi = zero.copy(), np.full(len(rows), float(max_range))
    m1 = hi - _INV_PHI * (hi - lo)
    m2 = lo + _INV_PHI * (hi - lo)
    f1, f2 = f(m1), f(m2)
    for _ in range(_GOLDEN_STEPS):
        left = f1 <= f2  # the minimum lies in [lo, m2]
        hi = np.where(left, m2, hi)
        lo = np.where(left, lo, m1)
        new = np.where(left, hi - _INV_PHI * (hi - lo), lo + _INV_PHI * (hi - lo))
        fn = f(new)
        m1, m2 = np.where(left, new, m2), np.where(left, m1, new)
        f1, f2 = np.where(left, fn, f2), np.where(left, f1, fn)
    s_min = np.where(f1 <= f2, m1, m2)
    reach = np.minimum(f1, f2) <= 0.0
    a, b = zero.copy(), s_min.copy()  # Gamma(a) > 1 >= Gamma(b) where reached
    for _ in range(_BISECT_STEPS):
        mid = 0.5 * (a + b)
        below = f(mid) <= 0.0
        b = np.where(below, mid, b)
        a = np.where(below, a, mid)
    out[rows] = np.where(inside, 0.0, np.where(reach, b, np.inf))
    return out


def ray_separation(
    dirs: FloatArray,
    separation: Callable[[FloatArray], FloatArray],
    max_range: float,
    *,
    tolerance: float = 1e-6,
    step_min: float = 1e-6,
    max_steps: int = 512,
) -> FloatArray:
    """(B,) first-hit distances (within ``max_range``) against a shape given by a conservative
    signed distance ``separation(points (N, 3)) -> (N,)`` (points relative to the origin), by
    sphere tracing (module docstring)."""
    s = np.zeros(len(dirs))
    out = np.full(len(dirs), np.inf)
    live = np.arange(len(dirs))
    for _ in range(max_steps):
        if not live.size:
            return out
        sep = np.asarray(separation(s[live, None] * dirs[live]), dtype=np.float64)
        hit = sep <= tolerance
        out[live[hit]] = s[live[hit]]
        s[live] += np.maximum(sep, step_min)
        live = live[~hit & (s[live] <= max_range)]
    out[live] = s[live]  # still marching along a surface: hit where it stands
    return out


def ray_flat_ground(dirs: FloatArray, height: float) -> FloatArray:
    """(B,) distances from an origin ``height`` metres above a horizontal ground plane to the
    plane along the rays (0 at or below it; inf for rays that do not point down)."""
    dz = dirs[:, 2]
    if height <= 0.0:
        return np.zeros(len(dirs))
    with np.errstate(divide="ignore"):
        return np.asarray(np.where(dz < 0.0, height / -dz, np.inf))
