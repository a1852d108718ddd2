"""FGA (seed 004): the geometry, the critical time's sign, both manoeuvres, holding without
chattering, the Monte Carlo generator, Table VIII's cases, and bad input."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from planner.mission import mission_from_dict
from replay.avoidance import make_avoider
from replay.avoidance.fga import FgaAvoider
from replay.avoidance.fga_geometry import (
    FgaObstacle,
    cone_half_angle,
    conflict_matrix,
    encounter,
    flips,
    in_conflict,
    tangent_course,
    tangent_courses,
)
from replay.avoidance.fga_plan import climb_limits
from replay.campaign import seed004
from replay.campaign.generators import file_records
from replay.flight.fixedwing.presets import preset
from replay.flight.fixedwing.stack import measure_turn
from replay.run import ReplayRequest, run_replay
from replay.threats.file import threats_from_records
from terrain.errors import InputError

ROOT = Path(__file__).resolve().parents[1]
SCEN = ROOT / "data" / "scenarios"
MISSION = SCEN / "seed004-mission.yaml"
D_M = 30.0


def _fly(threats: object, **kw: object):  # type: ignore[no-untyped-def]
    return run_replay(
        ReplayRequest.of(
            str(MISSION),
            threats=threats,  # type: ignore[arg-type]
            avoid="fga",
            sensor="cooperative",
            margin=D_M,
            **kw,  # type: ignore[arg-type]
        )
    )


def _least(result) -> float:  # type: ignore[no-untyped-def]
    return min(v["value"] for v in result.metrics.as_dict()["min_separation"].values())


def _records(tmp_path: Path, name: str, records: list[dict[str, object]]) -> str:
    import yaml

    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump({"terrapath": 1, "threats": records}), encoding="utf-8")
    return str(p)


# -- the vehicle (eq 5) and t_res (eq 8) ------------------------------------------------------------
def test_seed004_vehicle_turns_as_tightly_as_eq_5_assumes_and_t_res_is_measured() -> None:
    m = measure_turn("seed004-uas", 15.0)
    # eq 3 at 38 deg: 29.4 m; the 6-DOF aircraft's steady turn is within 5 % of it and within d_m
    # + 10 % (the option FGA checks)
    assert m["radius_eq3_m"] == pytest.approx(29.36, abs=0.05)
    assert m["radius_m"] == pytest.approx(m["radius_eq3_m"], rel=0.05)
    assert m["radius_m"] <= D_M * 1.1
    # the default t_res (0.5 s) covers every course step measured, and the lag is real
    assert all(0.2 < v <= FgaAvoider().t_res + 0.02 for v in m["t_res"].values())
    assert m["max_rate_deg_s"] == pytest.approx(m["ideal_rate_deg_s"], rel=0.03)


def test_a_vehicle_that_cannot_turn_within_a_given_d_m_is_refused_naming_the_numbers() -> None:
    fga = FgaAvoider(d_m=30.0)
    with pytest.raises(InputError, match=r"39\.7 m.*d_m = 30 m.*at least 36\.1 m"):
        fga.check_vehicle(preset("small-uas"), 15.0)
    fga.check_vehicle(preset("seed004-uas"), 15.0)  # 29.4 m: fine
    doc = mission_from_dict({**seed004.mission_doc(), "vehicle": "small-uas"}, "small-uas mission")
    with pytest.raises(InputError, match="minimum turn radius"):
        run_replay(ReplayRequest.of(doc, avoid="fga", avoid_options={"d_m": 30.0}))


def test_the_distances_follow_the_vehicle_and_reduce_to_table_ii_on_its_uas() -> None:
    """Issue 34: d_m is the larger of Table II's 30 m and the minimum turn radius, R = 10 d_m,
    buffer d_m / 10, the horizon the time to fly R when longer than 60 s."""
    cases = {
        ("seed004-uas", 15.0): (30.0, 300.0, 3.0, 60.0),  # Table II exactly
        ("small-uas", 15.0): (39.7, 397.0, 3.97, 60.0),
        ("aerosonde", 25.0): (110.3, 1103.0, 11.03, 60.0),
        ("cessna172", 50.0): (441.4, 4414.0, 44.14, 88.3),
    }
    for (name, speed), (d_m, r, buffer, horizon) in cases.items():
        fga = FgaAvoider()
        fga.check_vehicle(preset(name), speed)  # never refused by default
        got = (fga.d_m, fga.surveillance_m, fga.buffer_m, fga.horizon_s)
        assert got == pytest.approx((d_m, r, buffer, horizon), rel=2e-3), name
        assert fga.planner.d_m == fga.d_m
    # options given keep their values
    fga = FgaAvoider(d_m=200.0, surveillance_m=900.0, buffer_m=5.0, horizon_s=30.0)
    fga.check_vehicle(preset("aerosonde"), 25.0)
    assert (fga.d_m, fga.surveillance_m, fga.buffer_m, fga.horizon_s) == (200.0, 900.0, 5.0, 30.0)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"d_m": 0.0}, "d_m"),
        ({"d_m": -5.0}, "d_m"),
        ({"surveillance_m": 30.0}, "must exceed d_m"),
        ({"surveillance_m": 20.0, "d_m": 30.0}, "must exceed d_m"),
        ({"t_res": math.nan}, "t_res"),
    ],
)
def test_bad_options_are_refused(options: dict[str, float], message: str) -> None:
    with pytest.raises(InputError, match=message):
        make_avoider("fga", **options)


# -- geometry ---------------------------------------------------------------------------------------
def test_the_cone_half_angle_is_the_exact_tangent() -> None:
    # eq 1's atan and step 8's d_m / r are small-angle forms: at r = 2 d_m they are 26.6 and 28.6
    # deg, the tangent is 30 deg
    assert math.degrees(cone_half_angle(60.0, 30.0)) == pytest.approx(30.0)
    assert cone_half_angle(20.0, 30.0) == pytest.approx(math.pi / 2)


def _static(x: float, y: float, radius: float = 10.0) -> FgaObstacle:
    return FgaObstacle("o", (x, y, 100.0), (0.0, 0.0, 0.0), radius, -math.inf, 150.0)


def test_critical_time_sign_convention_relative_velocity_of_the_aircraft() -> None:
    pos = np.array([0.0, 0.0, 100.0])
    vel = np.array([0.0, 15.0, 0.0])
    ahead = encounter(pos, vel, _static(0.0, 300.0), keep_h=30, keep_v=30, rho=30, horizon=60)
    # along-track distance 300 m ahead, miss 0: eq 7 = (300 - 30 - 40) / 15 > 0
    assert ahead.along == pytest.approx(300.0)
    assert ahead.miss == pytest.approx(0.0)
    assert ahead.t_c == pytest.approx((300.0 - 30.0 - 40.0) / 15.0)
    assert ahead.window is not None and ahead.range_rate < 0
    # an obstacle behind is no conflict; one passing 60 m to the side neither
    behind = encounter(pos, vel, _static(0.0, -300.0), keep_h=30, keep_v=30, rho=30, horizon=60)
    side = encounter(pos, vel, _static(60.0, 300.0), keep_h=30, keep_v=30, rho=30, horizon=60)
    assert behind.window is None and behind.along < 0
    assert side.window is None and side.miss == pytest.approx(60.0)
    # an obstacle 40 m below its keep: the vertical cone leaves it alone
    low = FgaObstacle("low", (0.0, 300.0, 20.0), (0.0, 0.0, 0.0), 10.0, -math.inf, 20.0)
    assert encounter(pos, vel, low, keep_h=30, keep_v=30, rho=30, horizon=60).window is None


def test_tangent_courses_put_the_relative_velocity_on_the_cone_edge() -> None:
    pos = np.array([0.0, 0.0, 100.0])
    keep = 40.0
    # static: the closed form LOS +- asin(keep / r)
    o = _static(0.0, 200.0)
    right = tangent_course(pos, o, keep, 15.0, 1)
    left = tangent_course(pos, o, keep, 15.0, -1)
    assert right == pytest.approx(math.asin(keep / 200.0))
    assert left == pytest.approx(-math.asin(keep / 200.0))
    # moving: the quadratic; |own| = speed and the relative velocity on the edge, both roots for
    # an obstacle faster than the aircraft
    fast = FgaObstacle("f", (150.0, 100.0, 100.0), (-20.0, -5.0, 0.0), 1.0, 99.0, 101.0)
    for side in (1, -1):
        roots = tangent_courses(pos, fast, keep, 15.0, side)
        assert roots
        los = math.atan2(150.0, 100.0)
        for c in roots:
            w = np.array([15.0 * math.sin(c) + 20.0, 15.0 * math.cos(c) + 5.0])
            angle = math.atan2(w[0], w[1]) - los
            angle = (angle + math.pi) % (2 * math.pi) - math.pi
            assert angle == pytest.approx(side * math.asin(keep / math.hypot(150.0, 100.0)))
    assert len(tangent_courses(pos, fast, keep, 15.0, 1)) == 2


# -- flights ----------------------------------------------------------------------------------------
def test_heading_branch_a_tower_ahead_is_flown_round_once_without_chattering(
    tmp_path: Path,
) -> None:
    path = _records(
        tmp_path,
        "tower",
        [{"id": "tower", "kind": "cylinder", "center": [5.0, 600.0], "radius": 15.0, "top": 250}],
    )
    r = _fly(path)
    assert r.metrics.success
    assert _least(r) >= D_M
    starts = [d for d in r.decisions if d.get("fga") == "start"]
    assert len(starts) == 1 and starts[0]["manoeuvre"] == "heading"
    # started at eq 8's t_k, not at detection (the decision before it waited)
    waits = [d for d in r.decisions if d.get("fga") == "wait"]
    assert waits and waits[0]["t"] < starts[0]["t"] - 5.0
    # one return to the mission; no course command after it (no turning back and forth)
    returns = [d for d in r.decisions if d.get("fga") == "return"]
    assert len(returns) == 1
    after = [d for d in r.decisions if d["t"] > returns[0]["t"] and d.get("command")]
    assert not after
    # the courses commanded while steering all lie on one side of the mission's course
    courses = [
        d["command"]["course"]
        for d in r.decisions
        if (d.get("command") or {}).get("command") == "HoldCourse"
    ]
    assert len({math.copysign(1.0, c) for c in courses}) == 1
    # the avoider ran at 10 Hz
    assert r.metrics.avoider_calls == pytest.approx(r.metrics.flight_time_s * 10.0, rel=0.03)


def test_pitch_branch_a_wall_just_below_the_flight_level_is_climbed_over(tmp_path: Path) -> None:
    # a row of towers 32 m below the aircraft, too long to fly round cheaply
    wall = [
        {"id": f"w{k}", "kind": "cylinder", "center": [float(x), 600.0], "radius": 40.0, "top": 88}
        for k, x in enumerate(range(-500, 501, 100))
    ]
    r = _fly(_records(tmp_path, "wall", wall))
    assert r.metrics.success and _least(r) >= D_M
    starts = [d for d in r.decisions if d.get("fga") == "start"]
    assert starts[0]["manoeuvre"] == "pitch" and starts[0]["side"] == 1
    assert starts[0]["costs"]["pitch_s"] < starts[0]["costs"]["heading_s"]
    assert r.positions[:, 2].max() > 88 + D_M


def test_several_threats_the_chosen_course_is_outside_the_union_of_their_cones() -> None:
    fga = FgaAvoider()
    pos = np.array([0.0, 0.0, 100.0])
    vel = np.array([0.0, 15.0, 0.0])
    # the tangent course of the first alone runs into the second
    a = FgaObstacle("a", (0.0, 200.0, 100.0), (0.0, 0.0, 0.0), 10.0, -math.inf, 200.0)
    b = FgaObstacle("b", (45.0, 230.0, 100.0), (0.0, 0.0, 0.0), 10.0, -math.inf, 200.0)
    alone = tangent_course(pos, a, 10.0 + D_M + 6.0, 15.0, 1)
    assert alone is not None
    v_alone = np.array([15 * math.sin(alone), 15 * math.cos(alone), 0.0])
    assert fga.planner.encounter(pos, v_alone, b, 30.0).window is not None
    targets = [fga.planner.encounter(pos, vel, o, 30.0) for o in (a, b)]
    plan = fga.planner.heading_plan(pos, vel, 0.0, targets, [a, b], 30.0, 0.5)
    assert plan is not None
    v = np.array([15 * math.sin(plan.course), 15 * math.cos(plan.course), 0.0])
    assert all(fga.planner.encounter(pos, v, o, 30.0).window is None for o in (a, b))


def test_the_candidates_array_test_is_in_conflict_element_for_element() -> None:
    rng = np.random.default_rng(7)
    obstacles = [
        FgaObstacle(
            f"o{k}",
            (float(rng.uniform(-300, 300)), float(rng.uniform(-300, 300)), 100.0),
            (0.0, 0.0, 0.0) if k % 3 == 0 else (float(rng.uniform(-20, 20)), 15.0, 0.0),
            float(rng.uniform(1, 20)),
            float(rng.uniform(0, 110)) if k % 2 else -math.inf,
            float(rng.uniform(90, 200)),
        )
        for k in range(12)
    ]
    pos = np.array([3.0, -7.0, 100.0])
    courses = rng.uniform(-math.pi, math.pi, 200)
    # level and climbing, and one velocity equal to a moving obstacle's (no relative motion)
    vel = np.column_stack([15 * np.sin(courses), 15 * np.cos(courses), rng.choice([0, 2.5], 200)])
    vel[0] = obstacles[1].velocity
    got = conflict_matrix(pos, vel, obstacles, 34.5, 60.0)
    want = [[in_conflict(*pos, *v, o, 34.5, 60.0) for o in obstacles] for v in vel]
    assert got.tolist() == want
    assert 0 < got.sum() < got.size  # both outcomes occur


def test_only_a_closing_course_can_flip_the_side_an_obstacle_is_passed_on() -> None:
    ahead = FgaObstacle("a", (-20.0, 100.0, 100.0), (0.0, 0.0, 0.0), 5.0, -math.inf, 200.0)
    pos = np.array([0.0, 0.0, 100.0])
    north = np.array([0.0, 15.0, 0.0])
    side = 1 if flips(pos, north, ahead, -1) else -1  # the side north passes it on
    assert not flips(pos, north, ahead, side)
    west = np.array([-15.0 * math.sin(0.5), 15.0 * math.cos(0.5), 0.0])  # across its line of sight
    assert flips(pos, west, ahead, side)
    # once behind (as after holding past it), every turn opens the range: nothing flips
    behind = FgaObstacle("b", (-20.0, -60.0, 100.0), (0.0, 0.0, 0.0), 5.0, -math.inf, 200.0)
    for c in np.radians([-60.0, -20.0, 0.0, 30.0, 70.0]):
        v = np.array([15 * math.sin(c), 15 * math.cos(c), 0.0])
        assert not flips(pos, v, behind, 1) and not flips(pos, v, behind, -1)


def test_the_manoeuvre_governs_the_conflict_entered_first() -> None:
    fga = FgaAvoider()
    pos = np.array([0.0, 0.0, 100.0])
    vel = np.array([0.0, 15.0, 0.0])
    # a slow intruder overtaking from close behind, and a fast one crossing from farther ahead
    behind = FgaObstacle("behind", (5.0, -60.0, 100.0), (0.0, 16.0, 0.0), 1.0, 99.0, 101.0)
    crossing = FgaObstacle("crossing", (90.0, 75.0, 100.0), (-15.0, 0.0, 0.0), 1.0, 99.0, 101.0)
    targets = [fga.planner.encounter(pos, vel, o, 30.0) for o in (behind, crossing)]
    assert targets[0].distance < targets[1].distance
    assert targets[0].window and targets[1].window
    assert targets[1].window[0] < targets[0].window[0]
    assert fga.planner.first(pos, targets, [behind, crossing]) is crossing


# Monte Carlo cases (seed004-table3 / -table4 runs) FGA once failed, each for a reason fixed since:
# a passed obstacle's "side" forcing a reversal (static 1001, 4928), a gap between two obstacles
# too narrow to pass found only when urgent (static 1724), a crossing intruder steered round on
# the wrong obstacle's cone (dynamic 3405)
@pytest.mark.parametrize(
    "dynamic, run", [(False, 1001), (False, 4928), (False, 1724), (True, 3405)]
)
def test_monte_carlo_cases_once_failed_now_keep_d_m(dynamic: bool, run: int) -> None:
    from replay.campaign.runner import case
    from replay.campaign.spec import load_spec

    bench = ROOT / "replay" / "campaign" / "benches"
    spec = load_spec(bench / f"seed004-table{4 if dynamic else 3}.yaml")
    key = f"seed004-table2/{'dynamic' if dynamic else 'static'}/fga/{run}"
    flight = spec.find(key)
    mission, threats, notes = case(flight)
    assert notes["hazards"] >= 1
    r = run_replay(
        ReplayRequest.of(
            mission,
            threats=threats,
            avoid="fga",
            seed=flight.seed,
            sensor=flight.sensor,
            margin=flight.margin,
            radar_range=flight.sensor_range or 1500.0,
        )
    )
    assert r.metrics.success and r.metrics.reached_goal, key
    assert _least(r) >= D_M
    # and without FGA the same case breaks d_m
    bare = run_replay(
        ReplayRequest.of(mission, threats=threats, sensor=flight.sensor, margin=flight.margin)
    )
    assert _least(bare) < D_M


def test_an_obstacle_already_inside_d_m_is_recorded_and_escaped(tmp_path: Path) -> None:
    path = _records(
        tmp_path,
        "inside",
        [
            {
                "id": "close",
                "kind": "intruder",
                "position": [15.0, 40.0, 120.0],
                "velocity": [0.0, 0.0, 0.0],
                "radius": 1.0,
                "appears_at": 2.0,
            }
        ],
    )
    r = _fly(path)  # no exception: a violation recorded, the run ends normally
    assert not r.metrics.success and r.metrics.reached_goal
    assert any("already violated" in d["reason"] for d in r.decisions)


# -- Table VIII cases 5-9 ---------------------------------------------------------------------------
# ours: the manoeuvre chosen and its side (paper: pitch up, pitch up, left, left, right)
TABLE8 = {5: "heading", 6: "heading", 7: "heading", 8: "heading", 9: "heading"}


@pytest.mark.parametrize("case", sorted(TABLE8))
def test_table8_cases_keep_d_m_where_the_mission_alone_would_not(case: int) -> None:
    threats = str(SCEN / f"seed004-case{case}.yaml")
    before = run_replay(
        ReplayRequest.of(str(MISSION), threats=threats, sensor="cooperative", margin=D_M)
    )
    assert _least(before) < D_M  # the undisturbed flight breaks d_m (the paper's "orig. min")
    r = _fly(threats)
    assert r.metrics.success and _least(r) >= D_M
    starts = [d for d in r.decisions if d.get("fga") == "start"]
    assert starts[0]["manoeuvre"] == TABLE8[case]


# -- the Monte Carlo generator (Table II) -----------------------------------------------------------
@pytest.mark.parametrize("dynamic", [False, True])
def test_generator_hazards_are_exactly_the_obstacles_on_a_collision_course(dynamic: bool) -> None:
    leg = np.column_stack(
        [np.zeros(801), np.linspace(0.0, seed004.LEG_M, 801), np.full(801, seed004.ALTITUDE_M)]
    )
    t = np.linspace(0.0, seed004.LEG_M / seed004.SPEED_MPS, 801)
    for k in range(6):
        _doc, records, notes = seed004.seed004_case(np.random.default_rng(k), dynamic)
        assert 10 <= notes["obstacles"] <= 20 or notes["obstacles"] == notes["hazards"]
        threats = threats_from_records(file_records(records), name="case")
        hazards = 0
        for th in threats.threats:
            sep = float(np.min(th.separation(leg, t)))
            if th.id.startswith("hazard"):
                hazards += 1
                assert sep < D_M
            else:
                assert sep >= D_M + 4.0
        assert hazards == notes["hazards"]


def test_generator_hazard_counts_follow_the_tables_bins() -> None:
    rng = np.random.default_rng(0)
    for dynamic, freq in ((False, seed004.STATIC_FREQ), (True, seed004.DYNAMIC_FREQ)):
        n = 4000
        counts = np.bincount([seed004.hazard_count(rng, dynamic) for _ in range(n)], minlength=5)
        expected = np.array(freq) / sum(freq) * n
        chi2 = float(((counts - expected) ** 2 / expected).sum())
        assert chi2 < 18.5  # 4 degrees of freedom, p = 0.001
        # "> 3" as 4 reproduces the tables' means (1.44 static, 1.51 dynamic)
        mean = float(np.dot(seed004.HAZARD_BINS, freq)) / sum(freq)
        assert mean == pytest.approx(1.51 if dynamic else 1.44, abs=0.005)


# -- MCAP and view ----------------------------------------------------------------------------------
def test_cones_t_c_and_the_manoeuvre_are_recorded_drawn_in_foxglove_and_the_view(
    tmp_path: Path,
) -> None:
    import json

    from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
    from mcap.reader import make_reader

    from replay.record.picture import recorded_view
    from replay.record.reader import load_run
    from terrapath.view.decisions import decision_marks

    out = tmp_path / "case9.mcap"
    _fly_out = run_replay(
        ReplayRequest.of(
            str(MISSION),
            threats=str(SCEN / "seed004-case9.yaml"),
            avoid="fga",
            sensor="cooperative",
            margin=D_M,
        ),
        out,
    )
    assert _fly_out.metrics.success
    run = load_run(out)
    starts = [d.decision for d in run.decisions if d.decision.get("fga") == "start"]
    assert starts
    first = starts[0]
    for key in ("t_c", "t_k", "manoeuvre", "why", "costs", "classification", "cones"):
        assert key in first
    assert first["t_k"] == pytest.approx(first["t"], abs=0.11)  # started at t_k
    origin = np.array(json.loads(run.metadata["map_origin"]), dtype=float)
    cones, gone = [], 0
    with out.open("rb") as f:
        for _, _, msg in make_reader(f).iter_messages(topics=["/avoidance/guidance"]):
            update = SceneUpdate.FromString(msg.data)
            gone += sum(d.id == "guidance/cones" for d in update.deletions)
            cones += [e for e in update.entities if e.id == "guidance/cones"]
    assert cones and gone >= 1
    line = cones[0].lines[0]
    assert line.type == LinePrimitive.LINE_LIST
    pts = np.array([[p.x, p.y, p.z] for p in line.points]) + origin
    assert len(pts) % 2 == 0
    # the first cone: two edges from the apex, each tangent to the protected circle
    c = next(d.decision for d in run.decisions if d.decision.get("cones"))["cones"][0]
    apex = np.array(c["apex"])
    np.testing.assert_allclose(pts[0], apex, atol=1e-6)
    tangent = math.sqrt(c["range_m"] ** 2 - c["keep_m"] ** 2)
    assert np.linalg.norm(pts[1] - apex) == pytest.approx(tangent, rel=1e-6)
    centre = apex + c["range_m"] * np.array(
        [math.sin(math.radians(c["los_deg"])), math.cos(math.radians(c["los_deg"])), 0.0]
    )
    assert np.linalg.norm(pts[1] - centre) == pytest.approx(c["keep_m"], rel=1e-6)
    names = {m.name for m in decision_marks(recorded_view(out))}
    assert {"FGA's collision cones", "FGA's course"} <= names


def test_surveillance_radius_defaults_to_ten_d_m() -> None:
    # §II-C (4): "R is set to be 10 times d_m" (Table II: 300 m for 30 m)
    assert FgaAvoider().surveillance_m == 300.0
    assert FgaAvoider(d_m=50.0).surveillance_m == 500.0
    assert FgaAvoider(d_m=50.0, surveillance_m=800.0).surveillance_m == 800.0


def test_pso_ca_can_wait_for_the_critical_start_time() -> None:
    """PSO-CA with ``start=critical`` (seed 004 §III-B4) re-plans at t_c - t_res instead of at
    detection: later, still clear of the obstacle; a bad mode is refused."""
    from terrapath.testing.avoider import flown, fly

    # the contract's own "single" flight with PSO-CA (seed 0): flown once per process
    early = flown("single", "pso-ca")
    late = fly("single", make_avoider("pso-ca", start="critical"))
    assert early.metrics.success and late.metrics.success
    first = [min(d["t"] for d in r.decisions) for r in (early, late)]
    assert first[1] > first[0] + 300.0  # found at ~10 km, re-planned near the obstacle
    with pytest.raises(InputError, match="start must be one of detection, critical"):
        make_avoider("pso-ca", start="soon")


@pytest.mark.parametrize("side", [1, -1])
def test_pitch_latest_start_leaves_time_to_climb_or_descend(side: int) -> None:
    """The pitch manoeuvre's critical start is the latest from which the climb (descent) at the
    limit clears the obstacle's interval by its horizontal entry -- for a descent too."""
    from types import SimpleNamespace

    from replay.avoidance.fga_geometry import climbed

    fga = FgaAvoider()
    pos = np.array([0.0, 0.0, 120.0])
    vel = np.array([0.0, 15.0, 0.0])
    # a sphere 1 m across whose near side is 32 m away: inside the call margin (33 m)
    zc = 120.0 - side * 33.0
    o = FgaObstacle("o", (0.0, 300.0, zc), (0.0, 0.0, 0.0), 1.0, zc - 1.0, zc + 1.0)
    e = fga.planner.encounter(pos, vel, o, 30.0)
    assert e.window is not None
    ctx = SimpleNamespace(vehicle=preset("seed004-uas"), terrain=None)
    plan = fga.planner.pitch_plan(ctx, pos, vel, 0.0, [e], [o], 30.0)  # type: ignore[arg-type]
    assert plan is not None and plan.side == side
    entry = fga.planner.encounter(pos, vel, o, 30.0, fga.buffer_m).window
    assert entry is not None
    # from the latest start the climb (descent) gets exactly 2 buffers beyond the interval
    up, down = climb_limits(ctx.vehicle)
    rate = 0.9 * (up if side > 0 else -down)
    reach = 120.0 + climbed(rate, entry[0] - plan.t_c)
    goal = (o.top if side > 0 else o.bottom) + side * (D_M + 2 * fga.buffer_m)
    assert 0.0 <= plan.t_c < entry[0]
    assert reach == pytest.approx(goal, abs=0.05)


def test_a_course_off_the_map_is_taken_only_when_every_free_course_leaves_it() -> None:
    """Issue 34: an obstacle a little left of the course makes the smallest free change a right
    turn; where the map says that course leaves it (``bad``: metres off the map), the left one
    is taken; where every course does, the least is flown and the plan says so."""
    from replay.avoidance.fga_plan import FgaPlanner

    planner = FgaPlanner(30.0, 3.0, 60.0, 0.5, 20.0, 0.1)
    pos, vel = np.array([0.0, 0.0, 100.0]), np.array([0.0, 20.0, 0.0])
    o = FgaObstacle("o", (-15.0, 250.0, 100.0), (0.0, 0.0, 0.0), 40.0, -math.inf, math.inf)
    targets = [planner.encounter(pos, vel, o, 30.0)]
    free = planner.heading_plan(pos, vel, 0.0, targets, [o], 30.0, 0.5)
    assert free is not None and free.course > 0.0 and "unsafe_m" not in free.costs  # right

    def east_off(courses: Any) -> Any:  # the map ends just east of the aircraft
        return np.where(np.sin(courses) > 0.0, 100.0 * np.sin(courses), 0.0)

    left = planner.heading_plan(pos, vel, 0.0, targets, [o], 30.0, 0.5, bad=east_off)
    assert left is not None and left.course < 0.0 and "unsafe_m" not in left.costs
    assert abs(left.course) > abs(free.course)  # the larger change, but on the map
    every = planner.heading_plan(
        pos, vel, 0.0, targets, [o], 30.0, 0.5, bad=lambda c: np.full(len(c), 50.0) + c**2
    )
    assert every is not None and every.costs["unsafe_m"] >= 50.0
    assert "no safe course" in every.why
