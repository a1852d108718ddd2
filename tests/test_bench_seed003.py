"""``terrapath bench seed003-uncharted``: seed 003's uncharted scenarios flown by the priority
loop, PSO-CA, CTGA and FGA with the rangefinders only (replay/campaign/benches/)."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from replay.campaign.benches import BENCHES, HERE
from replay.campaign.runner import execute, run_campaign
from replay.campaign.spec import load_spec
from replay.campaign.store import Store
from terrain.errors import InputError

SPEC = HERE / "seed003-uncharted.yaml"
BENCH = BENCHES["seed003-uncharted"]


def test_the_spec_flies_four_scenarios_by_four_avoiders_with_the_rangefinders() -> None:
    spec = load_spec(SPEC)
    assert [r.label for r in spec.rows] == [
        "priority-convex",
        "priority-u-trap",
        "priority-corridor",
        "priority-box",
    ]
    names = ["priority", "pso-ca", "pso-ca", "ctga", "ctga", "fga", "fga"]
    assert [a.name for a in spec.avoiders] == names
    # the others at a tight (tau-like) and a wide (R / 2) safety distance
    safety = {"pso-ca": "rs", "ctga": "r_safe", "fga": "d_m"}
    kept = [dict(a.options)[safety[a.name]] for a in spec.avoiders if a.name in safety]
    assert kept == [2, 10, 2, 10, 3, 10]
    assert spec.sensor == "rangefinder" and spec.sensor_range == 20.0 and spec.runs == 1
    assert len(spec.all_runs()) == 28
    assert BENCH.spec_paths() == [SPEC]


def test_a_rangefinder_spec_sets_the_beams_range(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    text = SPEC.read_text(encoding="utf-8").replace("../../../data", str(Path.cwd() / "data"))
    path = tmp_path / "s.yaml"
    path.write_text(text.replace("sensor_range: 20", "sensor_range: 12"), encoding="utf-8")
    run = load_spec(path).all_runs()[0]
    seen: dict[str, Any] = {}

    def capture(request: Any, out: Any = None) -> Any:
        seen["request"] = request
        raise RuntimeError("not flown")

    monkeypatch.setattr("replay.run.run_replay", capture)
    row = execute(run, "s", "", "test", "", "none", None)
    r = seen["request"]
    c = r.config
    assert (c.sensor, c.rangefinder_range, c.radar_range) == ("rangefinder", 12.0, 10_000.0)
    assert row["status"] == "error" and row["error"] == "RuntimeError: not flown"
    path.write_text(text.replace("sensor: rangefinder", "sensor: sonar"), encoding="utf-8")
    with pytest.raises(InputError, match="expected one of radar, cooperative, rangefinder"):
        load_spec(path)


def test_a_tiny_version_flies_and_reports_the_outcome_beside_the_right_one(
    tmp_path: Path,
) -> None:
    spec = load_spec(SPEC)
    tiny = replace(spec, rows=spec.rows[:1]).narrowed(
        avoiders=tuple(a for a in spec.avoiders if a.name in ("priority", "fga"))
    )
    with Store(tmp_path / "s.sqlite", "test") as store:
        runs, rows = run_campaign(tiny, store, version="test", command="test", keep="none")
    assert len(runs) == len(rows) == 3 and all(r["status"] == "ok" for r in rows)
    lines = {(ln[1], ln[2]): ln for ln in BENCH.lines(rows)}
    assert {ln[0] for ln in lines.values()} == {"convex"}
    # the priority loop goes round the tower: the right outcome, longer than the straight line
    assert lines["priority", "outcome"][3:] == ("goal", "goal", "right")
    assert lines["priority", "success"][3] == "1/1"
    # no shorter than the shortest way keeping tau from the tower (radius 12 m at (2, 75), the
    # straight line 150 m): tangents to the 14 m circle and the arc between them
    d = math.hypot(2.0, 75.0)
    shortest = 2.0 * math.sqrt(d * d - 14.0**2) + 14.0 * 2.0 * math.asin(14.0 / d)
    assert shortest / 150.0 < float(lines["priority", "PLR (flown / straight)"][3]) < 2.0
    assert float(lines["priority", "smallest separation (m)"][3]) >= 2.0
    assert float(lines["priority", "flight time (s)"][3]) > 30.0  # 150 m at 5 m/s, and more
    # FGA keeping 10 m from what the beams have seen clears the tower; keeping 3 m it goes round
    # the point it has seen and meets the rest of the tower
    assert lines["fga d_m=10", "outcome"][3:] == ("goal", "goal", "right")
    assert float(lines["fga d_m=10", "smallest separation (m)"][3]) > 0.0
    assert lines["fga d_m=3", "outcome"][3:] == ("goal, through an obstacle", "goal", "wrong")


def test_the_box_reports_its_outcome_and_errors_their_reason() -> None:
    metrics: dict[str, Any] = {
        "plr": 6.3,
        "flight_time_s": 653.3,
        "violations": [],
        "min_separation": {},
    }
    base: dict[str, Any] = {
        "spec_name": "seed003-uncharted",
        "row": "priority-box",
        "metrics": metrics,
    }
    rows: list[dict[str, Any]] = [
        {**base, "avoider": "priority", "status": "ok", "success": False,
         "end_reason": "target unreachable: circled"},
        {**base, "avoider": "fga[d_m=3]", "status": "error", "success": None, "end_reason": None,
         "metrics": None, "error": "InputError: FGA: the turn radius is too large"},
    ]  # fmt: skip
    lines = BENCH.lines(rows)
    assert lines[0] == (
        "box",
        "priority",
        "outcome",
        "target unreachable: circled",
        "target unreachable",
        "right",
    )
    assert not any(ln[2] == "success" for ln in lines)  # no success rate for the box
    assert lines[-1] == (
        "box",
        "fga d_m=3",
        "outcome",
        "error: InputError: FGA: the turn radius is too large",
        "target unreachable",
        "wrong",
    )
