"""FGA: the flexible geometric avoider with a critical start time (seed 004, Lin, Castano & Xu),
``--avoid fga``.

Map frame throughout: x east, y north, z up (m); courses clockwise from north (rad).  The
aircraft flies FGA's manoeuvres with its own closed-loop course and altitude holds
(:class:`~replay.guidance.HoldCourse`), so every turn is the 6-DOF aircraft's, at its bank limit
at most, and every climb within its climb-rate limits.

**Obstacles and the protected volume (§II-B, Table I).**  Each obstacle is read from
:mod:`replay.avoidance.perception` once per scan and dead-reckoned at every decision: a centre, a
velocity, a horizontal size ``a`` and a vertical extent ``[bottom, top]``.  With the cooperative
sensor (the paper's "perfect sensor", §II-C (3)) the size is the reported one: a cylinder
(reported at its top-face centre, ``top`` = its z) stands on the ground (``bottom = -inf``); a
sphere, an intruder or a convex body (``top`` above its centre) reaches as far below its centre
as above.  With the radar: a stationary body is the circle of its returns plus ``point_radius``
for point returns, its top unknown (never flown over); a track has ``moving_radius``; a sphere
the radar measures (a ``solid`` threat) has its measured centre and radius, as reported.  The paper
protects a sphere of radius ``d_m`` and manoeuvres in two planes with separate horizontal and
vertical separations ``d_m,h`` and ``d_m,v`` (§III-B1): the protected volume here is their
product, the vertical cylinder of radius ``a + d_m`` from ``bottom - d_m`` to ``top + d_m`` -- for
a cylinder the exact ``d_m``-neighbourhood (without its rounded edges), for a sphere a volume
that contains its protected sphere, so keeping out of it keeps every separation >= ``d_m``.

**Collision cones (eq 1).**  The horizontal cone of an obstacle at range ``r`` has the exact
tangent half-angle ``asin(a_k / r)`` (``a_k`` the keep radius below; eq 1's ``atan`` and step 8's
``d_m / r`` are its small-angle forms).  The relative velocity is the aircraft's with respect to
the obstacle, ``V_r = V_u - V_a`` (the paper prints ``V_a - V_u``, with which every closing
threat gets ``t_c < 0``), against the line of sight aircraft -> obstacle ``r``: ``r cos theta``
is the along-track distance to the closest point of approach, ``r |sin theta|`` the miss
distance.  A *conflict* is a future time (within ``horizon_s``) at which the aircraft is inside
the horizontal cylinder *and* inside the vertical interval (the vertical cone's edges are the
interval's ends): both 2-D cones contain the relative motion over a common window.  Obstacles
are looked at within the surveillance radius ``R`` (``surveillance_m``, by default ``10 d_m`` as
§II-C (4) sets it: 300 m for Table II's 30 m), measured from their surface; one
already inside its protected volume when first seen is recorded "already violated" and escaped
from (the free heading that opens the separation fastest), never raised.

**Hysteresis.**  A conflict is called against the keep radius ``a + d_m + buffer_m`` (and
``buffer_m`` above and below); the manoeuvres steer to ``a + d_m + 2 buffer_m``: once on that
edge the aircraft is outside the calling threshold, so holding the new heading does not call the
same conflict again (chattering).  ``buffer_m`` (3 m) absorbs the controller's tracking error.

**Classification (§III-A).**  Single or multiple by the number of obstacles in conflict, static
or dynamic by their speed (> 0.5 m/s: dynamic); recorded with each decision.  The geometry is
the same for both: a static obstacle's tangent course is the closed form ``LOS +- asin(a_k/r)``,
a moving one's the root of a quadratic (:func:`tangent_course`).

**Heading or pitch (§III-B1).**  The paper names a cost but gives no formula.  Here the cost of
a manoeuvre is the time it needs to bring the relative motion out of the protected volume at
the aircraft's limits:

- heading: ``t_res + |Delta psi| / psi_dot_max``, ``Delta psi`` the smallest course change to a
  course outside the union of the horizontal cones of every obstacle within ``R``
  (candidates: each cone's two tangent courses and a 5 deg fan round the course), ``psi_dot_max
  = g tan(bank_max) / V``;
- pitch: the time to gain (or lose) ``Delta h`` at the autopilot's climb (descent) limit ``c``,
  its climb-rate command slewed at 1 m/s^2 (``Delta h / c + c / 2``, or ``sqrt(2 Delta h)`` for
  a small ``Delta h``), ``Delta h`` the height that puts the aircraft ``2 buffer_m`` beyond the
  vertical interval of every conflicting obstacle over its horizontal window --
  feasible only when it is done before the first horizontal entry, the course unchanged stays
  outside the other obstacles' volumes, and (descending) the aircraft stays ``floor_m`` above the
  ground.

The cheaper feasible one is flown (ties: heading).  Pitch wins where the vertical offset is
already most of the way there (Table VIII cases 5 and 6): an obstacle above is passed *below*
(pitch down), one below *above* -- the paper's "pitch up" for obstacles above (case 6) would
climb through their altitude.

**Critical start time (eqs 7-9).**  For the heading manoeuvre ``t_ci = (r cos theta - rho -
(a_k - r |sin theta|)) / |V_r|`` in the horizontal plane, ``rho`` the aircraft's minimum turn
radius ``V^2 / (g tan bank_max)`` -- eq 7 with ``a_k`` for ``d_m`` (an obstacle with extent is
kept ``d_m`` from its surface) and ``rho`` taken in the relative frame (:func:`encounter`); and
never later than the entry into the protected volume less the turn's time, which eq 7 --
written for obstacles small against the turn -- passes for a large one.  For the pitch
manoeuvre: the latest start from which a climb (descent) at the limit clears the interval by
the first horizontal entry.  ``t_k = t_c - t_res`` (eq 8); with several obstacles ``t_c = min
t_ci`` (eq 9).  When ``t_k`` is within ``LATE_WINDOW_S`` (10 s) the heading manoeuvre is also
flown kinematically from one decision later (:meth:`FgaAvoider._late_by`); if that would pass an
obstacle closer than ``d_m + buffer_m / 2`` it starts now.  ``t_res`` is not given by the paper:
measured on the 6-DOF ``seed004-uas`` (:func:`measure_turn`, ``tests/test_fga.py``) a course
step of 30 to 170 deg takes 0.34-0.51 s longer than an ideal vehicle turning at
``psi_dot_max`` from the start (roll-in); the default is 0.5 s.  While ``t_k`` is more than one
decision period away FGA waits on the mission (recording the plan once); at ``t_k`` it starts.

**Urgent and not urgent (step 5).**  When it starts, the obstacles with ``t_ki <= period`` (one
decision period, 0.1 s) are ``M1``, the rest ``M2``.  The manoeuvre is chosen for ``M1`` and
must not enter the volume of any obstacle within ``R`` (``M2`` included): a course outside the
union of all cones; only when none exists is ``M1`` resolved alone (``M2`` is met again on the
next decisions: steps 1-5 repeat at every decision).

**Map and zones** (not in the paper; issue 34).  A heading manoeuvre's course is held until the
obstacle passes: with a map or danger zones (the context's validity), each free course is
followed for ``R`` and the metres of it off the map or in a zone counted; a course with none is
taken before any with some (still the smallest change among them).  When every free course has
some, there is no safe manoeuvre: the least is flown and the decision says so (``no safe
course`` in its reason, ``costs.unsafe_m``).

**Steering and holding (steps 6-9).**  Heading: the course on the chosen side's cone edge is
re-computed every decision (the edge moves while the aircraft turns) until the aircraft flies it
(``|theta_t - theta_dm| < 0.01`` rad, step 8, checked as the course error); it is then *held*:
on a straight relative path the miss distance does not change.  Pitch: the course is kept and
the altitude commanded ``buffer_m`` beyond the interval.  The manoeuvre ends when the obstacle
it steers round (a climb: every obstacle it climbs over) has passed its closest point of approach
(range rate > 0 on the held course or on the way back; or, a slow encounter, that approach is
more than ``SLOW_CPA_S`` (20 s) off on the held course: holding would only put it off) and the
way back is clear:
the turn onto the direct leg to the return waypoint, flown kinematically (after ``t_res``, at the
turn rate, then straight for ``horizon_s``), keeps ``d_m + 2 buffer_m`` (the steering margin:
the conflict test's own is ``d_m + buffer_m``) from every obstacle within ``R``.  (An obstacle flying alongside, as fast on a
parallel course, may never open the range while the manoeuvre's course is held: it counts as
passed when the way back opens it.)  Then the aircraft flies direct to the nearest
reachable waypoint ahead on the original path (step 9): the first from the one it was flying to
that lies beyond twice the turn radius and whose direct leg is clear.  Until then it holds (it
never turns back as soon as the predicted miss exceeds ``d_m``).

**Period.**  FGA decides at 10 Hz (``period`` 0.1 s), the flight stack's avoider period, not at
the sensor's 1 Hz: at 40 m/s of closing speed a second is more than ``d_m``; between scans each
obstacle is dead-reckoned.

**Scale** (issue 34; :meth:`FgaAvoider.configure`).  The paper's distances are its UAS's: Table
II's ``d_m`` = 30 m is the minimum turn radius its eq 5 asks for (``rho_min = d_m``), ``R`` = 10
``d_m``.  Here ``d_m`` follows the vehicle: the larger of 30 m and the minimum turn radius at the
flight's speed (the ``seed004-uas`` at 15 m/s: 29.4 m, so the paper's 30 m; the aerosonde at 25
m/s: 110 m), ``R`` = 10 ``d_m``, ``buffer_m`` = ``d_m`` / 10 (the paper's 3 m), and the conflict
horizon the larger of 60 s and the time to fly ``R`` (a fast aircraft sees its conflicts within
``R`` before it flies through them).  Options given keep their values.

**Bad input.**  ``d_m <= 0``, ``R <= d_m``, a vehicle whose minimum turn radius exceeds a
``d_m`` given by more than ``turn_slack`` (10 %) -- the error names both numbers and the ``d_m``
that would do (:meth:`FgaAvoider.check_vehicle`, called before the flight).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from planner.optim.base import require_real
from replay.avoidance.base import AvoidanceContext, AvoiderBase
from replay.avoidance.fga_geometry import (
    Encounter,
    FgaObstacle,
    cone_half_angle,
    conflict_matrix,
    pass_side,
    tangent_courses,
)
from replay.avoidance.fga_plan import FgaPlanner, Plan, climb_limits, limits, velocity
from replay.avoidance.perception import Perception, PerceptionConfig, PerceptionState
from replay.flight.fixedwing.gains import LoopDesign
from replay.frames import bearing, wrap
from replay.guidance import AvoidanceDecision, FollowWaypoints, HoldCourse
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]

SURVEILLANCE_PER_D_M = 10.0  # §II-C (4): R = 10 d_m (Table II: 300 m for d_m = 30 m)
D_M_PAPER = 30.0  # Table II's d_m: its UAS's minimum turn radius (eq 5)
BUFFER_PER_D_M = 10.0  # buffer_m = d_m / 10 (3 m for the paper's 30 m)
HORIZON_S = 60.0
CONVERGED_RAD = 0.01  # step 8: |theta_t - theta_dm| < 0.01
SLOW_CPA_S = 20.0  # an encounter whose closest approach is further off than this is slow
STEER_STEP_DEG = 20.0  # the edge moves less than this between decisions, or it is another edge
LATE_WINDOW_S = 10.0  # the late-start check runs from this long before eq 8's t_k
RETURN_STEP_DEG = 10.0  # a blocked way back: the held course moves towards it in steps this big
EDGE_STEP_DEG = 5.0  # the courses tried when the course held leaves the map


@dataclass
class _Manoeuvre:
    plane: str  # "heading" or "pitch"
    side: int  # heading: +1 right turn side (obstacle on the left), -1; pitch: +1 up, -1 down
    keys: tuple[str, ...]  # the obstacles it is for
    governing: str  # the obstacle whose cone edge is steered to
    course: float  # commanded course
    altitude: float | None  # pitch: the altitude commanded
    started: float
    held: bool = False  # heading: converged on the edge, now held
    reason: str = ""
    free: bool = True  # False: an escape, no course was free


class FgaAvoider(AvoiderBase):
    """Seed 004's FGA (see the module docstring)."""

    name = "fga"
    period = 0.1
    OPTION_HELP: ClassVar[dict[str, str]] = {
        "d_m": "minimum safe separation d_m from an obstacle's surface, m (default: the larger "
        "of 30, seed 004 Table II's, and the vehicle's minimum turn radius at its speed)",
        "surveillance_m": "surveillance radius R, m (default 10 d_m: §II-C (4), Table II's 300 m)",
        "t_res": "the aircraft's response time t_res of eq 8, s (measured on seed004-uas: 0.5)",
        "buffer_m": "calling margin; the manoeuvres steer to twice it beyond d_m, m "
        "(default d_m / 10)",
        "horizon_s": "how far ahead conflicts are predicted, s (default the larger of 60 and the "
        "time to fly R)",
        "floor_m": "lowest height above the ground a pitch-down manoeuvre may reach, m",
        "turn_slack": "how far the minimum turn radius may exceed d_m (fraction, eq 5)",
        "moving_radius": "radar: size of a moving obstacle that reports none, m (seed 000: 1 km)",
        "point_radius": "radar: size added to an obstacle seen as points, m (seed 000: 1 km)",
        "memory_s": "obstacles not seen for this long are forgotten, s",
    }

    def __init__(
        self,
        *,
        d_m: float | None = None,
        surveillance_m: float | None = None,
        t_res: float = 0.5,
        buffer_m: float | None = None,
        horizon_s: float | None = None,
        floor_m: float = 30.0,
        turn_slack: float = 0.1,
        moving_radius: float = 1000.0,
        point_radius: float = 1000.0,
        memory_s: float = 10.0,
    ) -> None:
        self.d_m_opt = (
            None if d_m is None else require_real("FGA option d_m", d_m, 0.0, open_low=True)
        )
        self.surveillance_opt = (
            None
            if surveillance_m is None
            else require_real("FGA option surveillance_m", surveillance_m, 0.0)
        )
        self.buffer_opt = (
            None if buffer_m is None else require_real("FGA option buffer_m", buffer_m, 0.0)
        )
        self.horizon_opt = (
            None
            if horizon_s is None
            else require_real("FGA option horizon_s", horizon_s, 0.0, open_low=True)
        )
        self.t_res = require_real("FGA option t_res", t_res, 0.0, 10.0)
        self.floor_m = require_real("FGA option floor_m", floor_m, 0.0)
        self.turn_slack = require_real("FGA option turn_slack", turn_slack, 0.0)
        self.moving_radius = require_real("FGA option moving_radius", moving_radius, 0.0)
        self.point_radius = require_real("FGA option point_radius", point_radius, 0.0)
        memory_s = require_real("FGA option memory_s", memory_s, 0.0, open_low=True)
        self.configured = False
        self.configure(D_M_PAPER if self.d_m_opt is None else 0.0, None)
        self.configured = self.d_m_opt is not None
        self._perception = Perception(PerceptionConfig(memory_s=float(memory_s)))
        self._state: PerceptionState | None = None
        self._obstacles: list[FgaObstacle] = []
        self._man: _Manoeuvre | None = None
        self._waiting: tuple[str, ...] = ()
        self._violated: set[str] = set()

    # -- set-up ----------------------------------------------------------------------------------
    def configure(self, rho: float, speed: float | None) -> None:
        """The distances from the case (module docstring, *Scale*): ``d_m`` (the option, else the
        larger of the paper's 30 m and the minimum turn radius ``rho``), ``R`` = 10 ``d_m``,
        ``buffer_m`` = ``d_m`` / 10, ``horizon_s`` = the larger of 60 s and ``R / speed``;
        options given keep their values."""
        d_m = self.d_m_opt if self.d_m_opt is not None else max(D_M_PAPER, float(rho))
        surveillance = (
            self.surveillance_opt
            if self.surveillance_opt is not None
            else SURVEILLANCE_PER_D_M * d_m
        )
        if surveillance <= d_m:
            raise InputError(
                f"FGA option surveillance_m (R = {surveillance:g} m) must exceed d_m "
                f"({d_m:g} m): Table I needs R > r_c > d_m"
            )
        buffer = self.buffer_opt if self.buffer_opt is not None else d_m / BUFFER_PER_D_M
        if buffer > d_m:
            raise InputError(f"FGA option buffer_m ({buffer:g} m) must not exceed d_m ({d_m:g} m)")
        horizon = self.horizon_opt
        if horizon is None:
            horizon = HORIZON_S if not speed else max(HORIZON_S, surveillance / float(speed))
        self.d_m, self.surveillance_m = float(d_m), float(surveillance)
        self.buffer_m, self.horizon_s = float(buffer), float(horizon)
        self.planner = FgaPlanner(
            self.d_m, self.buffer_m, self.horizon_s, self.t_res, self.floor_m, self.period
        )
        self.configured = True

    def check_vehicle(self, params: Any, speed: float) -> None:
        """The distances from the vehicle's turn at ``speed`` (:meth:`configure`); then eq 5:
        the minimum turn radius must not exceed ``d_m`` by more than ``turn_slack``."""
        rho = float(params.min_turn_radius(speed))
        self.configure(rho, speed)
        if rho > self.d_m * (1.0 + self.turn_slack):
            raise InputError(
                f"FGA: {params.name}'s minimum turn radius at {speed:g} m/s is {rho:.1f} m, more "
                f"than d_m = {self.d_m:g} m allows (eq 5: rho_min = d_m; turn_slack "
                f"{self.turn_slack:g} allows {self.d_m * (1.0 + self.turn_slack):.1f} m): raise "
                f"d_m to at least {rho / (1.0 + self.turn_slack):.1f} m (--avoid-opt d_m=) or "
                "leave it to the default, which follows the vehicle"
            )

    def point_keep_m(self) -> tuple[float, float]:
        """A point return's size (``point_radius``, ``moving_radius``) plus ``d_m``."""
        return self.point_radius + self.d_m, self.moving_radius + self.d_m

    def reset(self, waypoints: FloatArray, rng: np.random.Generator) -> None:
        self._perception.reset()
        self._state = None
        self._obstacles = []
        self._man = None
        self._waiting = ()
        self._violated = set()

    # -- perception ------------------------------------------------------------------------------
    def _observe(self, ctx: AvoidanceContext) -> list[FgaObstacle]:
        """The obstacles now (read once per scan, dead-reckoned to ``ctx.t``)."""
        pic = ctx.picture
        if pic is not None and (self._state is None or pic.t > self._state.t):
            keep = np.zeros(len(pic), dtype=bool)
            keep[: pic.n_threat] = True  # the terrain is the autopilot's
            self._state = self._perception.update(pic, keep=keep)
            self._obstacles = self._read(self._state)
        if self._state is None:
            return []
        dt = ctx.t - self._state.t
        return [o.at(dt) for o in self._obstacles]

    def _read(self, st: PerceptionState) -> list[FgaObstacle]:
        out: list[FgaObstacle] = []
        if st.sensor == "cooperative":
            for i, ident in enumerate(st.ids):
                if st.terrain[i]:
                    continue
                c = st.positions[i] + 0.0
                vel = st.velocities[i]
                if not np.isfinite(vel).all():
                    vel = np.zeros(3)
                c = c + vel * (st.t - st.measured_at[i])
                radius = float(st.radii[i]) if math.isfinite(st.radii[i]) else 0.0
                top = float(st.tops[i]) if math.isfinite(st.tops[i]) else float(c[2])
                # a cylinder reports its top-face centre (top == z): it stands on the ground
                shift = top - float(st.positions[i][2])
                bottom = float(c[2]) - shift if shift > 1e-6 else -math.inf
                top = float(c[2]) + max(shift, 0.0)
                out.append(
                    FgaObstacle(
                        ident,
                        (float(c[0]), float(c[1]), float(c[2])),
                        (float(vel[0]), float(vel[1]), float(vel[2])),
                        radius,
                        bottom,
                        top,
                    )
                )
            return out
        for body in st.bodies:  # the radar: a circle per body, its top unknown
            idx = body.index
            c = body.center
            zc = float(np.mean(st.positions[idx, 2]))
            sized = st.radii[idx]
            if np.isfinite(sized).all():  # a sphere the radar measures (a solid threat)
                radius, top = float(body.outer_radius), float(body.top)
                bottom = float(np.min(st.positions[idx, 2] - sized))
            else:
                points = not bool(st.extended[idx].all())
                radius = float(body.radius) + (self.point_radius if points else 0.0)
                bottom, top = -math.inf, math.inf
            out.append(
                FgaObstacle(
                    st.sources[int(idx[0])],
                    (float(c[0]), float(c[1]), zc),
                    (0.0, 0.0, 0.0),
                    radius,
                    bottom,
                    top,
                )
            )
        for tr in st.tracks:
            pos = tr.predict(st.t)
            size = float(st.radii[st.index[tr.id]])
            r = size if math.isfinite(size) else self.moving_radius
            out.append(
                FgaObstacle(
                    tr.id,
                    (float(pos[0]), float(pos[1]), float(pos[2])),
                    (float(tr.velocity[0]), float(tr.velocity[1]), float(tr.velocity[2])),
                    r,
                    float(pos[2]) - r,
                    float(pos[2]) + r,
                )
            )
        return out

    # -- decisions -----------------------------------------------------------------------------
    def decide(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        if not self.configured:  # flown without check_vehicle (simulate): from the context
            self.configure(limits(ctx)[0], float(ctx.airspeed) or None)
        obstacles = self._observe(ctx)
        pos = np.asarray(ctx.position, dtype=np.float64)
        vel = np.asarray(ctx.velocity, dtype=np.float64)
        rho, turn_rate = limits(ctx)
        course = float(ctx.course)
        near = [
            o
            for o in obstacles
            if math.hypot(o.center[0] - pos[0], o.center[1] - pos[1]) - o.radius
            <= self.surveillance_m
        ]
        z = float(pos[2])
        violated = [
            self.planner.encounter(pos, vel, o, rho, -self.buffer_m)
            for o in near
            if o.key not in self._violated
            and math.hypot(o.center[0] - pos[0], o.center[1] - pos[1]) < o.radius + self.d_m
            and o.bottom - self.d_m < z < o.top + self.d_m
        ]
        for e in violated:
            self._violated.add(e.obstacle.key)
        if self._man is not None:
            return self._continue(ctx, self._man, pos, vel, course, near, rho, turn_rate, violated)
        conflicts = [
            self.planner.critical(pos, vel, course, o, rho)
            for o in self.planner.conflicts(pos, vel, near)
        ]
        if not conflicts:
            self._waiting = ()
            return None
        return self._start(ctx, pos, vel, course, near, conflicts, rho, turn_rate, violated)

    def _choose(
        self,
        ctx: AvoidanceContext,
        pos: FloatArray,
        vel: FloatArray,
        course: float,
        near: list[FgaObstacle],
        targets: list[Encounter],
        rho: float,
        turn_rate: float,
        keep_side: tuple[FgaObstacle, int] | None = None,
        plane: str | None = None,
    ) -> Plan:
        heading = self.planner.heading_plan(
            pos,
            vel,
            course,
            targets,
            near,
            rho,
            turn_rate,
            keep_side,
            float(ctx.course),
            self._unsafe(ctx, pos),
        )
        pitch = self.planner.pitch_plan(ctx, pos, vel, course, targets, near, rho)
        plans = [p for p in (heading, pitch) if p is not None]
        if not plans:
            return self.planner.escape(pos, vel, course, near, rho)
        # a manoeuvre under way stays in its plane while that plane has a free course
        plan = min(plans, key=lambda p: (p.plane != plane, p.cost, p.plane != "heading"))
        plan.costs = {**(heading.costs if heading else {}), **(pitch.costs if pitch else {})}
        return plan

    def _unsafe(
        self, ctx: AvoidanceContext, pos: FloatArray, reach: float | None = None
    ) -> Callable[[FloatArray], FloatArray] | None:
        """Courses -> metres of the course held for ``reach`` (default the surveillance radius
        ``R``) that lie off the map or in a danger zone (the context's validity; None without a
        map and zones)."""
        chk = ctx.validity
        if chk is None or not chk.bounded:
            return None
        reach = self.surveillance_m if reach is None else reach

        def unsafe(courses: FloatArray) -> FloatArray:
            a = np.broadcast_to(pos, (len(courses), 3))
            b = a + reach * np.column_stack(
                [np.sin(courses), np.cos(courses), np.zeros(len(courses))]
            )
            return chk.segments(a, b, clearance=False).outside_lengths

        return unsafe

    def _start(
        self,
        ctx: AvoidanceContext,
        pos: FloatArray,
        vel: FloatArray,
        course: float,
        near: list[FgaObstacle],
        conflicts: list[Encounter],
        rho: float,
        turn_rate: float,
        violated: list[Encounter],
    ) -> AvoidanceDecision | None:
        plan = self._choose(ctx, pos, vel, course, near, conflicts, rho, turn_rate)
        t_k = (plan.t_c if plan.plane == "pitch" else min(e.t_c for e in conflicts)) - (
            0.0 if plan.plane == "pitch" else self.t_res
        )
        keys = tuple(sorted(e.obstacle.key for e in conflicts))
        if (
            self.period < t_k < LATE_WINDOW_S
            and not violated
            and plan.plane == "heading"
            and self.planner.late_by(ctx, pos, vel, course, near, rho, turn_rate) is not None
        ):
            t_k = 0.0  # eq 7 assumes a sharper turn than the aircraft's: start now
        if t_k > self.period and not violated:
            if keys == self._waiting:
                return None
            self._waiting = keys
            return AvoidanceDecision(
                None,
                reason=f"{self._kind(conflicts)}: {plan.why} at t_c = {ctx.t + t_k:.1f} s "
                f"(in {t_k:.1f} s)",
                info=self._info(ctx, pos, conflicts, plan, t_k, [], near, rho, waiting=True),
            )
        urgent = [
            e
            for e in conflicts
            if (e.t_c - self.t_res <= self.period)
            or e.inside
            or e.obstacle.key in {v.obstacle.key for v in violated}
        ] or [min(conflicts, key=lambda e: e.t_c)]
        later = [e for e in conflicts if e not in urgent]
        if later and not plan.free:
            plan = self._choose(ctx, pos, vel, course, near, urgent, rho, turn_rate)
        self._waiting = ()
        self._man = _Manoeuvre(
            plan.plane,
            plan.side,
            tuple(e.obstacle.key for e in conflicts),
            plan.governing,
            plan.course,
            plan.altitude,
            ctx.t,
            reason=plan.why,
            free=plan.free,
        )
        info = self._info(ctx, pos, conflicts, plan, t_k, urgent, near, rho)
        prefix = "already violated: " if violated else ""
        return AvoidanceDecision(
            self._command(self._man, ctx),
            reason=f"{prefix}{self._kind(conflicts)}: {plan.why} (t_k {t_k:+.1f} s)",
            info=info,
        )

    @staticmethod
    def _kind(conflicts: list[Encounter]) -> str:
        many = "multiple" if len(conflicts) > 1 else "single"
        moving = "dynamic" if any(e.obstacle.moving for e in conflicts) else "static"
        return f"{many} {moving}"

    def _command(self, man: _Manoeuvre, ctx: AvoidanceContext) -> HoldCourse:
        if man.plane == "pitch":
            assert man.altitude is not None
            if man.held:  # there: hold the altitude
                return HoldCourse(man.course, altitude=man.altitude)
            # on the way: at the limit the plan counted on (an altitude command slows down
            # near its target), then held there (_continue)
            up, down = climb_limits(ctx.vehicle)
            rate = up if man.side > 0 else -down
            return HoldCourse(man.course, climb_rate=rate)
        return HoldCourse(man.course)  # the altitude mode is kept

    def _continue(
        self,
        ctx: AvoidanceContext,
        man: _Manoeuvre,
        pos: FloatArray,
        vel: FloatArray,
        course: float,
        near: list[FgaObstacle],
        rho: float,
        turn_rate: float,
        violated: list[Encounter],
    ) -> AvoidanceDecision | None:
        """A manoeuvre under way: re-planned on a new urgent conflict, else settled (a climb
        reaching its altitude, a turn converging on its cone's edge and steering along it), else
        ended by the way back to the mission (step 9)."""
        by_key = {o.key: o for o in near}
        horizontal = float(math.hypot(vel[0], vel[1]))
        # the velocity the manoeuvre is flying to (the command, not the transient)
        planned = velocity(man.course, horizontal, float(vel[2]))
        in_way, others = self._new_conflicts(ctx, man, pos, planned, near, rho, turn_rate)
        if others or violated:  # a new conflict on the way: steps 1-5 again, same side first
            return self._replan(
                ctx, man, pos, planned, near, rho, turn_rate, in_way, others, violated, by_key
            )
        if man.plane == "pitch" and not man.held:
            return self._settle_pitch(ctx, man, pos)
        if man.plane == "heading" and not man.held:
            return self._steer_heading(
                ctx, man, pos, vel, course, near, rho, turn_rate, planned, by_key
            )
        return self._step_back(ctx, man, pos, vel, course, near, rho, turn_rate, by_key)

    def _new_conflicts(
        self,
        ctx: AvoidanceContext,
        man: _Manoeuvre,
        pos: FloatArray,
        planned: FloatArray,
        near: list[FgaObstacle],
        rho: float,
        turn_rate: float,
    ) -> tuple[list[FgaObstacle], list[Encounter]]:
        """(the obstacles in the way of the course flown to, the urgent new conflicts)."""
        # a conflict of the course being flown to -- with a new obstacle, or with one of the
        # manoeuvre's own once the geometry has moved (an obstacle converging at the aircraft's
        # own speed) -- except the one being steered round, or climbed over, on the way there
        if not man.free:  # an escape (no course was free): only a new obstacle re-plans
            settling: set[str] = set(man.keys)
        elif man.held:
            settling = set()
        elif man.plane == "heading":
            settling = {man.governing}
        else:
            settling = set(man.keys)
        # -- re-planned only when urgent (step 5: t_k within a decision period, or within the
        # late-start check's reach); a later one is met when its time comes
        in_way = self.planner.conflicts(pos, planned, near)
        # the late-start check plans round every obstacle but the one being settled: the turn a
        # new conflict needs may be set by a neighbour (two obstacles closer than 2 d_m apart
        # close the gap between them, and the way round both is a much larger turn)
        # (one check for all of them: it does not depend on which new conflict asks)
        fresh = [
            self.planner.critical(pos, planned, man.course, o, rho)
            for o in in_way
            if o.key not in settling
        ]
        urgent = [e.t_c - self.t_res <= self.period for e in fresh]
        late = not all(urgent) and (
            self.planner.late_by(
                ctx,
                pos,
                planned,
                man.course,
                [o for o in near if o.key not in settling],
                rho,
                turn_rate,
            )
            is not None
        )
        return in_way, [e for e, now in zip(fresh, urgent, strict=True) if now or late]

    def _replan(
        self,
        ctx: AvoidanceContext,
        man: _Manoeuvre,
        pos: FloatArray,
        planned: FloatArray,
        near: list[FgaObstacle],
        rho: float,
        turn_rate: float,
        in_way: list[FgaObstacle],
        others: list[Encounter],
        violated: list[Encounter],
        by_key: dict[str, FgaObstacle],
    ) -> AvoidanceDecision:
        """Steps 1-5 again for a new conflict, from the manoeuvre's own course, in its own plane
        and on the same side first."""
        hit = {o.key for o in in_way}
        hit |= {v.obstacle.key for v in violated}
        conflicts = [
            self.planner.encounter(pos, planned, o, rho) for o in near if o.key in hit
        ] or others
        gov = by_key.get(man.governing)
        keep_side = None
        if man.plane == "heading" and gov is not None:
            keep_side = (gov, pass_side(pos, planned, gov))
        # from the manoeuvre's own course (not the turn's transient), in its own plane first
        plan = self._choose(
            ctx, pos, planned, man.course, near, conflicts, rho, turn_rate, keep_side, man.plane
        )
        self._man = _Manoeuvre(
            plan.plane,
            plan.side,
            tuple(sorted(set(man.keys) | {e.obstacle.key for e in conflicts})),
            plan.governing,
            plan.course,
            plan.altitude,
            ctx.t,
            reason=plan.why,
            free=plan.free,
        )
        return AvoidanceDecision(
            self._command(self._man, ctx),
            reason=f"{self._kind(conflicts)}: {plan.why} (new conflict)",
            info=self._info(ctx, pos, conflicts, plan, 0.0, conflicts, near, rho),
        )

    def _settle_pitch(
        self, ctx: AvoidanceContext, man: _Manoeuvre, pos: FloatArray
    ) -> AvoidanceDecision | None:
        """A climb or descent holds the altitude it was flying to once there."""
        assert man.altitude is not None
        if (float(pos[2]) - man.altitude) * man.side >= 0.0:
            man.held = True
            return AvoidanceDecision(
                self._command(man, ctx),
                reason=f"at {man.altitude:.0f} m: holding it",
                info={"fga": "hold altitude", "altitude": man.altitude},
            )
        return None

    def _steer_heading(
        self,
        ctx: AvoidanceContext,
        man: _Manoeuvre,
        pos: FloatArray,
        vel: FloatArray,
        course: float,
        near: list[FgaObstacle],
        rho: float,
        turn_rate: float,
        planned: FloatArray,
        by_key: dict[str, FgaObstacle],
    ) -> AvoidanceDecision | None:
        """A turn converges on its cone's edge (then holds) and steers along the edge while it
        moves (step 8)."""
        horizontal = float(math.hypot(vel[0], vel[1]))
        gov = by_key.get(man.governing)
        err = abs(wrap(course - man.course))
        if gov is None or err < CONVERGED_RAD:
            man.held = True
            return None
        keep = gov.radius + self.d_m + 2.0 * self.buffer_m
        # the root of the edge's quadratic nearest to the course being flown to
        roots = tangent_courses(pos, gov, keep, horizontal, man.side)
        c = min(roots, key=lambda r: abs(wrap(r - man.course))) if roots else None
        if c is None or abs(wrap(c - man.course)) > math.radians(STEER_STEP_DEG):
            # the edge steered to is gone (no course puts the relative velocity on it any
            # more, e.g. an obstacle as fast on a converging course): hold the course; the
            # conflict test of the course flown to re-plans if it must
            man.held = True
            return None
        if abs(wrap(c - man.course)) > 0.2 * CONVERGED_RAD:
            v = velocity(c, horizontal, float(vel[2]))
            if not self.planner.clear(pos, v, near, rho):
                # the edge runs into another cone: the free course nearest to the aircraft's,
                # passing the governing obstacle on the same side (the union of the cones)
                keep_side = (gov, pass_side(pos, planned, gov))
                edge = self.planner.heading_plan(
                    pos, vel, course, [], near, rho, turn_rate, keep_side
                )
                c = edge.course if edge is not None else None
                if c is not None and abs(wrap(c - man.course)) > math.radians(STEER_STEP_DEG):
                    # not a step along the edge but another manoeuvre (a reversal across the
                    # obstacle's track): hold; the conflict test re-plans if it must
                    man.held = True
                    return None
            if c is not None and abs(wrap(c - man.course)) > 0.2 * CONVERGED_RAD:
                man.course = c
                return AvoidanceDecision(
                    self._command(man, ctx),
                    reason=f"steer on the cone edge of {gov.key}",
                    info={"obstacle": gov.key, "course_deg": math.degrees(c), "fga": "steer"},
                )
        return None

    def _step_back(
        self,
        ctx: AvoidanceContext,
        man: _Manoeuvre,
        pos: FloatArray,
        vel: FloatArray,
        course: float,
        near: list[FgaObstacle],
        rho: float,
        turn_rate: float,
        by_key: dict[str, FgaObstacle],
    ) -> AvoidanceDecision | None:
        """Step 9: the closest approach passed and the way back clear -> the mission."""
        horizontal = float(math.hypot(vel[0], vel[1]))
        back = self._return(ctx, pos, vel, course, near, rho)
        if back is None:
            return self._toward_return(ctx, man, pos, vel, near, rho, turn_rate) or (
                self._off_edge(ctx, man, pos, vel, near, rho, turn_rate)
            )
        index, info = back
        ahead = float(info["climb"])
        going = velocity(math.radians(info["course_deg"]), horizontal, ahead)
        # the obstacle steered round (a climb: every one climbed over) must have passed its
        # closest approach; the others met on the way need only the clear way back
        for key in man.keys if man.plane == "pitch" else (man.governing,):
            o = by_key.get(key)
            # passed: the range grows -- or, flying alongside it (an obstacle as fast on a
            # parallel course), the way back itself opens the range
            if o is None:
                continue
            held = self.planner.encounter(pos, vel, o, rho)
            if held.range_rate > 0.0 or self.planner.encounter(pos, going, o, rho).range_rate > 0.0:
                continue
            # a slow encounter (its closest approach on the held course far off): holding
            # only puts it off -- the clear way back (checked above) is taken
            if held.closing > 1e-9 and held.along / held.closing > SLOW_CPA_S:
                continue
            return self._off_edge(ctx, man, pos, vel, near, rho, turn_rate)
        self._man = None
        return AvoidanceDecision(
            FollowWaypoints(ctx.waypoints, index, direct=True),
            reason=f"avoided {', '.join(man.keys)}: direct to waypoint {index}",
            info={"fga": "return", "waypoint": index, "duration_s": ctx.t - man.started, **info},
        )

    def _toward_return(
        self,
        ctx: AvoidanceContext,
        man: _Manoeuvre,
        pos: FloatArray,
        vel: FloatArray,
        near: list[FgaObstacle],
        rho: float,
        turn_rate: float,
    ) -> AvoidanceDecision | None:
        """The way back is blocked (an obstacle flying alongside, across the way back): hold
        instead the free course nearest to the way back, when it is at least ``RETURN_STEP_DEG``
        nearer than the course held and the turn onto it is clear -- the aircraft works its way
        back round the obstacle's cone instead of following it for ever."""
        if man.plane != "heading" or not man.held:
            return None
        w = np.asarray(ctx.waypoints, dtype=np.float64)
        j = min(ctx.next_index, len(w) - 1)
        home = bearing(pos, w[j])
        horizontal = float(math.hypot(vel[0], vel[1]))
        back = velocity(home, horizontal, float(vel[2]))
        blocking = [
            self.planner.encounter(pos, back, o, rho)
            for o in self.planner.conflicts(pos, back, near)
        ]
        if not blocking:
            return None
        plan = self.planner.heading_plan(pos, back, home, blocking, near, rho, turn_rate)
        if plan is None:
            return None
        gain = abs(wrap(man.course - home)) - abs(wrap(plan.course - home))
        if gain < math.radians(RETURN_STEP_DEG):
            return None
        sep, _key = self.planner.turn_separation(
            pos, vel, man.course, plan.course, self.t_res, near, turn_rate
        )
        if sep < self.d_m + 2.0 * self.buffer_m:
            return None
        man.course = plan.course
        return AvoidanceDecision(
            self._command(man, ctx),
            reason=f"way back blocked by {', '.join(e.obstacle.key for e in blocking)}: "
            f"{math.degrees(gain):.0f} deg nearer to it",
            info={"fga": "toward return", "course_deg": math.degrees(plan.course)},
        )

    def _off_edge(
        self,
        ctx: AvoidanceContext,
        man: _Manoeuvre,
        pos: FloatArray,
        vel: FloatArray,
        near: list[FgaObstacle],
        rho: float,
        turn_rate: float,
    ) -> AvoidanceDecision | None:
        """A held course about to leave the map or enter a danger zone (within a half turn's run
        and ``2 d_m``, ``pi rho + 2 d_m``: what the aircraft needs to turn away) while the way
        back is not yet open: hold instead the free course (outside every cone, its turn clear
        by the steering margin) that leaves the map least over ``R``, the nearest to the way
        back among equals; None when the course held is not leaving or no course is better.
        (A small map: the own suite's ``own-planned/momepy_bubenec/fga/3`` held its cone edge
        40 s off a 600 m map waiting for the way back to open.)"""
        edge = math.pi * rho + 2.0 * self.d_m
        soon, over_r = self._unsafe(ctx, pos, edge), self._unsafe(ctx, pos)
        if man.plane != "heading" or not man.held or soon is None or over_r is None:
            return None
        if soon(np.array([man.course]))[0] <= 0.0:
            return None
        horizontal = float(math.hypot(vel[0], vel[1]))
        w = np.asarray(ctx.waypoints, dtype=np.float64)
        home = bearing(pos, w[min(ctx.next_index, len(w) - 1)])
        courses = np.asarray(
            wrap(man.course + np.radians(np.arange(-180.0, 180.0, EDGE_STEP_DEG))), dtype=np.float64
        )
        velocities = np.column_stack(
            [
                horizontal * np.sin(courses),
                horizontal * np.cos(courses),
                np.full(len(courses), float(vel[2])),
            ]
        )
        keep_clear = self.d_m + 1.5 * self.buffer_m
        free = ~np.any(conflict_matrix(pos, velocities, near, keep_clear, self.horizon_s), axis=1)
        if not free.any():
            return None
        held_off = over_r(np.array([man.course]))[0]
        best: tuple[float, float, float] | None = None
        for c, leaves in zip(courses[free], over_r(courses[free]), strict=True):
            if leaves >= held_off:
                continue
            sep, _key = self.planner.turn_separation(
                pos, vel, man.course, float(c), self.t_res, near, turn_rate
            )
            if sep < self.d_m + 2.0 * self.buffer_m:
                continue
            key = (float(leaves), abs(wrap(float(c) - home)), float(c))
            if best is None or key[:2] < best[:2]:
                best = key
        if best is None:
            return None
        man.course = best[2]
        return AvoidanceDecision(
            self._command(man, ctx),
            reason=f"the course held leaves the map or enters a zone within {edge:.0f} m: "
            f"course {math.degrees(best[2]) % 360:.0f} deg ({best[0]:.0f} m off over R)",
            info={"fga": "off edge", "course_deg": math.degrees(best[2]), "unsafe_m": best[0]},
        )

    def _return(
        self,
        ctx: AvoidanceContext,
        pos: FloatArray,
        vel: FloatArray,
        course: float,
        near: list[FgaObstacle],
        rho: float,
    ) -> tuple[int, dict[str, Any]] | None:
        """The nearest reachable waypoint ahead whose direct leg (and the turn onto it) is clear
        (module docstring), or None."""
        w = np.asarray(ctx.waypoints, dtype=np.float64)
        horizontal = float(math.hypot(vel[0], vel[1]))
        up, down = climb_limits(ctx.vehicle)
        turn_rate = horizontal / max(rho, 1e-9)
        for j in range(min(ctx.next_index, len(w) - 1), len(w)):
            d = float(np.hypot(*(w[j, :2] - pos[:2])))
            if d < 2.0 * rho and j < len(w) - 1:
                continue
            if j < len(w) - 1 and self._kept_out(w[j], near):
                continue  # a waypoint in a stationary obstacle's keep-out: led past it
            c = bearing(pos, w[j])
            # the climb the autopilot's altitude loop will command towards the waypoint
            climb = min(max(LoopDesign.altitude_gain * float(w[j, 2] - pos[2]), -down), up)
            sep, _key = self.planner.turn_separation(
                pos, vel, course, c, self.t_res, near, turn_rate, climb
            )
            if sep >= self.d_m + 2.0 * self.buffer_m:  # the steering margin: hysteresis
                return j, {"course_deg": math.degrees(c), "climb": climb}
            return None
        return None

    def _kept_out(self, waypoint: FloatArray, near: list[FgaObstacle]) -> bool:
        """A waypoint inside a stationary obstacle's keep-out (its radius plus ``d_m``,
        horizontally, within its vertical extent): no way back to it is ever clear, so the
        way back leads past it to the next (not in the paper; PSO-CA's Fig. 9 / 23 rule) --
        an obstacle moves on and is not skipped round."""
        for o in near:
            if o.moving:
                continue
            inside = math.hypot(waypoint[0] - o.center[0], waypoint[1] - o.center[1])
            if (
                inside < o.radius + self.d_m
                and o.bottom - self.d_m <= waypoint[2] <= o.top + self.d_m
            ):
                return True
        return False

    def _info(
        self,
        ctx: AvoidanceContext,
        pos: FloatArray,
        conflicts: list[Encounter],
        plan: Plan,
        t_k: float,
        urgent: list[Encounter],
        near: list[FgaObstacle],
        rho: float,
        *,
        waiting: bool = False,
    ) -> dict[str, Any]:
        keep = self.d_m + self.buffer_m
        cones = []
        for e in conflicts:
            o = e.obstacle
            half = cone_half_angle(e.distance, o.radius + keep)
            los = math.atan2(o.center[0] - pos[0], o.center[1] - pos[1])
            cones.append(
                {
                    "obstacle": o.key,
                    "apex": [float(v) for v in pos],
                    "los_deg": math.degrees(los),
                    "half_angle_deg": math.degrees(half),
                    "range_m": e.distance,
                    "keep_m": o.radius + keep,
                    "miss_m": e.miss,
                    "t_c": e.t_c,
                    "moving": o.moving,
                    "window": list(e.window) if e.window else None,
                }
            )
        return {
            "fga": "wait" if waiting else "start",
            "classification": self._kind(conflicts),
            "manoeuvre": plan.plane,
            "side": plan.side,
            "why": plan.why,
            "costs": plan.costs,
            "t_c": ctx.t + min((e.t_c for e in conflicts), default=math.inf),
            "t_k": ctx.t + t_k,
            "t_res": self.t_res,
            "rho": rho,
            "urgent": [e.obstacle.key for e in urgent],
            "cones": cones,
            "course_deg": math.degrees(plan.course),
            "altitude": plan.altitude,
            "d_m": self.d_m,
            "surveillance_m": self.surveillance_m,
            "near": len(near),
        }


__all__ = ["FgaAvoider"]
