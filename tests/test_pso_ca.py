"""PSO-CA behaviour beyond the contract (seed 000 §3, §5.3, §5.7): failed decisions, replacing an
inserted waypoint, terrain returns, the side rule for intruders, the CLI options, bad input."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from affine import Affine

from planner.mission import mission_from_dict
from replay.avoidance import make_avoider
from replay.avoidance.pso_ca import PsoCaAvoider
from replay.avoidance.pso_ca_geometry import PsoCaParams
from replay.flight.fixedwing.presets import load_vehicle
from replay.record.reader import load_run
from replay.sim import ReplayConfig, ReplayResult, simulate
from replay.threats.file import threats_from_records
from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrapath.cli import main

R = 1000.0


def _mission(waypoints: list[list[float]], name: str = "t") -> Any:
    return mission_from_dict(
        {
            "terrapath": 1,
            "name": name,
            "crs": "local",
            "vehicle": "solar-uav",
            "cruise": {"speed": 15.0, "altitude": 200.0},
            "waypoints": waypoints,
        }
    )


def _fly(
    waypoints: list[list[float]],
    threats: list[dict[str, Any]],
    avoider: str = "pso-ca",
    seed: int = 0,
    **kw: Any,
) -> ReplayResult:
    return simulate(
        _mission(waypoints),
        threats_from_records(threats),
        make_avoider(avoider, **({} if avoider == "none" else kw.pop("options", {}))),
        load_vehicle("solar-uav"),
        config=ReplayConfig(seed=seed, **kw.pop("config", {})),
        **kw,
    )


def _collides(legs: list[list[float]], threats: list[dict[str, Any]], **config: Any) -> bool:
    """The baseline: flown without avoidance, a safety volume is entered.  Every threat here is
    met within 1200 s of straight flight (the crossing intruder, the latest, at 1133 s), so only
    the first 1500 s are flown (the duration only ends the loop: the same flight, cut short); an
    entry there is one in the whole flight, which is then no success."""
    r = _fly(legs, threats, avoider="none", config={**config, "duration": 1500.0})
    return not r.metrics.success and bool(r.metrics.violations)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"rs": -1.0}, "rs must be a positive"),
        ({"params": PsoCaParams(tolerance=1000.0, search_limit=4000.0), "rs": 3500.0}, "room"),
        ({"moving_rs": 0.0}, "moving safety radius"),
        ({"moving_rs": 3500.0}, "moving safety radius plus"),
        ({"optimizer": "cmaes"}, "unknown PSO-CA optimiser"),
        ({"act_range": float("nan")}, "act range"),
    ],
)
def test_bad_avoider_parameters_are_refused(kwargs: dict[str, Any], message: str) -> None:
    with pytest.raises(InputError, match=message):
        PsoCaAvoider(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"wt": 0.2, "wo": 0.9}, "sum to 1"),
        ({"tolerance": 3500.0}, "search limit"),
        ({"tolerance": -1.0}, "tolerance must be a number >= 0"),
        ({"rs": 0.0}, "rs must be a positive"),
        ({"leg_margin": float("inf")}, "leg_margin"),
    ],
)
def test_bad_pso_ca_constants_are_refused(kwargs: dict[str, Any], message: str) -> None:
    with pytest.raises(InputError, match=message):
        PsoCaParams(**kwargs)


def test_no_feasible_waypoint_is_a_recorded_failure_not_an_exception() -> None:
    """An obstacle on the goal itself: no new waypoint can lead to the goal clear of it (g3), and
    the goal cannot be skipped.  The run goes on with the old list; each failed decision is
    recorded, retried no more often than every 5 s."""
    r = _fly(
        [[0, 0, 200], [20000, 0, 200]],
        [{"id": "on-goal", "kind": "static", "position": [20000, 0, 200], "radius": R}],
    )
    assert r.decisions, "the obstacle was seen and a decision attempted"
    assert all(not d["feasible"] and d["reason"].startswith("failed") for d in r.decisions)
    np.testing.assert_array_equal(r.waypoints, r.initial_waypoints)
    assert r.metrics.waypoints_added == 0 and r.metrics.end_reason == "goal"
    t = np.array([d["t"] for d in r.decisions])
    assert (np.diff(t) >= 5.0 - 1e-9).all()


def test_an_inserted_waypoint_made_unsafe_by_a_later_obstacle_is_replaced() -> None:
    """§5.3 / Fig. 23: a second obstacle that pops up next to the waypoint inserted for the
    first makes it unsafe; the avoider leads past it with a new one."""
    legs = [[0, 0, 200], [30000, 0, 200], [50000, 0, 200]]
    first = [{"id": "a", "kind": "static", "position": [12000, 0, 200], "radius": R}]
    # only r1's first decision is read: its flight ends 600 s in, well after that decision (the
    # duration only ends the loop, so the run is the full flight's first 600 s)
    r1 = _fly(legs, first, config={"duration": 600.0})
    w = np.array(r1.decisions[0]["new_waypoint"])
    t1 = r1.decisions[0]["t"]
    b = {"id": "b", "kind": "static", "position": [w[0] + 300.0, w[1], 200], "radius": R}
    b["appears_at"] = t1 + 30.0
    r2 = _fly(legs, [*first, b])
    assert r2.decisions[0]["new_waypoint"] == r1.decisions[0]["new_waypoint"]
    later = [d for d in r2.decisions[1:] if d["obstacles"] == ["b"]]
    assert later and later[0]["skipped_waypoints"] == 1 and later[0]["feasible"]
    final = r2.waypoints[:, :2]
    assert np.hypot(*(final - np.array(b["position"][:2])).T).min() > R
    assert r2.metrics.success and r2.metrics.reached_goal


def test_an_intruder_crossing_to_the_left_is_passed_on_the_right() -> None:
    """§5.7 / Fig. 28: an intruder heading to the left of the aircraft's leg -> the aircraft turns
    right (the new waypoint lies right of the leg, g6 >= 0 with side -1)."""
    legs = [[0, 0, 200], [40000, 0, 200]]
    crosser = {
        "id": "crosser",
        "kind": "intruder",
        "position": [17000, -17000, 200],  # meets the aircraft at (17000, 0) without avoidance
        "velocity": [0, 15, 0],
        "radius": R,
    }
    assert _collides(legs, [crosser])
    r = _fly(legs, [crosser])
    moving = [d for d in r.decisions if d["obstacle_kind"] == "moving" and d["feasible"]]
    assert moving and all(d["side"] == -1 for d in moving)
    first = moving[0]
    a, tgt = np.array(first["inputs"]["aircraft"]), np.array(first["inputs"]["target"])
    p = np.array(first["new_waypoint"][:2])
    leg, rel = tgt - a, p - a
    assert leg[0] * rel[1] - leg[1] * rel[0] < 0  # right of the leg
    assert r.metrics.success and r.metrics.min_separation["crosser"]["value"] >= 0.0


def test_terrain_that_rises_above_the_flight_altitude_is_avoided() -> None:
    """Terrain returns of a hill above the (constant) flight altitude are a continuous obstacle:
    without avoidance the aircraft flies into the hill; with PSO-CA it goes round it."""
    from terrain.model import TerrainModel

    cell = 100.0
    ys, xs = np.mgrid[0:80, 0:400]
    x = xs * cell + cell / 2
    y = 4000.0 - (ys * cell + cell / 2)
    hill = 600.0 * np.exp(-((x - 20000.0) ** 2 + y**2) / (2 * 900.0**2))
    grid = HeightGrid(hill.astype(np.float32), Affine(cell, 0, 0.0, 0, -cell, 4000.0), None)
    model = TerrainModel.from_grid(grid)
    legs = [[1000, 0, 200], [39000, 0, 200]]
    base = _fly(legs, [], avoider="none", grid=grid, terrain_model=model)
    assert base.metrics.terrain_contact
    r = _fly(legs, [], grid=grid, terrain_model=model)
    assert not r.metrics.terrain_contact and r.metrics.reached_goal
    assert r.metrics.min_terrain_clearance_m > 0.0
    assert any(all(o.startswith("terrain/") for o in d["obstacles"]) for d in r.decisions)
    assert r.metrics.waypoints_added >= 1


def test_replay_cli_ca_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mission = tmp_path / "m.yaml"
    mission.write_text(
        yaml.safe_dump(
            {
                "terrapath": 1,
                "name": "cli",
                "crs": "local",
                "vehicle": "solar-uav",
                "cruise": {"speed": 15.0, "altitude": 200.0},
                "waypoints": [[0, 0, 200], [20000, 0, 200], [30000, 0, 200]],
            }
        )
    )
    threats = tmp_path / "t.yaml"
    threats.write_text(
        yaml.safe_dump(
            {
                "terrapath": 1,
                "threats": [
                    {"id": "o", "kind": "static", "position": [10000, 0, 200], "radius": 1400}
                ],
            }
        )
    )
    out = tmp_path / "run.mcap"
    args = ["replay", str(mission), "--threats", str(threats), "-o", str(out)]
    # the paper's RS = 1 km does not keep clear of a 1.4 km threat; --ca-safety-radius does
    rc = main([*args, "--avoid", "pso-ca", "--ca-optimizer", "ga", "--ca-safety-radius", "1500"])
    assert rc == 0
    capsys.readouterr()
    run = load_run(out, with_states=False)
    decisions = [d.decision for d in run.decisions]
    assert decisions and all(d["optimizer"] == "ga" for d in decisions)
    assert all(d["safety_radius"] == 1500.0 for d in decisions)
    assert "ga" in run.metadata["avoid"] and "1500" in run.metadata["avoid"]
    assert main(["inspect", str(out), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["min_separation"]["o"]["value"] >= 0.0 and len(s["final_waypoints"]) >= 4
    # --ca-paper: seed 000's logic only, recorded as such
    assert main([*args, "--avoid", "pso-ca", "--ca-paper", "--ca-safety-radius", "1500"]) == 0
    capsys.readouterr()
    meta = load_run(out, with_states=False).metadata["avoid"]
    assert all(f"{k}=False" in meta for k in ("rescue", "narrow", "corners"))
    assert "max_skip=0" in meta
    # --ca-* without pso-ca is a usage error; a bad value is one line, exit 1, nothing written
    assert main([*args, "--ca-optimizer", "ga"]) == 2
    capsys.readouterr()
    out.unlink()
    assert main([*args, "--avoid", "pso-ca", "--ca-moving-radius", "-3"]) == 1
    err = capsys.readouterr().err
    assert "moving safety radius" in err and err.strip().count("\n") == 0
    assert not out.exists()


def _separation(r: ReplayResult, threats: list[dict[str, Any]]) -> float:
    p = np.asarray(r.positions)[:, :2]
    return min(float(np.hypot(*(p - np.array(t["position"][:2])).T).min()) for t in threats) - R


def test_a_corner_the_autopilot_cuts_towards_an_obstacle_is_avoided() -> None:
    """The leg clears the obstacle by 1105 m (no hit for the paper's test), but 1 km before the
    waypoint the autopilot turns for the next leg and swings about 140 m towards it
    (pso_ca_geometry.corner_cut): flown as planned, the safety sphere is entered.  PSO-CA tests
    the cut corner too and inserts a waypoint (measured: the version without this flew 33 m
    inside)."""
    legs = [[-12000, 0, 200], [0, 0, 200], [8000, -6028, 200]]
    threats = [{"id": "o", "kind": "static", "position": [-400, 1105, 200], "radius": R}]
    assert _separation(_fly(legs, threats, avoider="none"), threats) < 0
    r = _fly(legs, threats)
    assert len(r.decisions) >= 1 and all(d["feasible"] for d in r.decisions)
    assert _separation(r, threats) >= 0 and r.metrics.reached_goal
    straight = _fly(legs, threats, options={"corners": False})  # the paper's straight legs
    assert not straight.decisions and _separation(straight, threats) < 0


# a decision taken 2.6 km from two obstacles (Table 6 seed 50002, its first failing decision)
RESCUE_LEGS = [[196144, 13795, 200], [200000, 15000, 200], [215000, 15500, 200]]
RESCUE_THREATS = [
    {"id": "a", "kind": "static", "position": [198538, 15436, 200], "radius": R},
    {"id": "b", "kind": "static", "position": [198761, 13472, 200], "radius": R},
]


def test_a_feasible_region_the_seeded_swarm_misses_is_found_by_the_rescue_grid() -> None:
    """The only waypoints that meet g1-g5 lie near the edge of the 4 km search zone, which the
    swarm seeded round the tangent points does not reach: the grid scan of the same objective
    finds them and the optimiser, re-seeded there, returns a feasible waypoint.  Without the
    rescue the escalation still gives a safe waypoint: the narrower g1 stage (its swarm finds the
    region for 2-3 seeds of 12, e.g. seed 3) or else leaving the next waypoint out; without all
    three the decision fails."""
    r = _fly(RESCUE_LEGS, RESCUE_THREATS)
    first = r.decisions[0]
    assert first["feasible"] and first["stage"] == "paper" and first["grid_evaluations"] > 0
    assert all(d["feasible"] for d in r.decisions)
    assert _separation(r, RESCUE_THREATS) >= 0 and r.metrics.reached_goal
    for seed, stage in ((3, "narrow"), (0, "skip 1")):
        esc = _fly(RESCUE_LEGS, RESCUE_THREATS, seed=seed, options={"rescue": False})
        assert esc.decisions[0]["stage"] == stage and esc.decisions[0]["feasible"]
        assert esc.decisions[0]["grid_evaluations"] == 0
        assert _separation(esc, RESCUE_THREATS) >= 0 and esc.metrics.reached_goal
    # only the first decision (taken at once, 2.6 km from the obstacles) is read: 300 s of flight
    bare = _fly(
        RESCUE_LEGS,
        RESCUE_THREATS,
        options={"rescue": False, "narrow": False, "max_skip": 0},
        config={"duration": 300.0},
    )
    assert not bare.decisions[0]["feasible"] and bare.decisions[0]["stage"] == "failed"


def test_a_waypoint_no_leg_reaches_clear_of_the_obstacles_is_left_out() -> None:
    """A turning point ringed by obstacles (Table 6 seed 40004): no new waypoint leads to it
    clear of them, even with the rescue grid and the narrower g1, so the decision leaves it out
    and leads to the one after it (as Fig. 23 does for a waypoint next to an obstacle).
    Without that stage the decisions fail and the aircraft flies into a safety sphere."""
    t = np.array([350000.0, 20000.0])
    rel = {
        "o1": [-1038, 1904],
        "o10": [-897, 1656],
        "o13": [-151, 1473],
        "o28": [-2494, -2436],
        "o38": [-2398, 875],
        "o40": [-1654, -1215],
    }
    legs = [[345478, 19192, 200], [*t.tolist(), 200], [300000, 11000, 200]]
    threats = [
        {"id": k, "kind": "static", "position": [*(t + v).tolist(), 200], "radius": R}
        for k, v in rel.items()
    ]
    r = _fly(legs, threats)
    skipped = [d for d in r.decisions if d["stage"].startswith("skip")]
    assert skipped and skipped[0]["skipped_waypoints"] == 1 and skipped[0]["feasible"]
    assert all(d["feasible"] for d in r.decisions)
    assert _separation(r, threats) >= 0 and r.metrics.reached_goal
    assert not np.any(np.all(np.isclose(r.waypoints[:, :2], t), axis=1))  # it was left out
    # a failed decision and an entry both come near the turning point (4.6 km in), not on the
    # 50 km back to the goal: the run ends at 1200 s (the duration only ends the loop, so this is
    # the full flight's first 1200 s, and what it shows the full flight shows)
    stuck = _fly(legs, threats, options={"max_skip": 0}, config={"duration": 1200.0})
    assert any(not d["feasible"] for d in stuck.decisions)
    assert _separation(stuck, threats) < 0


# Table 6, 100 obstacles, run 8 (seed000-table6.yaml): the 19 obstacles within 9 km of the
# turning point (200000, 15000), relative to it.  The gaps between their safety circles are
# 0.3-1 km wide: no leg reaches the turning point clear of them all.
RING = {
    "obs7": [-2044, -3347],
    "obs12": [2488, 3418],
    "obs19": [-970, -761],
    "obs30": [5101, -1575],
    "obs36": [-4347, -2203],
    "obs42": [304, 1944],
    "obs47": [-4511, 80],
    "obs51": [656, 2560],
    "obs62": [1752, 5161],
    "obs63": [1668, -1794],
    "obs66": [-2360, 2892],
    "obs73": [84, 1644],
    "obs77": [-4915, 7051],
    "obs79": [594, -2419],
    "obs87": [-3153, -2344],
    "obs90": [-2088, -4095],
    "obs91": [2853, 449],
    "obs99": [2156, 1663],
    "obs100": [3129, -2350],
}


@pytest.mark.parametrize("seed", [1, 2])
def test_a_ringed_waypoint_does_not_lead_the_avoider_round_and_round(seed: int) -> None:
    """Approached from the south (where the Table 6 run was when it began to cycle), the paper's
    search leads east round the obstacles south of the ringed waypoint with a second leg 300 m
    past one further east; flown there, the next decision leads back west, and so on: 22-34
    decisions and the 2-h limit in four seeds, 94 waypoints and 656 km in the Table 6 run.  With
    the last search's legs tested against every known point (one whose legs still pass a point
    escalates: narrower g1, then the waypoint left out), the ringed waypoint is left out at the
    first decision and the goal is reached clear of every circle."""
    t = np.array([200000.0, 15000.0])
    threats = [
        {"id": k, "kind": "static", "position": [*(t + v).tolist(), 200], "radius": R}
        for k, v in RING.items()
    ]
    legs = [[199900, 10300, 200], [*t.tolist(), 200], [215000, 15500, 200]]
    r = _fly(legs, threats, seed=seed, config={"duration": 7200.0})
    assert r.metrics.success and r.metrics.reached_goal
    assert _separation(r, threats) >= 0
    assert len(r.decisions) <= 3
    assert all(d["feasible"] and d["clear_of_known"] for d in r.decisions)


def test_reset_compiles_the_cost_before_the_flight(tmp_path: Path) -> None:
    """A fresh process with an empty numba cache: after ``reset`` the compiled cost exists, so
    the first decision in the air is not a JIT compilation (seconds on a fresh install)."""
    import os
    import subprocess
    import sys

    code = (
        "import numpy as np\n"
        "from replay.avoidance import make_avoider\n"
        "from replay.avoidance.pso_ca_kernel import penalised_costs as k, segment_clearances\n"
        "assert not k.signatures and not segment_clearances.signatures\n"
        "a = make_avoider('pso-ca')\n"
        "assert not k.signatures\n"
        "a.reset(np.zeros((2, 3)), np.random.default_rng(0))\n"
        "print(len(k.signatures), len(segment_clearances.signatures))\n"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    root = Path(__file__).resolve().parents[1]
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=root, env=env, capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["1", "1"]


CROSSER = {
    "id": "crosser",
    "kind": "intruder",
    "position": [17000, -17000, 200],  # meets the aircraft at (17000, 0) without avoidance
    "velocity": [0, 15, 0],
    "radius": R,
}
ON_LEG = {"id": "rock", "kind": "static", "position": [8000, 0, 200], "radius": R}


def test_asked_between_scans_pso_ca_reasons_on_each_scan_once() -> None:
    """The avoider asked four times per radar scan: perception takes each scan once (a second
    update with the same scan would be refused as out of time order), the intruder is still
    confirmed over two scans and passed on the right, and the obstacle on the leg is avoided."""
    legs = [[0, 0, 200], [40000, 0, 200]]
    assert _collides(legs, [CROSSER, ON_LEG])
    r = _fly(legs, [CROSSER, ON_LEG], config={"avoid_period": 0.25})
    assert r.metrics.success
    kinds = {d["obstacle_kind"] for d in r.decisions if d["feasible"]}
    assert kinds == {"moving", "stationary"}
    assert all(d["side"] == -1 for d in r.decisions if d["obstacle_kind"] == "moving")
    # some decisions come between scans
    times = [d["t"] for d in r.decisions]
    assert any(t % 1.0 for t in times)
    assert r.metrics.min_separation["crosser"]["value"] >= 0.0


@pytest.mark.parametrize("latency", [0.0, 2.0])
def test_pso_ca_avoids_with_the_cooperative_sensor(latency: float) -> None:
    """With ADS-B-like reports (true position and velocity, ``latency`` seconds old) instead of
    the radar, perception gives PSO-CA the same obstacles and tracks: both threats are passed."""
    legs = [[0, 0, 200], [40000, 0, 200]]
    cfg = {"sensor": "cooperative", "coop_latency": latency}
    assert _collides(legs, [CROSSER, ON_LEG], **cfg)
    r = _fly(legs, [CROSSER, ON_LEG], config=cfg)
    assert r.metrics.success
    assert {d["obstacle_kind"] for d in r.decisions if d["feasible"]} == {"moving", "stationary"}
    for ident in ("crosser", "rock"):
        assert r.metrics.min_separation[ident]["value"] >= 0.0


def test_with_the_cooperative_sensor_a_reported_size_wider_than_rs_is_kept() -> None:
    """The cooperative sensor reports a 2.5 km cylinder by its centre and radius (the radar
    returns points of its surface): PSO-CA keeps the reported radius, not RS = 1 km, from the
    centre, and stays out of it."""
    legs = [[0, 0, 200], [40000, 0, 200]]
    storm = {"id": "storm", "kind": "cylinder", "center": [15000, 200], "radius": 2500, "top": 900}
    cfg = {"sensor": "cooperative"}
    assert _collides(legs, [storm], **cfg)
    r = _fly(legs, [storm], config=cfg)
    assert r.metrics.success, r.metrics
    assert r.metrics.min_separation["storm"]["value"] >= 0.0
    feasible = [d for d in r.decisions if d["feasible"]]
    assert feasible and all(d["inputs"]["params"]["rs"] == 2500.0 for d in feasible)


def test_tolerance_and_search_limit_are_options_checked_as_table_1() -> None:
    # a 20 m rangefinder's scale (benches/seed003-uncharted.yaml): Table 1's distances / 500
    av = make_avoider("pso-ca", rs=2, tolerance=2, search_limit=8, mxrsk=6, moving_rs=4)
    assert isinstance(av, PsoCaAvoider)
    assert (av.params.rs, av.params.tolerance, av.params.search_limit) == (2.0, 2.0, 8.0)
    assert make_avoider("pso-ca", tolerance=500).params.search_limit == 4000.0  # the other kept
    with pytest.raises(InputError, match=r"search limit \(8 m\) must exceed .* \(2 \+ 6 m\)"):
        make_avoider("pso-ca", rs=2, tolerance=6, search_limit=8, moving_rs=1)


def test_the_distances_follow_the_map_and_the_vehicle_and_reduce_to_seed_000s() -> None:
    """Issue 34 (module docstring, *Scale*): seed 000's distances times min(1, W / 40 km), each
    at least its floor in turn radii; no map: seed 000's exactly; a point whose size is not
    reported keeps seed 000's 1 km (and 2 km moving) whatever the map."""
    paper = (1000.0, 1000.0, 4000.0, 100.0, 2000.0, 8000.0, 3000.0)

    def dists(av: PsoCaAvoider) -> tuple[float, ...]:
        p = av.params
        return (
            p.rs,
            p.tolerance,
            p.search_limit,
            p.leg_margin,
            av.moving_rs,
            av.act_range,
            p.mxrsk,
        )

    av = PsoCaAvoider()
    av.configure(39.7, None)  # seed 000: no map, its UAV's 40 m turn
    assert dists(av) == paper and (av.point_rs, av.moving_point_rs) == (1000.0, 2000.0)
    av.configure(441.4, 80_000.0)  # a Cessna over a big map: seed 000's, but for its wide turn
    assert dists(av) == (*paper[:3], 441.4 / 4, *paper[4:])
    av.configure(110.3, 4395.0)  # the aerosonde on Christmas Island (4.4 km): the floors
    r = 110.3
    assert dists(av) == pytest.approx((r, r, 2 * r + r + 2 * r, r / 4, 2 * r, 8 * r, 3 * r))
    av.configure(29.4, 592.0)  # the seed004-uas over the Bubenec block (592 m)
    r = 29.4
    assert dists(av) == pytest.approx(
        (r, r, 2 * r + r + 2 * r, r / 4, 2 * r, 8 * r, 3 * r), rel=1e-9
    )
    assert av.point_keep_m() == (1000.0, 2000.0)  # the radar's points: not scaled
    # options given keep their values; scale false (--ca-paper) is seed 000's everywhere
    av = PsoCaAvoider(rs=50.0, moving_rs=80.0)
    av.configure(29.4, 592.0)
    assert (av.params.rs, av.moving_rs) == (50.0, 80.0)
    av = PsoCaAvoider.paper()
    av.configure(29.4, 592.0)
    assert dists(av) == paper


def test_a_small_map_s_threat_is_avoided_with_the_cooperative_sensor(tmp_path: Any) -> None:
    """Issue 34's small-map failure: own-scenarios' Bubenec case 6 (592 m map, the small-uas at
    15 m/s, a 178 m sphere across the leg).  At seed 000's kilometres (--ca-paper) no waypoint
    fits the map and the aircraft flies through the sphere; scaled, it goes round it."""
    import yaml

    from replay.campaign.generators import file_records
    from replay.campaign.own import own_case
    from replay.campaign.spec import derive_seed
    from replay.run import ReplayRequest, run_replay

    rng = np.random.default_rng(derive_seed(34, "scenario", "own-scenarios", "momepy_bubenec", 6))
    doc, records, notes = own_case(rng, "momepy_bubenec")
    assert notes["vehicle"] == "small-uas" and notes["excluded"] == []
    mission = tmp_path / "m.yaml"
    mission.write_text(yaml.safe_dump(doc))
    threats = tmp_path / "t.yaml"
    threats.write_text(yaml.safe_dump({"terrapath": 1, "threats": file_records(records)}))

    def fly(**options: Any) -> Any:
        return run_replay(
            ReplayRequest.of(
                str(mission),
                threats=str(threats),
                avoid="pso-ca",
                avoid_options=options,
                sensor="cooperative",
            )
        ).metrics

    scaled = fly()
    assert scaled.success and scaled.min_separation["t1"]["value"] > 0.0
    assert scaled.waypoints_added >= 1 and scaled.off_map_s == 0.0
    paper = fly(rescue=False, narrow=False, max_skip=0, corners=False, scale=False)
    assert not paper.success and paper.min_separation["t1"]["value"] < 0.0


def test_the_radar_pairing_warns_when_a_point_s_radius_exceeds_what_is_kept() -> None:
    from replay.run import radar_pairing
    from replay.threats.file import threats_from_records

    threats = threats_from_records(
        [
            {"id": "small", "kind": "static", "position": [0, 5000, 200], "radius": 400},
            {"id": "big", "kind": "static", "position": [0, 9000, 200], "radius": 1500},
            {
                "id": "fast",
                "kind": "intruder",
                "position": [0, 0, 200],
                "velocity": [10, 0, 0],
                "radius": 2500,
            },
        ]
    )
    av = PsoCaAvoider()
    warned = radar_pairing("radar", av, threats)
    assert len(warned) == 2
    assert "'big' as a point, not its 1500 m radius; pso-ca keeps 1000 m" in warned[0]
    assert "'fast'" in warned[1] and "keeps 2000 m" in warned[1]
    assert radar_pairing("cooperative", av, threats) == ()
