"""Take-off from a launch point on the ground (issue 33): where the plan's airborne start comes
from when the aircraft is launched, not already flying.

A fixed wing climbs straight out from the launch point ``L`` (1 m above the measured ground:
a catapult or hand launch at its cruise speed) at its planned climb gradient, on the heading
given, else on the best one of 72 (every 5 deg): the one that reaches a safe height soonest,
ties broken towards the goal. Along the climb-out the aircraft must stay above the terrain by
the clearance once it has climbed that high, and by at least half the height it has gained before
(an obstacle-clearance surface rising from the launch: the ground ahead may not rise towards the
aircraft faster than it climbs); it is over measured terrain, on the map and out of the zones.
The climb-out ends at ``S``, the plan's airborne start, where the aircraft first stands
``--cruise-agl`` (or the given start altitude's height) above the planner's conservative terrain
around it -- from there the planner plans as for an airborne start.

Where no straight climb-out exists (a launch in a valley narrower than the climb needs), the
fixed wing spirals over the launch: launched on a heading, it circles at once (the planned turn
radius, the climb it makes in that banked turn) until it stands ``height`` above the terrain
around, then flies on straight on that heading for one turn diameter to ``S``; the helix and
the straight piece are checked as above. The mission then starts at the launch point with a
spiral there (:class:`planner.spiral.Spiral`, entered at the launch height), and ``S`` follows.

A multirotor climbs vertically from the launch point to the start straight above it.

Heights are the safety heights the replay judges contact by (the highest source value in each
cell, bilinear between cells), sampled every half cell.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.performance import Performance
from planner.spiral import GRADIENT_MARGIN, Spiral, helix
from terrain.errors import InputError
from terrain.grid import HeightGrid

FloatArray = npt.NDArray[np.float64]
LAUNCH_HEIGHT = 1.0  # m above the measured ground: the launch
HEADINGS = 72  # the best climb-out heading is looked for every 360 / HEADINGS deg


@dataclass(frozen=True)
class Takeoff:
    """A take-off: the launch point, the airborne start it climbs to, the heading (deg from
    north, None for a vertical climb), and the climb-out's length (m, horizontal)."""

    launch: FloatArray
    start: FloatArray
    heading_deg: float | None
    length_m: float
    spiral: Spiral | None = None  # a climb spiral over the launch (at waypoint 0)
    top: float | None = None  # with a spiral: the altitude it leaves the launch point at

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "launch": [round(float(v), 2) for v in self.launch],
            "start": [round(float(v), 2) for v in self.start],
            "heading_deg": None if self.heading_deg is None else round(self.heading_deg, 1),
            "climb_out_m": round(self.length_m, 1),
        }
        if self.spiral is not None:
            out["spiral_turns"] = self.spiral.turns
        return out

    def path(self) -> FloatArray:
        """The take-off as flown (K, 3): the straight climb-out, or the helix over the launch and
        the straight piece on to the start."""
        if self.spiral is None or self.heading_deg is None or self.top is None:
            return np.vstack([self.launch, self.start])
        h = math.radians(self.heading_deg)
        q = np.array([math.sin(h), math.cos(h)])
        pts = helix(self.launch[:2], q, self.spiral, self.spiral.entry, self.top)
        return np.vstack([pts, self.start[None, :]])


def _climb_out(
    safety: HeightGrid,
    top: Any,
    launch: FloatArray,
    heading: float,
    gradient: float,
    clearance: float,
    height: float,
    fits: Any,
    limit: float,
) -> tuple[float, FloatArray] | None:
    """(length, start) of the straight climb-out on ``heading`` (rad) from ``launch``, or None
    when the terrain, the map or a zone stops it within ``limit`` m (module docstring)."""
    step = 0.5 * min(safety.cell_size)
    q = np.array([math.sin(heading), math.cos(heading)])
    d = np.arange(step, limit + step, step)
    xy = launch[:2] + d[:, None] * q
    inside = np.asarray(safety.contains(xy[:, 0], xy[:, 1]), dtype=bool)
    if not inside.all():
        n = int(np.argmin(inside))
        d, xy = d[:n], xy[:n]
    if not len(d):
        return None
    z = launch[2] + gradient * d
    ground = np.asarray(safety.height_at(xy[:, 0], xy[:, 1]), dtype=np.float64)
    gained = z - launch[2]
    need = np.minimum(clearance, 0.5 * gained)
    bad = z - ground < need
    # the start: high enough above the planner's conservative terrain around it
    ok_here = np.array([z[k] >= top(xy[k, 0], xy[k, 1]) + height for k in range(len(d))])
    done = np.flatnonzero(ok_here & (np.cumsum(bad) == 0))
    if not done.size:
        return None
    k = int(done[0])
    start = np.array([xy[k, 0], xy[k, 1], z[k]])
    line = np.vstack([launch, start])
    if not fits(line):
        return None
    return float(d[k]), start


def plan_takeoff(
    grid: HeightGrid,
    launch_xy: tuple[float, float],
    goal_xy: tuple[float, float],
    perf: Performance,
    clearance: float,
    height: float,
    top: Any,
    fits: Any,
    heading_deg: float | None = None,
) -> Takeoff:
    """The take-off from ``launch_xy`` (module docstring): ``height`` above the conservative
    terrain ``top(x, y)`` is where the climb-out ends; ``fits(points (2, 3)) -> bool`` checks the
    climb-out against the map, unknown terrain and zones. One-line errors name what stops it."""
    safety = grid.safety()
    x, y = float(launch_xy[0]), float(launch_xy[1])
    ground = float(np.asarray(safety.height_at(x, y)).reshape(-1)[0])
    launch = np.array([x, y, ground + LAUNCH_HEIGHT])
    if perf.hover:
        z = max(top(x, y) + height, launch[2] + clearance)
        return Takeoff(launch, np.array([x, y, z]), None, 0.0)
    span = math.hypot(*(np.subtract(goal_xy, (x, y))))
    limit = max(2000.0, min(0.5 * span, 20000.0))
    toward = math.atan2(goal_xy[0] - x, goal_xy[1] - y)
    if heading_deg is not None:
        headings = [math.radians(float(heading_deg))]
    else:
        headings = [toward + 2.0 * math.pi * k / HEADINGS for k in range(HEADINGS)]
    best: tuple[float, float, float, FloatArray] | None = None
    for h in headings:
        got = _climb_out(
            safety, top, launch, h, perf.climb_gradient, clearance, height, fits, limit
        )
        if got is None:
            continue
        off = abs(math.remainder(h - toward, 2.0 * math.pi))
        key = (round(got[0], -1), off)  # soonest safe (to 10 m), then towards the goal
        if best is None or key < (best[0], best[1]):
            best = (key[0], key[1], h, got[1])
    if best is None and heading_deg is None:
        spiral = _spiral_takeoff(safety, top, launch, perf, clearance, height, fits, toward)
        if spiral is not None:
            return spiral
    if best is None:
        what = (
            f"on heading {float(heading_deg):g} deg"
            if heading_deg is not None
            else "on any heading (every 5 deg)"
        )
        raise InputError(
            f"no take-off from the launch point ({x:.0f}, {y:.0f}, ground {ground:.0f} m): "
            f"climbing straight out {what} at {100 * perf.climb_gradient:.1f} % the "
            f"{perf.name} does not reach {height:g} m above the terrain within "
            f"{limit / 1000:.1f} km without the ground rising into its climb, the map's edge, "
            "unknown terrain or a zone, nor spiral up over the launch; launch elsewhere or give "
            "the start in the air"
        )
    _, _, h, start = best
    length = float(np.hypot(*(start[:2] - launch[:2])))
    return Takeoff(launch, start, math.degrees(h) % 360.0, length)


def _spiral_takeoff(
    safety: HeightGrid,
    top: Any,
    launch: FloatArray,
    perf: Performance,
    clearance: float,
    height: float,
    fits: Any,
    toward: float,
    heading: float | None = None,
) -> Takeoff | None:
    """The take-off spiralling over the launch (module docstring), or None where no helix of
    the turn radius climbs clear on ``heading`` (rad), else on 16 headings (towards the goal
    first), on either side."""
    radius = perf.turn_radius
    rate = GRADIENT_MARGIN * perf.turn_climb_gradient
    run = 2.0 * radius  # then straight on for one turn diameter to the plan's start
    # towards the goal, then 22.5 deg either side of it, 45 deg ... (the opposite last)
    headings = (
        [heading]
        if heading is not None
        else [toward + ((k + 1) // 2) * (1.0 if k % 2 else -1.0) * math.pi / 8.0 for k in range(16)]
    )
    for h in headings:
        q = np.array([math.sin(h), math.cos(h)])
        s_xy = launch[:2] + run * q
        if not bool(np.asarray(safety.contains(s_xy[0], s_xy[1])).all()):
            continue
        # the altitude it leaves the circle at: height above the terrain round the launch and
        # round the start, less the straight piece's climb
        z_top = max(top(launch[0], launch[1]), top(s_xy[0], s_xy[1]) - perf.climb_gradient * run)
        z_top = max(z_top + height, launch[2] + clearance)
        turns = max(1, math.ceil((z_top - launch[2]) / (2.0 * math.pi * radius * rate)))
        for clockwise in (False, True):
            sp = Spiral(0, float(launch[2]), turns, radius, clockwise)
            pts = helix(launch[:2], q, sp, float(launch[2]), z_top)
            start = np.array([s_xy[0], s_xy[1], z_top + perf.climb_gradient * run])
            pts = np.vstack([pts, start[None, :]])
            ground = np.asarray(safety.height_at(pts[:, 0], pts[:, 1]), dtype=np.float64)
            if not (
                pts[:, 2] - ground >= np.minimum(clearance, 0.5 * (pts[:, 2] - launch[2]))
            ).all():
                continue
            if not _dense_ok(safety, pts, launch[2], clearance) or not fits(pts):
                continue
            return Takeoff(
                launch,
                start,
                math.degrees(h) % 360.0,
                2.0 * math.pi * radius * turns + run,
                sp,
                z_top,
            )
    return None


MAX_LANDING_SLOPE = 0.10  # the steepest ground (rise over run) a landing point may have
MAX_GLIDE = math.tan(math.radians(6.0))  # the steepest final approach planned


@dataclass(frozen=True)
class Landing:
    """A landing: the touchdown point (1 m above the measured ground), the approach fix it is
    approached from -- the plan's goal -- the approach heading (deg from north, the direction
    of travel; None for a multirotor's vertical descent), the glide gradient, and the
    go-around altitude (the fix's, m AMSL)."""

    touchdown: FloatArray
    fix: FloatArray
    heading_deg: float | None
    glide: float
    go_around: float

    def as_dict(self) -> dict[str, Any]:
        return {
            "touchdown": [round(float(v), 2) for v in self.touchdown],
            "approach_fix": [round(float(v), 2) for v in self.fix],
            "heading_deg": None if self.heading_deg is None else round(self.heading_deg, 1),
            "glide_gradient": round(self.glide, 5),
            "go_around_altitude": round(self.go_around, 2),
        }

    def path(self) -> FloatArray:
        """The final approach as flown: the fix, then the touchdown point."""
        return np.vstack([self.fix, self.touchdown])


def ground_slope(safety: HeightGrid, x: float, y: float) -> float:
    """The ground's slope (rise over run) at a map point: the largest of the height differences
    to the eight neighbouring cells over their distance."""
    r, c = (int(v) for v in safety.cell_of(x, y))
    h = np.asarray(safety.heights, dtype=np.float64)
    dx, dy = safety.cell_size
    worst = 0.0
    for i in (-1, 0, 1):
        for j in (-1, 0, 1):
            rr, cc = r + i, c + j
            if (i or j) and 0 <= rr < h.shape[0] and 0 <= cc < h.shape[1]:
                worst = max(worst, abs(h[rr, cc] - h[r, c]) / math.hypot(i * dy, j * dx))
    return worst


def plan_landing(
    grid: HeightGrid,
    touch_xy: tuple[float, float],
    from_xy: tuple[float, float],
    perf: Performance,
    clearance: float,
    height: float,
    top: Any,
    fits: Any,
    heading_deg: float | None = None,
) -> Landing:
    """The landing at ``touch_xy`` (module docstring, mirrored: the final approach descends at
    the glide gradient -- the planned descent gradient, at most 6 deg -- above the same
    obstacle-clearance surface, now falling towards the touchdown); the fix is where, flying
    back from the touchdown, the approach first stands ``height`` above the conservative
    terrain ``top``. The heading: the one given, else the one closest to the arrival from
    ``from_xy`` (then the shortest approach) that fits. One-line errors: a landing point on a
    slope steeper than ``MAX_LANDING_SLOPE``, no approach."""
    safety = grid.safety()
    x, y = float(touch_xy[0]), float(touch_xy[1])
    slope = ground_slope(safety, x, y)
    if slope > MAX_LANDING_SLOPE:
        raise InputError(
            f"the landing point ({x:.0f}, {y:.0f}) lies on a {100 * slope:.0f} % slope: a "
            f"landing needs ground of at most {100 * MAX_LANDING_SLOPE:.0f} %; choose a flatter "
            "landing point"
        )
    ground = float(np.asarray(safety.height_at(x, y)).reshape(-1)[0])
    touch = np.array([x, y, ground + LAUNCH_HEIGHT])
    if perf.hover:
        z = max(top(x, y) + height, touch[2] + clearance)
        fix = np.array([x, y, z])
        return Landing(touch, fix, None, math.inf, float(z))
    glide = min(GRADIENT_MARGIN * perf.descent_gradient, MAX_GLIDE)
    arrival = math.atan2(x - from_xy[0], y - from_xy[1])
    if heading_deg is not None:
        headings = [math.radians(float(heading_deg))]
    else:
        headings = [arrival + 2.0 * math.pi * k / HEADINGS for k in range(HEADINGS)]
    best: tuple[float, float, float, FloatArray] | None = None
    for h in headings:
        # flown back from the touchdown: the approach is the climb-out of the reverse heading
        got = _climb_out(safety, top, touch, h + math.pi, glide, clearance, height, fits, 20000.0)
        if got is None:
            continue
        off = abs(math.remainder(h - arrival, 2.0 * math.pi))
        key = (round(off, 1), got[0])
        if best is None or key < (best[0], best[1]):
            best = (key[0], key[1], h, got[1])
    if best is None:
        what = (
            f"on heading {float(heading_deg):g} deg"
            if heading_deg is not None
            else "from any heading"
        )
        raise InputError(
            f"no approach to the landing point ({x:.0f}, {y:.0f}, ground {ground:.0f} m) "
            f"{what}: descending at {100 * glide:.1f} % the {perf.name} meets the terrain, the "
            "map's edge, unknown terrain or a zone before it is clear of the terrain around; "
            "choose another landing point or --land-heading"
        )
    _, _, h, fix = best
    return Landing(touch, fix, math.degrees(h) % 360.0, glide, float(fix[2]))


def _dense_ok(safety: HeightGrid, pts: FloatArray, z0: float, clearance: float) -> bool:
    """The obstacle-clearance surface between the points too (every half cell)."""
    step = 0.5 * min(safety.cell_size)
    for a, b in itertools.pairwise(pts):
        n = max(2, int(math.ceil(float(np.hypot(*(b[:2] - a[:2]))) / step)) + 1)
        t = np.linspace(0.0, 1.0, n)[:, None]
        p = a + t * (b - a)
        ground = np.asarray(safety.height_at(p[:, 0], p[:, 1]), dtype=np.float64)
        if not (p[:, 2] - ground >= np.minimum(clearance, 0.5 * (p[:, 2] - z0)) - 1e-9).all():
            return False
    return True


__all__ = ["LAUNCH_HEIGHT", "Landing", "Takeoff", "ground_slope", "plan_landing", "plan_takeoff"]
