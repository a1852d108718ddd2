"""FGA's manoeuvre planning (Lin, Castano & Xu; seed 004 §III): for the obstacles within the
surveillance radius, the encounter each course leads to, the critical avoidance time of eq 7-8,
and the manoeuvre a decision starts -- the smallest course change onto a cone's edge (the
heading plan), a climb or descent over or under the obstacle (the pitch plan), the check that a
start one period later would come too late, the kinematic turn's least separation, and the
escape when no course is free. :class:`replay.avoidance.fga.FgaAvoider` decides with a
:class:`FgaPlanner`; the cone geometry is :mod:`replay.avoidance.fga_geometry`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import numpy.typing as npt

from replay.avoidance.base import AvoidanceContext
from replay.avoidance.fga_geometry import (
    Encounter,
    FgaObstacle,
    climb_time,
    climbed,
    conflict_matrix,
    encounter,
    flips,
    in_conflict,
    interval_disk,
    pass_side,
    path_separation,
    tangent_course,
    tangent_courses,
)
from replay.flight.base import G
from replay.flight.fixedwing.gains import LoopDesign
from replay.frames import wrap

FloatArray = npt.NDArray[np.float64]

FAN_DEG = 5.0  # the course fan searched when no cone edge is free
CLIMB_MARGIN = 0.9  # the fraction of the climb / descent limit the plan counts on
FORMATION_MPS = 3.0  # a course this slow relative to a moving obstacle flies alongside it
TURN_CHECKS = 12  # the cheapest free courses whose turns are flown kinematically
UNSAFE_PENALTY = 1000.0  # rad: a course off the map or into a zone after every one that is not


@dataclass
class Plan:
    plane: str
    side: int
    course: float
    altitude: float | None
    cost: float
    t_c: float
    governing: str
    why: str
    free: bool  # clear of every obstacle within R
    costs: dict[str, float] = field(default_factory=dict)


# -- geometry helpers ----------------------------------------------------------------------
def limits(ctx: AvoidanceContext) -> tuple[float, float]:
    """(rho, psi_dot_max) of the aircraft now: its minimum turn radius and turn rate."""
    speed = max(float(ctx.airspeed), 1e-3)
    tan_bank = math.tan(math.radians(float(getattr(ctx.vehicle, "bank_max_deg", 30.0))))
    return speed * speed / (G * tan_bank), G * tan_bank / speed


def climb_limits(params: Any) -> tuple[float, float]:
    """(climb, descent) rates the autopilot commands at most: the vehicle's limits less
    its climb margin."""
    inside = 1.0 - LoopDesign.climb_margin
    return (
        inside * float(getattr(params, "climb_rate_max", 3.0)),
        inside * float(getattr(params, "descent_rate_max", 2.0)),
    )


def velocity(course: float, horizontal: float, climb: float) -> FloatArray:
    return np.array([horizontal * math.sin(course), horizontal * math.cos(course), climb])


def ground(ctx: AvoidanceContext, pos: FloatArray) -> float:
    terrain = ctx.terrain
    if terrain is None:
        return 0.0
    try:
        h = float(np.asarray(terrain.height_at(pos[0:1], pos[1:2])).reshape(-1)[0])
    except Exception:  # a terrain without heights here: the floor is not lowered
        return float(pos[2])
    return h if math.isfinite(h) else float(pos[2])


class FgaPlanner:
    """The manoeuvres FGA plans with its settings: the minimum separation ``d_m`` and the
    ``buffer_m`` the manoeuvres steer beyond it, the prediction ``horizon_s``, the response time
    ``t_res``, the lowest height ``floor_m`` a descent may reach and the decision ``period``."""

    def __init__(
        self,
        d_m: float,
        buffer_m: float,
        horizon_s: float,
        t_res: float,
        floor_m: float,
        period: float,
    ) -> None:
        self.d_m = d_m
        self.buffer_m = buffer_m
        self.horizon_s = horizon_s
        self.t_res = t_res
        self.floor_m = floor_m
        self.period = period

    def encounter(
        self, pos: FloatArray, vel: FloatArray, o: FgaObstacle, rho: float, extra: float = 0.0
    ) -> Encounter:
        keep = self.d_m + self.buffer_m + extra
        return encounter(pos, vel, o, keep_h=keep, keep_v=keep, rho=rho, horizon=self.horizon_s)

    def critical(
        self, pos: FloatArray, vel: FloatArray, course: float, o: FgaObstacle, rho: float
    ) -> Encounter:
        """The encounter with eq 7's ``t_c`` for the turn this obstacle needs: ``rho`` is the
        distance flown while turning one radian; a turn of more than a radian onto the nearest
        edge of the cone (a fast obstacle nearly head-on) takes proportionally longer."""
        horizontal = float(math.hypot(vel[0], vel[1]))
        keep = o.radius + self.d_m + 2.0 * self.buffer_m
        turns = [
            abs(wrap(c - course))
            for c in (tangent_course(pos, o, keep, horizontal, s) for s in (1, -1))
            if c is not None
        ]
        need = max(1.0, min(turns, default=math.pi))
        k = self.d_m + self.buffer_m
        e = encounter(
            pos,
            vel,
            o,
            keep_h=k,
            keep_v=k,
            rho=rho * need,
            horizon=self.horizon_s,
            speed=max(horizontal, 1e-3),
        )
        if e.window is None:
            return e
        # eq 7 takes the obstacle small against the turn; a large one's protected volume is
        # entered before eq 7's point: start no later than the entry less the turn's time
        turn_rate = horizontal / max(rho, 1e-9)
        entry = e.window[0] - need / turn_rate - self.t_res
        return replace(e, t_c=min(e.t_c, entry)) if entry < e.t_c else e

    def conflicting(
        self, pos: FloatArray, vel: FloatArray, near: list[FgaObstacle], extra: float = 0.0
    ) -> Iterator[FgaObstacle]:
        """The obstacles of ``near`` the aircraft flying ``vel`` is in conflict with (lazily)."""
        x, y, z = float(pos[0]), float(pos[1]), float(pos[2])
        vx, vy, vz = float(vel[0]), float(vel[1]), float(vel[2])
        keep, horizon = self.d_m + self.buffer_m + extra, self.horizon_s
        return (o for o in near if in_conflict(x, y, z, vx, vy, vz, o, keep, horizon))

    def clear(
        self,
        pos: FloatArray,
        vel: FloatArray,
        near: list[FgaObstacle],
        rho: float,
        extra: float = 0.0,
    ) -> bool:
        return next(self.conflicting(pos, vel, near, extra), None) is None

    def conflicts(
        self, pos: FloatArray, vel: FloatArray, near: list[FgaObstacle]
    ) -> list[FgaObstacle]:
        return list(self.conflicting(pos, vel, near))

    # -- planning ------------------------------------------------------------------------------
    @staticmethod
    def first(
        pos: FloatArray, targets: list[Encounter], near: list[FgaObstacle]
    ) -> FgaObstacle | None:
        """The obstacle a manoeuvre steers round: of the conflicts, the one whose protected
        volume is entered first (a fast intruder crossing ahead comes before a nearer one
        overtaking slowly from behind); without conflicts, the nearest obstacle."""
        timed = [e for e in targets if e.window is not None]
        if timed:
            return min(timed, key=lambda e: e.window[0] if e.window else math.inf).obstacle
        return min(
            [e.obstacle for e in targets] or near,
            key=lambda o: math.hypot(o.center[0] - pos[0], o.center[1] - pos[1]) - o.radius,
            default=None,
        )

    def heading_plan(
        self,
        pos: FloatArray,
        vel: FloatArray,
        course: float,
        targets: list[Encounter],
        near: list[FgaObstacle],
        rho: float,
        turn_rate: float,
        keep_side: tuple[FgaObstacle, int] | None = None,
        flown_from: float | None = None,
        bad: Callable[[FloatArray], FloatArray] | None = None,
    ) -> Plan | None:
        """The smallest course change outside the union of the cones of ``near`` (module
        docstring); None when no course is free.  ``keep_side`` (an obstacle and a side): a
        manoeuvre under way keeps passing that obstacle on the same side when it can (a course
        that flips to the other side crosses its cone).  ``flown_from`` (the aircraft's course
        now): the turn onto the course is flown kinematically (:meth:`FgaPlanner.turn_separation`) and
        the cheapest course whose turn keeps ``d_m + buffer_m / 2`` is taken -- else the one
        whose turn keeps the most.  ``bad`` (courses -> metres): how far the course held leaves
        the map or runs through danger zones; a course with none is taken before any with some,
        and when every free course has some the least is flown and the plan says so (``why``,
        ``costs["unsafe_m"]``)."""
        horizontal = float(math.hypot(vel[0], vel[1]))
        keep = self.d_m + 2.0 * self.buffer_m
        candidates: list[tuple[float, int, str]] = []
        seen = {e.obstacle.key: e.obstacle for e in targets}
        for o in near:
            seen.setdefault(o.key, o)
        for o in seen.values():
            for side in (1, -1):
                for c in tangent_courses(pos, o, o.radius + keep, horizontal, side):
                    candidates.append((c, side, o.key))
        # a fan besides the edges: the nearest free course need not lie on an edge (an obstacle
        # overtaking from behind leaves every course ahead free, and its edges point back)
        # the fan's courses resolve the nearest obstacle in conflict (the one steered round; its
        # side is worked out below for the course chosen, as for another obstacle's edge)
        first = self.first(pos, targets, list(seen.values()))
        if first is not None:
            for k in range(1, int(180 / FAN_DEG) + 1):
                for sgn in (1, -1):
                    candidates.append((wrap(course + sgn * math.radians(FAN_DEG * k)), 0, ""))
        free = []
        # clear by half a buffer more than the conflict test calls: a course chosen right at
        # another obstacle's threshold would be called in conflict again at the next decision
        courses = np.array([c for c, _side, _key in candidates], dtype=np.float64)
        velocities = np.column_stack(
            [
                horizontal * np.sin(courses),
                horizontal * np.cos(courses),
                np.full(len(courses), float(vel[2])),
            ]
        )
        keep_clear = self.d_m + 1.5 * self.buffer_m
        blocked = np.any(
            conflict_matrix(pos, velocities, near, keep_clear, self.horizon_s), axis=1
        ).tolist()
        # flying alongside an obstacle (hardly any relative speed) never resolves: the encounter
        # is only put off -- taken only when nothing else is free
        moving = np.array([o.velocity[:2] for o in seen.values() if o.moving], dtype=np.float64)
        alongside = (
            np.hypot(
                velocities[:, 0:1] - moving[None, :, 0], velocities[:, 1:2] - moving[None, :, 1]
            ).min(axis=1)
            < FORMATION_MPS
            if len(moving)
            else np.zeros(len(candidates), dtype=bool)
        )
        for (c, side, key), v, hit, slow in zip(
            candidates, velocities, blocked, alongside, strict=True
        ):
            if not hit:
                penalty = 5.0 if slow else 0.0
                if keep_side is not None and flips(pos, v, *keep_side):
                    penalty += 10.0
                free.append((abs(wrap(c - course)) + penalty, c, side, key))
        if not free:
            return None
        unsafe = dict.fromkeys([f[1] for f in free], 0.0)
        if bad is not None:
            metres = bad(np.array(list(unsafe), dtype=np.float64))
            unsafe = dict(zip(unsafe, metres.tolist(), strict=True))
            free = [(f[0] + (UNSAFE_PENALTY if unsafe[f[1]] > 0 else 0.0), *f[1:]) for f in free]
        free.sort()
        if flown_from is None:
            _, c, side, key = free[0]
        else:
            best: tuple[float, tuple[float, float, int, str]] | None = None
            for item in free[:TURN_CHECKS]:
                sep, _k = self.turn_separation(
                    pos, vel, flown_from, item[1], self.t_res, near, turn_rate
                )
                if sep >= self.d_m + 0.5 * self.buffer_m:
                    best = (math.inf, item)
                    break
                if best is None or sep > best[0]:
                    best = (sep, item)
            assert best is not None
            _, c, side, key = best[1]
        if first is not None and key != first.key:
            # the course is another obstacle's edge or the fan's: the manoeuvre still steers
            # round the nearest obstacle in conflict, on the side this course passes it
            key, side = first.key, pass_side(pos, velocity(c, horizontal, 0.0), first)
        turn = wrap(c - course)
        cost = self.t_res + abs(turn) / turn_rate
        t_c = min((e.t_c for e in targets), default=math.inf)
        why = f"steer {'right' if turn > 0 else 'left'} {abs(math.degrees(turn)):.0f} deg"
        costs = {"heading_s": cost}
        if unsafe[c] > 0:  # no free course keeps to the map and out of the zones
            why += (
                f"; no safe course: every free course leaves the map or enters a zone "
                f"(this one {unsafe[c]:.0f} m), the least flown"
            )
            costs["unsafe_m"] = unsafe[c]
        return Plan("heading", side, c, None, cost, t_c, key, why, True, costs)

    def pitch_plan(
        self,
        ctx: AvoidanceContext,
        pos: FloatArray,
        vel: FloatArray,
        course: float,
        targets: list[Encounter],
        near: list[FgaObstacle],
        rho: float,
    ) -> Plan | None:
        """Climb (or descend) clear of every target's vertical interval before its horizontal
        entry, course unchanged (module docstring); None when not feasible."""
        up, down = (CLIMB_MARGIN * r for r in climb_limits(ctx.vehicle))
        z = float(pos[2])
        keep = self.d_m + 2.0 * self.buffer_m
        best: Plan | None = None
        for side in (1, -1):
            rate = up if side > 0 else -down
            need = z
            latest = math.inf
            ok = True
            for e in targets:
                o = e.obstacle
                assert e.window is not None
                wz = o.velocity[2]
                h = interval_disk(
                    o.center[0] - float(pos[0]),
                    o.center[1] - float(pos[1]),
                    float(vel[0]) - o.velocity[0],
                    float(vel[1]) - o.velocity[1],
                    o.radius + keep,
                )
                if h is None:
                    continue
                enter, leave = max(h[0], 0.0), h[1]
                for t in (enter, leave):
                    goal = (o.top + keep + wz * t) if side > 0 else (o.bottom - keep + wz * t)
                    if not math.isfinite(goal):
                        ok = False
                        break
                    reach = z + climbed(rate, t)
                    if (side > 0 and reach < goal) or (side < 0 and reach > goal):
                        ok = False
                        break
                    need = max(need, goal) if side > 0 else min(need, goal)
                    # the latest start from which the climb at the limit still gets there
                    lo_t, hi_t = 0.0, t
                    for _ in range(30):  # bisection: beyond the goal (above it climbing,
                        # below it descending) when the climb starts at mid
                        mid = 0.5 * (lo_t + hi_t)
                        there = z + float(vel[2]) * mid + climbed(rate, t - mid)
                        if (there - goal) * side >= 0.0:
                            lo_t = mid
                        else:
                            hi_t = mid
                    latest = min(latest, lo_t)
                if not ok:
                    break
            if not ok:
                continue
            if side < 0 and need - ground(ctx, pos) < self.floor_m:
                continue
            target = need + side * self.buffer_m
            v = np.array([vel[0], vel[1], rate])
            if not self.clear(
                pos, v, [o for o in near if o.key not in {e.obstacle.key for e in targets}], rho
            ):
                continue
            cost = climb_time(rate, abs(need - z))
            plan = Plan(
                "pitch",
                side,
                course,
                target,
                cost,
                latest,
                targets[0].obstacle.key,
                f"pitch {'up' if side > 0 else 'down'} to {target:.0f} m",
                True,
                {"pitch_s": cost},
            )
            if best is None or plan.cost < best.cost:
                best = plan
        return best

    def late_by(
        self,
        ctx: AvoidanceContext,
        pos: FloatArray,
        vel: FloatArray,
        course: float,
        near: list[FgaObstacle],
        rho: float,
        turn_rate: float,
    ) -> tuple[float, str] | None:
        """Whether a heading manoeuvre started one decision period from now would come too
        late: the turn flown kinematically -- straight for ``period + t_res``, then at the
        aircraft's turn rate onto the course the heading plan chooses from there, then straight
        -- passes an obstacle within ``R`` closer than ``d_m + buffer_m / 2`` (its protected
        volume with half the margin).  Returns (the least separation, the obstacle) when it
        does, else None."""
        delay = self.period + self.t_res
        start = pos + delay * np.array([vel[0], vel[1], vel[2]])
        moved = [o.at(delay) for o in near]
        targets = [self.encounter(start, vel, o, rho) for o in self.conflicts(start, vel, moved)]
        if not targets:
            return None
        plan = self.heading_plan(start, vel, course, targets, moved, rho, turn_rate)
        if plan is None:
            return (-math.inf, targets[0].obstacle.key)
        worst = self.turn_separation(pos, vel, course, plan.course, delay, near, turn_rate)
        return worst if worst[0] < self.d_m + 0.5 * self.buffer_m else None

    def turn_separation(
        self,
        pos: FloatArray,
        vel: FloatArray,
        course: float,
        target: float,
        delay: float,
        near: list[FgaObstacle],
        turn_rate: float,
        climb: float | None = None,
    ) -> tuple[float, str]:
        """The least separation from ``near`` (the protected volume's metric: the larger of the
        horizontal and the vertical distance outside the obstacle) of the aircraft flying
        straight for ``delay``, then turning the short way at ``turn_rate`` from ``course`` onto
        ``target``, then straight for ``horizon_s`` -- its turn flown kinematically (the
        obstacles at constant velocity), and the obstacle it is least from."""
        horizontal = float(math.hypot(vel[0], vel[1]))
        start = pos + delay * np.array([vel[0], vel[1], vel[2]])
        turn = wrap(target - course)
        t_turn = abs(turn) / turn_rate
        ts = np.linspace(0.0, t_turn, 12)
        if abs(turn) > 1e-9:
            sgn = float(np.sign(turn))
            psi = course + sgn * turn_rate * ts
            arm = horizontal / turn_rate  # the turn's radius
            ax = start[0] + sgn * arm * (math.cos(course) - np.cos(psi))
            ay = start[1] + sgn * arm * (np.sin(psi) - math.sin(course))
        else:
            ax = np.full(len(ts), start[0])
            ay = np.full(len(ts), start[1])
        tail = np.linspace(0.0, self.horizon_s, 121)[1:]
        bx = ax[-1] + horizontal * math.sin(target) * tail
        by = ay[-1] + horizontal * math.cos(target) * tail
        t_all = np.concatenate([[0.0], delay + np.concatenate([ts, t_turn + tail])])
        px = np.concatenate([[pos[0]], ax, bx])
        py = np.concatenate([[pos[1]], ay, by])
        vz = float(vel[2])
        if climb is None:
            pz = float(pos[2]) + vz * t_all
        else:  # the climb (descent) the way back asks for, from the end of the delay
            pz = (
                float(pos[2])
                + vz * np.minimum(t_all, delay)
                + climb * np.maximum(t_all - delay, 0.0)
            )
        return path_separation(t_all, px, py, pz, near)

    def escape(
        self,
        pos: FloatArray,
        vel: FloatArray,
        course: float,
        near: list[FgaObstacle],
        rho: float,
    ) -> Plan:
        """No free course: the course of a 5 deg fan whose worst predicted separation is the
        largest (an obstacle that outruns the aircraft, or one already inside)."""
        horizontal = float(math.hypot(vel[0], vel[1]))
        best: tuple[float, float] | None = None
        times = np.linspace(0.0, min(self.horizon_s, 30.0), 61)
        for k in range(int(360 / FAN_DEG)):
            c = wrap(course + math.radians(FAN_DEG * k))
            own = pos[None, :] + times[:, None] * velocity(c, horizontal, 0.0)[None, :]
            worst, _key = path_separation(times, own[:, 0], own[:, 1], own[:, 2], near)
            score = worst - 1e-3 * abs(wrap(c - course))
            if best is None or score > best[0]:
                best = (score, c)
        assert best is not None
        return Plan(
            "heading", 0, best[1], None, math.inf, -math.inf, "", "escape: no free course", False
        )


__all__ = ["FgaPlanner", "Plan", "climb_limits", "ground", "limits", "velocity"]
