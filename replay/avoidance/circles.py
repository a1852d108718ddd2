"""Horizontal circles fitted to sampled obstacle points (seed 001 §2.1, eqs 1-2, corrected).

CTGA (seed 001) models an obstacle by a circle fitted to the points the sensors sampled on it
("an obstacle circle is fitted which can cover the whole or key parts of the obstacle").  Its eqs 1-2:

    R = 1/2 max_{i<j} |p_i - p_j|                                   (1)
    [o_x, o_y] = 1/2 [x_i,idx - x_j,idx, y_i,idx - y_j,idx]         (2)

take the farthest pair of points as a diameter.  Two errors:

1. **Eq 2 as printed is half the difference** of the farthest pair, a vector, not a point: the
   centre the text describes is their midpoint, ``(p_i + p_j) / 2``.
   :func:`farthest_pair_circle` is eqs 1-2 with this correction.
2. **Even corrected, the farthest-pair circle need not enclose the points**, so an avoider that
   keeps its safety distance from this circle can cross the obstacle.  For an equilateral triangle
   of side s the farthest pair is any side: a circle of radius s/2 about that side's midpoint,
   which the third vertex, at the triangle's height ``s sqrt(3)/2`` from it, lies
   ``s (sqrt(3) - 1)/2 = 0.37 s`` outside of.  The smallest circle containing the three vertices
   is the one through them, of radius ``s/sqrt(3)``: the paper's radius is
   ``1 - sqrt(3)/2 = 13.4 %`` too small.

The correction is the **minimum enclosing circle** (:func:`min_enclosing_circle`): the smallest
circle containing every point, unique, and always determined by two points on its boundary that
are diametrically opposite or by three on its boundary whose triangle contains the centre (acute
or right).  It equals the farthest-pair circle whenever that one encloses the points (two
points, collinear points, a rectangle: no enclosing circle has a diameter shorter than the
farthest pair), and it is computed exactly by Welzl's algorithm (E. Welzl, "Smallest enclosing disks
(balls and ellipsoids)", 1991) in its iterative form: points in random order (expected linear time;
the order only changes the running time, never the circle), each "is a point outside the current
circle" search vectorised over the remaining points.  Coordinates are shifted to the first point
before the arithmetic, so map coordinates of ~1e6 m lose no precision.  "Outside" means farther
than the radius plus 1e-10 of the points' extent (rounding slack), so a point may lie outside the
returned circle by at most that much (1e-7 m for a 1 km obstacle).

:func:`cone_outline` draws a recorded collision cone (FGA's) and its protected circle, for the
recorder and ``terrapath view`` alike.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]

_TOL = 1e-10  # relative to the points' extent: "inside" and "on the boundary" slack


@dataclass(frozen=True, eq=False)
class Circle:
    """A horizontal circle (map metres): ``center`` (2,), ``radius`` and ``support``, the indices
    (into the points it was fitted to) of the points on its boundary that determine it: one (all
    points coincide), two (a diameter) or three (their triangle contains the centre)."""

    center: FloatArray
    radius: float
    support: IntArray

    def distance(self, points: npt.ArrayLike) -> FloatArray:
        """Horizontal distance (N,) of points (N, 2 or 3) from the centre."""
        p = _xy(points, "points")
        return np.asarray(np.hypot(p[:, 0] - self.center[0], p[:, 1] - self.center[1]))

    def contains(self, points: npt.ArrayLike, tol: float = 1e-6) -> BoolArray:
        """Bool (N,): the point lies inside or on the circle, within ``tol`` metres."""
        return np.asarray(self.distance(points) <= self.radius + tol)


def cone_outline(
    cone: Mapping[str, Any], apex: npt.ArrayLike, segments: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The outline of a recorded collision cone (FGA's decision ``cones``: ``los_deg``,
    ``half_angle_deg``, ``range_m``, ``keep_m``) from ``apex`` (3,), in its horizontal plane:
    the ends of its two edges (each tangent to the protected circle) and that circle, closed,
    ``segments + 1`` points about the obstacle's centre at ``range_m`` along the line of sight."""
    here = np.asarray(apex, dtype=np.float64)
    los = math.radians(float(cone["los_deg"]))
    half = math.radians(float(cone["half_angle_deg"]))
    rng, keep = float(cone["range_m"]), float(cone["keep_m"])
    length = math.sqrt(max(rng * rng - keep * keep, 0.0))
    a_end, b_end = (
        here + length * np.array([math.sin(e), math.cos(e), 0.0]) for e in (los - half, los + half)
    )
    a = np.linspace(0.0, 2.0 * math.pi, segments + 1)
    centre = here + rng * np.array([math.sin(los), math.cos(los), 0.0])
    ring = centre + np.column_stack([keep * np.sin(a), keep * np.cos(a), np.zeros(len(a))])
    return a_end, b_end, ring


def _xy(points: npt.ArrayLike, name: str) -> FloatArray:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] not in (2, 3):
        raise InputError(f"{name} must be an array (N, 2) or (N, 3); got shape {p.shape}")
    if not np.isfinite(p).all():
        raise InputError(f"{name} must be finite numbers")
    if len(p) == 0:
        raise InputError(f"{name}: a circle needs at least one point")
    return p[:, :2]


def farthest_pair_circle(points: npt.ArrayLike) -> Circle:
    """Seed 001 eqs 1-2 with eq 2's centre corrected to the midpoint (module docstring): the
    circle whose diameter is the farthest pair of points (N, 2 or 3).  It may leave points
    outside (the equilateral triangle: radius s/2 instead of s/sqrt(3)).  O(N^2) distances."""
    p = _xy(points, "points")
    if len(p) == 1:
        return Circle(p[0].copy(), 0.0, np.array([0], dtype=np.int64))
    d2 = ((p[:, None, :] - p[None, :, :]) ** 2).sum(axis=-1)
    i, j = np.unravel_index(int(np.argmax(d2)), d2.shape)
    centre = (p[i] + p[j]) / 2.0
    radius = float(np.hypot(*(p[i] - p[j]))) / 2.0
    return Circle(centre, radius, np.array(sorted((i, j)), dtype=np.int64))


def min_enclosing_circle(points: npt.ArrayLike, seed: int | np.random.Generator = 0) -> Circle:
    """The smallest circle containing every point (N, 2 or 3; the horizontal part is used), by
    Welzl's algorithm (module docstring).  ``seed`` only orders the points: the circle is the same
    for every seed (to rounding), so the default fixed seed keeps results reproducible.
    Duplicated points are harmless.  The result's ``support`` is canonical: two points on a
    diameter, or three whose triangle contains the centre."""
    p = _xy(points, "points")
    origin = p[0].copy()
    if len(p) == 1:
        return Circle(origin, 0.0, np.array([0], dtype=np.int64))
    local = p - origin
    # the distinct points in lexicographic (x, y) order, as np.unique(axis=0) gives them, by a
    # one-dimensional unique of x + iy (complex numbers sort by real, then imaginary part)
    _, first = np.unique(local[:, 0] + 1j * local[:, 1], return_index=True)
    uniq = local[first]
    if len(uniq) == 1:
        return Circle(origin, 0.0, np.array([0], dtype=np.int64))
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    perm = rng.permutation(len(uniq))
    q = uniq[perm]
    index = first[perm].astype(np.int64)
    tol = _TOL * float(np.abs(q).max())
    c, r, sup = _welzl(q, tol)
    if len(sup) == 3 and not _contains_centre(q[sup], c, tol):
        sup = _canonical_support(q, c, r, sup, tol)
    return Circle(c + origin, float(r), np.sort(index[sup]))


# -- Welzl's algorithm, iterative, with vectorised violator searches -------------------------------
def _next_outside(q: FloatArray, start: int, stop: int, c: FloatArray, r: float, tol: float) -> int:
    """First index in [start, stop) of a point outside the circle (c, r + tol), or -1."""
    if start >= stop:
        return -1
    d = q[start:stop] - c
    out = np.einsum("ij,ij->i", d, d) > (r + tol) ** 2
    k = int(np.argmax(out))
    return start + k if out[k] else -1


def _circumcircle(q: FloatArray, i: int, j: int, k: int) -> tuple[FloatArray, float, list[int]]:
    """Circle through q[i], q[j], q[k]; for (numerically) collinear points the circle on the
    farthest pair of the three."""
    a, b, c = q[i], q[j], q[k]
    ba, ca = b - a, c - a
    d = 2.0 * (ba[0] * ca[1] - ba[1] * ca[0])
    scale = max(float(ba @ ba), float(ca @ ca))
    if abs(d) <= 1e-12 * scale:
        pairs = [(i, j), (i, k), (j, k)]
        lens = [float(np.sum((q[m] - q[n]) ** 2)) for m, n in pairs]
        m, n = pairs[int(np.argmax(lens))]
        return (q[m] + q[n]) / 2.0, math.sqrt(max(lens)) / 2.0, [m, n]
    b2, c2 = float(ba @ ba), float(ca @ ca)
    u = np.array([ca[1] * b2 - ba[1] * c2, ba[0] * c2 - ca[0] * b2]) / d
    centre = a + u
    return centre, float(max(np.hypot(*(q[[i, j, k]] - centre).T))), [i, j, k]


def _with_two(q: FloatArray, i: int, j: int, tol: float) -> tuple[FloatArray, float, list[int]]:
    """Smallest circle through q[i] and q[j] containing q[:j]."""
    c = (q[i] + q[j]) / 2.0
    r = float(np.hypot(*(q[i] - q[j]))) / 2.0
    sup = [i, j]
    k = _next_outside(q, 0, j, c, r, tol)
    while k >= 0:
        c, r, sup = _circumcircle(q, i, j, k)
        k = _next_outside(q, k + 1, j, c, r, tol)
    return c, r, sup


def _with_one(q: FloatArray, i: int, tol: float) -> tuple[FloatArray, float, list[int]]:
    """Smallest circle through q[i] containing q[:i]."""
    c, r, sup = q[i].copy(), 0.0, [i]
    j = _next_outside(q, 0, i, c, r, tol)
    while j >= 0:
        c, r, sup = _with_two(q, i, j, tol)
        j = _next_outside(q, j + 1, i, c, r, tol)
    return c, r, sup


def _welzl(q: FloatArray, tol: float) -> tuple[FloatArray, float, list[int]]:
    c, r, sup = q[0].copy(), 0.0, [0]
    i = _next_outside(q, 1, len(q), c, r, tol)
    while i >= 0:
        c, r, sup = _with_one(q, i, tol)
        i = _next_outside(q, i + 1, len(q), c, r, tol)
    return c, r, sup


def _contains_centre(tri: FloatArray, c: FloatArray, tol: float) -> bool:
    """The triangle (3, 2) contains c (within tol): no angle is obtuse."""
    for k in range(3):
        a, b, o = tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]
        if float((a - o) @ (b - o)) < -tol * (1.0 + float(np.abs(tri).max())):
            return False
    return True


def _canonical_support(
    q: FloatArray, c: FloatArray, r: float, sup: list[int], tol: float
) -> list[int]:
    """With four or more points on the boundary Welzl may end on an obtuse triple that is not
    what makes the circle minimal; pick a diameter pair or a triple around the centre among the
    boundary points instead.  Sorted by angle from the centre, take the first point a and the
    two neighbours b (last before a + pi) and d (first after): arcs a -> b and d -> a are < pi
    by construction and b -> d is at most the largest gap, which is <= pi for a minimal circle."""
    dist = np.hypot(*(q - c).T)
    on = np.flatnonzero(np.abs(dist - r) <= 10.0 * tol + 1e-9 * r)
    ang = np.arctan2(q[on, 1] - c[1], q[on, 0] - c[0])
    order = np.argsort(ang, kind="stable")
    on, ang = on[order], ang[order]
    rel = ang - ang[0]
    eps = 1e-9
    opposite = np.flatnonzero(np.abs(rel - math.pi) <= eps)
    if opposite.size:
        return [int(on[0]), int(on[opposite[0]])]
    below = np.flatnonzero(rel < math.pi)
    above = np.flatnonzero(rel > math.pi)
    if below.size < 2 or not above.size:
        return sup
    b, d = int(below[-1]), int(above[0])
    if abs(rel[d] - rel[b] - math.pi) <= eps:
        return [int(on[b]), int(on[d])]
    return [int(on[0]), int(on[b]), int(on[d])]
