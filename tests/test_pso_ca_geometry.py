"""Exact geometric cases for the PSO-CA building blocks (seed 000 §2.3, §3, eq 27, Table 4)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from replay.avoidance.pso_ca_geometry import (
    PsoCaParams,
    WaypointProblem,
    brute_force_waypoint,
    closest_first,
    continuous_mask,
    corner_cut,
    group_obstacles,
    near_end_waypoint,
    obstacle_between,
    search_grid,
    segment_clearance,
    segment_hits_sphere,
    segment_sphere_intersections,
    tangent_points,
    tangent_seed_points,
)
from terrain.errors import InputError

# Table 4 / §6 obstacles (z = 200 m, as the waypoints)
OBS = np.array(
    [[60000, 7000], [135000, 12000], [290400, 17300], [290200, 17400], [290000, 17500]], float
)


# -- eqs 22-26 ----------------------------------------------------------------------------------
def test_segment_through_centre_has_exact_entry_and_exit():
    r = segment_sphere_intersections([0, 0, 0], [10, 0, 0], [[5, 0, 0]], 1.0)
    assert r.hit.tolist() == [True]
    assert r.t_enter[0] == pytest.approx(0.4)
    assert r.t_exit[0] == pytest.approx(0.6)
    assert r.discriminant[0] == pytest.approx(4 * 100 * 1.0)  # b^2 - 4ac = 4 a r^2 through centre


def test_segment_passing_at_1001_radius_misses_and_tangent_hits():
    centres = [[5, 1.001, 0], [5, 1.0, 0]]
    r = segment_sphere_intersections([0, 0, 0], [10, 0, 0], centres, 1.0)
    assert r.hit.tolist() == [False, True]  # eq 26: tangency is a collision
    assert r.discriminant[0] < 0 and np.isnan(r.t_enter[0])
    assert r.t_enter[1] == pytest.approx(0.5) and r.t_exit[1] == pytest.approx(0.5)


def test_segment_ending_before_or_starting_after_the_sphere_misses():
    # the infinite line of eq 26 meets both spheres (discriminant > 0); the segment does not
    r = segment_sphere_intersections([0, 0], [3, 0], [[5, 0], [-5, 0]], 1.0)
    assert r.hit.tolist() == [False, False]
    assert np.all(r.discriminant > 0)
    assert r.t_enter[0] == pytest.approx(4 / 3)
    assert r.t_exit[1] == pytest.approx(-4 / 3)


def test_start_inside_sphere_hits_and_radius_per_obstacle():
    r = segment_sphere_intersections([0, 0], [10, 0], [[0.5, 0], [5, 3]], [1.0, 3.0])
    assert r.hit.tolist() == [True, True]
    assert r.t_enter[0] < 0 <= r.t_exit[0]


def test_degenerate_segment_is_a_point_test():
    assert segment_hits_sphere([1, 1], [1, 1], [[1, 1.5], [1, 3]], 1.0).tolist() == [True, False]


def test_table4_leg_hits_obstacle_2_not_obstacle_1():
    assert segment_hits_sphere(
        [100000, 11000, 200], [200000, 15000, 200], [[135000, 12000, 200]], 1000.0
    )[0]
    assert not segment_hits_sphere(
        [20000, 1000, 200], [70000, 6500, 200], [[60000, 7000, 200]], 1000.0
    )[0]
    # the 2D and 3D tests agree at constant altitude, for all five obstacles at once
    hits = segment_hits_sphere([100000, 11000], [200000, 15000], OBS, 1000.0)
    assert hits.tolist() == [False, True, False, False, False]


def test_segment_clearance_matches_the_hit_test():
    rng = np.random.default_rng(3)
    p0, p1 = rng.uniform(-10, 10, (50, 2)), rng.uniform(-10, 10, (50, 2))
    c = rng.uniform(-10, 10, (7, 2))
    clear = segment_clearance(p0, p1, c)
    for i in range(50):
        hit = segment_hits_sphere(p0[i], p1[i], c, 2.0)
        assert np.array_equal(hit, clear[i] <= 2.0)


@pytest.mark.parametrize("dims", [2, 3])
def test_segment_clearance_hand_cases_and_degenerate_segment(dims: int) -> None:
    pad = [0.0] * (dims - 2)
    p0, p1 = np.array([[0.0, 0.0, *pad]] * 2), np.array([[10.0, 0.0, *pad], [0.0, 0.0, *pad]])
    c = np.array([[5.0, 3.0, *pad], [-4.0, 3.0, *pad], [13.0, -4.0, *pad]])
    want = [[3.0, 5.0, 5.0], [math.hypot(5, 3), 5.0, math.hypot(13, 4)]]  # middle, ends, point
    np.testing.assert_allclose(segment_clearance(p0, p1, c), want, rtol=0, atol=1e-12)


# -- Figs 8-10, §5.3 ----------------------------------------------------------------------------
def test_table4_obstacles_group_as_paper_says():
    groups = group_obstacles(OBS)
    assert [g.tolist() for g in groups] == [[0], [1], [2, 3, 4]]
    assert continuous_mask(OBS).tolist() == [False, False, True, True, True]
    obs3 = np.column_stack([OBS, np.full(5, 200.0)])
    assert [g.tolist() for g in group_obstacles(obs3)] == [[0], [1], [2, 3, 4]]


def test_near_end_between_and_ordering():
    wp = [200000, 15000]
    assert near_end_waypoint([[200500, 15000], [201000, 15000], [198000, 15000]], wp).tolist() == [
        True,
        False,  # exactly 1 km: "Distance < safety distance" is strict
        False,
    ]
    pos = [100000, 11000]
    obs = [[135000, 12000], [210000, 15000], [90000, 11000]]
    assert obstacle_between(pos, wp, obs).tolist() == [True, False, True]  # Fig. 10: range only
    assert obstacle_between(pos, wp, obs, along_track=True).tolist() == [True, False, False]
    assert closest_first(pos, obs).tolist() == [2, 0, 1]


# -- eq 27 --------------------------------------------------------------------------------------
def test_tangent_points_exact():
    tp = tangent_points([0, 0], [10000, 0], 2000.0)
    s = math.sqrt(10000**2 - 2000**2)
    np.testing.assert_allclose(tp, [[9600, 2000 * s / 10000], [9600, -2000 * s / 10000]])
    o = np.array([10000.0, 0.0])
    for t in tp:
        assert math.hypot(*(t - o)) == pytest.approx(2000.0)
        assert np.dot(t - o, t) == pytest.approx(0.0, abs=1e-6)  # radius ⟂ line of sight


def test_tangent_points_any_direction_left_first():
    a, o = np.array([500.0, -300.0]), np.array([-4000.0, 6000.0])
    tp = tangent_points(a, o, 1500.0)
    los = o - a
    cross = los[0] * (tp[:, 1] - a[1]) - los[1] * (tp[:, 0] - a[0])
    assert cross[0] > 0 > cross[1]
    np.testing.assert_allclose(np.hypot(*(tp - o).T), 1500.0)
    np.testing.assert_allclose(np.einsum("kd,kd->k", tp - o, tp - a), 0.0, atol=1e-6)
    with pytest.raises(InputError):
        tangent_points([0, 0], [1000, 0], 2000.0)


def test_tangent_seed_points_on_circle_both_sides_and_deterministic():
    a, o, r = np.array([125000.0, 11600.0]), np.array([135000.0, 12000.0]), 2000.0
    seeds = tangent_seed_points(a, o, r, n=10, rng=np.random.default_rng(1))
    assert seeds.shape == (10, 2)
    np.testing.assert_allclose(seeds[:2], tangent_points(a, o, r))
    d = np.hypot(*(seeds - o).T)
    assert np.all(d >= r - 1e-6) and np.all(d <= 1.1 * r + 1e-6)
    los = o - a
    cross = los[0] * (seeds[:, 1] - a[1]) - los[1] * (seeds[:, 0] - a[0])
    assert (cross > 0).sum() >= 3 and (cross < 0).sum() >= 3
    np.testing.assert_array_equal(seeds, tangent_seed_points(a, o, r, n=10, rng=1))
    np.testing.assert_array_equal(
        tangent_seed_points(a, o, r, n=10, rng=1), tangent_seed_points(a, o, r, n=10, rng=1)
    )
    # every seed satisfies g1 of the matching problem
    prob = WaypointProblem(a, [200000, 15000], o)
    assert np.all(prob.constraint_report(seeds).g1 >= -1e-6)


def test_seed_points_when_aircraft_inside_the_circle():
    seeds = tangent_seed_points([0, 0], [1000, 0], 2000.0, n=4, rng=0)
    np.testing.assert_allclose(seeds[:2], [[1000, 2000], [1000, -2000]], atol=1e-9)


# -- eqs 2-12 -----------------------------------------------------------------------------------
def _problem(**params):
    return WaypointProblem([0, 0], [20000, 0], [[10000, 0]], params=PsoCaParams(**params))


def test_constraints_on_hand_made_candidates():
    prob = _problem()
    X = np.array([[10000, 2500], [10000, 1500], [6000, 0], [15000, 1000]], float)
    rep = prob.constraint_report(X)
    L = math.hypot(10000, 2500)
    np.testing.assert_allclose(rep.g1, [500, -500, 2000, math.hypot(5000, 1000) - 2000])
    np.testing.assert_allclose(rep.g2, [1500, 2500, 0, 4000 - math.hypot(5000, 1000)])
    # g3: segment (10000, 2500) -> (20000, 0) passes 2.5e7 / L from the centre
    assert rep.g3[0] == pytest.approx(2.5e7 / L - 1000)
    assert rep.g3[2] == pytest.approx(-1000)  # (6000, 0) -> (20000, 0) goes through the centre
    assert rep.g5[2] == pytest.approx(3000)  # (0, 0) -> (6000, 0) stops 4 km short
    theta = 2 * math.atan(0.25)
    assert rep.turn_angle[0] == pytest.approx(theta)
    R = 15.0**2 / (9.81 * math.tan(math.radians(30)))
    assert prob.params.turn_radius == pytest.approx(R)
    assert rep.g4[0] == pytest.approx(L - R * math.tan(theta / 2))
    assert rep.feasible.tolist() == [True, False, False, False]
    assert rep.violation[1] == pytest.approx(500)


def test_g4_rejects_a_hairpin_and_g2_aircraft_centre():
    prob = WaypointProblem([0, 0], [20000, 0], [[20000, 3000]])
    rep = prob.constraint_report([[20030, 5]])
    theta = math.pi - math.atan2(5, 30) + math.atan2(5, 20030)  # from course +b to 180° + a
    R = prob.params.turn_radius
    assert rep.turn_angle[0] == pytest.approx(theta)
    assert rep.g4[0] == pytest.approx(math.hypot(30, 5) - R * math.tan(theta / 2))
    assert rep.g4[0] < 0 and not rep.feasible[0]
    air = _problem(g2_centre="aircraft").constraint_report([[3000, 0], [10000, 2500]])
    np.testing.assert_allclose(air.g2, [1000, 4000 - math.hypot(10000, 2500)])


def test_corner_cut_hand_cases():
    """The autopilot's turn: 1 km before the waypoint it heads for the next leg's line at up to
    60 deg (replay.flight.fixedwing.autopilot).  Arriving east, leaving north (90 deg left): from (-1000, 0) to the
    line x = 0, met at y = 1000 / tan 60; leaving 20 deg left, the line is met *behind* the
    waypoint and the part of it up to the waypoint is flown too."""
    w = np.zeros((1, 2))
    (c1, m), (m2, back) = corner_cut(w, np.array([[5000.0, 0]]), np.array([[0, 3000.0]]), 1000, 60)
    np.testing.assert_allclose(m2, m)
    np.testing.assert_allclose(c1, [[-1000, 0]])
    np.testing.assert_allclose(m, [[0, 1000 / math.sqrt(3)]])
    np.testing.assert_allclose(back, m)  # met beyond the waypoint: the second piece is empty
    a = math.radians(20)
    e = np.array([[math.cos(a), math.sin(a)]])
    (c1, m), (m2, back) = corner_cut(w, np.array([[5000.0, 0]]), 4000 * e, 1000, 60)
    np.testing.assert_allclose(c1, [[-1000, 0]])
    np.testing.assert_allclose(m2, m)
    reach = -1000 * math.cos(a) + 1000 * math.sin(a) / math.sqrt(3)
    assert reach < 0
    np.testing.assert_allclose(m, reach * e)
    np.testing.assert_allclose(back, w)
    # the cut starts at most half the incoming leg before the waypoint
    (c1, _), _ = corner_cut(w, np.array([[600.0, 0]]), np.array([[0, 3000.0]]), 1000, 60)
    np.testing.assert_allclose(c1, [[-300, 0]])


def test_g3_and_g5_count_the_cut_corners():
    """A waypoint whose straight legs clear the obstacle by more than RS + margin can still be
    unsafe: the turn at the next waypoint swings towards the obstacle (g3), or the turn at the new
    waypoint does (g5).  Without the switch distance (the paper) both are feasible."""
    o = [[-400.0, 1105.0 + 1000.0]]  # 2105 m north of the line y = 0 ...
    target, after = [0.0, 1000.0], [8000.0, 1000.0 - 6028.0]
    paper = WaypointProblem([-20000, 1000], target, o, params=PsoCaParams(leg_margin=100.0))
    cut = WaypointProblem(
        [-20000, 1000],
        target,
        o,
        params=PsoCaParams(leg_margin=100.0, switch_distance=1000.0),
        after=after,
    )
    p = np.array([[-3000.0, 1000.0]])  # ... so both legs clear it by 1105 m
    assert paper.constraint_report(p).feasible[0]
    rep = cut.constraint_report(p)
    assert rep.g3[0] < 0 and not rep.feasible[0]
    assert rep.g5[0] == pytest.approx(paper.constraint_report(p).g5[0])
    # the cut corner at the new waypoint itself: a right turn at p towards an obstacle behind it
    inbound = WaypointProblem(
        [-20000, 0],
        [-10000 + 8000, -6028],
        [[-10400, 1105]],
        params=PsoCaParams(leg_margin=100.0, switch_distance=1000.0, tolerance=100.0),
    )
    q = np.array([[-10000.0, 0.0]])
    assert inbound.constraint_report(q).g5[0] < 0
    assert (
        WaypointProblem(
            [-20000, 0], [-2000, -6028], [[-10400, 1105]], params=PsoCaParams(leg_margin=100.0)
        )
        .constraint_report(q)
        .g5[0]
        > 0
    )


def test_g4_asks_that_the_cut_corner_fits_in_the_leg_onto_the_target():
    """Seed 000 Table 6 (100 obstacles, run 3): a waypoint 611 m from the goal after a 99 deg
    turn.  The autopilot leaves the 26.6 km leg 1 km before it and meets the goal leg's line
    722 m along it -- beyond the goal, which the aircraft passed 373 m off the track (missed).
    With the autopilot's switch distance g4 is that overrun; with fillets (no switch distance)
    the fly-by lead alone; a waypoint whose corner fits is feasible."""
    pos, goal = [296367.4, 13464.7], [270000.0, 10500.0]
    p = np.array([[269853.5, 11093.9]])
    o = [[272000.0, 8500.0]]  # 3.4 km south-east of p: g1, g2, g3 and g5 hold
    cut = WaypointProblem(pos, goal, o, params=PsoCaParams(switch_distance=1000.0))
    rep = cut.constraint_report(p)
    assert math.degrees(rep.turn_angle[0]) == pytest.approx(98.7, abs=0.3)
    assert rep.g4[0] == pytest.approx(611.7 - 722.0, abs=15.0) and not rep.feasible[0]
    assert cut(p)[0] >= cut.params.penalty_offset  # the compiled cost agrees
    flat = WaypointProblem(pos, goal, o, params=PsoCaParams())
    assert flat.constraint_report(p).g4[0] > 0 and flat.constraint_report(p).feasible[0]
    # a stack flying fillets: its corner is an arc, the fly-by lead alone (565 m to spare)
    arcs = WaypointProblem(
        pos, goal, o, params=PsoCaParams(switch_distance=1000.0, corner_fit=False)
    )
    assert arcs.constraint_report(p).g4[0] == pytest.approx(flat.constraint_report(p).g4[0])
    assert arcs(p)[0] < arcs.params.penalty_offset
    far = np.array([[270500.0, 12000.0]])  # 1.6 km before the goal
    assert cut.constraint_report(far).g4[0] > 0 and cut.constraint_report(far).feasible[0]
    assert cut(far)[0] < cut.params.penalty_offset


def test_objective_terms_eqs_2_to_6():
    prob = WaypointProblem([0, 0], [20000, 0], [[10000, 0]], others=[[10000, 4000], [0, 9000]])
    X = np.array([[10000, 2500], [10000, -2500]])
    t = prob.terms(X)
    np.testing.assert_allclose(t.f1, 2 * math.hypot(10000, 2500))
    # only the first obstacle is within MXRSK = 3 km of the first candidate (1.5 km away)
    np.testing.assert_allclose(t.f2, [(3000 - 1500) ** 2, 0.0])
    np.testing.assert_allclose(t.f, 0.1 * t.f1 + 0.9 * t.f2)
    np.testing.assert_allclose(t.penalised, t.f)  # both feasible
    assert t.f[1] < t.f[0]  # risk makes the right side better
    bad = prob(np.array([[10000, 1000]]))
    assert bad[0] > 1e12
    norm = WaypointProblem(
        [0, 0], [20000, 0], [[10000, 0]], others=[[10000, 4000]], params=PsoCaParams(normalise=True)
    ).terms(X)
    np.testing.assert_allclose(norm.f1, 2 * math.hypot(10000, 2500) / 20000)
    np.testing.assert_allclose(norm.f2, [0.25, 0.0])


def test_penalty_orders_infeasible_after_feasible_and_guides():
    prob = _problem()
    F = prob(np.array([[10000, 2500], [10000, 1900], [10000, 1000]]))
    assert F[0] < F[1] < F[2]


def test_paper_table4_waypoints_against_eq8_and_g3():
    """Table 4's PSO waypoints lie 5.3-5.8 km from the avoided obstacle, outside eq 8's 4 km; the
    hill waypoint's outgoing segment clears the safety sphere by a few metres (g3 active)."""
    p2 = WaypointProblem([125000, 11600], [200000, 15000], [[135000, 12000]])
    rep = p2.constraint_report([[130190, 14153]])
    assert rep.g2[0] < 0 and rep.g1[0] > 0 and rep.g3[0] > 0
    hill = WaypointProblem([280000, 17650], [350000, 20000], OBS[2:])
    rep = hill.constraint_report([[284710, 18371]])
    assert 0 < rep.g3[0] < 10
    assert rep.g2[0] < 0


# -- brute force --------------------------------------------------------------------------------
def test_brute_force_optimum_is_feasible_and_minimal():
    prob = WaypointProblem([0, 0], [20000, 0], [[10000, 0]], others=[[10000, -3500]])
    res = brute_force_waypoint(prob, step=50.0)
    assert res.status == "feasible"
    rep = prob.constraint_report(res.xy[None])
    assert rep.feasible[0]
    assert res.xy[1] > 0  # the other obstacle below pushes it up
    grid = search_grid(prob, 50.0)
    assert res.evaluations == len(grid)
    t = prob.terms(grid)
    assert np.all(t.f[t.report.feasible] >= res.f)
    assert res.f == pytest.approx(0.1 * res.f1 + 0.9 * res.f2)
    # no seed point beats it either
    seeds = tangent_seed_points([0, 0], [10000, 0], 2000.0, rng=0)
    assert np.all(prob(seeds) >= res.f - 1e-9)


def test_brute_force_chunks_agree_and_infeasible_status():
    prob = WaypointProblem([0, 0], [20000, 0], [[10000, 0]], others=[[10000, -3500]])
    a = brute_force_waypoint(prob, step=100.0)
    b = brute_force_waypoint(prob, step=100.0, chunk=97)
    np.testing.assert_array_equal(a.xy, b.xy)
    # the next waypoint inside the safety sphere: g3 can never hold (Fig. 9 case)
    stuck = WaypointProblem([0, 0], [10300, 0], [[10000, 0]])
    assert brute_force_waypoint(stuck, step=200.0).status == "infeasible"


def test_pso_from_tangent_seeds_reaches_the_grid_optimum():
    from planner.optim import make_optimizer

    prob = WaypointProblem([0, 0], [20000, 0], [[10000, 0]], others=[[10000, -3500]])
    lo, hi = prob.bounds()
    seeds = tangent_seed_points([0, 0], [10000, 0], 2000.0, n=10, rng=0)
    seeds = np.clip(seeds, lo, hi)
    opt = make_optimizer("pso", pop_size=10, max_iterations=60)
    out = opt.run(prob, lo, hi, seed=0, x0=seeds)
    best = brute_force_waypoint(prob, step=25.0)
    assert prob.constraint_report(out.x[None]).feasible[0]
    assert out.f <= best.f * 1.01


@pytest.mark.parametrize("side", [0, 1, -1])
@pytest.mark.parametrize(
    "options",
    [
        {},
        {"normalise": True, "leg_margin": 100.0},
        {"check_inbound": False, "check_outbound": False, "g2_centre": "aircraft"},
        {"switch_distance": 1000.0, "leg_margin": 100.0},
        {"switch_distance": 700.0, "approach_deg": 45.0, "tolerance": 100.0},
        {"switch_distance": 300.0, "corner_fit": False},
    ],
)
def test_compiled_cost_equals_the_numpy_terms(side: int, options: dict) -> None:  # type: ignore[type-arg]
    """The optimisers call the compiled penalised cost; it must be the documented one."""
    rng = np.random.default_rng(side + 7)
    both = []
    for _ in range(5):
        avoided = rng.uniform(-3000, 3000, (int(rng.integers(1, 5)), 2)) + np.array([10000.0, 0.0])
        others = rng.uniform(-6000, 6000, (int(rng.integers(0, 4)), 2)) + np.array([10000.0, 0.0])
        after = rng.uniform(-8000, 8000, 2) + np.array([20000.0, 500.0])
        pr = WaypointProblem(
            [0, 0],
            [20000, 500],
            avoided,
            others,
            params=PsoCaParams(**options),
            side=side,
            # cut corners onto an intermediate waypoint and onto the goal (no waypoint after)
            after=after if options.get("switch_distance") and rng.random() < 0.6 else None,
        )
        lo, hi = pr.bounds()
        X = rng.uniform(lo, hi, (200, 2))
        X[0] = pr.position  # degenerate legs
        X[1] = pr.target
        want = pr.terms(X).penalised
        np.testing.assert_allclose(pr(X), want, rtol=1e-12, atol=1e-6)
        feasible = pr.terms(X).report.feasible
        both.append(feasible.any() and not feasible.all())
    assert any(both)  # feasible and penalised candidates were both compared


@pytest.mark.parametrize("seed", [0, 1])
def test_compiled_constraint_report_has_the_numpy_bits(seed: int) -> None:
    """constraint_report's compiled geometry does the numpy twin's operations in its order: every
    field, for every candidate, the same bits (a decision records them), over the options, sides,
    cut corners with and without a waypoint after, a world check, and one to thousands of
    candidates (degenerate legs included)."""
    rng = np.random.default_rng(seed)
    options: list[dict] = [  # type: ignore[type-arg]
        {},
        {"normalise": True, "leg_margin": 100.0},
        {"check_inbound": False, "check_outbound": False, "g2_centre": "aircraft"},
        {"switch_distance": 1000.0, "leg_margin": 100.0},
        {"switch_distance": 700.0, "approach_deg": 45.0, "tolerance": 100.0},
        {"switch_distance": 300.0, "corner_fit": False},
        {"switch_distance": 1000.0, "leg_margin": 100.0, "speed": 30.0},
    ]

    def north_is_off(X: np.ndarray) -> np.ndarray:
        return np.clip(X[:, 1] - 1500.0, 0.0, None)

    for trial in range(70):
        avoided = rng.uniform(-3000, 3000, (int(rng.integers(1, 6)), 2)) + np.array([10000.0, 0.0])
        after = rng.uniform(-8000, 8000, 2) + np.array([20000.0, 500.0])
        pr = WaypointProblem(
            rng.normal(0.0, 3000.0, 2),
            np.array([20000.0, 500.0]) + rng.normal(0.0, 3000.0, 2),
            avoided,
            params=PsoCaParams(**options[trial % len(options)]),
            side=int(rng.integers(-1, 2)),
            after=after if rng.random() < 0.6 else None,
            world=north_is_off if trial % 5 == 0 else None,
        )
        lo, hi = pr.bounds()
        X = rng.uniform(lo, hi, (int(rng.choice([1, 2, 10, 3000])), 2))
        if len(X) > 2:
            X[0], X[1] = pr.position, pr.target
        got, want = pr.constraint_report(X), pr.constraint_report_numpy(X)
        for f in dataclasses.fields(got):
            a, b = getattr(got, f.name), getattr(want, f.name)
            assert a.dtype == b.dtype and a.shape == b.shape, f.name
            np.testing.assert_array_equal(a, b, err_msg=f.name)
            np.testing.assert_array_equal(np.signbit(a), np.signbit(b), err_msg=f.name)


def test_g7_the_world_check_enters_both_costs_alike() -> None:
    """A world check (g7: metres of the new legs that break the map's or the zones' validity)
    makes a candidate infeasible in the compiled cost exactly as in the documented terms, whether
    the paper's constraints already refused it or not."""
    rng = np.random.default_rng(3)
    pr0 = WaypointProblem([0, 0], [20000, 500], np.array([[10000.0, 0.0]]))

    def north_is_off(X: np.ndarray) -> np.ndarray:  # a map edge at y = 1500
        return np.clip(X[:, 1] - 1500.0, 0.0, None)

    pr = dataclasses.replace(pr0, world=north_is_off)
    lo, hi = pr.bounds()
    X = rng.uniform(lo, hi, (400, 2))
    t0, t = pr0.terms(X), pr.terms(X)
    np.testing.assert_allclose(pr(X), t.penalised, rtol=1e-12, atol=1e-6)
    np.testing.assert_array_equal(t.report.g7, -north_is_off(X))
    off = X[:, 1] > 1500.0
    assert not t.report.feasible[off].any()
    np.testing.assert_array_equal(t.report.feasible[~off], t0.report.feasible[~off])
    # refused by g7 alone, and by g7 on top of the paper's constraints: both are compared
    assert (off & t0.report.feasible).any() and (off & ~t0.report.feasible).any()
    assert (pr(X)[off] > pr0(X)[off]).all()


def test_compiled_cost_has_one_specialisation_for_every_caller() -> None:
    """An optimiser hands f a read-only view, a rescue grid scan a writable array and a problem
    may hold read-only waypoints: all must reach the same compiled specialisation, or the first
    rescue of a flight stalls for seconds of JIT compilation."""
    from replay.avoidance.pso_ca_kernel import penalised_costs

    target = np.array([20000.0, 500.0])
    target.flags.writeable = False
    pr = WaypointProblem([0, 0], target, np.array([[10000.0, 0.0]]), np.zeros((0, 2)))
    lo, hi = pr.bounds()
    X = np.random.default_rng(0).uniform(lo, hi, (10, 2))
    view = X.view()
    view.flags.writeable = False
    a = pr(view)
    b = pr(search_grid(pr, 500.0))
    c = pr(np.asfortranarray(np.repeat(X, 2, axis=0))[::2])  # strided, Fortran order
    np.testing.assert_array_equal(a, c)
    assert np.isfinite(b).all()
    assert len(penalised_costs.signatures) == 1


def _tangent_points_arrays(a: np.ndarray, o: np.ndarray, radius: float) -> np.ndarray:
    """Eq 27 in the array form tangent_points had before issue 38 (the reference)."""
    x0, y0 = o - a
    d2 = x0 * x0 + y0 * y0
    s = math.sqrt(d2 - radius * radius)
    cos_t = (-radius * x0 + np.array([1.0, -1.0]) * y0 * s) / d2
    sin_t = (-radius * y0 - np.array([1.0, -1.0]) * x0 * s) / d2
    pts = o + radius * np.column_stack([cos_t, sin_t])
    rel = pts - a
    left = x0 * rel[:, 1] - y0 * rel[:, 0] > 0.0
    return pts if left[0] else pts[::-1].copy()


def test_scalar_tangent_points_are_the_array_form_s_bits() -> None:
    rng = np.random.default_rng(7)
    for _ in range(3000):
        a = rng.uniform(-5e5, 5e5, 2) + np.array([4e5, 4e6])
        o = a + rng.normal(0.0, rng.choice([1e3, 1e4, 1e5]), 2)
        radius = float(rng.uniform(1.0, 0.999 * np.hypot(*(o - a))))
        got = tangent_points(a, o, radius)
        np.testing.assert_array_equal(got, _tangent_points_arrays(a, o, radius))
    with pytest.raises(InputError, match="no tangent"):
        tangent_points([0.0, 0.0], [10.0, 0.0], 20.0)
