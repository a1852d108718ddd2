"""The scenario generators (replay.campaign.generators) as benchmarks/bench_pso_ca.py composes them, and its helpers (no replays here)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks import bench_pso_ca as b
from planner.mission import load_mission
from replay.avoidance.pso_ca_geometry import PsoCaParams, WaypointProblem
from replay.campaign import generators as g
from replay.threats.clusters import cluster_hill_points


@pytest.fixture(scope="module")
def mission():
    return load_mission(b.MISSION)


def test_scenario_seed_is_readable_and_distinct():
    assert b.scenario_seed(40, 3) == 40_003
    assert b.scenario_seed(b.HILL_CODE, 0) == 1_001_000
    seeds = {
        b.scenario_seed(r.code, run) for r in b.rows_for(b.DEFAULT_COUNTS) for run in range(10)
    }
    assert len(seeds) == 13 * 10
    with pytest.raises(ValueError):
        b.scenario_seed(1, 1000)


def test_random_obstacles_deterministic_and_clear_of_the_ends(mission):
    w = np.asarray(mission.waypoints)
    a = g.random_obstacles(w, 500, np.random.default_rng(7))
    again = g.random_obstacles(w, 500, np.random.default_rng(7))
    np.testing.assert_array_equal(a, again)
    assert a.shape == (500, 2)
    for end in (w[0, :2], w[-1, :2]):
        assert np.hypot(*(a - end).T).min() >= g.KEEP_CLEAR_M
    # every obstacle lies round some waypoint: within 5 sigma of the nearest one
    d = np.sqrt(((a[:, None, :] - w[None, :, :2]) ** 2).sum(-1)).min(axis=1)
    assert d.max() < 5 * g.SIGMA_M
    # the spread round the waypoints is about sigma (per axis): mean squared distance ~ 2 sigma^2
    assert 0.5 * g.SIGMA_M < math.sqrt(np.mean(d**2) / 2) < 1.2 * g.SIGMA_M


def test_every_optimizer_sees_the_same_scenario(mission):
    row = b.Row("40", 40)
    one, seed1 = b.scenario_records(row, 2, mission)
    two, seed2 = b.scenario_records(row, 2, mission)
    assert one == two and seed1 == seed2 == 40_002
    other, _ = b.scenario_records(row, 3, mission)
    assert other != one


def test_special_rows_extend_the_40_obstacle_draw(mission):
    base, _ = b.scenario_records(b.Row("40", 40), 1, mission)
    hill_row, intruder_row = b.rows_for((), special=True)
    hill, seed = b.scenario_records(hill_row, 1, mission)
    assert seed == 1_001_001
    assert hill[:40] == base and hill[40]["kind"] == "hill"
    moving, seed = b.scenario_records(intruder_row, 1, mission)
    assert seed == 1_002_001
    assert moving[:40] == base and [r["kind"] for r in moving[40:]] == ["intruder"] * 2
    b.threat_set(hill, "hill")  # valid threat records
    b.threat_set(moving, "moving")


def test_hill_is_one_continuous_obstacle_across_a_leg(mission):
    w = np.asarray(mission.waypoints)[:, :2]
    for seed in range(20):
        pts = g.hill_ridge(w, np.random.default_rng(seed))
        assert pts.shape == (g.HILL_POINTS, 2)
        assert len(cluster_hill_points(np.column_stack([pts, np.zeros(len(pts))]))) == 1
        # the middle of the ridge lies on a leg, so the leg meets the hill's safety spheres
        mid = pts.mean(axis=0)
        d = min(_point_segment(mid, w[i], w[i + 1]) for i in range(len(w) - 1))
        assert d < 1e-6


def _point_segment(p, a, b_):
    ab = b_ - a
    t = np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0.0, 1.0)
    return float(np.hypot(*(a + t * ab - p)))


def test_intruders_meet_the_undisturbed_aircraft(mission):
    w = np.asarray(mission.waypoints)
    speed = float(mission.cruise_speed)
    recs = g.intruder_records(w, speed, np.random.default_rng(3))
    ts = b.threat_set(recs, "x")
    times = g.mission_timeline(w, speed)
    assert [r["meet_kind"] for r in recs] == ["head-on", "crossing"]
    for r in recs:
        th = ts.get(r["id"])
        np.testing.assert_allclose(th.position(r["meet_t"])[:2], r["meet_xy"], atol=1e-6)
        assert np.linalg.norm(th.velocity(r["meet_t"])) == pytest.approx(g.INTRUDER_SPEED)
        assert th.active(r["meet_t"]) and r["appears_at"] >= 0
        # where the undisturbed aircraft is at meet_t: the meeting point
        i = int(np.searchsorted(times, r["meet_t"])) - 1
        f = (r["meet_t"] - times[i]) / (times[i + 1] - times[i])
        np.testing.assert_allclose(
            w[i, :2] + f * (w[i + 1, :2] - w[i, :2]), r["meet_xy"], atol=1e-6
        )
    head, cross = recs
    leg = w[4, :2] - w[3, :2] if head["meet_t"] < times[4] else w[5, :2] - w[4, :2]
    v = np.asarray(head["velocity"][:2])
    assert np.dot(v, leg) / (np.linalg.norm(v) * np.linalg.norm(leg)) == pytest.approx(-1.0)
    leg1 = w[2, :2] - w[1, :2]
    v = np.asarray(cross["velocity"][:2])
    assert abs(np.dot(v, leg1)) < 1e-9 * np.linalg.norm(leg1) * np.linalg.norm(v) + 1e-9


def test_polyline_length_of_the_mission(mission):
    assert b.polyline_length(mission.waypoints) == pytest.approx(431_633.43, abs=0.01)
    assert b.polyline_length(np.zeros((1, 3))) == 0.0


def test_rebuild_problem_reproduces_a_decision():
    base = PsoCaParams(leg_margin=100.0)
    problem = WaypointProblem(
        np.array([0.0, 0.0]), np.array([20000.0, 0.0]), np.array([[10000.0, 0.0]]), params=base
    )
    xy = np.array([10000.0, 2100.0])
    terms = problem.terms(xy[None, :])
    info = {
        "new_waypoint": [xy[0], xy[1], 200.0],
        "f": float(terms.f[0]),
        "feasible": bool(terms.report.feasible[0]),
        "obstacle_kind": "stationary",
        "inputs": {
            "aircraft": [0.0, 0.0],
            "target": [20000.0, 0.0],
            "obstacles": [[10000.0, 0.0]],
            "others": [],
            "side": 0,
            "params": {"rs": 1000.0, "wt": 0.1, "wo": 0.9, "unknown_key": 1},
        },
    }
    out = b.decision_gap(info, base, step=50.0)
    assert out["rebuilt_ok"] and out["bf_feasible"] and out["feasible"]
    # the grid optimum is no worse than this waypoint, up to the grid's resolution
    assert out["gap"] > -0.2 * 50.0 * math.sqrt(2)
    assert (
        b.rebuild_problem({**info, "obstacle_kind": "moving"}, base).params.check_outbound is False
    )
    # the corner cut at the target (switch distance, the waypoint after it) is rebuilt too
    cut = {**info, "inputs": {**info["inputs"], "after": [21000.0, 5000.0]}}
    cut["inputs"]["params"] = {**cut["inputs"]["params"], "switch_distance": 1000.0}
    rebuilt = b.rebuild_problem(cut, base)
    assert rebuilt.after is not None and rebuilt.params.switch_distance == 1000.0
    np.testing.assert_array_equal(rebuilt.after, [21000.0, 5000.0])


def test_feasible_iteration_from_the_info():
    assert b.feasible_iteration({}, 1e12) is None
    assert b.feasible_iteration({"feasible_iteration": 4}, 1e12) == 4
    assert b.feasible_iteration({"history_best": [2e12, 1.5e12, 7000.0, 6900.0]}, 1e12) == 2


def test_parser_quick_defaults():
    args = b.parser().parse_args(["table6", "--quick"])
    assert args.quick and args.runs is None and args.optimizers is None
    with pytest.raises(SystemExit):
        b.parser().parse_args(["table4", "--optimizers", "pso,nope"])


def test_load_saved_skips_a_torn_last_line(tmp_path):
    p = tmp_path / "runs.jsonl"
    p.write_text('{"scenario": "40", "run": 0, "optimizer": "pso"}\n{"scenario": "40", "ru')
    assert b.load_saved(p) == [{"scenario": "40", "run": 0, "optimizer": "pso"}]


def test_stage_counts_separate_the_paper_search_from_the_additions():
    runs = [
        {
            "decisions": [
                {"stage": "paper", "grid": 0},
                {"stage": "paper", "grid": 900},
                {"stage": "failed", "grid": 900},
            ]
        },
        {"decisions": [{"stage": "skip 1", "grid": 12}, {"grid": 0}]},
    ]
    assert b.stage_counts(runs) == "paper 2, paper + rescue 1, skip 1 1"
    assert b.stage_counts([{"decisions": []}]) == "none"
