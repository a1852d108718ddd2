"""The multirotor flight stack (issue 19, "Vehicle"): the 6-DOF quadrotor, its compiled kernels
against the numpy twin, the controller's hover, yaw, step and speed figures, the guidance
commands it flies or refuses, and a mission flown by ``run_replay``.

Measured on the ``quadrotor`` preset (AscTec Hummingbird of RotorS; 100 Hz RK4), the numbers the
assertions below guard:
- hover at 1,500 m for 60 s with a 3 m/s wind arriving at t = 0: 0.18 m from the point at most;
- 90 deg yaw in place: 0.013 m of drift, within 0.5 deg of the heading after 2.65 s;
- 20 m step (GoTo) at the 5 m/s cruise: no overshoot (0.01 % short), within 2 % after 4.9 s;
  at the 12 m/s limit speed: 0.01 % short, 3.8 s (9.3 m/s at most on the way);
- speed: a 200 m go-to at 12 m/s flies 12.01 m/s at most (the limit + 0.1 %); the airframe's
  top level speed at the 45 deg tilt limit is 23.7 m/s (sea level).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from replay.flight.multirotor import kernels as kern
from replay.flight.multirotor.model import (
    MULTIROTOR_PRESETS,
    QUADROTOR,
    derivatives,
    forces_moments,
    hover_state,
    mix,
    multirotor_preset,
    rk4_step,
    top_speed,
)
from replay.flight.multirotor.stack import MultirotorStack
from replay.frames import rotation_body_to_ned
from replay.guidance import (
    ClimbRate,
    FlightPathAngle,
    FollowWaypoints,
    GoTo,
    GuidanceRefused,
    HoldAltitude,
    HoldCourse,
    HoldPosition,
    Orbit,
    YawTo,
)
from terrain.errors import InputError

Q = QUADROTOR


def _stack(alt: float = 100.0, **kw: object) -> tuple[MultirotorStack, np.ndarray]:
    st = MultirotorStack(Q, [[0.0, 0.0, alt], [0.0, 0.0, alt]], **kw)  # type: ignore[arg-type]
    return st, st.initial_state()


def _map(states: np.ndarray) -> np.ndarray:
    return np.column_stack([states[:, 1], states[:, 0], -states[:, 2]])


# ---- the preset and its parameters -------------------------------------------------------------
def test_preset_is_the_rotors_hummingbird() -> None:
    assert multirotor_preset("quadrotor") is Q and MULTIROTOR_PRESETS["quadrotor"] is Q
    assert (Q.mass, Q.Jx, Q.Jy, Q.Jz, Q.arm) == (0.68, 0.007, 0.007, 0.012, 0.17)
    assert Q.k_f == 8.54858e-06 and Q.k_m == pytest.approx(0.016 * Q.k_f)
    assert Q.rotor_speed_max == 838.0 and Q.configuration == "+"
    assert "RotorS" in Q.source and "Hummingbird" in Q.source
    # thrust to weight 3.6: 4 k_f 838^2 against 0.68 g
    assert Q.thrust_max() / Q.weight == pytest.approx(3.6, abs=0.05)
    with pytest.raises(InputError, match=r"unknown multirotor 'hexa'.*quadrotor"):
        multirotor_preset("hexa")


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"mass": -1.0}, "mass"),
        ({"Jz": 0.1}, "Jz"),
        ({"configuration": "h"}, "configuration"),
        ({"k_f": float("nan")}, "k_f"),
        ({"rotor_speed_max": 450.0}, "rotor_speed_max"),
        ({"rotor_speed_min": 500.0}, "rotor_speed_min"),
        ({"rotor_tau_up": 0.001}, "rotor_tau_up"),
        ({"tilt_max_deg": 90.0}, "tilt_max_deg"),
        ({"cruise_speed": 20.0}, "cruise_speed"),
        ({"rotor_drag": -1e-5}, "rotor_drag"),
    ],
)
def test_bad_parameters_are_refused_naming_the_field(change: dict, field: str) -> None:
    with pytest.raises(InputError, match=f"field '{field}': expected") as err:
        dataclasses.replace(Q, **change)
    assert "\n" not in str(err.value)


def test_hover_thrust_equals_the_weight_in_the_air_at_altitude() -> None:
    """The rotor speed that carries the weight is sqrt(m g / (4 sigma k_f)) with sigma the ISA
    density ratio: 443.8 rad/s at 100 m, 548.6 rad/s at 4,000 m; there the model's net force
    and moment vanish, and the controller settles on that speed from a disturbed start."""
    for alt, rho in ((100.0, 1.2133), (4000.0, 0.8194)):
        w = math.sqrt(Q.mass * 9.81 / (4.0 * (rho / 1.225) * Q.k_f))
        assert Q.hover_rotor_speed(alt) == pytest.approx(w, rel=2e-4)
        f, m = forces_moments(hover_state(Q, [0.0, 0.0, alt]), Q)
        assert np.abs(f).max() < 1e-12 and np.abs(m).max() < 1e-15
        st, x = _stack(alt)
        x[3], x[7] = 1.0, 0.1  # moving and pitched
        st.fly(np.concatenate([x, np.full(4, 0.8 * w)]), 0.0, 20.0)
        assert st.rotor_speeds == pytest.approx(np.full(4, w), rel=1e-4)


# ---- compiled kernels against the numpy twin -----------------------------------------------------
def test_compiled_dynamics_equal_the_numpy_twin() -> None:
    rng = np.random.default_rng(19)
    p = Q.pack(wind=(2.0, -1.0, 0.3))
    out = np.empty(16)
    for _ in range(50):
        x = hover_state(Q, [0.0, 0.0, rng.uniform(0.0, 3000.0)])
        x[3:12] += rng.normal(0.0, [3, 3, 1, 0.3, 0.3, 3, 1, 1, 1])
        x[12:] = rng.uniform(0.0, 838.0, 4)
        wc = rng.uniform(-50.0, 900.0, 4)  # commands beyond the limits are clipped
        kern.derivs(x, wc, p, out)
        ref = derivatives(x, wc, Q, wind=(2.0, -1.0, 0.3))
        assert out == pytest.approx(ref, rel=1e-12, abs=1e-9)
        assert kern.rk4(x, wc, 0.01, p) == pytest.approx(
            rk4_step(x, wc, 0.01, Q, wind=(2.0, -1.0, 0.3)), rel=1e-12, abs=1e-9
        )


def test_compiled_mixer_equals_the_numpy_twin_and_keeps_the_priorities() -> None:
    rng = np.random.default_rng(3)
    p = Q.pack()
    wc = np.empty(4)
    a = Q.allocation()
    for _ in range(200):
        t = rng.uniform(0.0, 30.0)
        mo = rng.normal(0.0, [0.5, 0.5, 0.05])
        kern.mix(t, mo[0], mo[1], mo[2], 1.0, p, wc)
        ref = mix(t, mo, Q)
        assert wc == pytest.approx(ref, rel=1e-12, abs=1e-9)
        assert wc.min() >= 0.0 and wc.max() <= Q.rotor_speed_max * (1 + 1e-12)
    # inside the limits every demand is met exactly
    kern.mix(7.0, 0.05, -0.03, 0.01, 1.0, p, wc)
    assert a @ (Q.k_f * wc**2) == pytest.approx([7.0, 0.05, -0.03, 0.01], rel=1e-9)
    # a yaw demand beyond what is left is cut, roll, pitch and the collective are not
    kern.mix(7.0, 0.05, -0.03, 5.0, 1.0, p, wc)
    got = a @ (Q.k_f * wc**2)
    assert got[:3] == pytest.approx([7.0, 0.05, -0.03], rel=1e-9) and 0 < got[3] < 5.0
    # a collective beyond the rotors' thrust still gets its roll moment
    kern.mix(100.0, 0.2, 0.0, 0.0, 1.0, p, wc)
    got = a @ (Q.k_f * wc**2)
    assert got[1] == pytest.approx(0.2, rel=1e-9) and got[0] < Q.thrust_max()


def test_a_closed_loop_flight_is_the_same_with_the_numpy_twin() -> None:
    """5 s of a climbing, yawing go-to: the compiled loop against the compiled control law
    stepping the numpy RK4 (positions agree to 1e-9 m)."""
    cmd = GoTo((15.0, 10.0, 110.0), yaw=1.0)
    a, x0 = _stack()
    a.apply(cmd)
    log = a.fly(x0, 0.0, 5.0, record_every=1)
    b, _ = _stack()
    b.apply(cmd)
    x = hover_state(Q, [0.0, 0.0, 100.0], 0.0)
    for k in range(500):
        assert x[:12] == pytest.approx(log.states[k], rel=1e-9, abs=1e-9)
        x = rk4_step(x, b.control(x), 0.01, Q)
    assert np.abs(x[:12] - log.x).max() < 1e-9
    assert np.linalg.norm(_map(log.states)[-1] - [15.0, 10.0, 110.0]) < 5.0


# ---- the controller's figures ------------------------------------------------------------------------
def test_hover_holds_the_point_for_60_s_in_a_3_mps_wind() -> None:
    """60 s at 1,500 m with a 3 m/s wind from t = 0 (the rotors trimmed for still air):
    0.18 m from the point at most, 0.1 mm at the end."""
    st = MultirotorStack(Q, [[0.0, 0.0, 1500.0]] * 2, wind=(1.8, 2.4, 0.0))
    x = st.initial_state()
    st.apply(HoldPosition())
    log = st.fly(x, 0.0, 60.0, record_every=1)
    d = np.linalg.norm(_map(log.states) - [0.0, 0.0, 1500.0], axis=1)
    assert len(d) == 6000 and d.max() < 0.25 and d[-100:].max() < 0.01


def test_yaw_90_deg_in_place() -> None:
    """Drift 0.013 m; the heading within 0.5 deg of 90 after 2.65 s (45 deg/s limit)."""
    st, x = _stack()
    st.apply(YawTo(math.pi / 2))
    log = st.fly(x, 0.0, 8.0, record_every=1)
    drift = np.linalg.norm(_map(log.states) - [0.0, 0.0, 100.0], axis=1)
    assert drift.max() < 0.05
    yaw = np.degrees(log.states[:, 8])
    assert abs(yaw[270:] - 90.0).max() < 0.5 and yaw.max() < 90.5
    rate = np.degrees(np.abs(log.states[:, 11])).max()
    assert rate < Q.yaw_rate_max_deg * 1.05


@pytest.mark.parametrize(("speed", "settle_s"), [(5.0, 5.2), (12.0, 4.1)])
def test_a_20_m_step_settles_without_overshoot(speed: float, settle_s: float) -> None:
    """GoTo 20 m north: no overshoot at 5 and at 12 m/s (0.01 % short), within 2 % (0.4 m)
    after 4.9 s and 3.8 s, 3 mm off after 15 s, and it stays on the line (0.1 m aside)."""
    st, x = _stack(speed=speed)
    st.apply(GoTo((0.0, 20.0, 100.0)))
    log = st.fly(x, 0.0, 15.0, record_every=1)
    p = _map(log.states)
    overshoot = (p[:, 1].max() - 20.0) / 20.0
    assert overshoot <= 0.01  # the issue asks for 10 %
    err = np.linalg.norm(p - [0.0, 20.0, 100.0], axis=1)
    late = log.times[err > 0.4]
    assert late.max() < settle_s and err[-1] < 0.01
    assert np.abs(p[:, 0]).max() < 0.15 and np.abs(p[:, 2] - 100.0).max() < 0.1


def test_speed_limit_and_top_speed() -> None:
    """A 200 m go-to at the 12 m/s limit: 12.01 m/s at most, tilted to the 45 deg limit; the
    airframe's top speed at that tilt is 23.7 m/s at sea level, 27.5 m/s at 3,000 m (thinner
    air, less drag), 16.7 m/s at 30 deg."""
    st, x = _stack(speed=12.0)
    st.apply(GoTo((0.0, 200.0, 100.0)))
    log = st.fly(x, 0.0, 25.0, record_every=1)
    v = np.linalg.norm(log.states[:, 3:6], axis=1)
    assert 11.95 < v.max() < 12.0 * 1.005
    tilt = np.degrees(np.arccos(np.cos(log.states[:, 6]) * np.cos(log.states[:, 7])))
    assert tilt.max() < Q.tilt_max_deg + 0.5
    assert top_speed(Q) == pytest.approx(23.7, abs=0.1)
    assert top_speed(Q, altitude=3000.0) == pytest.approx(27.5, abs=0.1)
    assert top_speed(Q, tilt_deg=30.0) == pytest.approx(16.7, abs=0.1)


def test_rotor_speeds_stay_within_their_limits_in_an_aggressive_command() -> None:
    """A weak quadrotor (560 rad/s: thrust/weight 1.6) told to climb 30 m, fly 200 m at 12 m/s
    and turn round at once: its rotor commands and speeds reach the limit and never pass it,
    and it gets there."""
    weak = dataclasses.replace(Q, rotor_speed_max=560.0)
    st = MultirotorStack(weak, [[0.0, 0.0, 100.0]] * 2, speed=12.0)
    x = st.initial_state()
    st.apply(GoTo((0.0, 200.0, 130.0), yaw=math.pi))
    speeds = []
    commands = []
    t = 0.0
    for _ in range(400):  # 40 s in 0.1 s pieces: the rotor speeds after each
        log = st.fly(x, t, 0.1, record_every=1)
        x, t = log.x, log.t
        speeds.append(st.rotor_speeds)
        commands.append(log.controls)
    w = np.array(speeds)
    c = np.concatenate(commands)
    assert c.max() == pytest.approx(560.0) and c.max() <= 560.0 and c.min() >= 0.0
    assert w.max() <= 560.0 and w.min() >= 0.0 and w.max() > 555.0
    assert np.linalg.norm(_map(x[None, :])[0] - [0.0, 200.0, 130.0]) < 0.5


# ---- commands ---------------------------------------------------------------------------------------
def test_commands_beyond_the_multirotor_are_refused() -> None:
    st, _ = _stack()
    with pytest.raises(GuidanceRefused, match="FlightPathAngle is a fixed-wing command; quadrotor"):
        st.apply(FlightPathAngle(0.1))
    with pytest.raises(GuidanceRefused, match=r"centre moving at 13\.0 m/s is beyond"):
        st.apply(Orbit((0.0, 0.0), 50.0, center_velocity=(5.0, 12.0)))
    with pytest.raises(GuidanceRefused, match=r"climb rate 5 m/s is beyond .* climb 3 m/s"):
        st.apply(ClimbRate(5.0))
    with pytest.raises(GuidanceRefused, match=r"climb rate -2 m/s is beyond .*descent 1 m/s"):
        st.apply(HoldCourse(0.0, climb_rate=-2.0))
    with pytest.raises(InputError, match=r"cruise speed 20\.0 m/s is beyond .*\(0, 12\] m/s"):
        MultirotorStack(Q, [[0.0, 0.0, 10.0]] * 2, speed=20.0)
    assert st.mode == "leg"  # a refused command changes nothing


def test_hold_course_altitude_and_climb_rate() -> None:
    """HoldCourse east at the cruise speed, then a climb at 2 m/s, then hold 130 m."""
    st, x = _stack()
    st.apply(HoldCourse(math.pi / 2))
    log = st.fly(x, 0.0, 10.0, record_every=10)
    vel = np.diff(_map(log.states), axis=0)[-10:] / 0.1
    assert vel[:, 0] == pytest.approx(5.0, abs=0.05) and np.abs(vel[:, 1:]).max() < 0.05
    assert log.states[-1, 8] == pytest.approx(math.pi / 2, abs=1e-3)
    st.apply(ClimbRate(2.0))
    log = st.fly(log.x, log.t, 5.0, record_every=10)
    assert -np.diff(log.states[-10:, 2]).mean() / 0.1 == pytest.approx(2.0, abs=0.05)
    st.apply(HoldAltitude(130.0))
    log = st.fly(log.x, log.t, 20.0, record_every=10)
    assert -log.x[2] == pytest.approx(130.0, abs=0.05)


@pytest.mark.parametrize(
    ("radius", "clockwise", "center_velocity", "speed"),
    [(20.0, True, (0.0, 0.0), 5.0), (2.0, False, (0.0, 0.0), 1.0), (30.0, True, (2.0, 1.0), 5.0)],
)
def test_orbit(
    radius: float, clockwise: bool, center_velocity: tuple[float, float], speed: float
) -> None:
    """Orbits from 10 m off the centre: after 30 s within 2 mm of the circle (measured), at the
    cruise speed or the 0.5 rad/s a 2 m circle allows, turning the way asked, facing along it,
    the altitude held within 0.1 m (the capture)."""
    st, x = _stack()
    assert st.orbit_speed(radius) == pytest.approx(speed)
    st.apply(Orbit((0.0, 10.0), radius, clockwise=clockwise, center_velocity=center_velocity))
    assert st.mode == "orbit"
    log = st.fly(x, 0.0, 60.0, record_every=10)
    p = _map(log.states)
    c = np.array([0.0, 10.0]) + np.outer(log.times, center_velocity)
    rel = p[:, :2] - c
    vel = np.diff(p[:, :2], axis=0) / 0.1 - np.asarray(center_velocity)
    late = log.times[:-1] > 30.0
    assert np.abs(np.linalg.norm(rel, axis=1)[:-1][late] - radius).max() < 0.01
    assert np.linalg.norm(vel[late], axis=1) == pytest.approx(speed, abs=0.02)
    turn = rel[:-1, 0] * vel[:, 1] - rel[:-1, 1] * vel[:, 0]  # > 0: counter-clockwise
    assert (turn[late] < 0).all() if clockwise else (turn[late] > 0).all()
    ground = np.array([rotation_body_to_ned(*s[6:9]) @ s[3:6] for s in log.states[:-1][late]])
    course = np.arctan2(ground[:, 1] - center_velocity[0], ground[:, 0] - center_velocity[1])
    yaw = log.states[:-1, 8][late]
    assert np.abs((yaw - course + np.pi) % (2 * np.pi) - np.pi).max() < 0.01
    assert np.abs(p[:, 2] - 100.0).max() < 0.1


def test_hold_position_stops_where_it_can_and_follow_waypoints_resumes() -> None:
    st = MultirotorStack(Q, [[0.0, 0.0, 50.0], [0.0, 100.0, 50.0], [50.0, 100.0, 50.0]])
    log = st.fly(st.initial_state(), 0.0, 10.0)
    stop = st.stopping_point()
    assert stop[1] > st.position[1]  # ahead of it (flying north at 5 m/s: 4 m)
    st.apply(HoldPosition())
    log = st.fly(log.x, log.t, 10.0, record_every=1)
    p = _map(log.states)
    assert np.linalg.norm(p[-1] - stop) < 0.05 and p[:, 1].max() < stop[1] + 0.2
    st.apply(FollowWaypoints(st.waypoints, 1, direct=True))
    log = st.fly(log.x, log.t, 60.0)
    assert st.done and [r.index for r in st.reached] == [1, 2]
    assert np.linalg.norm(st.position - [50.0, 100.0, 50.0]) < 0.1


def test_a_quadrotor_mission_flown_by_run_replay(tmp_path: Path) -> None:
    """A mission file naming ``vehicle: quadrotor``: three legs (one climbing 20 m), flown to
    the goal within 0.5 m of the planned polyline (its corners cut by less than that)."""
    from replay.run import ReplayRequest, prepare_replay, run_replay

    mission = tmp_path / "quad.yaml"
    mission.write_text(
        "terrapath: 1\nname: quad\ncrs: local\nvehicle: quadrotor\n"
        "cruise: {speed: 5.0, altitude: 30.0}\n"
        "waypoints:\n- [0, 0, 30]\n- [0, 150, 30]\n- [100, 150, 50]\n- [100, 0, 50]\n"
    )
    prep = prepare_replay(ReplayRequest.of(source=str(mission)))
    assert prep.params is Q
    res = run_replay(prep)
    assert res.metrics.end_reason == "goal" and res.metrics.success
    w = res.initial_waypoints
    assert np.linalg.norm(res.positions[-1] - w[-1]) < 2.0 * 2.0
    assert 80.0 < res.metrics.flight_time_s < 90.0  # 400 m at 5 m/s, slowing for the corners
    p = res.positions
    off = np.full(len(p), np.inf)
    for a, b in itertools.pairwise(w):
        d = b - a
        s = np.clip((p - a) @ d / (d @ d), 0.0, 1.0)
        off = np.minimum(off, np.linalg.norm(p - (a + s[:, None] * d), axis=1))
    assert off.max() < 0.5
    warned = prepare_replay(ReplayRequest.of(source=str(mission), terrain_following=50.0))
    assert any("does not follow the terrain (50 m" in w for w in warned.warnings)
    # recorded, and re-flown from the recording: the same quadrotor, the same flight
    run = tmp_path / "quad.mcap"
    run_replay(prep, run)
    again = prepare_replay(ReplayRequest.of(source=str(run)))
    assert again.params is Q
    assert np.allclose(run_replay(again).positions, res.positions)
    fast = tmp_path / "fast.yaml"
    fast.write_text(mission.read_text().replace("speed: 5.0", "speed: 15.0"))
    with pytest.raises(InputError, match=r"cruise speed 15\.0 m/s is beyond quadrotor's"):
        prepare_replay(ReplayRequest.of(source=str(fast)))
