"""A picture of every run (issue 16): ``terrapath replay`` writes RUN.png beside the MCAP (not with
``--no-picture``) and ``terrapath inspect RUN.mcap --png OUT.png`` draws any recorded run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread

from terrapath.cli import main

ROOT = Path(__file__).resolve().parents[1]
MISSION = str(ROOT / "data" / "scenarios" / "seed001-mission.yaml")
THREATS = str(ROOT / "data" / "scenarios" / "seed001-simple-threats.yaml")
RED = np.array([0xD6, 0x27, 0x28]) / 255.0  # violations


def _red_pixels(png: Path) -> int:
    img = imread(png)[..., :3]
    return int(np.all(np.abs(img - RED) < 1.5 / 255.0, axis=-1).sum())


def _replay(tmp_path: Path, avoid: str, *extra: str) -> Path:
    out = tmp_path / f"{avoid}.mcap"
    args = ["replay", MISSION, "--threats", THREATS, "--avoid", avoid, "--sensor", "cooperative"]
    main([*args, *extra, "-o", str(out)])
    return out


def test_replay_draws_the_run_beside_the_mcap_and_marks_violations(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    failed = _replay(tmp_path, "none")  # flies into both obstacles
    png = failed.with_suffix(".png")
    assert f"wrote {png}" in capsys.readouterr().out
    img = imread(png)
    assert img.shape[0] > 800 and img.shape[1] > 800
    assert float(img[..., :3].std()) > 0.05  # not blank
    assert _red_pixels(png) > 50  # the track inside the obstacles, the negative separations
    clean = _replay(tmp_path, "ctga")  # 114 m from both
    assert _red_pixels(clean.with_suffix(".png")) == 0


def test_no_picture_and_inspect_png(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = _replay(tmp_path, "ctga", "--no-picture")
    assert not run.with_suffix(".png").exists()
    out = tmp_path / "again.png"
    assert main(["inspect", str(run), "--png", str(out)]) in (0, None)
    assert out.exists() and _red_pixels(out) == 0
    capsys.readouterr()
    assert main(["inspect", str(run), "--png", str(tmp_path / "x.jpg")]) == 2
    assert "the picture must end in .png" in capsys.readouterr().err
    assert main(["inspect", MISSION, "--png", str(tmp_path / "m.png")]) == 1  # not an MCAP
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "seed001-mission.yaml" in err
    assert not (tmp_path / "m.png").exists()


def test_the_separation_panel_keeps_the_threats_that_came_closest() -> None:
    from replay.record.picture import nearest_threats

    nan = float("nan")
    sep = {
        "far": np.array([900.0, 800.0]),
        "near": np.array([50.0, 3.0]),
        "never": np.array([nan, nan]),  # never active: infinitely far
        "inside": np.array([10.0, -2.0]),
        "mid": np.array([nan, 40.0]),
    }
    assert nearest_threats(sep, 3) == ["near", "inside", "mid"]  # in their given order
    assert nearest_threats(sep, 10) == list(sep)


def test_a_small_flight_on_a_large_map_is_zoomed_onto() -> None:
    from terrain.plot import zoom_box

    bounds = (0.0, 0.0, 1000.0, 1000.0)
    small = np.array([[400.0, 500.0], [500.0, 560.0]])  # 100 x 60 m: under a third each way
    assert zoom_box(bounds, small) == (350.0, 430.0, 550.0, 630.0)  # square, 50 m round it
    corner = np.array([[0.0, 0.0], [20.0, 10.0]])  # kept on the map
    assert zoom_box(bounds, corner) == (0.0, 0.0, 70.0, 65.0)
    assert zoom_box(bounds, np.array([[0.0, 500.0], [400.0, 510.0]])) is None  # 40 % wide
