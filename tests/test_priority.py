"""The priority loop (seed 003, ``replay/avoidance/priority.py``): the scan table, steps 4a-4d
with the corrected flanks and the tie rule, the visited threshold and loop detection on
hand-made tables; the avoider's steps against hand-made rangefinder pictures of a kinematic
aircraft among walls (no 6-DOF: seconds)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from replay.avoidance import make_avoider
from replay.avoidance.base import AvoidanceContext
from replay.avoidance.priority import (
    CIRCLED,
    LOOP,
    N_POINTS,
    SCAN_LIMIT,
    SETPOINT_LIMIT,
    UNREACHABLE,
    LoopDetector,
    PriorityAvoider,
    Surround,
    check_range,
    choose,
    flanks,
    possible,
    priority_order,
    ring,
    scan_steps,
    side_of,
    slot_of,
    stopping_distance,
    visited,
)
from replay.flight.fixedwing.presets import load_vehicle
from replay.flight.multirotor.model import MULTIROTOR_PRESETS
from replay.guidance import FollowWaypoints, GoTo, HoldPosition, YawTo
from terrain.errors import InputError

FOUR = [0.0, 0.5 * math.pi, math.pi, -0.5 * math.pi]  # front, right, back, left
R, TAU = 20.0, 2.0


def _label(n: int) -> str:
    return f"I{n // 2}" if n % 2 == 0 else f"D{n // 2}"


# -- the scan: which reading is which ------------------------------------------------------------
def test_four_beams_fill_the_32_directions_as_section_iii_c_lists_them() -> None:
    assert scan_steps(FOUR) == tuple(range(8))  # 0, 11.25 ... 78.75 deg
    # §III-C: (front, back, left, right) at each yaw step
    paper = {
        0: ("I0", "I8", "I12", "I4"),
        1: ("D0", "D8", "D12", "D4"),
        2: ("I1", "I9", "I13", "I5"),
        3: ("D1", "D9", "D13", "D5"),
        4: ("I2", "I10", "I14", "I6"),
        5: ("D2", "D10", "D14", "D6"),
        6: ("I3", "I11", "I15", "I7"),
        7: ("D3", "D11", "D15", "D7"),
    }
    front, right, back, left = FOUR
    for k, names in paper.items():
        got = tuple(_label(slot_of(k, b)) for b in (front, back, left, right))
        assert got == names, k
    every = {slot_of(k, b) for k in range(8) for b in FOUR}
    assert every == set(range(32))


def test_one_beam_scans_32_steps_and_odd_beams_are_refused() -> None:
    assert scan_steps([0.0]) == tuple(range(32))
    assert scan_steps([0.0, math.pi]) == tuple(range(16))
    with pytest.raises(InputError, match=r"multiple of 11\.25"):
        scan_steps([0.0, math.radians(100.0)])


def test_the_i_and_d_points_lie_on_the_circle_from_the_target_s_direction() -> None:
    pts = ring([10.0, 20.0], 0.5 * math.pi, R - TAU)  # heading east
    np.testing.assert_allclose(pts[0], [28.0, 20.0], atol=1e-12)  # I_0 towards the target
    np.testing.assert_allclose(pts[4], [10.0, 2.0], atol=1e-12)  # I_4: 90 deg clockwise: south
    d = ring([0.0, 0.0], 0.0, 1.0, math.radians(11.25))
    assert math.degrees(math.atan2(d[0, 0], d[0, 1])) == pytest.approx(11.25)


# -- IP and DP ---------------------------------------------------------------------------------------
def test_ip_needs_a_clear_beam_dp_the_printed_threshold() -> None:
    ir = np.full(N_POINTS, R)
    dr = np.full(N_POINTS, R)
    ir[1] = R - TAU  # the paper's IP_1 = 1: an obstacle *at* the set-point
    ir[2] = R - 1e-9
    dr[3] = R - TAU  # DP_3 = 1: clear as far as the circle
    dr[4] = R - TAU - 1e-9
    ip, dp = possible(ir, dr, R, TAU)
    assert not ip[1] and not ip[2] and ip[0] and ip[3]
    assert dp[3] and not dp[4] and dp[0]


def test_range_and_tau_are_checked_naming_the_option() -> None:
    check_range(20.0, 2.0)
    for rng, tau in ((2.0, 2.0), (1.0, 2.0), (10.0, 2.0)):
        with pytest.raises(InputError, match="priority option tau") as err:
            check_range(rng, tau)
        assert "\n" not in str(err.value)
    with pytest.raises(InputError, match="priority option tau"):
        PriorityAvoider(tau=-1.0)
    with pytest.raises(InputError, match="priority option visited_m"):
        PriorityAvoider(visited_m=0.0)


# -- step 4 ------------------------------------------------------------------------------------------
def _theta(heading: float = 0.0, target: tuple[float, float] = (0.0, 100.0)) -> np.ndarray:
    pts = ring([0.0, 0.0], heading, R - TAU)
    return np.hypot(pts[:, 0] - target[0], pts[:, 1] - target[1])


def test_flanks_are_the_d_points_either_side() -> None:
    assert flanks(0) == (15, 0) and flanks(1) == (0, 1) and flanks(15) == (14, 15)
    # D_{i-1} and D_i lie 11.25 deg either side of I_i
    i = 5
    a, b = flanks(i)
    assert (2 * a + 1) * 11.25 == i * 22.5 - 11.25 and (2 * b + 1) * 11.25 == i * 22.5 + 11.25


def test_the_corrected_flanks_choose_where_the_printed_ones_would_not() -> None:
    theta = _theta()
    ip = np.ones(N_POINTS, dtype=bool)
    ip[0] = False  # the obstacle ahead
    dp = np.ones(N_POINTS, dtype=bool)
    dp[2] = False  # something 33.75 deg right: no flank of I_1, but the printed D_{i+1}
    seen = np.zeros(N_POINTS, dtype=bool)
    c = choose(ip, dp, theta, seen, side=1)
    assert (c.index, c.level) == (1, "4a")  # D_0 and D_1 clear
    # the printed rule (D_i, D_{i+1}) rejects I_1 (D_2 blocked) and takes I_15 (D_15, D_0)
    printed = next(i for i in c.order if ip[i] and dp[i] and dp[(i + 1) % N_POINTS])
    assert printed == 15
    # the other way round: D_0 blocked rejects I_1 (its left flank), the printed rule would not
    dp = np.ones(N_POINTS, dtype=bool)
    dp[0] = False
    c = choose(ip, dp, theta, seen, side=1)
    assert c.index == 15 and c.level == "4a"  # I_15's flanks D_14, D_15 are clear
    assert next(i for i in c.order if ip[i] and dp[i] and dp[(i + 1) % N_POINTS]) == 1


def test_ties_go_to_the_side_of_the_previous_choice() -> None:
    theta = _theta()
    assert theta[1] == pytest.approx(theta[15], abs=1e-9)  # facing the target: a tie
    right = priority_order(theta, side=1)
    left = priority_order(theta, side=-1)
    assert right[:5] == [0, 1, 15, 2, 14] and left[:5] == [0, 15, 1, 14, 2]
    ip = np.ones(N_POINTS, dtype=bool)
    ip[0] = False
    dp = np.ones(N_POINTS, dtype=bool)
    seen = np.zeros(N_POINTS, dtype=bool)
    assert choose(ip, dp, theta, seen, side=1).index == 1
    assert choose(ip, dp, theta, seen, side=-1).index == 15
    # beyond the tolerance the nearer point wins whatever the side
    skew = theta.copy()
    skew[1] += 0.02
    assert priority_order(skew, side=1, tie_m=0.01)[:3] == [0, 15, 1]
    assert priority_order(skew, side=1, tie_m=0.05)[:3] == [0, 1, 15]
    assert [side_of(i) for i in (0, 1, 7, 8, 9, 15)] == [0, 1, 1, 0, -1, -1]


def test_visited_within_the_threshold_and_the_default_marks_no_neighbour() -> None:
    s = np.array([[0.0, 0.0, 10.0]])
    assert visited([[3.0, 0.0]], s, 3.0).tolist() == [True]
    assert visited([[3.0 + 1e-6, 0.0]], s, 3.0).tolist() == [False]
    assert visited([[3.0, 0.0]], np.zeros((0, 3)), 3.0).tolist() == [False]
    r = R - TAU
    default = r * math.sin(math.radians(11.25))
    pts = ring([0.0, 0.0], 0.3, r)
    # a set-point at I_3 (within a metre) marks I_3 only
    here = pts[3] + np.array([0.8, -0.5])
    assert visited(pts, here[None, :], default).tolist() == [i == 3 for i in range(N_POINTS)]
    # neighbours are 2 r sin(11.25 deg) apart: twice the default
    assert np.hypot(*(pts[4] - pts[3])) == pytest.approx(2.0 * default)


def test_levels_fall_through_4a_4b_4c_4d_then_unreachable() -> None:
    theta = _theta()
    order = priority_order(theta, 1)
    ip = np.ones(N_POINTS, dtype=bool)
    dp = np.ones(N_POINTS, dtype=bool)
    seen = np.zeros(N_POINTS, dtype=bool)
    c = choose(ip, dp, theta, seen)
    assert (c.index, c.level) == (order[0], "4a") and c.levels == {"4a": order[0]}
    # 4b: no point has both flanks clear; the best one is visited
    dp[:] = False
    seen[order[0]] = True
    c = choose(ip, dp, theta, seen)
    assert (c.index, c.level) == (order[1], "4b") and c.levels == {"4a": None, "4b": order[1]}
    # 4c: every point visited; flanks clear round the third only
    seen[:] = True
    a, b = flanks(order[2])
    dp[[a, b]] = True
    c = choose(ip, dp, theta, seen)
    assert (c.index, c.level) == (order[2], "4c")
    # 4d: no flank clear, everything visited: the best possible point
    dp[:] = False
    ip[order[0]] = False
    c = choose(ip, dp, theta, seen)
    assert (c.index, c.level) == (order[1], "4d")
    assert c.levels == {"4a": None, "4b": None, "4c": None, "4d": order[1]}
    # nothing possible: the target is unreachable
    ip[:] = False
    c = choose(ip, dp, theta, seen)
    assert c.unreachable and c.level is None and set(c.levels.values()) == {None}


def test_a_scan_where_one_was_made_with_nothing_new_since_is_a_loop() -> None:
    loops = LoopDetector(3.0)
    a, b, c = np.array([0.0, 0.0]), np.array([18.0, 0.0]), np.array([18.0, 18.0])
    assert loops.append(a) and not loops.scan(a)
    assert loops.append(b) and not loops.scan(b)
    assert loops.append(c) and not loops.scan(c)
    # back to A (an old place): the places known have grown since A's scan, go on
    assert not loops.append(a + np.array([1.0, 1.0])) and not loops.scan(a + np.array([1.0, 1.0]))
    # B again: C was new since B's scan, go on
    assert not loops.append(b + np.array([0.5, 0.0])) and not loops.scan(b + np.array([0.5, 0.0]))
    # C again: nothing new since C's scan -> the same visited set, the same choice: a loop
    assert not loops.append(c - np.array([0.5, 0.5]))
    assert loops.scan(c - np.array([0.5, 0.5]))
    # elsewhere it is not
    fresh = LoopDetector(3.0)
    fresh.append(a)
    fresh.scan(a)
    fresh.append(a + np.array([2.0, 0.0]))
    assert fresh.scan(a + np.array([2.0, 0.0])) and fresh.places == 1


def test_stopping_distance_and_the_vehicle_checks() -> None:
    av = PriorityAvoider()
    quad = MULTIROTOR_PRESETS["quadrotor"]
    av.check_vehicle(quad, 5.0)
    with pytest.raises(InputError, match="cannot hover"):
        av.check_vehicle(load_vehicle("solar-uav"), 15.0)
    assert stopping_distance(5.0) == pytest.approx(5.0 * 0.3 + 25.0 / 6.0)
    av.check_sensor(20.0, 5.0)
    with pytest.raises(InputError, match="to stop") as err:
        av.check_sensor(20.0, 12.0)
    assert "\n" not in str(err.value)
    assert isinstance(make_avoider("priority", tau=1.5), PriorityAvoider)


# -- the avoider against hand-made pictures ----------------------------------------------------------
@dataclass
class Walls:
    """Segments ((x0, y0), (x1, y1)) the beams stop at (a 2-D world of thin walls)."""

    segments: list[tuple[tuple[float, float], tuple[float, float]]]

    def cast(self, p: np.ndarray, course: float, reach: float) -> tuple[float, str]:
        d = np.array([math.sin(course), math.cos(course)])
        best = reach
        for (x0, y0), (x1, y1) in self.segments:
            e = np.array([x1 - x0, y1 - y0])
            m = np.array([[d[0], -e[0]], [d[1], -e[1]]])
            det = float(np.linalg.det(m))
            if abs(det) < 1e-12:
                continue
            s, u = np.linalg.solve(m, np.array([x0, y0]) - p[:2])
            if s >= 0.0 and -1e-12 <= u <= 1.0 + 1e-12:
                best = min(best, float(s))
        return best, "wall" if best < reach else ""


def _box(x0: float, y0: float, x1: float, y1: float) -> list[Any]:
    return [
        ((x0, y0), (x1, y0)),
        ((x1, y0), (x1, y1)),
        ((x1, y1), (x0, y1)),
        ((x0, y1), (x0, y0)),
    ]


def _fly(
    world: Walls,
    start: tuple[float, float],
    target: tuple[float, float],
    validity: Any = None,
    **opts: Any,
) -> tuple[PriorityAvoider, list[Any], str, np.ndarray]:
    """The avoider with an ideal hover vehicle: it turns at once, moves 0.5 m per 0.1 s tick
    (5 m/s), stops at once; pictures of four level beams of R = 20 m."""
    av = PriorityAvoider(**opts)
    wp = np.array([[*start, 10.0], [*target, 10.0]])
    av.reset(wp, np.random.default_rng(0))
    quad = MULTIROTOR_PRESETS["quadrotor"]
    pos = wp[0].copy()
    yaw = 0.0
    mode: tuple[Any, ...] = ("hold",)
    decisions: list[Any] = []
    track = [pos.copy()]
    for tick in range(40_000):
        t = 0.1 * (tick + 1)
        courses = [yaw + b for b in FOUR]
        hits = [world.cast(pos, c, R) for c in courses]
        pic = SimpleNamespace(
            t=t,
            yaw=yaw,
            range_m=R,
            beam_bearings=np.array(FOUR),
            beam_courses=np.array(courses),
            beam_ranges=np.array([h[0] for h in hits]),
            beam_reach=np.array([h[0] for h in hits]),
            beam_sources=tuple(h[1] for h in hits),
        )
        moving = mode[0] in ("goto", "fly")
        vel = np.zeros(3)
        if moving:
            goal = mode[1]
            step = goal - pos
            dist = float(np.linalg.norm(step))
            vel = step / max(dist, 1e-9) * min(5.0, dist / 0.1)
        state = np.zeros(12)
        state[8] = yaw
        ctx = AvoidanceContext(
            t=t,
            state=state,
            position=pos.copy(),
            velocity=vel,
            airspeed=float(np.linalg.norm(vel)),
            course=yaw,
            picture=pic,
            waypoints=wp,
            next_index=1,
            vehicle=quad,
            validity=validity,
        )
        d = av.decide(ctx)
        if d is not None:
            decisions.append(d)
            cmd = d.command
            if d.end is not None:
                return av, decisions, d.end, np.array(track)
            if isinstance(cmd, GoTo):
                mode = ("goto", np.array(cmd.point))
                yaw = cmd.yaw if cmd.yaw is not None else yaw
            elif isinstance(cmd, FollowWaypoints):
                mode = ("fly", np.array(cmd.waypoints[-1]))
                w = cmd.waypoints
                yaw = math.atan2(w[-1, 0] - pos[0], w[-1, 1] - pos[1])
            elif isinstance(cmd, HoldPosition):
                mode = ("hold",)
            elif isinstance(cmd, YawTo):
                mode = ("hold",)
                yaw = cmd.yaw
        if mode[0] in ("goto", "fly"):
            goal = mode[1]
            step = goal - pos
            dist = float(np.linalg.norm(step))
            pos = goal.copy() if dist <= 0.5 else pos + step / dist * 0.5
            track.append(pos.copy())
            if mode[0] == "fly" and dist <= 0.5:
                return av, decisions, "goal", np.array(track)
    raise AssertionError("the run did not end")


def _clearance(world: Walls, track: np.ndarray) -> float:
    """The least distance of the track from the walls."""
    best = math.inf
    for (x0, y0), (x1, y1) in world.segments:
        a, b = np.array([x0, y0]), np.array([x1, y1])
        e = b - a
        u = np.clip(((track[:, :2] - a) @ e) / (e @ e), 0.0, 1.0)
        best = min(best, float(np.hypot(*(track[:, :2] - (a + u[:, None] * e)).T).min()))
    return best


def test_a_flight_past_a_wall_reaches_the_target_keeping_tau() -> None:
    world = Walls([((-15.0, 60.0), (25.0, 60.0))])
    _, decisions, end, track = _fly(world, (0.0, 0.0), (0.0, 120.0))
    assert end == "goal"
    assert _clearance(world, track) >= TAU
    scans = [d for d in decisions if "scan" in d.info]
    assert scans and all(len(d.info["scan"]["Ir"]) == 16 for d in scans)
    first = scans[0].info
    # stopped facing the wall: I_0 blocked, the choice by 4a, to the right (clockwise) on a tie
    assert first["scan"]["IP"][0] == 0 and first["level"] == "4a"
    assert side_of(first["chosen"]) == 1
    # the set-points: S_0 at the altitude (10 m over flat ground), the stop, the chosen points
    s = decisions[-1].info["setpoints"]
    assert s[0] == [0.0, 0.0, 10.0] and all(p[2] == 10.0 for p in s)
    assert decisions[0].info["altitude"] == 10.0


def test_a_u_trap_facing_the_start_is_left_and_the_target_reached() -> None:
    # a U open towards the start (south), 40 m wide and 40 m deep, the target beyond it
    world = Walls(
        [
            ((-20.0, 40.0), (-20.0, 80.0)),
            ((-20.0, 80.0), (20.0, 80.0)),
            ((20.0, 80.0), (20.0, 40.0)),
        ]
    )
    av, decisions, end, track = _fly(world, (0.0, 0.0), (0.0, 140.0))
    assert end == "goal", decisions[-1].reason
    # the rays miss a wall's end between them: the path passed one 0.31 m off (documented)
    assert _clearance(world, track) > 0.0
    assert len(av.setpoints) < 60


def test_set_points_keep_out_of_the_danger_zones_and_on_the_map() -> None:
    """Issue 34: the way to a set-point stays out of the mission's danger zones and on the map.
    A wall across the way; the tie goes right (clockwise) -- unless a zone lies there."""
    from terrain.validity import ValidityChecker
    from terrain.zones import DangerZone

    world = Walls([((-15.0, 60.0), (25.0, 60.0))])
    _, decisions, end, _ = _fly(world, (0.0, 0.0), (0.0, 120.0))
    first = next(d.info for d in decisions if "chosen" in d.info)
    assert end == "goal" and side_of(first["chosen"]) == 1  # right, as without a zone
    zone = DangerZone(40.0, 60.0, 70.0, id="east")  # 5-75 m east of the way round the wall
    validity = ValidityChecker(zones=[zone])
    av, decisions, end, track = _fly(world, (0.0, 0.0), (0.0, 120.0), validity=validity)
    assert end == "goal", decisions[-1].reason
    assert np.hypot(track[:, 0] - 40.0, track[:, 1] - 60.0).min() >= 35.0  # never inside
    first = next(d.info for d in decisions if "chosen" in d.info)
    assert side_of(first["chosen"]) == -1  # left, round the wall's other end
    assert 0 in first["scan"]["valid"]
    assert all(p[0] < 5.0 for p in av.setpoints)


def _u(width: float, depth: float, y0: float) -> Walls:
    h = width / 2.0
    return Walls(
        [
            ((-h, y0), (-h, y0 + depth)),
            ((-h, y0 + depth), (h, y0 + depth)),
            ((h, y0 + depth), (h, y0)),
        ]
    )


def test_a_wide_u_is_left_by_returning_along_s_where_the_paper_s_steps_loop() -> None:
    """Issue 34's U (80 m wide, 60 m deep, open towards the start, the target behind it): the
    paper's 4c/4d choose visited points near the bottom and cycle there; the search returns
    along S to the last place with an unvisited possible point and leaves the U."""
    world = _u(80.0, 60.0, 50.0)
    av, decisions, end, track = _fly(world, (0.0, 0.0), (0.0, 160.0))
    assert end == "goal", decisions[-1].reason
    assert len(av.setpoints) <= 50 and av.scans <= 45
    assert _clearance(world, track) > 0.0  # line beams (this ideal picture) miss wall ends
    assert any("back" in d.info for d in decisions)  # it did return along S
    # every point chosen (forwards, or at a route's end) was unvisited: farther than visited_m
    # from every earlier point of S
    chosen = [d.info for d in decisions if "chosen" in d.info]
    assert chosen and {c["level"] for c in chosen} <= {"4a", "4b", "back"}
    for c in chosen:
        s_then = np.array(c["setpoints"])[:, :2]
        gap = np.hypot(*(s_then[:-1] - s_then[-1]).T).min()
        assert gap > av.visited_m, c
    paper = _fly(world, (0.0, 0.0), (0.0, 160.0), backtrack=False, max_scans=1000)
    assert paper[2] == LOOP


def test_a_pen_round_the_start_ends_unreachable_once_every_place_is_visited() -> None:
    """A 100 m square pen round the start, the target outside: no lap round the target is
    possible, so the circling rule cannot end it; the search ends "target unreachable" when no
    place's scan has an unvisited possible point left (step 4d over the whole tree)."""
    world = Walls(_box(-50.0, -50.0, 50.0, 50.0))
    av, decisions, end, track = _fly(world, (0.0, -40.0), (0.0, 100.0), max_scans=1000)
    assert end == UNREACHABLE, decisions[-1].reason
    assert "at any of the" in decisions[-1].reason and av.scans <= 80
    assert _clearance(world, track) > 0.0
    # the paper's steps fill the pen with places and end by the revisit rule
    paper = _fly(world, (0.0, -40.0), (0.0, 100.0), backtrack=False, max_scans=1000)
    assert paper[2] == LOOP and paper[0].scans > av.scans


def test_a_closed_box_round_the_target_ends_unreachable_in_bounded_time() -> None:
    world = Walls(_box(-20.0, 60.0, 20.0, 100.0))
    av, decisions, end, track = _fly(world, (0.0, 0.0), (0.0, 80.0))
    assert end == CIRCLED
    assert decisions[-1].info["outcome"] == CIRCLED and decisions[-1].end == CIRCLED
    assert _clearance(world, track) >= TAU
    assert av.surround is not None and av.surround.round
    # a lap and the part of a second that closes the gap where the first began (the search
    # takes the unvisited point nearest the target: from the box's last side it turns outwards)
    assert av.scans <= 25 and len(av.setpoints) <= 27
    # the paper's steps without the circling rule: the revisit rule ends it, once the places
    # fill the ground (the search would widen its rings round the box until max_flight_s)
    av, decisions, end, track = _fly(
        world,
        (0.0, 0.0),
        (0.0, 80.0),
        circled=False,
        backtrack=False,
        max_scans=1000,
        max_setpoints=1000,
    )
    assert end == LOOP and decisions[-1].info["outcome"] == LOOP
    assert av.scans < 1000


def test_surround_is_the_share_of_the_circle_swept_since_the_target_was_last_neared() -> None:
    def at(deg: float, d: float = 20.0) -> list[float]:
        a = math.radians(deg)
        return [d * math.sin(a), d * math.cos(a)]

    s = Surround([0.0, 0.0], 5.0)
    for deg in range(0, 331, 30):
        s.add(at(deg))
    assert s.share == pytest.approx(331.0 / 360.0) and not s.round
    # back and forth sweeps nothing new
    s.add(at(300.0))
    s.add(at(330.0))
    assert s.share == pytest.approx(331.0 / 360.0)
    s.add(at(0.0))
    assert s.round and s.nearest == pytest.approx(20.0)
    # 4 m nearer: not enough (5 m); 6 m nearer: the sweep restarts
    s.add(at(10.0, 16.0))
    assert s.round
    s.add(at(10.0, 14.0))
    assert s.share == pytest.approx(1.0 / 360.0) and s.nearest == pytest.approx(14.0)
    s.add(at(180.0, 20.0))  # a jump sweeps the short way
    assert s.share == pytest.approx(171.0 / 360.0)


def test_confined_on_every_side_is_unreachable_by_step_4d() -> None:
    world = Walls(_box(-10.0, -10.0, 10.0, 10.0))
    _, decisions, end, _ = _fly(world, (0.0, 0.0), (0.0, 80.0))
    assert end == UNREACHABLE
    last = decisions[-1].info
    assert last["levels"] == {"4a": None, "4b": None, "4c": None, "4d": None}
    assert sum(last["scan"]["IP"]) == 0


def test_the_bounds_end_the_run() -> None:
    world = Walls(_box(-20.0, 60.0, 20.0, 100.0))
    _, _, end, _ = _fly(world, (0.0, 0.0), (0.0, 80.0), max_scans=2)
    assert end == SCAN_LIMIT
    _, _, end, _ = _fly(world, (0.0, 0.0), (0.0, 80.0), max_setpoints=3)
    assert end == SETPOINT_LIMIT


# -- flights: the 6-DOF quadrotor, the rangefinders, data/scenarios/priority-*.yaml --------------
MISSION = "data/scenarios/priority-mission.yaml"


def _replay(threats: Any, **kw: Any) -> Any:
    from replay.run import ReplayRequest, run_replay

    kw.setdefault("duration", 3000.0)
    return run_replay(
        ReplayRequest.of(
            source=MISSION, threats=threats, avoid="priority", sensor="rangefinder", **kw
        )
    )


def _setpoints(result: Any) -> np.ndarray:
    return np.asarray(result.decisions[-1]["setpoints"], dtype=np.float64)


@pytest.mark.parametrize(
    ("name", "most"),
    [("convex", 6), ("corridor", 60), ("u-trap", 90)],
)
def test_flights_reach_the_target_keeping_tau(name: str, most: int) -> None:
    r = _replay(f"data/scenarios/priority-{name}.yaml")
    m = r.metrics
    assert m.end_reason == "goal" and m.success and not m.violations, m.as_dict()
    assert min(v["value"] for v in m.min_separation.values()) >= TAU
    s = _setpoints(r)
    assert 2 <= len(s) <= most
    np.testing.assert_allclose(s[0], [0.0, 0.0, 10.0])  # S_0 at §V's altitude
    # the flight stack's arrival: within 2 m (its arrival distance) or past the target's plane
    assert math.hypot(r.positions[-1, 0], r.positions[-1, 1] - 150.0) <= 4.0
    # level at the altitude after the climb (the scans turn in place)
    after = r.times > 20.0
    assert np.abs(r.positions[after, 2] - 10.0).max() < 0.5
    scans = [d for d in r.decisions if "scan" in d]
    assert scans and all(d["level"] in ("4a", "4b", "4c", "4d") for d in scans)


def test_a_closed_box_round_the_target_ends_unreachable_not_success() -> None:
    r = _replay("data/scenarios/priority-box.yaml")
    m = r.metrics
    assert m.end_reason == CIRCLED and not m.success and not m.reached_goal
    assert m.flight_time_s < 900.0 and len(_setpoints(r)) < 60
    assert min(v["value"] for v in m.min_separation.values()) >= TAU
    last = r.decisions[-1]
    assert last["end"] == CIRCLED and last["outcome"] == CIRCLED


def test_a_target_inside_an_obstacle_is_reported_unreachable() -> None:
    from replay.threats.file import threats_from_records

    tower = [{"id": "tower", "kind": "cylinder", "center": [0.0, 150.0], "radius": 15.0, "top": 40}]
    r = _replay(threats_from_records(tower))
    assert r.metrics.end_reason == CIRCLED and not r.metrics.success
    assert r.metrics.min_separation["tower"]["value"] >= TAU


def test_confined_the_run_ends_unreachable_and_the_cli_exits_3(tmp_path: Any, capsys: Any) -> None:
    from terrapath.cli import main

    pen = tmp_path / "pen.yaml"
    walls = [
        ("w", [[-13, -12], [-12, -12], [-12, 12], [-13, 12], [-13, -12]]),
        ("e", [[12, -12], [13, -12], [13, 12], [12, 12], [12, -12]]),
        ("s", [[-13, -13], [13, -13], [13, -12], [-13, -12], [-13, -13]]),
        ("n", [[-13, 12], [13, 12], [13, 13], [-13, 13], [-13, 12]]),
    ]
    pen.write_text(
        "terrapath: 1\nthreats:\n"
        + "".join(f"- {{id: {i}, kind: prism, top: 40, footprint: {f}}}\n" for i, f in walls)
    )
    out = tmp_path / "pen.mcap"
    code = main(
        [
            "replay",
            MISSION,
            "--threats",
            str(pen),
            "--avoid",
            "priority",  # no --sensor: the rangefinders are implied, its only sensor
            "--no-picture",
            "-o",
            str(out),
        ]
    )
    assert code == 3
    assert "ended by target unreachable" in capsys.readouterr().err
    from replay.record.reader import load_run

    run = load_run(out, with_states=False)
    assert run.metadata["sensor"] == "rangefinder" and "rangefinder" in run.metadata
    assert run.metrics["end_reason"] == UNREACHABLE and run.metrics["success"] is False
    last = run.decisions[-1].decision
    assert last["levels"] == {"4a": None, "4b": None, "4c": None, "4d": None}
    assert len(last["scan"]["Ir"]) == 16 and len(last["scan"]["Dr"]) == 16
    assert run.topic_counts["/avoidance/guidance"] >= 1
    # the set-points S: drawn by `terrapath view` (one marker each) and in RUN.png
    from replay.record.picture import recorded_view
    from terrapath.view.decisions import decision_marks

    view = recorded_view(out)
    (mark,) = [m for m in decision_marks(view) if m.name == "priority set-points"]
    s = np.asarray(last["setpoints"], dtype=np.float64)
    got = mark.xyz[np.isfinite(mark.xyz[:, 0])]
    np.testing.assert_allclose(got, s, atol=1e-9)


def test_a_sensor_the_avoider_cannot_use_is_one_line_and_help_says_the_default(
    tmp_path: Any, capsys: Any
) -> None:
    from replay.avoidance.registry import sensor_for
    from terrapath.cli import main

    out = tmp_path / "r.mcap"
    for given in ("radar", "cooperative"):
        argv = ["replay", MISSION, "--avoid", "priority", "--sensor", given, "-o", str(out)]
        assert main(argv) == 1
        assert capsys.readouterr().err == (
            f"terrapath: error: --sensor {given}: the priority avoider works with rangefinder "
            "only; give that sensor or leave the sensor out (it is implied)\n"
        )
        assert not out.exists()
    assert main(["replay", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert (
        "Default: the avoider's only sensor if it works with one alone (--avoid priority: "
        "rangefinder), else radar."
    ) in text
    # every other avoider works with any sensor: radar by default, the given one kept
    assert sensor_for(("priority",)) == "rangefinder"
    assert sensor_for(("none", "priority")) == "rangefinder"
    for name in ("none", "pso-ca", "ctga", "fga"):
        assert sensor_for((name,)) == "radar"
        assert sensor_for((name,), "cooperative") == "cooperative"


def test_bad_setups_are_refused_before_the_flight() -> None:
    from replay.run import ReplayRequest, prepare_replay
    from replay.threats.file import threats_from_records

    def prep(**kw: Any) -> None:
        kw.setdefault("sensor", "rangefinder")
        prepare_replay(ReplayRequest.of(source=MISSION, avoid="priority", **kw))

    prep()
    with pytest.raises(InputError, match="priority option tau"):
        prep(avoid_options={"tau": 20.0})
    with pytest.raises(InputError, match="priority option tau"):
        prep(avoid_options={"tau": -0.5})
    with pytest.raises(InputError, match="--sensor rangefinder"):
        prep(sensor="radar")
    with pytest.raises(InputError, match="rangefinder-beams"):
        prep(rangefinder_beams=3)
    with pytest.raises(InputError, match=r"needs .* m to stop"):
        prep(rangefinder_range=7.0, avoid_options={"tau": 1.0})
    with pytest.raises(InputError, match="cannot hover"):
        prep(vehicle="solar-uav")
    block = [{"id": "shed", "kind": "cylinder", "center": [1.0, 0.0], "radius": 4.0, "top": 20}]
    with pytest.raises(InputError, match="inside threat 'shed'") as err:
        prep(threats=threats_from_records(block))
    assert "\n" not in str(err.value)


def test_a_start_inside_an_obstacle_ends_the_flight_when_not_refused_before() -> None:
    from planner.mission import load_mission
    from replay.sim import ReplayConfig, simulate
    from replay.threats.file import threats_from_records

    block = [{"id": "shed", "kind": "cylinder", "center": [1.0, 0.0], "radius": 4.0, "top": 50}]
    r = simulate(
        load_mission(MISSION),
        threats_from_records(block),
        PriorityAvoider(),
        MULTIROTOR_PRESETS["quadrotor"],
        config=ReplayConfig(sensor="rangefinder", duration=60.0),
    )
    assert r.metrics.end_reason == "start inside an obstacle" and not r.metrics.success
    assert r.metrics.flight_time_s < 1.0


def test_over_terrain_it_holds_the_mission_altitude_or_above_m_over_the_ground(
    tmp_path: Any,
) -> None:
    from replay.run import ReplayRequest, run_replay
    from terrain.load import load_dem

    dem = str(Path("data/maps/lidar_1m_dem/dem.tif").resolve())
    grid = load_dem([dem])
    xmin, _, _, ymax = grid.bounds
    s = (xmin + 125.0, ymax - 285.0)  # a hollow at 379.8 m
    t = (xmin + 245.0, ymax - 125.0)  # another at 380.3 m, a rise between
    ground = grid.height_at(np.array([s[0], t[0]]), np.array([s[1], t[1]]))
    mission = tmp_path / "m.yaml"
    mission.write_text(
        "terrapath: 1\nname: hollows\ncrs: EPSG:26915\n"
        f"terrain: {{dem: [{dem}]}}\nvehicle: quadrotor\n"
        "cruise: {speed: 5.0, altitude: 420.0}\n"
        f"waypoints:\n- [{s[0]}, {s[1]}, 400.0]\n- [{t[0]}, {t[1]}, 400.0]\n"
    )
    for options, want in (
        ({}, 400.0),  # the mission's altitude
        ({"above_m": 10.0}, float(ground.max()) + 10.0),  # §V: 10 m over the higher ground
    ):
        r = run_replay(
            ReplayRequest.of(
                source=str(mission),
                avoid="priority",
                sensor="rangefinder",
                avoid_options={"max_flight_s": 30.0, **options},
            )
        )
        assert r.decisions[0]["altitude"] == pytest.approx(want, abs=1e-9)
        assert r.decisions[0]["setpoints"][0][2] == pytest.approx(want, abs=1e-3)  # mm
        late = r.times > 20.0
        assert np.abs(r.positions[late, 2] - want).max() < 0.5
        assert r.metrics.end_reason == "flight-time limit" and not r.metrics.success


def test_a_flight_is_identical_when_repeated() -> None:
    a = _replay("data/scenarios/priority-convex.yaml", seed=3)
    b = _replay("data/scenarios/priority-convex.yaml", seed=3)
    np.testing.assert_array_equal(a.states, b.states)
    assert [d["setpoints"] for d in a.decisions] == [d["setpoints"] for d in b.decisions]


def test_a_roof_just_below_the_flight_level_is_gone_round_not_skimmed() -> None:
    """A 12 m drum whose top is 1 m under the flight level (10 m): flown with lines for beams
    the loop passes over it 1 m up (the level beams meet nothing); with its cones
    (atan(tau / (R - tau)) = 6.3 deg, the default) the lower rim meets the drum's side, the
    aircraft stops and goes round it, never within tau."""
    from planner.mission import load_mission
    from replay.sim import ReplayConfig, simulate
    from replay.threats.file import threats_from_records

    av = PriorityAvoider()
    assert av.rangefinder_spread_deg(20.0) == pytest.approx(math.degrees(math.atan(2.0 / 18.0)))
    drum = [{"id": "drum", "kind": "cylinder", "center": [2.0, 75.0], "radius": 12.0, "top": 9}]

    def fly(spread: float | None) -> Any:
        return simulate(
            load_mission(MISSION),
            threats_from_records(drum),
            PriorityAvoider(),
            MULTIROTOR_PRESETS["quadrotor"],
            config=ReplayConfig(sensor="rangefinder", duration=300.0, rangefinder_spread=spread),
        )

    skim = fly(0.0)
    assert skim.metrics.success and skim.metrics.min_separation["drum"]["value"] < 1.5
    cone = fly(None)
    m = cone.metrics
    assert m.end_reason == "goal" and m.success
    assert m.min_separation["drum"]["value"] >= 2.0  # tau, in 3-D: beside the drum, not over it
    assert any(d.get("priority") == "scan" for d in cone.decisions)


def _walls_file(path: Path, walls: dict[str, list[list[float]]]) -> str:
    path.write_text(
        "terrapath: 1\nthreats:\n"
        + "".join(
            f"- {{id: {i}, kind: prism, top: 40, footprint: {f}}}\n" for i, f in walls.items()
        )
    )
    return str(path)


def test_issue_34_s_u_is_escaped_at_the_mission_s_altitude_within_the_default_limit(
    tmp_path: Any, capsys: Any
) -> None:
    """Issue 34's try-out: a quadrotor at 20 m, a U 80 m wide and 60 m deep open towards it,
    the target behind: the paper's steps bounced in the U until the time limit, at 10 m."""
    from terrapath.cli import main

    mission = tmp_path / "m.yaml"
    mission.write_text(
        "terrapath: 1\nname: user-u\ncrs: local\nvehicle: quadrotor\n"
        "cruise: {speed: 5.0, altitude: 20.0}\nwaypoints:\n- [0, 0, 20]\n- [0, 160, 20]\n"
    )
    u = _walls_file(
        tmp_path / "u.yaml",
        {
            "u-west": [[-41, 50], [-40, 50], [-40, 110], [-41, 110], [-41, 50]],
            "u-north": [[-41, 110], [41, 110], [41, 111], [-41, 111], [-41, 110]],
            "u-east": [[40, 50], [41, 50], [41, 110], [40, 110], [40, 50]],
        },
    )
    out = tmp_path / "u.mcap"
    argv = ["replay", str(mission), "--threats", u, "--avoid", "priority"]
    assert main([*argv, "--sensor", "rangefinder", "--no-picture", "-o", str(out)]) == 0
    from replay.record.reader import load_run

    run = load_run(out, with_states=True)
    assert run.metrics["success"] is True and run.metrics["end_reason"] == "goal"
    assert min(v["value"] for v in run.metrics["min_separation"].values()) >= TAU
    z = -np.asarray(run.states)[:, 2]  # the states are north-east-down
    assert np.abs(z[len(z) // 10 :] - 20.0).max() < 0.5  # at the mission's 20 m
    assert any("back" in d.decision for d in run.decisions)


def test_a_wide_box_round_the_target_ends_unreachable_within_the_default_limit(
    tmp_path: Any,
) -> None:
    """A 100 m box round the target: a lap round it is longer than the straight flight's
    default time limit allowed; the priority loop's own bound (max_flight_s) sets the limit and
    the run ends "circled", not by the time limit."""
    from replay.run import ReplayRequest, run_replay

    box = _walls_file(
        tmp_path / "box.yaml",
        {
            "s": [[-51, 99], [51, 99], [51, 100], [-51, 100], [-51, 99]],
            "e": [[50, 100], [51, 100], [51, 200], [50, 200], [50, 100]],
            "n": [[-51, 200], [51, 200], [51, 201], [-51, 201], [-51, 200]],
            "w": [[-51, 100], [-50, 100], [-50, 200], [-51, 200], [-51, 100]],
        },
    )
    r = run_replay(
        ReplayRequest.of(source=MISSION, threats=box, avoid="priority", sensor="rangefinder")
    )
    m = r.metrics
    assert m.end_reason == CIRCLED and not m.success and m.flight_time_s > 645.0
    assert min(v["value"] for v in m.min_separation.values()) >= TAU
