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

A multirotor climbs vertically from the launch point to the start straight above it.

Heights are the safety heights the replay judges contact by (the highest source value in each
cell, bilinear between cells), sampled every half cell.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.performance import Performance
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

    def as_dict(self) -> dict[str, Any]:
        return {
            "launch": [round(float(v), 2) for v in self.launch],
            "start": [round(float(v), 2) for v in self.start],
            "heading_deg": None if self.heading_deg is None else round(self.heading_deg, 1),
            "climb_out_m": round(self.length_m, 1),
        }


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
            "unknown terrain or a zone; launch elsewhere or give the start in the air"
        )
    _, _, h, start = best
    length = float(np.hypot(*(start[:2] - launch[:2])))
    return Takeoff(launch, start, math.degrees(h) % 360.0, length)


__all__ = ["LAUNCH_HEIGHT", "Takeoff", "plan_takeoff"]
