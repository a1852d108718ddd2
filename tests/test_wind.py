"""Wind in the replay (issue 36): the air mass of replay.flight.wind in the 6-DOF models, the
autopilot tracking course with crab, orbits and their wind-corrected radius, the options."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from planner.mission import Mission
from replay.avoidance.registry import make_avoider
from replay.flight.fixedwing.autopilot import OrbitRefused
from replay.flight.fixedwing.presets import preset
from replay.flight.fixedwing.stack import FixedWingStack
from replay.flight.multirotor.model import MULTIROTOR_PRESETS
from replay.flight.wind import Wind, WindLayer, load_wind_file, parse_wind
from replay.frames import velocities_ned
from replay.guidance import Orbit
from replay.sim import ReplayConfig, simulate
from replay.threats.kinds import ThreatSet
from terrain.errors import InputError
from terrapath.cli import main

AEROSONDE = preset("aerosonde")
V = 25.0


def test_direction_profiles_and_layers() -> None:
    """A wind "from 270" moves the air east; the profiles grow the 10 m surface wind to 300 m
    (power 30^(1/7), log ln(1e4)/ln(333)); layers interpolate the vector in altitude."""
    np.testing.assert_allclose(parse_wind("10,270").velocity(500.0), [0.0, 10.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(parse_wind("8,0,2").velocity(500.0), [-8.0, 0.0, -2.0], atol=1e-9)
    power = parse_wind("10,180", "power")
    n = power.velocity(np.full(4, 900.0), np.array([0.2, 10.0, 300.0, 2000.0]))[:, 0]
    np.testing.assert_allclose(
        n, 10 * np.array([0.1 ** (1 / 7), 1.0, 30 ** (1 / 7), 30 ** (1 / 7)])
    )
    log = parse_wind("10,180", "log")
    assert log.velocity(900.0, 300.0)[0] == pytest.approx(10 * math.log(1e4) / math.log(1e3 / 3))
    layers = Wind(layers=(WindLayer(1000.0, 10.0, 270.0), WindLayer(3000.0, 10.0, 0.0)))
    np.testing.assert_allclose(layers.velocity(2000.0), [-5.0, 5.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(layers.velocity(500.0), [0.0, 10.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(layers.velocity(9000.0), [-10.0, 0.0, 0.0], atol=1e-9)
    assert layers.strongest(0.0, 5000.0) == pytest.approx(10.0)


def _straight(wind: Wind) -> tuple[Mission, object]:
    m = Mission(
        name="east",
        waypoints=np.array(
            [[0.0, 0.0, 500.0], [20_000.0, 0.0, 500.0], [20_000.0, 20_000.0, 500.0]]
        ),
        vehicle="aerosonde",
        cruise_speed=V,
        turn_radius=AEROSONDE.performance(V).turn_radius,
    )
    r = simulate(
        m, ThreatSet(()), make_avoider("none"), AEROSONDE, config=ReplayConfig(seed=1, wind=wind)
    )
    return m, r


@pytest.mark.parametrize("from_deg", [0.0, 300.0, 135.0])
def test_a_straight_leg_crabs_into_the_wind(from_deg: float) -> None:
    """Flying east in 10 m/s: the heading is turned into the wind by the crab angle of the wind
    triangle, asin(w sin(theta) / V), within 0.2 deg, the ground speed within 1 % of
    sqrt(V^2 - w_x^2) + w_a, and the track holds the leg; the goal is reached."""
    wind = parse_wind(f"10,{from_deg}")
    _, r = _straight(wind)
    assert r.metrics.success, r.metrics.failures
    x, y = r.positions[:, 0], r.positions[:, 1]
    mid = (x > 8_000) & (x < 12_000) & (np.abs(y) < 500)
    v = velocities_ned(r.states[mid])
    w = wind.velocity(500.0)
    cross, along = w[0], w[1]  # the course is east: the air's north is across, east along
    crab = math.degrees(np.median(r.states[mid, 8] - np.arctan2(v[:, 1], v[:, 0])))
    assert crab == pytest.approx(math.degrees(math.asin(cross / V)), abs=0.2)
    ground = np.median(np.hypot(v[:, 0], v[:, 1]))
    assert ground == pytest.approx(math.sqrt(V * V - cross * cross) + along, rel=0.01)
    assert np.abs(y[mid]).max() < 5.0
    # the stall judge and the avoiders see the speed through the air, not over the ground
    air = np.linalg.norm(v - w, axis=1)
    assert np.median(air) == pytest.approx(V, rel=0.01)


@pytest.mark.parametrize(
    ("vehicle", "speed", "radius"), [("aerosonde", 25.0, 300.0), ("cessna172", 50.0, 900.0)]
)
def test_an_orbit_holds_its_radius_in_wind(vehicle: str, speed: float, radius: float) -> None:
    """A 360-deg orbit in 10 m/s from the west stays within 10 % of its radius (measured: 1 %)
    -- the downwind side flown at the ground speed V + w; an orbit tighter than the bank limit
    allows at V + w is refused, naming the wind."""
    p = preset(vehicle)
    st = FixedWingStack(p, np.array([[0.0, 0.0, 1000.0], [0.0, 20_000.0, 1000.0]]), airspeed=speed)
    st.set_wind(parse_wind("10,270").velocity(1000.0))
    log = st.fly(st.initial_state(), 0.0, 5.0, record_every=1)
    centre = (radius, 5.0 * speed)
    st.apply(Orbit(centre, radius, clockwise=True, altitude=1000.0))
    lap = 2 * math.pi * radius / (speed - 10.0)  # at least one lap, upwind slowest
    log = st.fly(log.x, log.t, 60.0 + lap, record_every=1)
    d = np.hypot(log.states[:, 1] - centre[0], log.states[:, 0] - centre[1])
    settled = d[int(60.0 / (log.times[1] - log.times[0])) :]
    assert np.abs(settled / radius - 1.0).max() < 0.10
    tightest = p.min_turn_radius(speed + 10.0)
    with pytest.raises(OrbitRefused, match=r"\(V \+ w\)\^2, w = 10\.0 m/s of wind"):
        st.apply(Orbit(centre, 0.95 * tightest, clockwise=True))


def test_a_multirotor_holds_its_track_across_the_wind() -> None:
    """The quadrotor at 5 m/s across an 4 m/s wind: on its legs, and at the goal."""
    quad = MULTIROTOR_PRESETS["quadrotor"]
    m = Mission(
        name="quad",
        waypoints=np.array([[0.0, 0.0, 60.0], [600.0, 0.0, 60.0], [600.0, 400.0, 60.0]]),
        vehicle="quadrotor",
        cruise_speed=5.0,
    )
    cfg = ReplayConfig(seed=1, wind=parse_wind("4,0"))
    r = simulate(m, ThreatSet(()), make_avoider("none"), quad, config=cfg)
    assert r.metrics.success, r.metrics.failures
    on_leg = (r.positions[:, 0] > 100) & (r.positions[:, 0] < 500)
    assert np.abs(r.positions[on_leg, 1]).max() < 3.0


def test_wind_options_and_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`replay --wind` records the wind (metadata and the states' air data); a wind as fast as
    the airspeed, a bad wind text, a profile without a wind and a bad wind file are one-line
    errors naming what is wrong."""
    from planner.mission import save_mission
    from replay.record.reader import load_run

    m, _ = _straight(Wind())
    path = save_mission(m, tmp_path / "east.yaml", None)
    out = tmp_path / "w.mcap"
    args = ["replay", str(path), "--seed", "1", "--no-picture", "-o", str(out)]
    assert main([*args, "--wind", "10,300"]) == 0
    run = load_run(out, with_states=False)
    assert json.loads(run.metadata["wind"])["text"] == "10 m/s from 300 deg"
    capsys.readouterr()
    bad = [
        (["--wind", "25,90"], "is not slower than aerosonde's 25 m/s airspeed"),
        (["--wind", "10"], "expected SPEED,FROM_DEG"),
        (["--wind", "10,north"], "expected numbers"),
        (["--wind-profile", "power"], "--wind-profile shapes --wind: give --wind too"),
    ]
    for extra, message in bad:
        assert main([*args, *extra]) in (1, 2)
        err = capsys.readouterr().err.strip()
        assert message in err and err.count("\n") <= 1, err
    wf = tmp_path / "aloft.yaml"
    wf.write_text(
        "terrapath: 1\nwind:\n  layers:\n    - {altitude: 400, speed: 8, from: 270}\n    - {altitude: 300, speed: 9, from: 250}\n"
    )
    with pytest.raises(InputError, match="wind layers must go up in altitude"):
        load_wind_file(wf)
    wf.write_text("terrapath: 1\nwind:\n  layers:\n    - {altitude: 400, speed: -3, from: 270}\n")
    with pytest.raises(InputError, match=r"field 'wind.layers\[0\].speed'"):
        load_wind_file(wf)
    wf.write_text(
        "terrapath: 1\nwind:\n  layers:\n    - {altitude: 300, speed: 8, from: 270}\n    - {altitude: 900, speed: 12, from: 290}\n"
    )
    aloft = load_wind_file(wf)
    assert aloft.describe().startswith("winds aloft: 8 m/s from 270 deg at 300 m")
    assert main([*args, "--wind-file", str(wf)]) == 0
