"""The priority loop: uncharted 2-D navigation with four rangefinders (seed 003, Goje, Singh &
Nikhal 2021), ``--avoid priority``.  Hover-capable vehicles only, with ``sensor="rangefinder"``.

Map frame: x east, y north, z up (m); yaws and bearings clockwise from north (rad), the paper's
IMU yaw (§III-A 3).  The mission's first waypoint is the start ``S_0``, its last the target
``S_T``; the waypoints between are not flown (the environment is uncharted).

**Altitude.**  The mission's: the higher of its start's and target's altitudes (a mission
flown at 20 m is flown at 20 m), or ``altitude_m`` as given.  §V climbs to 10 m above the higher
of the start's and the target's ground elevation: option ``above_m`` (10 for the paper; the
bench's mission, ``data/scenarios/priority-mission.yaml``, is at 10 m over flat ground, the
same).  The aircraft flies level there: obstacles are what the rangefinders hit (threats,
terrain).

**tau round the beams.**  A beam that is a line sees only what crosses it: a roof or a ridge just
below the flight level passes under the aircraft, a corner just beside the way of step 2 passes
beside it (flown with lines, the Bubenec mission at 10 m crossed a roof 0.3 m below it and
passed building corners 0.8 and 1.1 m off; the Jacksboro one a ridge 0.83 m below).  Each beam
is therefore a cone of half-angle ``atan(tau / (R - tau))``
(:meth:`PriorityAvoider.rangefinder_spread_deg`, 6.3 deg for the defaults; a real rangefinder
has a field of view, ultrasonic ones wider than this; ``--rangefinder-spread`` overrides it),
cast as its axis and four rays on its rim (down, up, right, left), and it reads the hit nearest
horizontally (:attr:`~replay.sensors.rangefinder.RangefinderPicture.beam_reach`).  At the set-point
circle the rim is ``tau`` from the axis: whatever stands within ``tau`` below the flight level or
beside a beam's line there stops the aircraft or closes the direction like a wall.  Over flat
ground 10 m below, the lower rim meets the ground at 90 m, beyond R; flown lower than ``R
sin(spread)`` (2.2 m) above open ground, the ground fills every beam and the target is
unreachable, as it should be for an aircraft that must keep ``tau`` from the ground.  What lies
between the rays of a cone is not seen, as with any beam.

**Steps 1-2.**  Climb (or descend) over ``S_0`` to the altitude facing the target (``atan2`` of
the east and north offsets), then fly straight to it (:class:`~replay.guidance.FollowWaypoints`
from here to the target: the flight stack ends the run with ``goal`` on arrival).  The front beam
watches: a hit closer than ``R - tau`` and closer than the target (``theta_D``) stops the
aircraft (:class:`~replay.guidance.HoldPosition`); where it comes to rest is appended to ``S``.

**Step 3: the scan.**  The heading at the stop faces the target (step 3 puts the front reading in
``Ir_0`` and step 5 treats ``I_0`` as the target's direction), so the 32 directions are taken
relative to ``h``, the bearing from the stop to the target: ``I_i`` at ``h + 22.5 i deg``,
``D_i`` at ``h + 11.25 + 22.5 i deg`` (§III-C 9-10), on the circle of radius ``R - tau``.  The
aircraft turns clockwise in place by 11.25 deg steps (:class:`~replay.guidance.YawTo`) and takes
every beam's range at each: the reading of a beam at bearing ``b`` (relative to the nose) at yaw
step ``k`` looks along ``h + 11.25 k deg + b``, the ``n``-th of the 32 directions with ``n =
round((11.25 k + b) / 11.25) mod 32``; an even ``n`` is ``I_{n/2}``, an odd one ``D_{(n-1)/2}``
(:func:`slot_of`).  With the paper's four beams (front 0, right 90, back 180, left 270 deg) the
steps 0, 11.25 ... 78.75 deg fill them all, interleaved exactly as §III-C lists them: step 0 gives
``Ir_0, Ir_4, Ir_8, Ir_12`` (front, right, back, left), step 11.25 ``Dr_0, Dr_4, Dr_8, Dr_12``,
step 22.5 ``Ir_1, Ir_5, Ir_9, Ir_13`` ... step 78.75 ``Dr_3, Dr_7, Dr_11, Dr_15``.  Other beam
layouts scan the steps that fill the 32 directions (:func:`scan_steps`; one beam: 32 steps, the
paper's "easily modified" single sensor).  A reading is taken from the first scan after the yaw
is within ``YAW_TOL_DEG`` of the step's and the aircraft at rest; the picture's ``beam_courses``
are recorded with it.

**Possible points (§III-C 15-16).**  ``IP_i``: the beam towards ``I_i`` is clear over its whole
range, ``Ir_i >= R``, so the set-point (at ``R - tau``) keeps at least ``tau`` from whatever lies
beyond it on that line -- the paper's ``Ir_i >= R - tau`` admits an obstacle *at* the set-point
(an aircraft sent there would stop touching it) -- *and* the way there keeps ``tau`` (§III-C 2's
definition of ``tau``) from every point the scan's 32 beams hit (:func:`keeps_clear`; not in
the paper: without it a corner beside the way, between the beam and its flanks, was passed 0.3
to 1.5 m off in the flights of ``tests/test_priority.py``), *and* the way stays on the map, over
measured terrain and out of the mission's danger zones (the replay's validity layer, sampled
every 2 m; issue 34: an uncharted world still has a map edge and airspace).  ``DP_i = Dr_i >= R - tau`` as
printed: the flanking line is clear as far as the circle, and an obstacle just beyond ``D_i`` is
``2 (R - tau) sin 5.625 deg`` (3.5 m for the defaults) from the set-point, more than ``tau``
whenever ``R >= 6.1 tau`` (refused otherwise: :func:`check_range`).  ``IP`` (both tests) and
the beam test alone (``IP_beam``) are recorded.

**Step 4: the priority loop.**  ``theta_i = |I_i - S_T|`` sorted ascending; the first ``I_i``
passing a level is chosen, the levels tried in turn (:func:`choose`, the paper's steps):

- 4a ``IP_i``, both flanks possible, not visited;
- 4b ``IP_i``, not visited;
- 4c ``IP_i``, both flanks possible;
- 4d ``IP_i``; none -> ``target unreachable``.

The flanks of ``I_i`` are ``D_{i-1}`` and ``D_i`` (at -11.25 and +11.25 deg; indices modulo 16):
§IV-D prints ``D_i`` and ``D_{i+1}``, i.e. +11.25 and +33.75 deg, one flank on one side and
none on the other (:func:`flanks`).

*Ties.*  Facing the target, ``I_k`` and ``I_{16-k}`` are equally far from it.  Distances within
``tie_m`` (1 cm: rounding is 1e-12 m, and the closest distinct ``theta`` differ by ``(R - tau)(1
- cos 22.5 deg)``, 1.4 m for the defaults) are ties, ordered by side: the side of the previous
choice first (right ``I_1..I_7``, clockwise, the way the scan turns, or left ``I_9..I_15``; ``I_0``
and ``I_8`` have no side and keep the side as it was), clockwise before any choice
(:func:`priority_order`).  Keeping the side keeps the aircraft going round an obstacle the way it
started instead of swinging back and forth.

**Step 4 as a search** (``backtrack``, the default; not in the paper).  4c and 4d send the
aircraft to a visited point, and which one is the greedy order's: in a concave place (a U open
towards the aircraft, the target behind it) every choice is again near the bottom and the steps
cycle there (issue 34: an 80 x 60 m U held a quadrotor until the time limit).  The list ``S``
is kept to leave such places, so it is searched depth first (Tremaux's rule for mazes): every
scan makes a *place* of a tree, its parent the place the aircraft came from (the way between
them was flown straight, so it is known clear).  A scan whose 4a/4b find a point goes on as the
paper does; one where only 4c/4d would (every possible point visited) is a dead end: the
aircraft returns along the tree, place by place, to the latest place whose scan still has a
possible point not visited *now* (``S`` has grown since), and takes it (level ``back``).  The
record of such a decision carries ``back`` (the place, the route, the point).  When no place of
the tree has one, every set-point reachable from the start at this spacing has been visited:
``target unreachable`` -- the paper's 4d (no point possible) over the whole tree instead of one
scan.  Every point taken is unvisited, so the places are at least ``visited_m`` apart and their
number in a bounded region is finite: a closed pen ends so (a 100 m one, in the tests, after 72
scans).  In the open the search is not bounded (it would widen its rings round a box
containing the target for ever): the circling rule below ends that.  ``backtrack=false`` flies
the paper's 4c/4d.

*Visited.*  The paper compares points exactly; here ``I_i`` is visited when it lies within
``visited_m`` (horizontally) of a point of ``S`` (:func:`visited`).  The default with the
search is ``(R - tau) / 2`` (9 m for R = 20, tau = 2): a set-point marks the points nearer to it
than half a step, so the places cover the ground they explore at half the circle's radius (the
80 x 60 m U: 45 set-points; with the paper's spacing below, 202).  For the paper's steps it is
``(R - tau) sin 11.25 deg`` (3.5 m), half the distance between neighbouring ``I`` points: a
set-point marks itself, never its neighbours on the next circle (larger, 4c/4d find visited
points everywhere and loop sooner).

**Step 5.**  The chosen point is appended to ``S``.  ``I_0``: turn back to face the target (the
scan ended at 78.75 deg) and resume step 2.  Another: fly to it (:class:`~replay.guidance.GoTo`,
facing along the way), stop, face the target, scan again (step 3; the point is in ``S``
already).  Not in the paper: while flying to a set-point the front beam watches as in step 2 (a
threat that popped up since the scan): a hit closer than ``R - tau`` and short of the set-point's
``tau`` beyond it stops the aircraft and starts a scan there.

**Termination.**  The paper has no loop guarantee: a closed box round the target with room round
the aircraft never ends in 4d.  Two loop rules and four bounds end a run, each with a typed
outcome (:data:`OUTCOMES`):

- ``target unreachable``: step 4d found no point (with the search: at any place of the tree);
- ``target unreachable: circled`` (:class:`Surround`, Bug1's test): the moves of ``S`` have swept
  every direction round the target (each move the bearings between its ends, seen from the
  target, the short way) without coming ``R - tau`` (one move) nearer to it than when the sweep
  began.  A closed box ends after one lap (the flight: 246 s), and so does a
  target inside an obstacle once the aircraft has gone round it;
- ``loop: set-points revisited`` (:class:`LoopDetector`): a *place* is a point of ``S`` farther
  than ``visited_m`` from every earlier one; each scan is made at a place with the number of
  places known so far; a scan at a place scanned before with no new place since finds the same
  visited set and the same readings (the world is static between them), so it makes the same
  choice: the steps are cycling.  That says the algorithm is stuck, not that the target cannot
  be reached (with ``visited_m`` 6 or 9 m the U trap's flight ends so);
- ``set-point limit`` (``max_setpoints``), ``scan limit`` (``max_scans``), ``flight-time limit``
  (``max_flight_s``); and ``start inside an obstacle`` when a beam reads 0 before the first scan
  (a start refused before the flight by :meth:`PriorityAvoider.check_setup` cannot get there).

A run never loops forever.  These end the run through :attr:`~replay.guidance.AvoidanceDecision.
end`: the run's end reason, never a success, and ``terrapath replay`` exits 3.

**Time limit.**  An explorer's flight is not 1.5 x the straight one: the avoider's
``time_limit_s`` (``max_flight_s`` + 10 s) is the replay's default limit when longer (a 100 m
box round the target ends ``circled`` after 13 min of flight, 14 s of wall time).

**Limits.**  A beam's cone is five rays: a corner between two of the 32 directions that none of
them hits can still come nearer than ``tau`` (:func:`keeps_clear` knows only the hits).  The
greedy order (nearest the target first) still explores the bottom of a concave trap before it
leaves it (the 80 x 60 m U: 9.4 min of flight).  Between two hollows of
``data/maps/lidar_1m_dem`` (379.8 and 380.3 m, a rise to 393.6 m between) the flight at 390.3 m
(``above_m=10``) ends ``target unreachable`` after 70 set-points and 1288 s, never nearer the
ground than 2.3 m (the paper's steps: ``loop: set-points revisited`` after 73 set-points and
944 s; with lines for beams they reached the target after 170 set-points and 2246 s, 0.3 m over
the ground at its lowest).

**Records.**  Every decision carries ``priority`` (the step), ``setpoints`` (``S`` so far) and
the point it appended, if any; a completed scan carries ``scan`` (``Ir``, ``Dr``, ``IP``, ``DP``,
``theta``, ``IP_beam``, the order, the visited flags, the beam courses), ``levels`` (4a-4d: the
point each chose, or none), ``chosen`` and ``level``; an end carries ``outcome``.  The recorder
draws ``setpoints`` on ``/avoidance/guidance``; ``terrapath view`` and ``RUN.png`` mark them.

**Bad input**, refused before the flight (``replay.run.prepare_replay`` calls
:meth:`PriorityAvoider.check_vehicle` and :meth:`PriorityAvoider.check_setup`) with one line
naming the option: ``tau < 0``; ``R <= tau`` or ``R < 6.1 tau`` (:func:`check_range`); a vehicle
that cannot hover; a sensor other than the rangefinders, or beams off the 32 directions; a
cruise speed that cannot stop within ``R - 2 tau`` of a detection (:func:`stopping_distance`); a
start inside an obstacle (over ``S_0``, from the mission's altitude to the flight altitude).  A
target inside an obstacle is not refused: the flight finds it out (``circled``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from planner.optim.base import require_real
from replay.avoidance.base import AvoidanceContext, AvoiderBase
from replay.flight.multirotor.stack import ControllerDesign
from replay.frames import bearing, wrap
from replay.guidance import AvoidanceDecision, FollowWaypoints, GoTo, HoldPosition, YawTo
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

N_POINTS = 16  # I_0..I_15 (and D_0..D_15)
N_DIRECTIONS = 2 * N_POINTS  # the 32 scanned directions
SLOT_DEG = 360.0 / N_DIRECTIONS  # 11.25
SLOT = math.radians(SLOT_DEG)
SLOT_SNAP_DEG = 0.5  # a beam bearing this close to a multiple of 11.25 deg counts as one
YAW_TOL_DEG = 1.0  # a scan step's reading is taken within this of its yaw
ARRIVE_M = 0.5  # a set-point (or the altitude) is reached within this (3-D)
REST_MPS = 0.25  # at rest below this ground speed
BRAKE_MPS2 = ControllerDesign().brake  # the multirotor stack's braking deceleration
REACTION_S = 0.3  # a scan period, a decision period and the controller's lag, rounded up
FLANK_CLEARANCE = 2.0 * math.sin(math.radians(SLOT_DEG / 2.0))  # x (R - tau): I_i to past D_i
TIE_M = 0.01
WAY_STEP_M = 2.0  # the way to a set-point is checked against the map and the zones this often

UNREACHABLE = "target unreachable"  # step 4d: no I point is possible
LOOP = "loop: set-points revisited"  # a scan where one was made, nothing new visited since
CIRCLED = "target unreachable: circled"  # a full turn round the target, none nearer
SETPOINT_LIMIT = "set-point limit"
SCAN_LIMIT = "scan limit"
FLIGHT_TIME_LIMIT = "flight-time limit"
START_INSIDE = "start inside an obstacle"  # a beam reads 0 before the first scan
OUTCOMES = (
    UNREACHABLE,
    LOOP,
    CIRCLED,
    SETPOINT_LIMIT,
    SCAN_LIMIT,
    FLIGHT_TIME_LIMIT,
    START_INSIDE,
)
LEVELS = ("4a", "4b", "4c", "4d")


# -- the scan table --------------------------------------------------------------------------------
def slot_of(step: int, beam_bearing: float) -> int:
    """The direction (0..31, 11.25 deg each, clockwise from the stop heading) a beam at
    ``beam_bearing`` (rad from the nose, clockwise) reads at yaw step ``step`` (the aircraft
    turned ``11.25 step`` deg clockwise).  Even ``n``: ``I_{n/2}``; odd: ``D_{(n-1)/2}``."""
    rel = step * SLOT_DEG + math.degrees(beam_bearing)
    n = round(rel / SLOT_DEG)
    if abs(rel - n * SLOT_DEG) > SLOT_SNAP_DEG:
        raise InputError(
            f"priority: a beam at {math.degrees(beam_bearing):g} deg from the nose is not at a "
            f"multiple of {SLOT_DEG} deg; the scan needs beams on the 32 directions of §III-C"
        )
    return n % N_DIRECTIONS


def scan_steps(beam_bearings: Sequence[float]) -> tuple[int, ...]:
    """The yaw steps (multiples of 11.25 deg clockwise, in order) whose readings fill all 32
    directions: each step that fills one not yet read (four beams at 90 deg: 0..7)."""
    filled: set[int] = set()
    steps: list[int] = []
    for k in range(N_DIRECTIONS):
        slots = {slot_of(k, b) for b in beam_bearings}
        if slots - filled:
            steps.append(k)
            filled |= slots
        if len(filled) == N_DIRECTIONS:
            return tuple(steps)
    raise InputError("priority: the rangefinders have no beam to scan with")


def check_range(range_m: float, tau: float) -> None:
    """``R`` and ``tau`` as the scan needs them (module docstring): ``R > tau`` and the flank
    clearance ``2 (R - tau) sin 5.625 deg >= tau``."""
    if not range_m > tau:
        raise InputError(
            f"priority option tau ({tau:g} m) must be below the rangefinders' range R "
            f"({range_m:g} m): the set-points lie on a circle of radius R - tau"
        )
    if FLANK_CLEARANCE * (range_m - tau) < tau:
        raise InputError(
            f"priority option tau ({tau:g} m) is too large for the rangefinders' range R "
            f"({range_m:g} m): a set-point must keep tau from an obstacle past its flanks, "
            f"which needs R >= {1.0 + 1.0 / FLANK_CLEARANCE:.2f} tau"
        )


def stopping_distance(speed: float) -> float:
    """Metres flown from a detection to rest at ``speed``: the reaction time, then braking."""
    return speed * REACTION_S + speed * speed / (2.0 * BRAKE_MPS2)


def ring(center: npt.ArrayLike, heading: float, radius: float, offset: float = 0.0) -> FloatArray:
    """The 16 points at ``heading + offset + 22.5 i deg`` on the circle of ``radius`` about
    ``center`` (x, y): the ``I`` points (offset 0) or the ``D`` points (offset 11.25 deg)."""
    c = np.asarray(center, dtype=np.float64)[:2]
    a = heading + offset + 2.0 * SLOT * np.arange(N_POINTS)
    return np.column_stack([c[0] + radius * np.sin(a), c[1] + radius * np.cos(a)])


def possible(
    ir: npt.ArrayLike, dr: npt.ArrayLike, range_m: float, tau: float
) -> tuple[BoolArray, BoolArray]:
    """``(IP, DP)``: ``IP_i = Ir_i >= R`` (a clear beam), ``DP_i = Dr_i >= R - tau`` (§III-C
    16 as printed).  Ranges are ``R`` (or more) where the beam hit nothing."""
    i = np.asarray(ir, dtype=np.float64)
    d = np.asarray(dr, dtype=np.float64)
    if i.shape != (N_POINTS,) or d.shape != (N_POINTS,):
        raise InputError(f"priority: Ir and Dr need {N_POINTS} readings each")
    return i >= range_m, d >= range_m - tau


def hit_points(
    center: npt.ArrayLike, ranges: npt.ArrayLike, courses: npt.ArrayLike, range_m: float
) -> FloatArray:
    """(H, 2) the points a scan's beams hit (x, y): ``center`` + range along each course, for
    the readings short of ``range_m``."""
    c = np.asarray(center, dtype=np.float64)[:2]
    r = np.asarray(ranges, dtype=np.float64)
    a = np.asarray(courses, dtype=np.float64)
    hit = np.isfinite(r) & np.isfinite(a) & (r < range_m)
    return np.column_stack([c[0] + r[hit] * np.sin(a[hit]), c[1] + r[hit] * np.cos(a[hit])])


def keeps_clear(
    center: npt.ArrayLike, points: npt.ArrayLike, hits: npt.ArrayLike, tau: float
) -> BoolArray:
    """For each of ``points`` (P, 2), whether the segment from ``center`` to it keeps at least
    ``tau`` from every one of ``hits`` (H, 2): §III-C 2's tolerance, for the obstacles the scan
    saw beside the way (a corner next to the path, between its beam and the flanking ones).  A
    hit already nearer than ``tau`` blocks only the segments that come nearer to it still
    (an aircraft that stopped close to a wall may move away from it)."""
    c = np.asarray(center, dtype=np.float64)[:2]
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    h = np.asarray(hits, dtype=np.float64).reshape(-1, 2)
    if len(h) == 0:
        return np.ones(len(p), dtype=bool)
    e = p - c  # (P, 2)
    ee = np.maximum((e * e).sum(axis=1), 1e-12)
    w = h[None, :, :] - c  # (1, H, 2)
    u = np.clip((w * e[:, None, :]).sum(axis=2) / ee[:, None], 0.0, 1.0)  # (P, H)
    near = c + u[:, :, None] * e[:, None, :]
    d = np.hypot(*(h[None, :, :] - near).transpose(2, 0, 1))  # (P, H)
    now = np.hypot(h[:, 0] - c[0], h[:, 1] - c[1])  # (H,)
    blocked = (d < tau) & (d < now[None, :] - 1e-9)
    return np.asarray(~blocked.any(axis=1))


def flanks(i: int) -> tuple[int, int]:
    """The ``D`` points either side of ``I_i``: ``D_{i-1}`` (-11.25 deg) and ``D_i`` (+11.25
    deg), modulo 16 (§IV-D prints ``D_i``, ``D_{i+1}``)."""
    return (i - 1) % N_POINTS, i % N_POINTS


def side_of(i: int) -> int:
    """+1 for ``I_1..I_7`` (right of the target's direction, clockwise), -1 for ``I_9..I_15``,
    0 for ``I_0`` and ``I_8``."""
    i %= N_POINTS
    if i == 0 or i == N_POINTS // 2:
        return 0
    return 1 if i < N_POINTS // 2 else -1


def priority_order(theta: npt.ArrayLike, side: int = 1, tie_m: float = TIE_M) -> list[int]:
    """The 16 indices by distance to the target, ascending; distances within ``tie_m`` of the
    first of their group are a tie, ordered ``side`` first (+1 right, -1 left), then the points
    without a side, then the other side."""
    th = np.asarray(theta, dtype=np.float64)
    order = sorted(range(len(th)), key=lambda k: (float(th[k]), k))
    out: list[int] = []
    pos = 0
    while pos < len(order):
        end = pos + 1
        while end < len(order) and th[order[end]] - th[order[pos]] <= tie_m:
            end += 1
        group = order[pos:end]
        rank = {side: 0, 0: 1, -side: 2} if side else {1: 0, 0: 1, -1: 2}
        out += sorted(group, key=lambda k: (rank[side_of(k)], float(th[k]), k))
        pos = end
    return out


def visited(points: npt.ArrayLike, setpoints: npt.ArrayLike, visited_m: float) -> BoolArray:
    """For each point (x, y, ...), whether it lies within ``visited_m`` horizontally of a point
    of ``setpoints`` (the list ``S``)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, np.shape(points)[-1])[:, :2]
    s = np.asarray(setpoints, dtype=np.float64)
    if s.size == 0:
        return np.zeros(len(p), dtype=bool)
    s = s.reshape(-1, s.shape[-1])[:, :2]
    d = np.hypot(p[:, None, 0] - s[None, :, 0], p[:, None, 1] - s[None, :, 1])
    return np.asarray((d <= visited_m).any(axis=1))


@dataclass(frozen=True)
class Choice:
    """Step 4's answer: the index chosen (None: nothing possible, the target is unreachable),
    the level that chose it, the order tried and what each level found."""

    index: int | None
    level: str | None
    order: tuple[int, ...]
    levels: dict[str, int | None] = field(default_factory=dict)

    @property
    def unreachable(self) -> bool:
        return self.index is None


def choose(
    ip: npt.ArrayLike,
    dp: npt.ArrayLike,
    theta: npt.ArrayLike,
    seen: npt.ArrayLike,
    side: int = 1,
    tie_m: float = TIE_M,
) -> Choice:
    """Steps 4a-4d on a scan: ``ip``, ``dp`` (16 booleans each), ``theta`` (16 distances to the
    target), ``seen`` (16 booleans: visited), ``side`` the tie rule's preferred side."""
    ipa = np.asarray(ip, dtype=bool)
    dpa = np.asarray(dp, dtype=bool)
    seen_a = np.asarray(seen, dtype=bool)
    order = priority_order(theta, side, tie_m)
    levels: dict[str, int | None] = {}

    def clear_flanks(i: int) -> bool:
        a, b = flanks(i)
        return bool(dpa[a] and dpa[b])

    tests = {
        "4a": lambda i: clear_flanks(i) and not seen_a[i],
        "4b": lambda i: not seen_a[i],
        "4c": clear_flanks,
        "4d": lambda i: True,
    }
    for level in LEVELS:
        found = next((i for i in order if ipa[i] and tests[level](i)), None)
        levels[level] = found
        if found is not None:
            return Choice(found, level, tuple(order), levels)
    return Choice(None, None, tuple(order), levels)


class LoopDetector:
    """Places and the scans made at them (module docstring, *Termination*)."""

    def __init__(self, visited_m: float) -> None:
        self.visited_m = float(visited_m)
        self.points: list[tuple[float, float]] = []  # S, horizontally
        self.places = 0  # points of S farther than visited_m from every earlier one
        self.scans: list[tuple[float, float, int]] = []  # (x, y, places known then)

    def append(self, point: npt.ArrayLike) -> bool:
        """Add a point of ``S``; True when it is a new place."""
        p = np.asarray(point, dtype=np.float64)
        new = not bool(visited(p[:2], self.points, self.visited_m)[0]) if self.points else True
        self.points.append((float(p[0]), float(p[1])))
        self.places += int(new)
        return new

    def scan(self, place: npt.ArrayLike) -> bool:
        """Record a scan at ``place``; True when a scan was made there before with as many
        places known: nothing new since, the same choice again, a loop."""
        p = np.asarray(place, dtype=np.float64)
        loop = any(
            n == self.places and math.hypot(x - p[0], y - p[1]) <= self.visited_m
            for x, y, n in self.scans
        )
        self.scans.append((float(p[0]), float(p[1]), self.places))
        return loop


class Surround:
    """Which directions round ``target`` the set-points have swept since they last came
    ``improve_m`` nearer to it (module docstring, *Termination*): each move from one point of
    ``S`` to the next sweeps the bearings (seen from the target) between them, the short way."""

    BINS = 360  # one degree each

    def __init__(self, target: npt.ArrayLike, improve_m: float) -> None:
        self.target = np.asarray(target, dtype=np.float64)[:2].copy()
        self.improve_m = float(improve_m)
        self.nearest = math.inf  # distance to the target when the sweep last restarted
        self.swept = np.zeros(self.BINS, dtype=bool)
        self._last: float | None = None

    def add(self, point: npt.ArrayLike) -> float:
        """Add the next point of ``S``; the share of the circle swept since the last approach."""
        p = np.asarray(point, dtype=np.float64)
        d = float(math.hypot(p[0] - self.target[0], p[1] - self.target[1]))
        b = bearing(self.target, p)
        if not math.isfinite(self.nearest) or d < self.nearest - self.improve_m:
            self.nearest = d
            self.swept[:] = False
            self._last = None
        if self._last is not None:
            turn = wrap(b - self._last)
            n = 2 * math.ceil(abs(math.degrees(turn))) + 1  # a sample inside every degree
            a = self._last + np.linspace(0.0, turn, n)
            self.swept[np.floor(np.degrees(a) % 360.0).astype(np.int64) % self.BINS] = True
        else:
            self.swept[int(math.floor(math.degrees(b) % 360.0)) % self.BINS] = True
        self._last = b
        return self.share

    @property
    def share(self) -> float:
        return float(self.swept.mean())

    @property
    def round(self) -> bool:
        return bool(self.swept.all())


# -- the avoider -------------------------------------------------------------------------------------
@dataclass
class _Place:
    """A scanned place of the search tree (module docstring, *Step 4 as a search*): where the
    scan was made, its ``I`` points and what the scan found possible there."""

    center: FloatArray
    points: FloatArray  # (16, 2) the I points
    ip: BoolArray
    dp: BoolArray
    theta: FloatArray
    parent: int | None  # index of the place it was reached from (None: the first scan)


@dataclass
class _Scan:
    """A scan under way (step 3) at ``center``, directions relative to ``heading``."""

    center: FloatArray
    heading: float
    steps: tuple[int, ...]
    k: int = 0  # index in ``steps`` of the step being read
    ir: FloatArray = field(default_factory=lambda: np.full(N_POINTS, np.nan))
    dr: FloatArray = field(default_factory=lambda: np.full(N_POINTS, np.nan))
    courses: FloatArray = field(default_factory=lambda: np.full(N_DIRECTIONS, np.nan))
    commanded_t: float = -math.inf

    def yaw(self) -> float:
        return wrap(self.heading + self.steps[self.k] * SLOT)


class PriorityAvoider(AvoiderBase):
    """Seed 003's priority loop (see the module docstring)."""

    name = "priority"
    period = 0.1
    hover_only = True  # flies GoTo / HoldPosition / YawTo: not under the fixed-wing contract
    OPTION_HELP: ClassVar[dict[str, str]] = {
        "tau": "tolerance tau: the least distance kept from an obstacle, m (set-points at R - tau)",
        "visited_m": "a point within this of a set-point is visited, m (default (R - tau) sin 11.25 deg)",
        "tie_m": "target distances within this are a tie (the previous choice's side wins), m",
        "altitude_m": "flight altitude AMSL, m (default: the higher of the mission's start and "
        "target altitudes)",
        "above_m": "§V: fly this many metres above the higher of the start's and target's "
        "ground elevation (the paper: 10)",
        "max_setpoints": "end the run after this many set-points in S",
        "max_scans": "end the run after this many scans",
        "max_flight_s": "end the run after this many seconds",
        "circled": "end the run when S has gone all round the target without nearing it",
        "backtrack": "step 4 as a search: return along S instead of choosing a visited point "
        "(false: the paper's 4c/4d)",
    }

    def __init__(
        self,
        *,
        tau: float = 2.0,
        visited_m: float | None = None,
        tie_m: float = TIE_M,
        altitude_m: float | None = None,
        above_m: float | None = None,
        max_setpoints: int = 200,
        max_scans: int = 200,
        max_flight_s: float = 3600.0,
        circled: bool = True,
        backtrack: bool = True,
    ) -> None:
        self.tau = require_real("priority option tau", tau, 0.0)
        self.visited_opt = (
            None
            if visited_m is None
            else require_real("priority option visited_m", visited_m, 0.0, open_low=True)
        )
        self.tie_m = require_real("priority option tie_m", tie_m, 0.0)
        self.altitude_opt = (
            None if altitude_m is None else require_real("priority option altitude_m", altitude_m)
        )
        self.above_m = (
            None
            if above_m is None
            else require_real("priority option above_m", above_m, 0.0, open_low=True)
        )
        self.max_setpoints = int(
            require_real("priority option max_setpoints", max_setpoints, 1.0, 1e6)
        )
        self.max_scans = int(require_real("priority option max_scans", max_scans, 1.0, 1e6))
        self.max_flight_s = require_real(
            "priority option max_flight_s", max_flight_s, 0.0, open_low=True
        )
        # the replay's default time limit: past max_flight_s, which ends the run with its outcome
        self.time_limit_s = self.max_flight_s + 10.0
        if not isinstance(circled, bool):
            raise InputError(f"priority option circled must be true or false; got {circled!r}")
        self.circled = circled
        if not isinstance(backtrack, bool):
            raise InputError(f"priority option backtrack must be true or false; got {backtrack!r}")
        self.backtrack = backtrack
        self.reset(np.zeros((2, 3)), np.random.default_rng(0))

    # -- set-up -----------------------------------------------------------------------------------
    def check_vehicle(self, params: Any, speed: float) -> None:
        """The aircraft must hover (the scan turns in place) and stop in time."""
        from replay.flight.multirotor.model import MultirotorParams

        if not isinstance(params, MultirotorParams):
            raise InputError(
                f"priority: {params.name} cannot hover; the priority loop stops and turns in "
                "place to scan (use a multirotor, e.g. --vehicle quadrotor)"
            )

    def check_sensor(self, range_m: float, speed: float) -> None:
        """The rangefinders' range ``R`` against ``tau`` (:func:`check_range`), and the stop:
        from a detection at ``R - tau`` the aircraft at ``speed`` must come to rest ``tau``
        short of it."""
        check_range(range_m, self.tau)
        stop = stopping_distance(speed)
        if stop > range_m - 2.0 * self.tau:
            raise InputError(
                f"priority: at {speed:g} m/s the aircraft needs {stop:.1f} m to stop, more than "
                f"the {range_m - 2.0 * self.tau:g} m that R - 2 tau leaves (R = {range_m:g} m, "
                f"option tau = {self.tau:g} m): fly slower or use longer rangefinders"
            )

    def rangefinder_spread_deg(self, range_m: float) -> float:
        """The half-angle of the beams' cones (module docstring, "tau round the beams"):
        ``atan(tau / (R - tau))`` in degrees (0 with ``tau`` 0 or ``R <= tau``: refused later)."""
        if self.tau <= 0.0 or range_m <= self.tau:
            return 0.0
        return math.degrees(math.atan(self.tau / (range_m - self.tau)))

    def check_setup(self, config: Any, mission: Any, threats: Any, grid: Any, speed: float) -> None:
        """Before the flight (``replay.run.prepare_replay``): the sensor (the rangefinders, a
        beam layout on the 32 directions, ``R`` against ``tau`` and the stop at ``speed``: one
        line naming the option), and a start outside every obstacle there at t = 0 (over
        ``S_0`` from the mission's altitude to the flight altitude)."""
        if getattr(config, "sensor", None) != "rangefinder":
            raise InputError(
                "priority: the priority loop scans with rangefinders; use --sensor rangefinder "
                f"(sensor='rangefinder'), not {getattr(config, 'sensor', None)!r}"
            )
        beams = int(config.rangefinder_beams)
        try:
            scan_steps([2.0 * math.pi * j / beams for j in range(beams)])
        except InputError:
            raise InputError(
                f"priority: {beams} rangefinder beams are not on the 32 directions of §III-C; "
                "use 1, 2, 4, 8, 16 or 32 (--rangefinder-beams)"
            ) from None
        self.check_sensor(float(config.rangefinder_range), speed)
        w = np.asarray(mission.waypoints, dtype=np.float64)
        start = w[0]

        def ground(p: FloatArray) -> float:
            if grid is None:
                return 0.0
            return float(np.asarray(grid.height_at(p[0:1], p[1:2])).reshape(-1)[0])

        altitude = self.flight_altitude(w[0], w[-1], ground)
        climb = np.column_stack(
            [
                np.full(21, start[0]),
                np.full(21, start[1]),
                np.linspace(float(start[2]), altitude, 21),
            ]
        )
        for th in threats:
            if float(getattr(th, "appears_at", 0.0) or 0.0) > 0.0:
                continue
            inside = np.asarray(th.separation(climb, 0.0)).reshape(-1) < 0.0
            if inside.any():
                z = float(climb[int(np.argmax(inside)), 2])
                raise InputError(
                    f"priority: the start ({start[0]:g}, {start[1]:g}) at {z:.1f} m lies inside "
                    f"threat {th.id!r}; the aircraft must start (and climb to the flight "
                    f"altitude {altitude:.1f} m) outside every obstacle"
                )

    def flight_altitude(
        self, start: FloatArray, target: FloatArray, ground: Callable[[FloatArray], float]
    ) -> float:
        """The level flown (module docstring, *Altitude*): option ``altitude_m``; else with
        ``above_m`` that much over the higher ground of start and target (§V); else the higher
        of the mission's start and target altitudes."""
        if self.altitude_opt is not None:
            return self.altitude_opt
        if self.above_m is not None:
            return max(ground(start), ground(target)) + self.above_m
        return float(max(start[2], target[2]))

    def reset(self, waypoints: FloatArray, rng: np.random.Generator) -> None:
        w = np.asarray(waypoints, dtype=np.float64)
        self.start = w[0].copy()
        self.target = w[-1].copy()
        self.phase = "start"
        self.range_m = math.nan
        self.visited_m = math.nan
        self.altitude = math.nan
        self.setpoints: list[FloatArray] = []
        self.side = 1
        self.scans = 0
        self.loops: LoopDetector | None = None
        self.surround: Surround | None = None
        self._scan: _Scan | None = None
        self.places: list[_Place] = []  # every scan's place (the search tree)
        self.path: list[int] = []  # the places from the first scan's to the current one
        self._route: list[int] = []  # places still to return to (phase "return")
        self._next: int | None = None  # the I point to take at the route's end
        self._goal: FloatArray | None = None  # where a GoTo flies
        self._yaw = 0.0  # the yaw commanded last

    # -- helpers -------------------------------------------------------------------------------------
    def _ground(self, ctx: AvoidanceContext, p: FloatArray) -> float:
        """The ground elevation under ``p``: the map's grid (as :meth:`check_setup`), else the
        terrain model's surface, else flat ground at 0 m."""
        grid = getattr(ctx.validity, "grid", None)
        if grid is not None:
            return float(np.asarray(grid.height_at(p[0:1], p[1:2])).reshape(-1)[0])
        terrain = ctx.terrain
        if terrain is not None and hasattr(terrain, "surface_height"):
            return float(np.asarray(terrain.surface_height(p[0:1], p[1:2])).reshape(-1)[0])
        return 0.0

    def _first(self, ctx: AvoidanceContext) -> None:
        """On the first picture: ``R``, the thresholds, the altitude (§V), ``S_0``."""
        pic = ctx.picture
        if not hasattr(pic, "beam_ranges"):
            raise InputError(
                "priority: the priority loop scans with rangefinders; fly it with "
                "sensor='rangefinder' (--sensor rangefinder)"
            )
        self.range_m = float(pic.range_m)
        check_range(self.range_m, self.tau)  # the stop at the cruise speed: check_setup
        self.steps = scan_steps([float(b) for b in pic.beam_bearings])
        bearings = np.asarray(pic.beam_bearings, dtype=np.float64)
        self.front = int(np.argmin(np.abs(np.vectorize(wrap)(bearings))))
        if abs(wrap(float(bearings[self.front]))) > math.radians(SLOT_SNAP_DEG):
            raise InputError("priority: the rangefinders have no beam facing forward (step 2)")
        r = self.range_m - self.tau
        if self.visited_opt is not None:
            self.visited_m = self.visited_opt
        else:  # module docstring, *Visited*
            self.visited_m = r / 2.0 if self.backtrack else r * math.sin(SLOT)
        self.loops = LoopDetector(self.visited_m)
        self.surround = Surround(self.target, r)
        self.altitude = self.flight_altitude(
            self.start, self.target, lambda p: self._ground(ctx, p)
        )
        self.target = np.array([self.target[0], self.target[1], self.altitude])
        s0 = np.array([self.start[0], self.start[1], self.altitude])
        self._append(s0)

    def _append(self, point: FloatArray) -> None:
        self.setpoints.append(np.asarray(point, dtype=np.float64).copy())
        assert self.loops is not None and self.surround is not None
        self.loops.append(point)
        self.surround.add(point)

    def _decision(
        self,
        command: Any,
        reason: str,
        *,
        end: str | None = None,
        appended: FloatArray | None = None,
        **info: Any,
    ) -> AvoidanceDecision:
        doc: dict[str, Any] = {
            "priority": self.phase,
            "setpoints": [[round(float(v), 3) for v in p] for p in self.setpoints],
        }
        if appended is not None:
            doc["appended"] = [round(float(v), 3) for v in appended]
        doc.update(info)
        if isinstance(command, YawTo | GoTo) and getattr(command, "yaw", None) is not None:
            self._yaw = float(command.yaw)  # type: ignore[arg-type]
        return AvoidanceDecision(command, reason, end, doc)

    @staticmethod
    def _speed(ctx: AvoidanceContext) -> float:
        return float(math.hypot(ctx.velocity[0], ctx.velocity[1]))

    @staticmethod
    def _yaw_of(ctx: AvoidanceContext) -> float:
        return float(ctx.state[8])

    def _end(self, outcome: str, why: str, **info: Any) -> AvoidanceDecision:
        self.phase = "end"
        return self._decision(HoldPosition(), why, end=outcome, outcome=outcome, **info)

    # -- steps ------------------------------------------------------------------------------------
    def decide(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        if self.phase == "end":
            return None
        if self.phase == "start":
            self._first(ctx)
            if self._inside(ctx):
                return self._end(START_INSIDE, "a beam reads 0 m: the start is inside an obstacle")
            return self._climb(ctx)
        if ctx.t >= self.max_flight_s:
            return self._end(FLIGHT_TIME_LIMIT, f"{ctx.t:.0f} s of flight (max_flight_s)")
        handlers = {
            "climb": self._on_climb,
            "fly": self._on_fly,
            "stopping": self._on_stopping,
            "scan": self._on_scan,
            "face": self._on_face,
            "move": self._on_move,
            "return": self._on_return,
        }
        return handlers[self.phase](ctx)

    def _here(self, ctx: AvoidanceContext) -> FloatArray:
        return np.array([ctx.position[0], ctx.position[1], self.altitude])

    def _arrived(self, ctx: AvoidanceContext) -> bool:
        assert self._goal is not None
        return (
            float(np.linalg.norm(ctx.position - self._goal)) <= ARRIVE_M
            and self._speed(ctx) <= REST_MPS
        )

    def _yawed(self, ctx: AvoidanceContext) -> bool:
        return abs(wrap(self._yaw_of(ctx) - self._yaw)) <= math.radians(YAW_TOL_DEG)

    def _climb(self, ctx: AvoidanceContext) -> AvoidanceDecision:
        """Step 1: to the altitude over S_0 (§V), facing the target."""
        s0 = self.setpoints[0]
        self._goal = s0
        self.phase = "climb"
        return self._decision(
            GoTo((float(s0[0]), float(s0[1]), float(s0[2])), bearing(s0, self.target)),
            f"step 1: to {self.altitude:.1f} m over the start, facing the target",
            appended=s0,
            altitude=self.altitude,
            range_m=self.range_m,
            tau=self.tau,
            visited_m=self.visited_m,
        )

    @staticmethod
    def _inside(ctx: AvoidanceContext) -> bool:
        """A beam starting inside an obstacle reads 0 (replay.sensors.rangefinder)."""
        return bool((np.asarray(ctx.picture.beam_ranges) <= 0.0).any())

    def _on_climb(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        if self._inside(ctx):
            return self._end(START_INSIDE, "a beam reads 0 m: the climb is inside an obstacle")
        if not (self._arrived(ctx) and self._yawed(ctx)):
            return None
        return self._go(ctx)

    def _go(self, ctx: AvoidanceContext) -> AvoidanceDecision:
        """Step 2: straight to the target (the flight stack ends the run there)."""
        self.phase = "fly"
        return self._decision(
            FollowWaypoints(np.vstack([self._here(ctx), self.target]), 1, direct=True),
            "step 2: fly to the target",
        )

    def _front(self, ctx: AvoidanceContext) -> float:
        return float(ctx.picture.beam_reach[self.front])

    def _on_fly(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        """Step 2's watch: a hit closer than R - tau and than the target stops the aircraft."""
        front = self._front(ctx)
        theta_d = float(math.hypot(*(self.target[:2] - ctx.position[:2])))
        if front < self.range_m - self.tau and front < theta_d:
            return self._stop(front, f"step 2: obstacle {front:.1f} m ahead, stop")
        return None

    def _stop(self, front: float, why: str) -> AvoidanceDecision:
        self.phase = "stopping"
        return self._decision(HoldPosition(), why, front_m=round(front, 3))

    def _on_stopping(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        """Step 3 starts at rest; the stop is appended to S."""
        if self._speed(ctx) > REST_MPS:
            return None
        here = self._here(ctx)
        self._append(here)
        if len(self.setpoints) >= self.max_setpoints:
            return self._end(SETPOINT_LIMIT, f"{len(self.setpoints)} set-points (max_setpoints)")
        return self._begin_scan(ctx, here, appended=here)

    def _begin_scan(
        self, ctx: AvoidanceContext, center: FloatArray, appended: FloatArray | None = None
    ) -> AvoidanceDecision:
        """Step 3: face the target, the scan's first yaw step."""
        assert self.loops is not None and self.surround is not None
        if self.scans >= self.max_scans:
            return self._end(SCAN_LIMIT, f"{self.scans} scans (max_scans)")
        if self.circled and self.surround.round:
            return self._end(
                CIRCLED,
                f"S went all round the target without coming {self.surround.improve_m:g} m "
                f"nearer than {self.surround.nearest:.1f} m",
                places=self.loops.places,
            )
        if self.loops.scan(center):
            return self._end(
                LOOP,
                "a scan where one was made before, no new place visited since",
                places=self.loops.places,
            )
        self.scans += 1
        self._scan = _Scan(center.copy(), bearing(center, self.target), self.steps)
        self._scan.commanded_t = ctx.t
        self.phase = "scan"
        return self._decision(
            YawTo(self._scan.yaw()),
            f"step 3: scan {self.scans}, face the target",
            appended=appended,
        )

    def _on_scan(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        """A reading when the yaw step is reached and the aircraft at rest; then the next step,
        or step 4."""
        sc = self._scan
        assert sc is not None
        pic = ctx.picture
        want = sc.yaw()
        if (
            pic.t <= sc.commanded_t
            or self._speed(ctx) > REST_MPS
            or abs(wrap(float(pic.yaw) - want)) > math.radians(YAW_TOL_DEG)
        ):
            return None
        step = sc.steps[sc.k]
        for b, bearing_b in enumerate(pic.beam_bearings):
            n = slot_of(step, float(bearing_b))
            value = float(pic.beam_reach[b])
            if n % 2 == 0:
                sc.ir[n // 2] = value
            else:
                sc.dr[n // 2] = value
            sc.courses[n] = float(pic.beam_courses[b])
        sc.k += 1
        if sc.k < len(sc.steps):
            sc.commanded_t = ctx.t
            return self._decision(
                YawTo(sc.yaw()),
                f"step 3: scan {self.scans}, yaw +{sc.steps[sc.k] * SLOT_DEG:g} deg",
            )
        return self._choose(ctx, sc)

    def _choose(self, ctx: AvoidanceContext, sc: _Scan) -> AvoidanceDecision:
        """Step 4 on the completed scan, then step 5."""
        r = self.range_m - self.tau
        points = ring(sc.center, sc.heading, r)
        theta = np.hypot(points[:, 0] - self.target[0], points[:, 1] - self.target[1])
        beam_ip, dp = possible(sc.ir, sc.dr, self.range_m, self.tau)
        readings = np.empty(N_DIRECTIONS)
        readings[0::2], readings[1::2] = sc.ir, sc.dr
        hits = hit_points(sc.center, readings, sc.courses, self.range_m)
        valid = self._valid_ways(ctx, sc.center, points)
        ip = beam_ip & keeps_clear(sc.center, points, hits, self.tau) & valid
        seen = visited(points, self.setpoints, self.visited_m)
        choice = choose(ip, dp, theta, seen, self.side, self.tie_m)
        table = {
            "center": [round(float(v), 3) for v in sc.center],
            "heading_deg": round(math.degrees(sc.heading), 4),
            "Ir": [round(float(v), 3) for v in sc.ir],
            "Dr": [round(float(v), 3) for v in sc.dr],
            "IP": [int(v) for v in ip],
            "IP_beam": [int(v) for v in beam_ip],
            "valid": [int(v) for v in valid],
            "DP": [int(v) for v in dp],
            "theta": [round(float(v), 3) for v in theta],
            "visited": [int(v) for v in seen],
            "order": list(choice.order),
            "courses_deg": [round(math.degrees(float(v)), 3) for v in sc.courses],
        }
        levels = {k: v for k, v in choice.levels.items()}
        parent = self.path[-1] if self.path else None
        self.places.append(_Place(sc.center.copy(), points, ip, dp, theta, parent))
        self.path.append(len(self.places) - 1)
        if self.backtrack and choice.level not in ("4a", "4b"):
            return self._back(ctx, scan=table, levels=levels)
        if choice.index is None:
            return self._end(
                UNREACHABLE, "step 4d: no I point is possible", scan=table, levels=levels
            )
        assert choice.index is not None
        return self._forward(
            points, sc.center, choice.index, str(choice.level), scan=table, levels=levels
        )

    def _valid_ways(
        self, ctx: AvoidanceContext, center: FloatArray, points: FloatArray
    ) -> BoolArray:
        """For each ``I`` point, whether the way there stays on the map, over measured terrain
        (unless the replay allows unknown terrain) and out of the mission's danger zones (module
        docstring, *Possible points*), sampled every ``WAY_STEP_M``; all True without a
        validity layer."""
        v = ctx.validity
        if v is None:
            return np.ones(len(points), dtype=bool)
        n = max(2, int(math.ceil((self.range_m - self.tau) / WAY_STEP_M)) + 1)
        s = np.linspace(0.0, 1.0, n)[:, None, None]
        c = np.asarray(center, dtype=np.float64)[:2]
        way = (c + s * (points - c)).reshape(-1, 2)
        pv = v.points(np.column_stack([way, np.full(len(way), self.altitude)]))
        ok = pv.on_map & (pv.known | pv.allow_unknown)
        if pv.zones.shape[1]:
            ok &= pv.zones.min(axis=1) >= 0.0
        return np.asarray(ok.reshape(n, len(points)).all(axis=0))

    def _forward(
        self, points: FloatArray, center: FloatArray, i: int, level: str, **info: Any
    ) -> AvoidanceDecision:
        """Step 5: ``I_i`` of the scan at ``center`` joins ``S``; ``I_0`` resumes step 2, another
        is flown to."""
        if side_of(i):
            self.side = side_of(i)
        point = np.array([points[i, 0], points[i, 1], self.altitude])
        self._append(point)
        info.update(chosen=i, level=level)
        if len(self.setpoints) >= self.max_setpoints:
            return self._end(
                SETPOINT_LIMIT, f"{len(self.setpoints)} set-points (max_setpoints)", **info
            )
        heading = bearing(center, self.target)
        if i == 0:  # step 5: I_0 -> step 2, facing the target again first
            self.phase = "face"
            return self._decision(
                YawTo(heading),
                f"step {level}: I_0, face the target and fly on",
                appended=point,
                **info,
            )
        self.phase = "move"
        self._goal = point
        return self._decision(
            GoTo((float(point[0]), float(point[1]), float(point[2])), bearing(center, point)),
            f"step {level}: I_{i}, fly to it",
            appended=point,
            **info,
        )

    def _open(self, place: _Place) -> Choice:
        """Steps 4a-4b on a place's scan with ``S`` as it is now."""
        seen = visited(place.points, self.setpoints, self.visited_m)
        return choose(place.ip & ~seen, place.dp, place.theta, seen, self.side, self.tie_m)

    def _back(self, ctx: AvoidanceContext, **info: Any) -> AvoidanceDecision:
        """Step 4 as a search (module docstring): nothing unvisited is possible here, so return
        along the places of the path to the latest one whose scan still has an unvisited
        possible ``I`` point; none left anywhere: the target is unreachable."""
        route: list[int] = []
        for k in reversed(self.path[:-1]):
            route.append(k)
            choice = self._open(self.places[k])
            if choice.index is not None:
                self._route = route
                self._next = choice.index
                self.phase = "return"
                info["back"] = {
                    "to": k,
                    "route": [[round(float(v), 3) for v in self.places[j].center] for j in route],
                    "next": choice.index,
                }
                return self._go_back(
                    ctx,
                    f"step 4: nothing new here; back {len(route)} place(s) along S to "
                    f"I_{choice.index} of place {k}",
                    **info,
                )
        return self._end(
            UNREACHABLE,
            f"step 4d: no unvisited I point is possible at any of the {len(self.places)} "
            "places scanned",
            **info,
        )

    def _go_back(self, ctx: AvoidanceContext, why: str, **info: Any) -> AvoidanceDecision:
        center = self.places[self._route[0]].center
        self._goal = center
        return self._decision(
            GoTo(
                (float(center[0]), float(center[1]), float(center[2])),
                bearing(ctx.position, center),
            ),
            why,
            **info,
        )

    def _on_return(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        """Back along the path, place by place; at the route's end the chosen point."""
        assert self._goal is not None and self.surround is not None
        if not self._arrived(ctx):
            return self._watch(ctx, beyond=0.0)
        k = self._route.pop(0)
        while self.path and self.path[-1] != k:
            self.path.pop()
        self.surround.add(self.places[k].center)
        if self._route:
            return self._go_back(ctx, f"step 4: back along S, place {self._route[0]}")
        assert self._next is not None
        place = self.places[k]
        i, self._next = self._next, None
        return self._forward(place.points, place.center, i, "back")

    def _on_face(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        if not self._yawed(ctx):
            return None
        return self._go(ctx)

    def _on_move(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        """Step 5: to the set-point, then stop, face the target, scan; the front beam watches
        for what the scan did not see (module docstring)."""
        assert self._goal is not None
        if self._arrived(ctx):
            return self._begin_scan(ctx, self._here(ctx))
        return self._watch(ctx)

    def _watch(
        self, ctx: AvoidanceContext, beyond: float | None = None
    ) -> AvoidanceDecision | None:
        """The front beam on the way to ``_goal``: a hit closer than ``R - tau`` and short of
        ``beyond`` past the goal (``tau``, where the set-point is to be scanned; 0 on the way
        back to a place already scanned, whose way was flown) stops the aircraft (a threat the
        scans did not see)."""
        assert self._goal is not None
        margin = self.tau if beyond is None else beyond
        remaining = float(math.hypot(*(self._goal[:2] - ctx.position[:2])))
        course = bearing(ctx.position, self._goal)
        if remaining > ARRIVE_M and abs(wrap(self._yaw_of(ctx) - course)) <= math.radians(2.0):
            front = self._front(ctx)
            if front < self.range_m - self.tau and front < remaining + margin - 0.1:
                return self._stop(front, f"step 5: obstacle {front:.1f} m ahead, stop")
        return None


__all__ = [
    "CIRCLED",
    "FLIGHT_TIME_LIMIT",
    "LOOP",
    "OUTCOMES",
    "SCAN_LIMIT",
    "SETPOINT_LIMIT",
    "START_INSIDE",
    "UNREACHABLE",
    "Choice",
    "LoopDetector",
    "PriorityAvoider",
    "Surround",
    "bearing",
    "check_range",
    "choose",
    "flanks",
    "hit_points",
    "keeps_clear",
    "possible",
    "priority_order",
    "ring",
    "scan_steps",
    "side_of",
    "slot_of",
    "stopping_distance",
    "visited",
]
