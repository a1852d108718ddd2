"""Pure, vectorised building blocks of PSO-CA (seed 000, Krishnan & Manimala 2020).

Nothing here simulates or optimises: an avoider wires these pieces to the radar picture and to
``planner.optim``'s PSO, which minimises :class:`WaypointProblem` (a callable ``f(X (P, 2)) -> (P,)``
over the design variables ``p = (x_p, y_p)`` of eq 1, altitude constant) inside
:meth:`WaypointProblem.bounds`, seeded with :func:`tangent_seed_points` (eq 27, Fig. 14).

Coordinates are map metres (x east, y north; :mod:`replay.frames`).  The pieces:

- **Collision test** (§3.8, eqs 22-26): :func:`segment_sphere_intersections` /
  :func:`segment_hits_sphere`, restricted to the segment ``t in [0, 1]`` (the paper tests the
  infinite line), and :func:`segment_clearance` (closest approach of segments to centres).
- **Classification** (§3.7, Figs 8-10, §5.3): :func:`group_obstacles` (single linkage < 1 km,
  :func:`replay.threats.clusters.cluster_hill_points`), :func:`continuous_mask`, :func:`near_end_waypoint`,
  :func:`obstacle_between`, :func:`closest_first`.
- **Seeds** (eq 27, Fig. 14): :func:`tangent_points`, :func:`tangent_seed_points`.
- **Objective and constraints** (§2.3, eqs 2-12): :class:`PsoCaParams`, :class:`WaypointProblem`
  (``f1``, ``f2``, ``terms``, ``constraint_report``, penalised ``__call__``) and
  :func:`brute_force_waypoint`, the grid optimum an optimiser is measured against.

Choices where the paper is silent or inconsistent (see each docstring):

- **MXRSK = 3 km** (eqs 4-5 give no value): risk starts when the waypoint is within one
  ``tolerance`` + ``RS`` of another obstacle's safety sphere, i.e. other obstacles are kept one
  tolerance further off than the avoided one (g1 = 2 km), because no segment is tested against them.
- **g2 centred on the avoided obstacle** (eq 8 literally: ``|p - o| < searchspaceLimit``); the
  aircraft-centred reading (§6: "restricted ... with respect to the current UAV location") is
  ``g2_centre="aircraft"``.  Because the paper never tests the segment aircraft -> new waypoint,
  :class:`ConstraintReport` adds ``g5`` (that segment clears the safety sphere); it is part of the
  feasibility by default (``check_inbound=True``).
- **g3 on the segment**, not the infinite line of eq 9, reported as a signed clearance in metres.
- **g4 flyability**, not eq 11's "turn angle <= bank angle": the heading change ``theta`` at the
  new waypoint is flyable when the fly-by lead ``R tan(theta / 2)`` with
  ``R = V^2 / (g tan(phi_max))`` (eq 13) fits in the shorter of the two adjoining legs.
- **g5 for an aircraft already inside** the margin of a point: the leg may not get closer to it
  (otherwise no leg could start where the aircraft is).  **g6** (not in the paper): the side of
  the leg a moving intruder's heading imposes (§5.7).  ``check_outbound=False`` drops g3 for
  intruders (the next leg is flown when the intruder is elsewhere).  ``leg_margin`` adds a margin
  to RS in g3 and g5 (0 here, the paper; the avoider uses 100 m, see :mod:`replay.avoidance.pso_ca`).
- **Cut corners** (not in the paper): with ``switch_distance`` > 0 (the avoider passes the
  replay autopilot's 1 km), g5 also covers the path flown round the new waypoint and g3 the
  path round the target towards the waypoint ``after`` it (:func:`corner_cut`): the autopilot
  leaves a leg before its end and heads for the next leg's line at up to ``approach_deg``.
  g4 then also asks that the corner at the new waypoint fits in the leg onto the target: the
  aircraft meets that leg's line (:func:`corner_reach`) before the target's plane -- a waypoint
  600 m from the goal after a 99 deg turn had the aircraft still converging when it passed the
  goal's plane, 373 m off (seed 000 Table 6).  Asking more (back on the line before the target's
  own 1 km corner begins) left the narrow stage without a waypoint in Table 6's two-obstacle
  decision (tests/test_pso_ca.py); that corner starting off the line is left to the leg margin.
  Only for a stack that cuts its corners (``corner_fit``): one that flies turn fillets keeps the
  fly-by lead alone, its corners being arcs, not the switch-and-approach path.
- **f1 in metres** (eq 2 as printed; the paper does not normalise it).  ``normalise=True`` divides
  f1 by the straight distance aircraft -> next waypoint (the PLR of §6) and the risk sum by MXRSK.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt

from replay.threats.clusters import HILL_LINK_M, cluster_hill_points
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]
Seed = int | np.random.Generator | None

G = 9.81  # m/s^2, as in §3.5
RS_M = 1000.0  # radius of the safety sphere (Table 1)
TOLERANCE_M = 1000.0  # extra distance of g1 (Table 1)
SEARCH_LIMIT_M = 4000.0  # searchspaceLimit (Table 1)
MXRSK_M = 3000.0  # maximal risk distance: our choice, the paper gives none
NEAR_END_M = 1000.0  # Fig. 9 "safety distance (1 Km)"
_BIG = 1e9  # cap of a violation (m) so that penalised costs stay finite


# -- helpers ----------------------------------------------------------------------------------
def _points(a: npt.ArrayLike, name: str, dims: tuple[int, ...] = (2, 3)) -> FloatArray:
    """(..., D) float array with D in ``dims`` and finite values."""
    out = np.asarray(a, dtype=np.float64)
    if out.ndim < 1 or out.shape[-1] not in dims:
        raise InputError(f"{name} must have a last axis of size {dims}; got shape {out.shape}")
    if not np.isfinite(out).all():  # the method: no dispatch overhead (called every scan)
        raise InputError(f"{name} must be finite; got {out!r}")
    return out


def _xy(a: npt.ArrayLike, name: str) -> FloatArray:
    """The horizontal part (..., 2) of points given as (..., 2) or (..., 3)."""
    return _points(a, name)[..., :2]


def _rng(seed: Seed) -> np.random.Generator:
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


# -- 1. line-sphere collision test (eqs 22-26) --------------------------------------------------
@dataclass(frozen=True)
class SphereIntersections:
    """Segment ``p(t) = p0 + t (p1 - p0)``, ``t in [0, 1]``, against K spheres (one row each).

    ``discriminant`` is eq 26's ``b^2 - 4ac``; ``t_enter <= t_exit`` are the two roots of eq 24
    (NaN when the discriminant is negative); ``hit`` says whether the segment meets the closed
    ball: real roots (tangency counts, eq 26) and ``[t_enter, t_exit]`` overlapping ``[0, 1]``.
    A start inside the sphere has ``t_enter < 0 <= t_exit`` and is a hit.
    """

    hit: BoolArray
    t_enter: FloatArray
    t_exit: FloatArray
    discriminant: FloatArray


def segment_sphere_intersections(
    p0: npt.ArrayLike, p1: npt.ArrayLike, centers: npt.ArrayLike, radius: npt.ArrayLike
) -> SphereIntersections:
    """Eqs 22-26 for one segment p0 -> p1 ((D,), D = 2 or 3) and K centres (K, D).

    With ``d = p1 - p0`` the line of eq 22 is ``p0 + t d``; substituting it into the sphere of
    eq 23 gives ``a t^2 + b t + c = 0`` with (eq 25)
    ``a = |d|^2``, ``b = 2 d . (p0 - o)``, ``c = |o|^2 + |p0|^2 - 2 o . p0 - r^2 = |p0 - o|^2 - r^2``
    and roots ``t = (-b -+ sqrt(b^2 - 4ac)) / 2a`` (eq 24).  The paper decides collision on the
    sign of the discriminant alone (eq 26), i.e. for the infinite line; here the roots are also
    required to bracket part of ``[0, 1]`` so an obstacle behind the aircraft or beyond the next
    waypoint is not a hit.  A zero-length segment hits when its point is inside (``c <= 0``).
    ``radius`` is a scalar or (K,).
    """
    a0 = _points(p0, "p0")
    a1 = _points(p1, "p1")
    o = _points(centers, "centers").reshape(-1, a0.shape[-1])
    if a0.shape != a1.shape or a0.ndim != 1:
        raise InputError(
            f"p0 and p1 must be two points of the same size; got {a0.shape}, {a1.shape}"
        )
    r = np.broadcast_to(np.asarray(radius, dtype=np.float64), (len(o),))
    d = a1 - a0
    w = a0 - o  # (K, D)
    a = float(d @ d)
    b = 2.0 * (w @ d)
    c = np.einsum("kd,kd->k", w, w) - r**2
    disc = b * b - 4.0 * a * c
    if a == 0.0:
        inside = c <= 0.0
        nan = np.full(len(o), np.nan)
        return SphereIntersections(
            inside, np.where(inside, 0.0, nan), np.where(inside, 0.0, nan), disc
        )
    real = disc >= 0.0
    root = np.sqrt(np.where(real, disc, 0.0))
    t_in = np.where(real, (-b - root) / (2.0 * a), np.nan)
    t_out = np.where(real, (-b + root) / (2.0 * a), np.nan)
    hit = (
        real & (np.nan_to_num(t_in, nan=np.inf) <= 1.0) & (np.nan_to_num(t_out, nan=-np.inf) >= 0.0)
    )
    return SphereIntersections(hit, t_in, t_out, disc)


def segment_hits_sphere(
    p0: npt.ArrayLike, p1: npt.ArrayLike, centers: npt.ArrayLike, radius: npt.ArrayLike
) -> BoolArray:
    """Bool (K,): does the segment p0 -> p1 meet each safety sphere (eqs 22-26, Fig. 12
    ``collision_possibility``)?  See :func:`segment_sphere_intersections`."""
    return segment_sphere_intersections(p0, p1, centers, radius).hit


def segment_clearance(p0: npt.ArrayLike, p1: npt.ArrayLike, centers: npt.ArrayLike) -> FloatArray:
    """Closest distance (P, K) from each segment ``p0[i] -> p1[i]`` ((P, D) each) to each centre
    (K, D).  ``clearance > r`` is the same as "no real root of eq 24 in [0, 1]" (no hit)."""
    from replay.avoidance.pso_ca_kernel import segment_clearances

    a0 = _points(p0, "p0").reshape(-1, np.shape(p0)[-1])
    a1 = _points(p1, "p1").reshape(a0.shape)
    o = _points(centers, "centers").reshape(-1, a0.shape[-1])
    # s = clip(((o - a0) . d) / |d|^2, 0, 1), clearance = |o - a0 - s d|, d = a1 - a0; compiled,
    # on fresh writable C arrays (one numba specialisation for every caller)
    return np.asarray(
        segment_clearances(*(np.array(a, dtype=np.float64, order="C") for a in (a0, a1, o)))
    )


def _clearances(p0: FloatArray, p1: FloatArray, centers: FloatArray) -> FloatArray:
    """:func:`segment_clearance` of arrays already checked ((P, D), (P, D), (K, D)): the same
    compiled arithmetic without the checks, for :meth:`WaypointProblem.constraint_report`'s
    calls, several a decision (issue 38)."""
    from replay.avoidance.pso_ca_kernel import segment_clearances

    return np.asarray(
        segment_clearances(*(np.array(a, dtype=np.float64, order="C") for a in (p0, p1, centers)))
    )


# -- 2. grouping and classification (Figs 8-10, §5.3) ---------------------------------------------
def route_altitude(route: npt.ArrayLike, points: npt.ArrayLike) -> FloatArray:
    """The altitude (m) the polyline ``route`` (R, 3; R >= 1) has at the point nearest each of
    ``points`` (N, 2 or 3) horizontally: the altitude, linear along each leg, at the foot of the
    horizontal perpendicular (clamped to the leg; the nearest leg wins). How high the aircraft
    will be when it passes a terrain return, where it flies the route as planned."""
    r = _points(route, "route", (3,))
    p = _points(points, "points")[:, :2]
    if len(r) == 1:
        return np.full(len(p), float(r[0, 2]))
    a, b = r[:-1], r[1:]
    ab = b[:, :2] - a[:, :2]  # (S, 2)
    l2 = np.einsum("ij,ij->i", ab, ab)
    ap = p[:, None, :] - a[None, :, :2]  # (N, S, 2)
    u = np.clip(np.einsum("nsk,sk->ns", ap, ab) / np.maximum(l2, 1e-12), 0.0, 1.0)
    foot = a[None, :, :2] + u[..., None] * ab[None]
    d2 = np.sum((p[:, None, :] - foot) ** 2, axis=2)
    k = np.argmin(d2, axis=1)
    rows = np.arange(len(p))
    uk = u[rows, k]
    return np.asarray(a[k, 2] + uk * (b[k, 2] - a[k, 2]), dtype=np.float64)


def group_obstacles(points: npt.ArrayLike, link: float = HILL_LINK_M) -> tuple[IntArray, ...]:
    """Continuous obstacles (Fig. 8, §5.3): index arrays of points (N, 2 or 3) whose chains of
    distances are < ``link`` (1 km), via :func:`replay.threats.clusters.cluster_hill_points`.  2D points
    are grouped on the plane (z = 0)."""
    p = _points(points, "points").reshape(-1, np.shape(points)[-1])
    if p.shape[1] == 2:
        p = np.column_stack([p, np.zeros(len(p))])
    return cluster_hill_points(p, link)


def continuous_mask(points: npt.ArrayLike, link: float = HILL_LINK_M) -> BoolArray:
    """Bool (N,): Fig. 8 ``continuous_obstacle`` -- True for points in a group of two or more,
    False for single (scattered) obstacles."""
    groups = group_obstacles(points, link)
    n = sum(len(g) for g in groups)
    out = np.zeros(n, dtype=bool)
    for g in groups:
        out[g] = len(g) > 1
    return out


def near_end_waypoint(
    obstacles: npt.ArrayLike, waypoint: npt.ArrayLike, distance: float = NEAR_END_M
) -> BoolArray:
    """Fig. 9 ``near_end_waypoint``: horizontal distance obstacle -> ``X_fin`` below ``distance``
    (the paper's "safety distance (1 Km)", = RS).  Such a waypoint is skipped (Fig. 23): with the
    next waypoint inside a safety sphere, g3 cannot be met.  Obstacles (K, D) -> bool (K,)."""
    o = _xy(obstacles, "obstacles").reshape(-1, 2)
    w = _xy(waypoint, "waypoint").reshape(2)
    return np.asarray(np.hypot(*(o - w).T) < distance)


def obstacle_between(
    p_start: npt.ArrayLike,
    p_end: npt.ArrayLike,
    obstacles: npt.ArrayLike,
    *,
    along_track: bool = False,
) -> BoolArray:
    """Fig. 10 ``obs_bet_wps``: ``|X_fin - pos| > |obstacle - pos|`` (a range comparison, as in
    the paper, with ``p_start`` the aircraft position).  The paper's test also accepts obstacles
    behind the aircraft or far to the side; ``along_track=True`` further requires the obstacle's
    projection on the leg to fall strictly between its ends.  Obstacles (K, D) -> bool (K,)."""
    a = _xy(p_start, "p_start").reshape(2)
    b = _xy(p_end, "p_end").reshape(2)
    o = _xy(obstacles, "obstacles").reshape(-1, 2)
    d1 = math.hypot(*(b - a))
    d2 = np.hypot(*(o - a).T)
    out = d1 > d2
    if along_track:
        leg = b - a
        s = (o - a) @ leg / max(float(leg @ leg), 1e-300)
        out = out & (s > 0.0) & (s < 1.0)
    return np.asarray(out)


def closest_first(position: npt.ArrayLike, obstacles: npt.ArrayLike) -> IntArray:
    """Indices of obstacles (K, D) by increasing horizontal distance from ``position`` (stable):
    "for simultaneous view of many obstacles, the closest one is avoided first" (§5.3)."""
    p = _xy(position, "position").reshape(2)
    o = _xy(obstacles, "obstacles").reshape(-1, 2)
    return np.argsort(np.hypot(*(o - p).T), kind="stable").astype(np.int64)


# -- 3. seed points (eq 27, Fig. 14) ----------------------------------------------------------
def tangent_points(
    aircraft_xy: npt.ArrayLike, obstacle_xy: npt.ArrayLike, radius: float
) -> FloatArray:
    """The two tangent points (2, 2) from the aircraft to the circle (obstacle, ``radius``):
    row 0 on the left of the line of sight aircraft -> obstacle, row 1 on the right.

    Eq 27 with the aircraft at the origin and ``(x0, y0)`` the obstacle relative to it: a point
    ``T = o + r (cos t, sin t)`` is a tangent point when ``(T - o) . T = 0``, i.e.
    ``x0 cos t + y0 sin t = -r``, whose solutions are
    ``cos t = (-r x0 +- y0 s) / d^2``, ``sin t = (-r y0 -+ x0 s) / d^2`` with
    ``d^2 = x0^2 + y0^2``, ``s = sqrt(d^2 - r^2)`` -- eq 27 is the ``arccos`` of the first; its
    outer ``+-`` gives four angles of which only these two (paired signs) are tangent points.
    Raises :class:`InputError` when the aircraft is inside the circle (no tangent)."""
    a = _xy(aircraft_xy, "aircraft_xy").reshape(2)
    o = _xy(obstacle_xy, "obstacle_xy").reshape(2)
    pts = _tangents(float(a[0]), float(a[1]), float(o[0]), float(o[1]), radius)
    if pts is None:
        d = math.hypot(float(o[0] - a[0]), float(o[1] - a[1]))
        raise InputError(
            f"no tangent: the aircraft is {d:.1f} m from the obstacle, inside the "
            f"circle of radius {radius} m"
        )
    return pts


def _tangents(ax: float, ay: float, ox: float, oy: float, radius: float) -> FloatArray | None:
    """:func:`tangent_points` of checked coordinates, None inside the circle: eq 27 in scalars
    (a PSO-CA decision asks twice, where small numpy arrays cost more than the arithmetic; the
    same operations in the same order as the array form ``(-r x0 +- y0 s) / d^2``, so the same
    bits)."""
    x0, y0 = ox - ax, oy - ay
    d2 = x0 * x0 + y0 * y0
    if not (radius > 0.0) or d2 <= radius * radius:
        return None
    s = math.sqrt(d2 - radius * radius)
    p0x = ox + radius * ((-radius * x0 + y0 * s) / d2)
    p0y = oy + radius * ((-radius * y0 - x0 * s) / d2)
    p1x = ox + radius * ((-radius * x0 - y0 * s) / d2)
    p1y = oy + radius * ((-radius * y0 + x0 * s) / d2)
    left = x0 * (p0y - ay) - y0 * (p0x - ax) > 0.0  # cross(line of sight, T - aircraft) > 0
    return np.array([[p0x, p0y], [p1x, p1y]] if left else [[p1x, p1y], [p0x, p0y]])


def tangent_seed_points(
    aircraft_xy: npt.ArrayLike,
    obstacle_xy: npt.ArrayLike,
    safety_radius: float,
    n: int = 10,
    rng: Seed = None,
    *,
    spread: float = math.radians(20.0),
    radial_jitter: float = 0.1,
) -> FloatArray:
    """Fig. 14 ``Find_InitialNew_Waypoints``: n (>= 2) seed waypoints (n, 2) around the safety
    circle of radius ``safety_radius`` (pass RS + tolerance so the seeds satisfy g1).

    Rows 0 and 1 are the exact tangent points of eq 27 (:func:`tangent_points`, left then right);
    the others alternate left/right, at angle ``t_side + N(0, spread)`` on the circle and radius
    ``safety_radius * (1 + U(0, radial_jitter))`` -- on or just outside the circle, on both sides.
    When the aircraft is inside the circle there is no tangent; the two "tangent" angles are then
    taken perpendicular to the line of sight (±90° from the obstacle's bearing).
    """
    if n < 2:
        raise InputError(f"n must be >= 2 (one seed each side); got {n}")
    gen = _rng(rng)
    a = _xy(aircraft_xy, "aircraft_xy").reshape(2)
    o = _xy(obstacle_xy, "obstacle_xy").reshape(2)
    tp = _tangents(float(a[0]), float(a[1]), float(o[0]), float(o[1]), safety_radius)
    if tp is not None:
        base = np.arctan2(tp[:, 1] - o[1], tp[:, 0] - o[0])
    else:
        los = o - a
        bearing = math.atan2(los[1], los[0])
        base = np.array([bearing + math.pi / 2, bearing - math.pi / 2])
    k = np.arange(n)
    first = k < 2
    ang = base[k % 2] + np.where(first, 0.0, gen.normal(0.0, spread, n))
    rad = safety_radius * (1.0 + np.where(first, 0.0, gen.uniform(0.0, radial_jitter, n)))
    return np.asarray(o + rad[:, None] * np.column_stack([np.cos(ang), np.sin(ang)]))


# -- corner cutting ---------------------------------------------------------------------------
def corner_reach(
    w: FloatArray, u_in: FloatArray, u_next: FloatArray, switch: float, approach_deg: float
) -> tuple[FloatArray, FloatArray]:
    """Where the autopilot leaves the leg into waypoints ``w`` (P, 2) -- ``c1``, ``switch``
    metres before them, at most half the leg -- and how far along the next leg (metres from
    ``w``, P) it meets that leg's line at ``approach_deg`` (negative: before ``w``, on the line's
    extension; more than the next leg's length: it does not meet the leg before its end).
    :func:`corner_cut` draws the path; g4 asks that the corner fits in the next leg."""
    l_in = np.hypot(*np.asarray(u_in).T)
    l_nx = np.hypot(*np.asarray(u_next).T)
    e_in = u_in / np.where(l_in > 0, l_in, 1.0)[:, None]
    e_nx = u_next / np.where(l_nx > 0, l_nx, 1.0)[:, None]
    c1 = w - np.minimum(switch, 0.5 * l_in)[:, None] * e_in
    rel = c1 - w
    along = np.einsum("pd,pd->p", rel, e_nx)
    dd = np.abs(e_nx[:, 0] * rel[:, 1] - e_nx[:, 1] * rel[:, 0])
    return c1, along + dd / math.tan(math.radians(approach_deg))


def corner_cut(
    w: FloatArray, u_in: FloatArray, u_next: FloatArray, switch: float, approach_deg: float
) -> tuple[tuple[FloatArray, FloatArray], tuple[FloatArray, FloatArray]]:
    """The path the autopilot flies round waypoints ``w`` (P, 2), as two segments
    ``(c1 -> m, m -> w)`` of (P, 2) arrays each.

    The legs arrive along ``u_in`` (P, 2) and leave along ``u_next`` (P, 2) (any lengths: the
    leg vectors).  :mod:`replay.flight.fixedwing.autopilot` ends a leg ``switch`` metres before its waypoint (at
    most half the leg's length) at ``c1`` and from there follows the next leg's *line* with the
    vector field ``chi_leg - chi_inf (2/pi) atan(k DD)``: it heads for the line at up to
    ``approach_deg`` (``chi_inf``, 60 deg) and meets it at ``m``, the point reached at that angle
    from ``c1`` (the steepest approach) -- which may lie *before* ``w`` on the line's extension, so
    that with a small turn the aircraft first swings to the other side (measured: 10 m inside a
    safety sphere behind a waypoint 1.3 km from it).  The second segment ``m -> w`` is the part
    of the line flown before ``w`` (zero length, ``m -> m``, when ``m`` lies beyond ``w``).  The slower
    convergence of the last ~100 m of cross-track (the atan) is left to the leg margin."""
    c1, reach = corner_reach(w, u_in, u_next, switch, approach_deg)
    l_nx = np.hypot(*np.asarray(u_next).T)
    e_nx = u_next / np.where(l_nx > 0, l_nx, 1.0)[:, None]
    reach = np.minimum(reach, l_nx)
    m = w + reach[:, None] * e_nx
    back = np.where((reach < 0.0)[:, None], w, m)
    return (c1, m), (m, back)


# -- 4. objective and constraints (eqs 2-12) ----------------------------------------------------
@dataclass(frozen=True)
class PsoCaParams:
    """Constants of §2.3 / Table 1 (metres, degrees, m/s).  ``mxrsk``, ``g2_centre``,
    ``check_inbound``, ``normalise`` and the penalty are our choices (module docstring)."""

    rs: float = RS_M
    tolerance: float = TOLERANCE_M
    search_limit: float = SEARCH_LIMIT_M
    mxrsk: float = MXRSK_M
    wt: float = 0.1
    wo: float = 0.9
    max_bank_deg: float = 30.0
    speed: float = 15.0  # §2.1.1
    g2_centre: Literal["obstacle", "aircraft"] = "obstacle"
    check_inbound: bool = True
    check_outbound: bool = True
    normalise: bool = False
    leg_margin: float = 0.0
    switch_distance: float = 0.0
    approach_deg: float = 60.0
    # g4 asks that the cut corner fits in the leg onto the target (a stack that cuts corners at
    # its switch distance; one that flies fillets has the fly-by lead alone)
    corner_fit: bool = True
    penalty_offset: float = 1e12
    penalty_weight: float = 1e6  # per metre of violation

    def __post_init__(self) -> None:
        for name in ("rs", "search_limit", "mxrsk", "speed"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise InputError(f"PSO-CA {name} must be a positive number of metres; got {v!r}")
        if not (0 < self.approach_deg <= 90):
            raise InputError(f"PSO-CA approach_deg must be in (0, 90]; got {self.approach_deg!r}")
        if not (0 < self.max_bank_deg < 90):
            raise InputError(f"PSO-CA max_bank_deg must be in (0, 90); got {self.max_bank_deg!r}")
        if self.g2_centre not in ("obstacle", "aircraft"):
            raise InputError(
                f"PSO-CA g2_centre must be 'obstacle' or 'aircraft'; got {self.g2_centre!r}"
            )
        for name in ("tolerance", "wt", "wo", "leg_margin", "switch_distance"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise InputError(f"PSO-CA {name} must be a number >= 0; got {v!r}")
        if abs(self.wt + self.wo - 1.0) > 1e-9:
            raise InputError(
                f"PSO-CA weights must sum to 1 (eq 6: Wt + Wo = 1); got Wt = {self.wt!r}, "
                f"Wo = {self.wo!r}"
            )
        if self.rs + self.tolerance >= self.search_limit:
            raise InputError(
                f"PSO-CA search limit ({self.search_limit:g} m) must exceed the safety radius plus "
                f"the tolerance ({self.rs:g} + {self.tolerance:g} m): g1 and g2 leave no room"
            )

    @property
    def turn_radius(self) -> float:
        """Eq 13 solved for R at the maximum bank: ``R = V^2 / (g tan(phi_max))`` (39.7 m at
        15 m/s and 30°)."""
        return self.speed**2 / (G * math.tan(math.radians(self.max_bank_deg)))


@dataclass(frozen=True)
class ConstraintReport:
    """Per-candidate constraint values (P,), all in the form ``g >= 0`` is satisfied (metres):

    - ``g1 = min_k |p - o_k| - (RS + tolerance)`` (eq 7; min over the avoided group);
    - ``g2 = searchspaceLimit - min_k |p - o_k|`` (eq 8) or ``- |p - pos|`` (aircraft centre);
    - ``g3 = clearance(segment p -> X_fin, o_k) - (RS + leg_margin)`` (eqs 9-10 on the segment,
      min over k; ``leg_margin`` = 0 is the paper);
    - ``g4 = min(|p - pos|, |X_fin - p|) - R tan(theta / 2)`` (our reading of eq 11; ``theta`` is
      the heading change at p in radians, ``turn_angle``); with cut corners also at most
      ``|X_fin - p| - reach`` (:func:`corner_reach`);
    - ``g5 = clearance(segment pos -> p, o_k) - min(RS + leg_margin, |pos - o_k| - 1 m)`` (not in
      the paper; see the module docstring): an aircraft already inside the margin of a point
      (e.g. the nearest point of a large body) must fly a leg that does not get closer to it;
    - ``g6 = side * (signed distance of p left of the line pos -> X_fin)``: the side a moving
      intruder's heading imposes (§5.7: "if the obstacle is heading towards left, the UAV turns
      right"); ``+inf`` when the problem has no side (``side = 0``);
    - ``g7 = - (metres of the two new legs that break the world's validity)`` (not in the paper):
      off the map, over unknown terrain, inside a danger zone -- :class:`WaypointProblem`'s
      ``world`` (:mod:`terrain.validity`); 0 when the problem has none.

    ``feasible`` holds g1, g2, g4, g6 and g7, g3 unless ``check_outbound`` is off (a moving
    intruder: the next leg is flown later, when it is elsewhere) and g5 when ``check_inbound``;
    ``violation`` is the sum of the negative parts of the checked ones (capped at 1e9 m each).
    """

    g1: FloatArray
    g2: FloatArray
    g3: FloatArray
    g4: FloatArray
    g5: FloatArray
    g6: FloatArray
    turn_angle: FloatArray
    feasible: BoolArray
    violation: FloatArray
    g7: FloatArray


@dataclass(frozen=True)
class ObjectiveTerms:
    """Eqs 2, 5 and 6 per candidate (P,), and the penalised cost handed to the optimiser."""

    f1: FloatArray
    f2: FloatArray
    f: FloatArray
    penalised: FloatArray
    report: ConstraintReport


@dataclass(frozen=True)
class WaypointProblem:
    """One PSO-CA waypoint search (§2.3): minimise ``f = Wt f1 + Wo f2`` over ``p = (x_p, y_p)``
    subject to g1..g4.  ``position`` is the aircraft (x_pos, y_pos), ``target`` the next waypoint
    (x_fin, y_fin), ``avoided`` the obstacle being avoided (1, 2) or the (terminal) points of a
    continuous group (K, 2), ``others`` the other obstacles (M, 2) for the risk term f2.

    Calling the problem on X (P, 2) returns the penalised cost (P,):
    ``f + [infeasible] (penalty_offset + penalty_weight * violation)`` -- any infeasible point
    costs more than any feasible one (for f < penalty_offset), and the violation term still
    points an unconstrained minimiser towards feasibility."""

    position: FloatArray
    target: FloatArray
    avoided: FloatArray
    others: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    params: PsoCaParams = field(default_factory=PsoCaParams)
    side: int = 0  # +1: the waypoint must lie left of the leg pos -> target, -1: right, 0: either
    after: FloatArray | None = None  # the waypoint after the target (its corner is cut too)
    # g7: candidates (P, 2) -> metres (P,) of their two legs that break the world's validity
    world: Callable[[FloatArray], FloatArray] | None = field(default=None, compare=False)
    # the compiled kernels' constants (:meth:`__post_init__`)
    _consts: FloatArray = field(init=False, repr=False, compare=False)
    _cost_consts: FloatArray = field(init=False, repr=False, compare=False)
    _flags: IntArray = field(init=False, repr=False, compare=False)
    _after: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.side not in (-1, 0, 1):
            raise InputError(f"side must be -1 (right), 0 (either) or +1 (left); got {self.side!r}")
        object.__setattr__(self, "position", _xy(self.position, "position").reshape(2).copy())
        object.__setattr__(self, "target", _xy(self.target, "target").reshape(2).copy())
        avoided = _xy(self.avoided, "avoided").reshape(-1, 2).copy()
        if len(avoided) == 0:
            raise InputError("avoided must hold at least one obstacle")
        object.__setattr__(self, "avoided", avoided)
        others = np.asarray(self.others, dtype=np.float64)
        others = np.zeros((0, 2)) if others.size == 0 else _xy(others, "others").reshape(-1, 2)
        object.__setattr__(self, "others", others.copy())
        if self.after is not None:
            object.__setattr__(self, "after", _xy(self.after, "after").reshape(2).copy())
        # the compiled kernels' inputs, built once (a decision calls the problem some ten times)
        pr = self.params
        leg = self.target - self.position
        consts = np.array(
            [
                pr.rs,
                pr.tolerance,
                pr.search_limit,
                pr.mxrsk,
                pr.wt,
                pr.wo,
                pr.turn_radius,
                pr.leg_margin,
                pr.switch_distance,
                math.tan(math.radians(pr.approach_deg)),
                pr.penalty_offset,
                pr.penalty_weight,
                _BIG,
                max(math.hypot(*leg), 1e-9),  # report_geometry's g6 divisor, as the numpy one
            ]
        )
        flags = np.array(
            [
                pr.g2_centre == "obstacle",
                pr.check_inbound,
                pr.check_outbound,
                pr.normalise,
                self.side,
                self.after is not None,
                pr.corner_fit,
            ],
            dtype=np.int64,
        )
        object.__setattr__(self, "_consts", consts)
        object.__setattr__(self, "_cost_consts", consts[:13].copy())
        object.__setattr__(self, "_flags", flags)
        object.__setattr__(self, "_after", self.target if self.after is None else self.after)

    # eq 2
    def f1(self, X: npt.ArrayLike) -> FloatArray:
        """Eq 2: ``|p - pos| + |X_fin - p|`` (m), or divided by ``|X_fin - pos|`` when
        ``normalise`` (>= 1, the path-length ratio of §6)."""
        p = _xy(X, "X").reshape(-1, 2)
        out = np.hypot(*(p - self.position).T) + np.hypot(*(self.target - p).T)
        if self.params.normalise:
            out = out / max(math.hypot(*(self.target - self.position)), 1e-9)
        return np.asarray(out)

    # eqs 3-5
    def f2(self, X: npt.ArrayLike) -> FloatArray:
        """Eqs 3-5: ``(sum over others with dis^k < MXRSK of (MXRSK - dis^k))^2`` (m^2), with
        ``dis^k`` the horizontal distance to the k-th other obstacle (eq 3); the sum is divided by
        MXRSK before squaring when ``normalise``."""
        p = _xy(X, "X").reshape(-1, 2)
        if len(self.others) == 0:
            return np.zeros(len(p))
        dis = np.sqrt(((p[:, None, :] - self.others[None, :, :]) ** 2).sum(axis=-1))
        s = np.clip(self.params.mxrsk - dis, 0.0, None).sum(axis=1)
        if self.params.normalise:
            s = s / self.params.mxrsk
        return np.asarray(s**2)

    def _centre_distance(self, p: FloatArray) -> FloatArray:
        return np.asarray(np.sqrt(((p[:, None, :] - self.avoided[None]) ** 2).sum(-1)).min(axis=1))

    def constraint_report(self, X: npt.ArrayLike) -> ConstraintReport:
        """g1..g4 (eqs 7-12) and g5 per candidate; see :class:`ConstraintReport`.  The geometry
        (distances, clearances, cut corners) from a compiled loop
        (:func:`~replay.avoidance.pso_ca_kernel.report_geometry`, the operations of
        :meth:`constraint_report_numpy` in its order: the same bits), the turn's arccos and tan and
        the sums from numpy: a decision reports its waypoint, where some sixty small numpy calls
        cost a fifth of it (issue 38)."""
        from replay.avoidance.pso_ca_kernel import report_geometry

        pr = self.params
        p = np.array(_xy(X, "X").reshape(-1, 2), dtype=np.float64, order="C")
        geo = report_geometry(
            p, self.position, self.target, self._after, self.avoided, self._consts, self._flags
        )
        g1, g2, g3, g5, g6, cos_t, l_in, l_out, fit = geo  # rows: contiguous (9, P)
        theta = np.arccos(np.clip(cos_t, -1.0, 1.0))
        with np.errstate(over="ignore"):
            lead = pr.turn_radius * np.tan(np.minimum(theta, math.pi * (1 - 1e-12)) / 2.0)
        g4 = np.minimum(np.minimum(l_in, l_out) - lead, fit)
        g7 = -self._world(p)
        # the checked ones as rows of one array: the numpy version's sum and test over its list
        checked = np.vstack(
            [g1, g2, g4, g6, g7]
            + ([g3] if pr.check_outbound else [])
            + ([g5] if pr.check_inbound else [])
        )
        violation = np.sum(np.clip(-checked, 0.0, _BIG), axis=0)
        feasible = np.all(checked >= 0.0, axis=0)
        return ConstraintReport(
            g1,
            g2,
            g3,
            g4,
            g5,
            g6,
            theta,
            np.asarray(feasible),
            violation,
            np.asarray(g7),
        )

    def constraint_report_numpy(self, X: npt.ArrayLike) -> ConstraintReport:
        """:meth:`constraint_report` in numpy, one array operation per step: the reference the
        compiled version is checked against (``tests/test_pso_ca_geometry.py``: the same bits)."""
        pr = self.params
        p = _xy(X, "X").reshape(-1, 2)
        n = len(p)
        dist_obs = self._centre_distance(p)
        g1 = dist_obs - (pr.rs + pr.tolerance)
        if pr.g2_centre == "obstacle":
            g2 = pr.search_limit - dist_obs
        else:
            g2 = pr.search_limit - np.hypot(*(p - self.position).T)
        fin = np.broadcast_to(self.target, (n, 2))
        pos = np.broadcast_to(self.position, (n, 2))
        u_in = p - self.position
        g3 = _clearances(p, fin, self.avoided).min(axis=1) - (pr.rs + pr.leg_margin)
        # g5: an aircraft already closer than RS + margin to a point may not get any closer
        # (1 m slack): otherwise no leg could start where it is and it could not leave
        d0 = np.hypot(*(self.avoided - self.position).T)
        need = np.minimum(pr.rs + pr.leg_margin, d0 - 1.0)
        g5 = (_clearances(pos, p, self.avoided) - need[None, :]).min(axis=1)
        u_out = self.target - p
        l_in = np.hypot(*u_in.T)
        l_out = np.hypot(*u_out.T)
        sw = pr.switch_distance
        if sw > 0:
            # the corners the autopilot cuts (:func:`corner_cut`): the one at p belongs with the
            # inbound leg (g5), the one at X_fin (towards ``after``) with the outbound leg (g3)
            cut = corner_cut(p, u_in, u_out, sw, pr.approach_deg)
            for a, b in cut:
                g5 = np.minimum(g5, (_clearances(a, b, self.avoided) - need).min(axis=1))
            if self.after is not None:
                v = np.broadcast_to(self.after - self.target, (n, 2))
                cut = corner_cut(
                    np.broadcast_to(self.target, (n, 2)), u_out, v, sw, pr.approach_deg
                )
                for a, b in cut:
                    g3 = np.minimum(
                        g3,
                        _clearances(a, b, self.avoided).min(axis=1) - (pr.rs + pr.leg_margin),
                    )
        if self.side:
            leg = self.target - self.position
            g6 = (
                self.side
                * (leg[0] * u_in[:, 1] - leg[1] * u_in[:, 0])
                / max(math.hypot(*leg), 1e-9)
            )
        else:
            g6 = np.full(n, np.inf)
        denom = l_in * l_out
        cos_t = np.where(
            denom > 0, np.einsum("pd,pd->p", u_in, u_out) / np.where(denom > 0, denom, 1.0), 1.0
        )
        theta = np.arccos(np.clip(cos_t, -1.0, 1.0))
        with np.errstate(over="ignore"):
            lead = pr.turn_radius * np.tan(np.minimum(theta, math.pi * (1 - 1e-12)) / 2.0)
        g4 = np.minimum(l_in, l_out) - lead
        if sw > 0 and pr.corner_fit:
            # the cut corner at p fits in the leg onto the target: the aircraft is back on that
            # leg before the target's plane (a corner still converging there passes the goal's
            # plane off the track and misses it; an intermediate target's leg ends off it)
            _, reach = corner_reach(p, u_in, u_out, sw, pr.approach_deg)
            g4 = np.minimum(g4, l_out - reach)
        g7 = -self._world(p)
        checked = (
            [g1, g2, g4, g6, g7]
            + ([g3] if pr.check_outbound else [])
            + ([g5] if pr.check_inbound else [])
        )
        neg = [np.clip(-g, 0.0, _BIG) for g in checked]
        violation = np.sum(neg, axis=0)
        feasible = np.all([g >= 0.0 for g in checked], axis=0)
        return ConstraintReport(
            g1, g2, g3, g4, g5, g6, theta, np.asarray(feasible), violation, np.asarray(g7)
        )

    def _world(self, p: FloatArray) -> FloatArray:
        """Metres (P,) of each candidate's legs that break the world's validity (0: none)."""
        if self.world is None:
            return np.zeros(len(p))
        return np.asarray(self.world(p), dtype=np.float64).reshape(len(p))

    def terms(self, X: npt.ArrayLike) -> ObjectiveTerms:
        """Eq 6 ``f = Wt f1 + Wo f2`` with its parts, the constraints and the penalised cost."""
        f1 = self.f1(X)
        f2 = self.f2(X)
        f = self.params.wt * f1 + self.params.wo * f2
        rep = self.constraint_report(X)
        pen = np.where(
            rep.feasible,
            0.0,
            self.params.penalty_offset + self.params.penalty_weight * rep.violation,
        )
        return ObjectiveTerms(f1, f2, f, f + pen, rep)

    def __call__(self, X: npt.ArrayLike) -> FloatArray:
        """Penalised cost (P,) of candidates X (P, 2) -- the function a PSO minimises; the same
        numbers as ``terms(X).penalised`` from a compiled loop
        (:mod:`replay.avoidance.pso_ca_kernel`), about 100x faster for 10 candidates."""
        from replay.avoidance.pso_ca_kernel import penalised_costs

        pr = self.params
        # Always a fresh writable C array: an optimiser hands f a read-only view of its
        # population, a grid scan a writable array, and numba compiles one specialisation per
        # (layout, read-only) kind -- a second one costs ~3 s of JIT in the middle of a flight.
        p = np.array(_xy(X, "X").reshape(-1, 2), dtype=np.float64, order="C")
        # the fields are writable C copies already (__post_init__), the constants built there
        cost = np.asarray(
            penalised_costs(
                p,
                self.position,
                self.target,
                self._after,
                self.avoided,
                self.others,
                self._cost_consts,
                self._flags,
            )
        )
        if self.world is None:
            return cost
        # g7 outside the kernel: a candidate it alone makes infeasible gets the offset too
        # (any cost >= penalty_offset is infeasible already: f < penalty_offset, see above)
        v = np.clip(self._world(p), 0.0, _BIG)
        offset = np.where(cost >= pr.penalty_offset, 0.0, pr.penalty_offset)
        return np.asarray(cost + np.where(v > 0, offset + pr.penalty_weight * v, 0.0))

    def search_centres(self) -> FloatArray:
        """Centres (C, 2) of the g2 discs: the avoided obstacle(s) or the aircraft."""
        return self.avoided if self.params.g2_centre == "obstacle" else self.position[None, :]

    def bounds(self) -> tuple[FloatArray, FloatArray]:
        """Box (lower, upper) (2,) enclosing the g2 search zone -- the optimiser's bounds."""
        c = self.search_centres()
        lim = self.params.search_limit
        return c.min(axis=0) - lim, c.max(axis=0) + lim


# -- 5. brute force --------------------------------------------------------------------------
@dataclass(frozen=True)
class WaypointResult:
    """Best waypoint of a search: ``status`` is ``"feasible"`` or ``"infeasible"`` (no grid point
    met the constraints; ``xy`` is then the least-penalised one)."""

    xy: FloatArray
    f: float
    f1: float
    f2: float
    penalised: float
    status: Literal["feasible", "infeasible"]
    evaluations: int
    step: float


def search_grid(problem: WaypointProblem, step: float) -> FloatArray:
    """Grid points (G, 2) with spacing ``step`` over :meth:`WaypointProblem.bounds`, kept when
    inside the g2 search zone (the union of discs)."""
    if not (math.isfinite(step) and step > 0):
        raise InputError(f"step must be a positive number of metres; got {step!r}")
    lo, hi = problem.bounds()
    xs = np.arange(lo[0], hi[0] + 0.5 * step, step)
    ys = np.arange(lo[1], hi[1] + 0.5 * step, step)
    gx, gy = np.meshgrid(xs, ys, indexing="xy")
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    from scipy.spatial import cKDTree

    limit = problem.params.search_limit
    c = problem.search_centres()
    # the nearest centre of each point (a k-d tree: many centres, e.g. terrain returns); the
    # bound is only a pruning hint, the test is the exact distance
    d, _ = cKDTree(c).query(pts, k=1, distance_upper_bound=limit * (1.0 + 1e-9) + 1e-9)
    return np.asarray(pts[d <= limit])


def brute_force_waypoint(
    problem: WaypointProblem, step: float = 25.0, chunk: int = 65536
) -> WaypointResult:
    """Evaluate the same objective on every point of :func:`search_grid` and return the feasible
    point of least ``f`` (ties: first in grid order) -- the reference "best possible" an optimiser
    is compared with (its error is at most about ``step / sqrt(2)`` in position)."""
    pts = search_grid(problem, step)
    best: tuple[float, float, int, FloatArray, ObjectiveTerms] | None = None
    for start in range(0, len(pts), chunk):
        block = pts[start : start + chunk]
        t = problem.terms(block)
        key = np.where(t.report.feasible, t.f, np.inf)
        i = int(np.argmin(key)) if np.isfinite(key).any() else int(np.argmin(t.penalised))
        cand = (0.0 if np.isfinite(key[i]) else 1.0, float(t.penalised[i]), i, block, t)
        if best is None or cand[:2] < best[:2]:
            best = cand
    if best is None:
        raise InputError("the search grid is empty")
    flag, _, i, block, t = best
    return WaypointResult(
        xy=block[i].copy(),
        f=float(t.f[i]),
        f1=float(t.f1[i]),
        f2=float(t.f2[i]),
        penalised=float(t.penalised[i]),
        status="feasible" if flag == 0.0 else "infeasible",
        evaluations=len(pts),
        step=float(step),
    )
