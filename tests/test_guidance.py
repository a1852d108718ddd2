"""Guidance commands and the fixed-wing flight stack (issue 13): orbit and climb-rate modes on the
cessna172 and small-uas presets, refusals, the avoider's own period and end outcome, the explicit
avoider registry."""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np
import pytest

from planner.mission import Mission
from replay.avoidance import AvoidanceContext, AvoiderBase, make_avoider
from replay.avoidance.registry import AVOIDERS, avoider_class, avoider_options
from replay.flight.fixedwing.presets import load_vehicle
from replay.flight.fixedwing.stack import FixedWingStack
from replay.frames import ned_to_map, rotation_body_to_ned
from replay.guidance import (
    AvoidanceDecision,
    ClimbRate,
    FlightPathAngle,
    FollowWaypoints,
    GoTo,
    GuidanceRefused,
    HoldAltitude,
    HoldCourse,
    Orbit,
    YawTo,
    check_command,
    command_record,
)
from replay.sim import ReplayConfig, simulate
from replay.threats.kinds import ThreatSet
from terrain.errors import InputError

LINE = np.array([[0.0, 0.0, 500.0], [200000.0, 0.0, 500.0]])
PRESETS = ["cessna172", "small-uas"]


def _stack(name: str) -> FixedWingStack:
    return FixedWingStack(load_vehicle(name), LINE)


def _climb_rates(states: np.ndarray) -> np.ndarray:
    return np.array([-(rotation_body_to_ned(*s[6:9]) @ s[3:6])[2] for s in states])


@pytest.mark.parametrize("preset", PRESETS)
@pytest.mark.parametrize("factor", [1.0, 2.0])
def test_orbit_holds_its_radius_within_3_percent_after_capture(preset: str, factor: float) -> None:
    stack = _stack(preset)
    radius = factor * stack.autopilot.min_orbit_radius()  # 1.0: at the bank limit
    centre = (4.0 * radius, 0.0)
    stack.apply(Orbit(centre, radius, clockwise=factor > 1.5, altitude=550.0))
    log = stack.fly(stack.initial_state(), 0.0, 900.0, record_every=20)
    pos = ned_to_map(log.states[:, :3])
    d = np.hypot(pos[:, 0] - centre[0], pos[:, 1] - centre[1])
    captured = log.times > 450.0
    assert np.abs(d[captured] / radius - 1.0).max() < 0.03
    assert np.abs(pos[captured, 2] - 550.0).max() < 2.0
    # it really goes round, in the direction asked
    ang = np.unwrap(np.arctan2(pos[captured, 1] - centre[1], pos[captured, 0] - centre[0]))
    turns = (ang[-1] - ang[0]) / (2 * math.pi)
    assert (turns < -1.0) if factor > 1.5 else (turns > 1.0)


def test_orbit_about_a_moving_centre_keeps_the_radius() -> None:
    stack = _stack("small-uas")
    radius = 1.5 * stack.autopilot.min_orbit_radius()
    stack.apply(Orbit((3 * radius, 0.0), radius, clockwise=False, center_velocity=(2.0, 1.0)))
    log = stack.fly(stack.initial_state(), 0.0, 400.0, record_every=20)
    pos = ned_to_map(log.states[:, :3])
    cx, cy = 3 * radius + 2.0 * log.times, 1.0 * log.times
    d = np.hypot(pos[:, 0] - cx, pos[:, 1] - cy)
    assert np.abs(d[log.times > 200] / radius - 1.0).max() < 0.03


@pytest.mark.parametrize("preset", PRESETS)
def test_an_orbit_tighter_than_the_aircraft_can_fly_is_refused(preset: str) -> None:
    stack = _stack(preset)
    tightest = stack.autopilot.min_orbit_radius()
    with pytest.raises(GuidanceRefused, match=r"tighter than .* at least \d+ m"):
        stack.apply(Orbit((1000.0, 0.0), 0.9 * tightest))
    assert stack.autopilot.guidance.mode == "waypoints"  # nothing was flown instead


@pytest.mark.parametrize("preset", PRESETS)
@pytest.mark.parametrize("share", [0.6, -0.6])
def test_climb_rate_is_tracked_within_0_3_m_s(preset: str, share: float) -> None:
    stack = _stack(preset)
    p = stack.params
    rate = share * (p.climb_rate_max if share > 0 else p.descent_rate_max)
    stack.apply(ClimbRate(rate))
    log = stack.fly(stack.initial_state(), 0.0, 120.0, record_every=10)
    steady = log.times > 40.0
    assert np.abs(_climb_rates(log.states)[steady] - rate).max() < 0.3


def test_flight_path_angle_and_hold_altitude_and_hold_course() -> None:
    stack = _stack("cessna172")
    gamma = math.radians(2.0)
    stack.apply(FlightPathAngle(gamma))
    log = stack.fly(stack.initial_state(), 0.0, 60.0, record_every=10)
    want = stack.airspeed * math.sin(gamma)
    assert abs(_climb_rates(log.states[-20:]).mean() - want) < 0.3
    stack.apply(HoldCourse(math.radians(90.0), altitude=600.0))
    log = stack.fly(log.x, log.t, 240.0, record_every=10)
    vn, ve = (rotation_body_to_ned(*log.x[6:9]) @ log.x[3:6])[:2]
    assert abs(math.degrees(math.atan2(ve, vn)) - 90.0) < 1.0
    assert abs(-log.x[2] - 600.0) < 2.0
    stack.apply(HoldAltitude(580.0))
    log = stack.fly(log.x, log.t, 120.0, record_every=10)
    assert abs(-log.x[2] - 580.0) < 2.0


def test_climb_rates_beyond_the_vehicle_and_hover_commands_are_refused() -> None:
    stack = _stack("small-uas")
    with pytest.raises(GuidanceRefused, match="outside small-uas's limits"):
        stack.apply(ClimbRate(10.0))
    for cmd in (GoTo((0.0, 0.0, 100.0)), YawTo(1.0)):
        with pytest.raises(GuidanceRefused, match="needs a vehicle that can hover"):
            stack.apply(cmd)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: Orbit((0.0, 0.0), 0.0), "Orbit radius must be > 0"),
        (lambda: Orbit((0.0, 0.0), -5.0), "Orbit radius must be > 0"),
        (lambda: Orbit((0.0,), 100.0), "Orbit center must be 2 numbers"),
        (lambda: HoldCourse(math.nan), "finite"),
        (lambda: HoldCourse(0.0, altitude=100.0, climb_rate=1.0), "not both"),
        (lambda: FollowWaypoints(np.zeros((2, 3)), 5), "next_index must be in"),
        (lambda: check_command({"course": 1.0}), "unknown guidance command dict"),
        (lambda: AvoidanceDecision(command="left"), "unknown guidance command str"),  # type: ignore[arg-type]
    ],
)
def test_bad_guidance_input(make: Any, message: str) -> None:
    with pytest.raises(InputError, match=message):
        make()


def test_command_record_is_plain_data() -> None:
    rec = command_record(Orbit((1.0, 2.0), 300.0, clockwise=False, center_velocity=(0.5, 0)))
    assert rec == {
        "command": "Orbit",
        "center": [1.0, 2.0],
        "radius": 300.0,
        "clockwise": False,
        "altitude": None,
        "center_velocity": [0.5, 0.0],
    }


# -- the avoider in the loop ---------------------------------------------------------------------------
class _Scripted(AvoiderBase):
    """An avoider that records when it is asked and orbits, refuses, or ends the run."""

    name = "scripted"

    def __init__(self, period: float, plan: dict[float, AvoidanceDecision]) -> None:
        self.period = period
        self.plan = plan
        self.asked: list[float] = []

    def reset(self, waypoints: Any, rng: Any) -> None:
        self.asked.clear()

    def decide(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        self.asked.append(round(ctx.t, 6))
        return self.plan.get(round(ctx.t, 6))


def _mission() -> Mission:
    return Mission("line", LINE[:, :] * [0.1, 1, 1], vehicle="small-uas", cruise_speed=15.0)


def test_the_avoider_is_asked_at_its_own_period() -> None:
    av = _Scripted(0.2, {})
    simulate(
        _mission(), ThreatSet(()), av, load_vehicle("small-uas"), config=ReplayConfig(duration=5.0)
    )
    assert av.asked == pytest.approx(np.arange(1, 26) * 0.2)  # from the first radar scan on


def test_a_refused_command_is_recorded_and_an_end_outcome_ends_the_run() -> None:
    av = _Scripted(
        1.0,
        {
            2.0: AvoidanceDecision(Orbit((500.0, 0.0), 5.0), reason="too tight"),
            4.0: AvoidanceDecision(reason="give up", end="target unreachable"),
        },
    )
    r = simulate(_mission(), ThreatSet(()), av, load_vehicle("small-uas"))
    assert r.metrics.end_reason == "target unreachable" and not r.metrics.success
    refused, ended = r.decisions
    assert "tighter than small-uas can fly" in refused["refused"]
    assert refused["command"]["command"] == "Orbit"
    assert ended["end"] == "target unreachable" and r.metrics.flight_time_s == pytest.approx(4.0)


# -- the registry --------------------------------------------------------------------------------------
def test_registry_lists_avoiders_and_checks_their_options() -> None:
    assert set(AVOIDERS) >= {"none", "pso-ca"}
    opts = avoider_options("pso-ca")
    assert opts["optimizer"] == "pso" and "rs" in opts
    with pytest.raises(
        InputError, match=r"avoider 'pso-ca' has no option 'radius'; its options: .*rs"
    ):
        make_avoider("pso-ca", radius=5)
    with pytest.raises(
        InputError, match="unknown avoider 'teleport'; available: ctga, fga, none, priority, pso-ca"
    ):
        make_avoider("teleport")
    with pytest.raises(InputError, match="avoider 'none' has no option 'x'; its options: none"):
        make_avoider("none", x=1)


def test_importing_the_avoidance_package_imports_no_avoider_module() -> None:
    import subprocess
    import sys

    code = "import sys, replay.avoidance\nprint('replay.avoidance.pso_ca' in sys.modules)\n"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


# -- the replay as a library, and the avoider options on the command line ----------------------------
def _short_seed000(folder: Any) -> tuple[str, str]:
    """Seed 000's aircraft and obstacles on a 40 km mission (the avoidance contract's "two":
    an obstacle on each leg) written as files: 45 min of flight, a tenth of Table 4's 8 h, and
    the same questions for the command line (the avoider's options, the sensor) as Table 4."""
    import yaml

    mission = folder / "short-seed000.yaml"
    mission.write_text(
        yaml.safe_dump(
            {
                "terrapath": 1,
                "name": "short-seed000",
                "crs": "local",
                "vehicle": "solar-uav",
                "cruise": {"speed": 15.0, "altitude": 200.0},
                "waypoints": [[0, 0, 200], [20000, 0, 200], [40000, 0, 200]],
            }
        )
    )
    threats = folder / "short-seed000-threats.yaml"
    obstacles = [("o1", [9000, -200, 200]), ("o2", [27000, 300, 200])]
    threats.write_text(
        yaml.safe_dump(
            {
                "terrapath": 1,
                "threats": [
                    {"id": i, "kind": "static", "position": p, "radius": 1000.0}
                    for i, p in obstacles
                ],
            }
        )
    )
    return str(mission), str(threats)


def test_run_replay_is_what_the_cli_runs(tmp_path: Any, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from replay.run import ReplayRequest, run_replay
    from terrapath.cli import main

    mission, threats = _short_seed000(tmp_path)
    req = ReplayRequest.of(mission, threats=threats, avoid="pso-ca", avoid_options={"rs": 1200.0})
    lib = run_replay(req)  # no output: nothing written
    rc = main(
        [
            "replay",
            mission,
            "--threats",
            threats,
            "--avoid",
            "pso-ca",
            "--avoid-opt",
            "rs=1200",
            "--json",
            "-o",
            str(tmp_path / "r.mcap"),
        ]
    )
    cli = json.loads(capsys.readouterr().out)
    assert rc == 0 and lib.metrics.success
    assert cli["metrics"]["flown_length_m"] == pytest.approx(lib.metrics.flown_length_m)
    assert cli["final_waypoints"] == lib.waypoints.tolist()
    assert lib.decisions and all(
        d["params"]["rs"] == 1200.0 for d in lib.decisions if "params" in d
    )


def test_avoider_options_on_the_command_line(
    tmp_path: Any, capsys: pytest.CaptureFixture[str]
) -> None:
    from terrapath.cli import main
    from tests.conftest import ROOT

    mission = str(ROOT / "data/missions/seed000-table4.yaml")
    out = ["-o", str(tmp_path / "x.mcap")]
    assert main(["replay", mission, "--avoid", "pso-ca", "--avoid-opt", "radius=3", *out]) == 1
    err = capsys.readouterr().err
    assert "has no option 'radius'; its options: " in err and err.count("\n") == 1
    assert main(["replay", mission, "--avoid", "pso-ca", "--avoid-opt", "rs=-3", *out]) == 1
    assert "rs must be a positive number" in capsys.readouterr().err
    assert main(["replay", mission, "--avoid-opt", "nokey", *out]) == 2
    assert "expected KEY=VALUE" in capsys.readouterr().err
    assert not (tmp_path / "x.mcap").exists()
    assert main(["replay", "--help-avoider", "pso-ca"]) == 0
    text = capsys.readouterr().out
    lines = text.splitlines()
    assert lines[0].startswith("pso-ca: seed 000")
    opts = avoider_options("pso-ca")
    assert len(lines) == 1 + len(opts)  # one line per option, each with its default and meaning
    assert re.fullmatch(r"  --avoid-opt optimizer=\.\.\. +default 'pso': optimiser .*", lines[1])
    assert re.fullmatch(r"  --avoid-opt rs=\.\.\. +default None: safety radius RS .*", lines[3])
    for name in AVOIDERS:  # every option of every avoider says what it means
        assert set(avoider_options(name)) <= set(getattr(avoider_class(name), "OPTION_HELP", {}))
    assert main(["replay", "--help-avoider", "teleport"]) == 2
    assert (
        "unknown avoider 'teleport'; available: ctga, fga, none, priority, pso-ca"
        in capsys.readouterr().err
    )


# -- the sensor ---------------------------------------------------------------------------------------
def test_cooperative_sensor_drives_pso_ca_and_is_recorded(
    tmp_path: Any, capsys: pytest.CaptureFixture[str]
) -> None:
    import json

    from replay.record.reader import load_run
    from terrapath.cli import main

    mission, threats = _short_seed000(tmp_path)
    out = tmp_path / "coop.mcap"
    rc = main(
        [
            "replay",
            mission,
            "--threats",
            threats,
            "--avoid",
            "pso-ca",
            "--sensor",
            "cooperative",
            "--coop-noise",
            "5",
            "0.5",
            "--coop-latency",
            "0.5",
            "--seed",
            "2",
            "--json",
            "-o",
            str(out),
        ]
    )
    report = json.loads(capsys.readouterr().out)
    assert rc == 0 and report["metrics"]["success"] and report["metrics"]["decisions"] >= 1
    assert load_run(out, with_states=False).metadata["sensor"] == "cooperative"


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--sensor", "sonar"], "Invalid value for '--sensor'"),
        (
            ["--sensor", "cooperative", "--coop-noise", "-1", "0"],
            "Invalid value for '--coop-noise'",
        ),
        (["--coop-latency", "-2"], "Invalid value for '--coop-latency'"),
    ],
)
def test_bad_sensor_options(
    tmp_path: Any, capsys: pytest.CaptureFixture[str], extra: list[str], message: str
) -> None:
    from terrapath.cli import main
    from tests.conftest import ROOT

    rc = main(
        [
            "replay",
            str(ROOT / "data/missions/seed000-table4.yaml"),
            *extra,
            "-o",
            str(tmp_path / "x.mcap"),
        ]
    )
    assert rc == 2 and message in capsys.readouterr().err
    assert not (tmp_path / "x.mcap").exists()


def test_replay_config_refuses_unknown_sensors_and_negative_noise() -> None:
    with pytest.raises(
        InputError, match="unknown sensor 'sonar'; choose one of radar, cooperative"
    ):
        ReplayConfig(sensor="sonar")
    with pytest.raises(InputError, match="'coop_noise_position' must be a number >= 0"):
        ReplayConfig(sensor="cooperative", coop_noise_position=-1.0)
