"""An example terrapath plugin: the ``sidestep`` avoider and the ``on-the-path`` generator.

``sidestep`` is deliberately simple -- a rule, not an optimiser: at each radar scan it looks at
the threat returns ahead on the leg being flown; when one lies within ``keep_m`` of the leg, it
gathers the returns chained to it (closer than two ``keep_m``: one obstacle, as a hill's points
are), and inserts one waypoint abreast of that group, ``keep_m + margin_m`` beyond its farther
return on the side that needs the shorter step (the other side when the validity checker
refuses the first). A waypoint of the mission inside the group's keep distance is dropped (it
cannot be reached safely). A new step replaces the one it is flying to, if any. It ignores the returns the radar classifies as moving: it promises only the contract's static
scenarios.

What the loop gives it (:class:`replay.avoidance.base.AvoidanceContext`): the time, the
aircraft's position and velocity, the radar picture (``positions`` of its ``n_threat`` threat
returns first), the waypoint list and the index flown to, and ``validity`` (terrain, map edge,
danger zones). What it returns: an :class:`replay.guidance.AvoidanceDecision` carrying a
:class:`replay.guidance.FollowWaypoints`, or None (nothing to change).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from replay.avoidance import AvoidanceContext, AvoidanceDecision, AvoiderBase
from replay.guidance import FollowWaypoints
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
__version__ = "0.1.0"


class SidestepAvoider(AvoiderBase):
    """One waypoint beside each static obstacle on the leg (an example plugin)."""

    name = "sidestep"
    summary = "example plugin: one waypoint beside each static obstacle on the leg"
    sensors = ("radar",)  # it reads the radar's threat returns
    OPTION_HELP = {  # noqa: RUF012 - read by `terrapath replay --help-avoider sidestep`
        "keep_m": "distance (m) kept from each radar return's centre",
        "margin_m": "added to keep_m where the waypoint is put (corners are cut)",
    }

    def __init__(self, keep_m: float = 1000.0, margin_m: float = 300.0) -> None:
        for what, v in (("keep_m", keep_m), ("margin_m", margin_m)):
            if isinstance(v, bool) or not isinstance(v, int | float) or not 0 <= v < math.inf:
                raise InputError(f"sidestep option {what} must be a number >= 0; got {v!r}")
        self.keep_m = float(keep_m)
        self.margin_m = float(margin_m)

    def reset(self, waypoints: FloatArray, rng: np.random.Generator) -> None:
        self._steps: list[FloatArray] = []  # the waypoints it put (no randomness)

    def point_keep_m(self) -> tuple[float, float] | None:
        return (self.keep_m, self.keep_m)

    def decide(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        n = int(getattr(ctx.picture, "n_threat", 0))
        k = ctx.next_index
        if n == 0 or k >= len(ctx.waypoints):
            return None
        target = ctx.waypoints[k]
        # flying to a step of its own: a new step replaces it (steps do not pile up)
        replacing = any(np.array_equal(target, p) for p in self._steps)
        # the static returns only: it does not predict moving ones (the radar tells them apart
        # after two scans; -1, not yet known, counts as static)
        static = np.asarray(ctx.picture.moving_code[:n]) != 1
        returns = np.asarray(ctx.picture.positions, dtype=np.float64)[:n, :2][static]
        if not len(returns):
            return None
        here = np.asarray(ctx.position, dtype=np.float64)
        # the leg as the autopilot flies it: from the previous waypoint to the next
        start = ctx.waypoints[k - 1, :2] if k > 0 else here[:2]
        leg = target[:2] - start
        length = float(np.hypot(*leg))
        if length < 1.0:
            return None
        along = leg / length
        left = np.array([-along[1], along[0]])
        rel = returns - start
        s, c = rel @ along, rel @ left  # along the leg, and to its left
        ahead = float((here[:2] - start) @ along)
        blocking = (s > ahead) & (s < length + self.keep_m) & (np.abs(c) < self.keep_m)
        if not blocking.any():
            return None
        first = int(np.flatnonzero(blocking)[np.argmin(s[blocking])])
        group = _chained(returns, first, self.keep_m)
        step = self.keep_m + self.margin_m
        sides = sorted((float(c[group].max() + step), float(c[group].min() - step)), key=abs)
        at = float(s[group].mean())
        for offset in sides:
            p = start + at * along + offset * left
            point = np.array([p[0], p[1], target[2]])
            if ctx.validity is None or bool(ctx.validity.is_valid(point[None, :])[0]):
                break
        else:
            return AvoidanceDecision(reason="sidestep: neither side of the obstacle is valid")
        rest = ctx.waypoints[k + 1 :] if replacing else ctx.waypoints[k:]
        # a waypoint inside the obstacle's keep distance cannot be reached: dropped (not the goal)
        near = np.hypot(*(rest[:, None, :2] - returns[None, group]).T).min(axis=0) < self.keep_m
        near[-1] = False
        # the new leg starts where the aircraft is (a waypoint there), then passes the obstacle
        wps = np.vstack([ctx.waypoints[:k], here[None, :], point[None, :], rest[~near]])
        self._steps.append(point)
        return AvoidanceDecision(
            FollowWaypoints(wps, next_index=k + 1),
            reason=f"sidestep {offset:+.0f} m beside {len(group)} return(s) at {at:.0f} m",
            info={"offset_m": offset, "returns": len(group), "dropped": int(near.sum())},
        )


def _chained(points: FloatArray, first: int, keep: float) -> list[int]:
    """The indices of the points chained to ``first`` by links shorter than 2 ``keep``."""
    group, todo = {first}, [first]
    while todo:
        i = todo.pop()
        d = np.hypot(*(points - points[i]).T)
        for j in np.flatnonzero(d < 2.0 * keep):
            if int(j) not in group:
                group.add(int(j))
                todo.append(int(j))
    return sorted(group)


def on_the_path(
    mission: Any, count: int, rng: np.random.Generator, params: Any
) -> list[dict[str, Any]]:
    """``count`` static obstacles on the mission's legs (an example campaign generator)."""
    w = np.asarray(mission.waypoints, dtype=np.float64)
    legs = np.diff(w[:, :2], axis=0)
    lengths = np.hypot(*legs.T)
    out = []
    for k in range(count):
        i = int(rng.choice(len(legs), p=lengths / lengths.sum()))
        f = float(rng.uniform(0.3, 0.7))
        x, y = w[i, :2] + f * legs[i]
        z = float(params.altitude) if params.altitude is not None else float(w[i, 2])
        out.append(
            {"id": f"path{k + 1}", "kind": "static", "position": [x, y, z], "radius": params.radius}
        )
    return out


__all__ = ["SidestepAvoider", "on_the_path"]
