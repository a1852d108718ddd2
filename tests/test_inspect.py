"""`terrapath inspect` and `replay` as a new user reads them: rounded numbers, right plurals, an
integer seed, and what separation and PLR measure."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from replay.record.reader import load_run
from terrapath.cli import main
from terrapath.runtext import (
    PLR_MEANING,
    SEPARATION_NOTE,
    duration,
    kilometres,
    metres,
    metrics_rows,
    plural,
    seconds,
    threat_lines,
)
from tests.conftest import ROOT
from tests.test_record import record

MISSION = ROOT / "data" / "missions" / "seed000-table4.yaml"
# the tower sits on leg 1: the aircraft flies through its 300 m sphere and out again
THREATS = """terrapath: 1
threats:
  - {id: tower, kind: static, position: [3000, 150, 200], radius: 300}
  - {id: late, kind: static, position: [9000, 0, 200], radius: 100, appears_at: 5000}
"""


def test_numbers_and_plurals() -> None:
    assert plural(1, "change") == "1 change"
    assert plural(0, "change") == "0 changes" and plural(2, "change") == "2 changes"
    assert (
        plural(1, "entry", "entries") == "1 entry" and plural(3, "entry", "entries") == "3 entries"
    )
    assert metres(19452.600000000002) == "19452.6 m" and metres(-0.04) == "-0.0 m"
    assert seconds(1430.1000000000001) == "1430.1 s" and kilometres(45380.7189) == "45.38 km"
    assert duration(59.96) == "60.0 s" and duration(1787.0) == "29.8 min"
    assert duration(28649.0) == "7.96 h"
    for missing in (None, float("nan"), float("inf"), "x", True):
        assert metres(missing) == seconds(missing) == duration(missing) == "n/a"


def test_metrics_text_says_what_plr_and_separation_are() -> None:
    m = {
        "success": False,
        "end_reason": "time limit",
        "reached_goal": False,
        "terrain_contact": False,
        "flight_time_s": 400.0,
        "flown_length_m": 6012.34,
        "straight_distance_m": 269_731.0,
        "plr": 6012.34 / 269_731.0,
        "min_separation": {
            "tower": {"value": -212.04, "t": 200.10000000000002},
            "late": {"value": None, "t": None},
        },
        "violations": [
            {
                "threat": "tower",
                "t_enter": 180.3,
                "t_exit": 219.90000000000001,
                "min_separation": -212.04,
            }
        ],
        "decisions": 1,
        "decision_time_mean_s": 0.0027,
        "decision_time_max_s": 0.0027,
    }
    assert dict(metrics_rows(m)) == {
        "success": "NO (ended by time limit, 1 safety violation)",
        "flight time": "6.7 min",
        "flown length": "6.01 km",
        "PLR": f"0.022 ({PLR_MEANING}, 269.73 km; the goal was not reached)",
        "avoidance decisions": "1 (computation mean 2.7 ms, max 2.7 ms)",
    }
    assert threat_lines(m) == [
        "threat  min separation     at t  inside its safety volume",
        "tower         -212.0 m  200.1 s  t = 180.3 s to 219.9 s (deepest -212.0 m)",
        "late      never active           -",
        SEPARATION_NOTE,
    ]
    assert "surface" in SEPARATION_NOTE and "negative = inside" in SEPARATION_NOTE
    assert (
        PLR_MEANING == "flown length / straight-line distance from the first to the last waypoint"
    )
    assert threat_lines({"min_separation": {}}) == []


def test_replay_and_inspect_text(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    threats = tmp_path / "t.yaml"
    threats.write_text(THREATS)
    out = tmp_path / "run.mcap"
    args = ["replay", str(MISSION), "--threats", str(threats), "--duration", "400", "--seed", "3"]
    assert main([*args, "-o", str(out)]) == 3  # cut at 400 s with violations: not a success
    captured = capsys.readouterr()
    replay_text = captured.out
    assert captured.err.startswith("terrapath: replay failed: ended by time limit")
    run = load_run(out, with_states=False)
    m = run.metrics
    assert main(["inspect", str(out)]) == 0
    text = capsys.readouterr().out
    for shown in (replay_text, text):
        # no float noise: metres and seconds to 0.1, kilometres to 0.01, PLR to 0.001
        assert not re.search(r"\d\.\d{4,}", shown), shown
        assert SEPARATION_NOTE in shown and PLR_MEANING in shown
        plr = f"{m['flown_length_m'] / m['straight_distance_m']:.3f}"
        assert re.search(
            rf"^PLR +{re.escape(plr)} \({PLR_MEANING}, 270\.20 km; the goal was not reached\)$",
            shown,
            re.M,
        )
        (v,) = m["violations"]
        tower = m["min_separation"]["tower"]
        row = (
            rf"^tower +{tower['value']:.1f} m +{tower['t']:.1f} s +t = {v['t_enter']:.1f} s to "
            rf"{v['t_exit']:.1f} s \(deepest {v['min_separation']:.1f} m\)$"
        )
        assert re.search(row, shown, re.M), shown
        assert re.search(r"^late +never active +-$", shown, re.M)
        assert re.search(r"^success +NO \(ended by time limit, 1 safety violation\)$", shown, re.M)
    assert re.search(r"^seed +3$", text, re.M)
    assert re.search(r"^waypoints +8 in the final list, 0 changes during the flight$", text, re.M)
    assert re.search(r"^terrain +none \(flat ground at 0 m\)$", text, re.M)
    assert re.search(r"^vehicle +solar-uav$", text, re.M)
    assert "mission.yaml (" in text and "threats.yaml (" in text
    # --json: the seed is an integer, as in `replay --json` and `plan`
    assert main(["inspect", str(out), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["seed"] == 3 and isinstance(s["seed"], int) and s["waypoint_changes"] == 0
    assert s["vehicle"] == "solar-uav" and s["dem"] == [] and s["source"] == str(MISSION)


def test_inspect_a_run_with_partial_metrics(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A run written by the recorder alone (the synthetic one of test_record): what is there."""
    path = tmp_path / "synthetic.mcap"
    record(path)
    assert main(["inspect", str(path)]) == 0
    text = capsys.readouterr().out
    assert re.search(r"^success +yes ", text, re.M) and re.search(r"^seed +42$", text, re.M)
    assert re.search(r"^flight time +60\.0 s$", text, re.M)
    assert re.search(r"^PLR +1\.070 \(", text, re.M)
    changes = len(load_run(path, with_states=False).waypoints) - 1  # after the initial list
    assert re.search(
        rf"^waypoints +\d+ in the final list, {plural(changes, 'change')} ", text, re.M
    )


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("--duration", "-5"),
        ("--duration", "0"),
        ("--log-rate", "0"),
        ("--radar-range", "0"),
        ("--radar-noise", "-1"),
        ("--terrain-following", "-50"),
    ],
)
def test_replay_options_out_of_range_are_usage_errors(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], option: str, value: str
) -> None:
    out = tmp_path / "x.mcap"
    assert main(["replay", str(MISSION), option, value, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"Invalid value for '{option}': {float(value)} is not in the range" in err
    assert not out.exists()


def test_replay_does_not_overwrite_the_run_it_re_flies(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    run = tmp_path / "run.mcap"
    run.write_bytes(b"a run")
    monkeypatch.chdir(tmp_path)
    assert main(["replay", "run.mcap", "-o", str(run)]) == 2
    assert f"{str(run)!r} is the run being re-flown" in capsys.readouterr().err
    assert main(["replay", str(run), "-o", "./run.mcap"]) == 2
    assert "'./run.mcap' is the run being re-flown" in capsys.readouterr().err
    assert run.read_bytes() == b"a run"


def test_inspect_at_places_a_threat_where_the_aircraft_was(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`inspect --at T` says where the aircraft was at T as a threat entry: a threat placed there
    (appearing before T) is flown through at its centre when the same flight is flown again."""
    first = tmp_path / "first.mcap"
    args = ["replay", str(MISSION), "--duration", "300", "--seed", "3", "--no-picture"]
    assert main([*args, "-o", str(first)]) == 3  # cut at 300 s: the goal not reached
    capsys.readouterr()
    assert main(["inspect", str(first), "--at", "200", "--at", "250.5"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert re.match(r"^t = 200\.0 s: x [\d.]+, y -?[\d.]+ m, [\d,]+ m AMSL$", lines[0]), lines
    assert lines[2].startswith("t = 250.5 s: ")
    entry = re.search(r"as a threat: (\{.*\})$", lines[1])
    assert entry is not None
    threats = tmp_path / "here.yaml"
    threats.write_text(
        "terrapath: 1\nthreats:\n  - " + entry.group(1).replace("radius: ...", "radius: 40") + "\n"
    )
    again = tmp_path / "again.mcap"
    assert main([*args, "--threats", str(threats), "-o", str(again)]) == 3
    sep = load_run(again, with_states=False).metrics["min_separation"]["at-200s"]
    assert sep["value"] == pytest.approx(-40.0, abs=2.0)  # through the centre
    assert sep["t"] == pytest.approx(200.0, abs=1.0)
    capsys.readouterr()
    assert main(["inspect", str(first), "--at", "301"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert re.search(r"--at 301: the flight lasts from t = 0\.0 to 299\.\d s$", err), err
