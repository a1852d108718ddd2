"""The autopilot on the 6-DOF model: holds, turns, climbs, waypoint missions, waypoint changes in
flight, terrain following, and the slow path (``command``) against the fast one (``fly``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from replay.flight.fixedwing.autopilot import Autopilot, AutopilotConfig
from replay.flight.fixedwing.dynamics import air_data
from replay.flight.fixedwing.gains import design_gains
from replay.flight.fixedwing.kernels import step_n
from replay.flight.fixedwing.presets import PRESETS
from replay.flight.fixedwing.trim import trim
from replay.flight.log import GUIDANCE_COLUMNS, FlightLog
from replay.frames import rotation_body_to_ned
from terrain.errors import InputError

XT = GUIDANCE_COLUMNS.index("cross_track")
G = 9.81


def _altitude(log: FlightLog) -> np.ndarray:
    return np.asarray(-log.states[:, 2])


def _airspeed(log: FlightLog, wind: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    return np.array([air_data(s, wind)[0] for s in log.states])


def _climb_rate(log: FlightLog) -> np.ndarray:
    return np.array([-(rotation_body_to_ned(*s[6:9]) @ s[3:6])[2] for s in log.states])


def _fit_circle(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    a = np.c_[2 * x, 2 * y, np.ones_like(x)]
    cx, cy, c = np.linalg.lstsq(a, x * x + y * y, rcond=None)[0]
    return float(cx), float(cy), math.sqrt(c + cx * cx + cy * cy)


# ---- holds ------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["aerosonde", "solar-uav"])
def test_level_flight_holds_altitude_and_airspeed_for_ten_minutes(name: str) -> None:
    p = PRESETS[name]
    x, _ = trim(p, p.cruise_speed, 200.0)
    ap = Autopilot(p)  # no waypoints: hold the present course and altitude
    log = ap.fly(x, 0.0, 600.0, record_every=10)
    assert ap.guidance.mode == "hold"
    assert np.max(np.abs(_altitude(log) - 200.0)) < 5.0
    assert np.max(np.abs(_airspeed(log) - p.cruise_speed)) < 0.5
    # the same from a disturbed start (10 deg bank, 20 m low, 10 % fast), after 15 s
    x1 = x.copy()
    x1[6], x1[2], x1[3] = math.radians(10.0), -180.0, 1.1 * x[3]
    ap = Autopilot(p)
    ap.set_override(course=0.0, altitude=200.0)
    log = ap.fly(x1, 0.0, 600.0, record_every=10)
    late = log.times >= 15.0
    assert np.max(np.abs(_altitude(log)[late] - 200.0)) < 5.0
    assert np.max(np.abs(_airspeed(log)[late] - p.cruise_speed)) < 0.5
    assert log.t == pytest.approx(600.0)


def test_level_flight_holds_in_wind() -> None:
    p = PRESETS["aerosonde"]
    wind = (3.0, -4.0, 0.0)
    x, _ = trim(p, p.cruise_speed, 200.0)
    ap = Autopilot(p, wind=wind)
    ap.set_override(course=math.radians(45.0), altitude=200.0)
    log = ap.fly(x, 0.0, 300.0, record_every=10)
    late = log.times >= 30.0
    assert np.max(np.abs(_altitude(log)[late] - 200.0)) < 5.0
    assert np.max(np.abs(_airspeed(log, wind)[late] - p.cruise_speed)) < 0.5
    v = np.array([rotation_body_to_ned(*s[6:9]) @ s[3:6] for s in log.states[late]])
    course = np.degrees(np.arctan2(v[:, 1], v[:, 0]))
    assert np.max(np.abs(course - 45.0)) < 0.5  # ground course held against the crosswind


@pytest.mark.parametrize("name", ["aerosonde", "cessna172"])
def test_banked_turn_has_the_radius_of_the_bank(name: str) -> None:
    p = PRESETS[name]
    x, _ = trim(p, p.cruise_speed, 300.0)
    ap = Autopilot(p)
    ap.set_override(bank=math.radians(30.0), altitude=300.0)
    log = ap.fly(x, 0.0, 200.0, record_every=10)
    steady = log.times >= 80.0
    s = log.states[steady]
    _, _, radius = _fit_circle(s[:, 1], s[:, 0])
    speed = float(np.mean(_airspeed(log)[steady]))
    expected = speed**2 / (G * math.tan(math.radians(30.0)))  # seed 000 eq. 13
    assert radius == pytest.approx(expected, rel=0.05)
    assert np.max(np.abs(np.degrees(s[:, 6]) - 30.0)) < 0.2
    assert np.max(np.abs(_altitude(log)[steady] - 300.0)) < 5.0
    assert np.max(np.degrees(log.states[:, 6])) < 30.6  # the bank limit, with 2 % overshoot


# ---- climbs -----------------------------------------------------------------------------------
@pytest.mark.parametrize(("name", "settle"), [("aerosonde", 60.0), ("solar-uav", 90.0)])
def test_altitude_step_settles_within_limits(name: str, settle: float) -> None:
    p = PRESETS[name]
    x, _ = trim(p, p.cruise_speed, 200.0)
    ap = Autopilot(p)
    ap.set_override(course=0.0, altitude=400.0)
    log = ap.fly(x, 0.0, 200.0, record_every=10)
    h = _altitude(log)
    after = log.times >= settle
    assert np.max(np.abs(h[after] - 400.0)) < 5.0  # settled (+-5 m) within `settle` s
    assert h.max() < 405.0  # no overshoot past the band
    theta = np.degrees(log.states[:, 7])
    assert theta.max() <= p.pitch_max_deg and theta.min() >= p.pitch_min_deg
    rate = _climb_rate(log)
    assert rate.max() <= p.climb_rate_max  # the climb-rate limit holds
    assert rate.max() > 0.9 * p.climb_rate_max  # and is used
    assert np.max(np.abs(_airspeed(log) - p.cruise_speed)) < 0.5


def test_descent_respects_the_descent_limit() -> None:
    p = PRESETS["cessna172"]
    x, _ = trim(p, p.cruise_speed, 600.0)
    ap = Autopilot(p)
    ap.set_override(course=0.0, altitude=400.0)
    log = ap.fly(x, 0.0, 150.0, record_every=10)
    rate = _climb_rate(log)
    assert rate.min() >= -p.descent_rate_max
    assert np.max(np.abs(_altitude(log)[log.times >= 80.0] - 400.0)) < 5.0


# ---- waypoint missions ------------------------------------------------------------------------
@pytest.mark.parametrize(("name", "leg"), [("aerosonde", 5000.0), ("cessna172", 15000.0)])
def test_square_mission_tracks_legs_and_reaches_every_waypoint(name: str, leg: float) -> None:
    p = PRESETS[name]
    # map coordinates: x east, y north, z up; a square, then back across the middle
    wps = np.array(
        [
            [0, 0, 200],
            [0, leg, 200],
            [leg, leg, 300],
            [leg, 0, 300],
            [0, 0, 200],
            [leg, 0.3 * leg, 250],
        ],
        dtype=float,
    )
    x, _ = trim(p, p.cruise_speed, 200.0)
    ap = Autopilot(p, wps)
    length = float(np.sum(np.linalg.norm(np.diff(wps[:, :2], axis=0), axis=1)))
    log = ap.fly(x, 0.0, 1.2 * length / p.cruise_speed, record_every=10)
    assert ap.done and ap.guidance.mode == "done"
    assert [r.index for r in log.reached] == [1, 2, 3, 4, 5]
    for r in log.reached[:-1]:  # passed within the switching distance (seed 000 §3.6)
        assert r.how == "radius" and r.distance <= 1000.0
    assert log.reached[-1].distance <= 100.0  # the arrival distance of the last waypoint
    for k in range(1, len(wps)):
        on_leg = log.next_index == k
        t = log.times[on_leg]
        err = np.abs(log.guidance[on_leg, XT])
        # after the turn transient (at most 120 s: a 1 km corner cut and a few turn radii) the
        # cross-track error stays under 20 m
        assert np.max(err[t - t[0] >= 120.0]) < 20.0
        assert err[-1] < 1.0
    assert np.max(np.abs(np.degrees(log.states[:, 6]))) < 30.9  # bank limit (3 % overshoot)


def test_mission_in_crosswind_keeps_cross_track_bounded() -> None:
    p = PRESETS["solar-uav"]
    wind = (0.0, 4.0, 0.0)  # 4 m/s from the west at 15 m/s airspeed
    wps = np.array([[0, 0, 200], [0, 5000, 200], [5000, 5000, 200], [5000, 0, 200]], dtype=float)
    x, _ = trim(p, p.cruise_speed, 200.0)
    ap = Autopilot(p, wps, wind=wind)
    log = ap.fly(x, 0.0, 1500.0, record_every=10)
    assert [r.index for r in log.reached] == [1, 2, 3]
    for k in (2, 3):
        on_leg = log.next_index == k
        t = log.times[on_leg]
        assert np.max(np.abs(log.guidance[on_leg, XT][t - t[0] >= 150.0])) < 20.0


def test_waypoints_replaced_in_flight() -> None:
    p = PRESETS["aerosonde"]
    x, _ = trim(p, p.cruise_speed, 200.0)
    ap = Autopilot(p, np.array([[0, 0, 200], [0, 12000, 200]], dtype=float))
    first = ap.fly(x, 0.0, 60.0)
    assert ap.next_index == 1
    # an avoider inserts a waypoint 1.5 km east of the track, flown to from where the aircraft is
    new = np.array([[0, 0, 200], [1500, 5000, 260], [0, 12000, 200]], dtype=float)
    ap.set_waypoints(new, 1, direct=True)
    assert ap.guidance.next_index == 1
    log = ap.fly(first.x, first.t, 700.0, record_every=10)
    assert [(r.index, r.how) for r in log.reached] == [(1, "radius"), (2, "radius")]
    assert log.states[:, 1].max() > 1000.0  # it went round the new waypoint
    assert log.reached[1].distance <= 100.0  # and arrived at the old destination
    np.testing.assert_array_equal(ap.waypoints, new)
    with pytest.raises(InputError, match=r"in \[0, 2\]"):
        ap.set_waypoints(new, 3)
    with pytest.raises(InputError, match="finite"):
        ap.set_waypoints([[0, 0], [1, 1]], 1)


def test_terrain_following_climbs_over_a_ridge() -> None:
    p = PRESETS["aerosonde"]

    def ridge(east: np.ndarray, north: np.ndarray) -> np.ndarray:
        return 300.0 * np.exp(-(((np.asarray(north) - 5000.0) / 600.0) ** 2)) + 0.0 * east

    x, _ = trim(p, p.cruise_speed, 200.0)
    ap = Autopilot(
        p,
        np.array([[0, 0, 200], [0, 12000, 200]], dtype=float),
        terrain_height=ridge,
        config=AutopilotConfig(terrain_clearance=100.0),
    )
    log = ap.fly(x, 0.0, 420.0, record_every=10)
    s = log.states
    clearance = _altitude(log) - ridge(s[:, 1], s[:, 0])
    assert clearance.min() > 95.0
    assert _altitude(log).max() < 405.0
    assert abs(_altitude(log)[-1] - 200.0) < 5.0  # back down to the mission altitude
    assert _climb_rate(log).max() <= p.climb_rate_max


# ---- one control law, two paths ---------------------------------------------------------------
def test_command_path_flies_like_the_compiled_path() -> None:
    p = PRESETS["small-uas"]
    wps = np.array([[0, 0, 150], [0, 1500, 180], [1500, 1500, 150]], dtype=float)
    x, _ = trim(p, p.cruise_speed, 150.0)
    fast = Autopilot(p, wps)
    log = fast.fly(x, 0.0, 150.0)
    slow = Autopilot(p, wps)
    packed = p.pack()
    y = x.copy()
    for k in range(15000):
        u = slow.command(k * 0.01, y)
        y = step_n(y, u, 1, 0.01, packed)
    assert [r.index for r in slow.reached] == [r.index for r in log.reached] == [1]
    assert slow.reached[0].t == log.reached[0].t
    np.testing.assert_allclose(y, log.x, rtol=1e-7, atol=1e-6)
    g_fast, g_slow = fast.guidance, slow.guidance
    assert g_fast.next_index == g_slow.next_index == 2
    assert g_fast.cross_track == pytest.approx(g_slow.cross_track, abs=1e-6)


def test_fly_records_and_reports_guidance() -> None:
    p = PRESETS["aerosonde"]
    x, _ = trim(p, p.cruise_speed, 200.0)
    ap = Autopilot(p, np.array([[0, 0, 200], [0, 3000, 250]], dtype=float))
    log = ap.fly(x, 0.0, 20.0, record_every=50)
    assert log.states.shape == (40, 12) and log.controls.shape == (40, 4)
    assert log.guidance.shape == (40, len(GUIDANCE_COLUMNS))
    np.testing.assert_allclose(log.times, np.arange(40) * 0.5)
    g = ap.guidance
    assert (g.mode, g.next_index, g.leg_index) == ("waypoints", 1, 0)
    assert g.airspeed_cmd == p.cruise_speed and g.course_cmd == pytest.approx(0.0, abs=1e-3)
    # linear altitude along the leg: 200 m at the start, 250 m at the end
    assert g.altitude_cmd == pytest.approx(200.0 + 50.0 * g.along_track / 3000.0)
    assert g.terrain_floor is None
    ap.set_override(airspeed=22.0)
    assert ap.guidance.mode == "override"
    later = ap.fly(log.x, log.t, 60.0)
    assert air_data(later.x)[0] == pytest.approx(22.0, abs=0.5)
    assert ap.guidance.airspeed_cmd == 22.0
    ap.clear_override()
    assert ap.guidance.mode == "waypoints"
    with pytest.raises(
        InputError,
        match=r"outside aerosonde's envelope at 225 m 18.2–30.3 m/s \(true airspeed; 18–30 m/s",
    ):
        ap.set_override(airspeed=50.0)


def test_gains_are_designed_for_every_preset() -> None:
    for p in PRESETS.values():
        g = design_gains(p)
        assert g.roll_p > 0 and g.roll_i > 0 and g.roll_d >= 0  # positive aileron rolls right
        assert g.pitch_p < 0 and g.pitch_d <= 0  # positive elevator pitches down
        assert g.speed_i > 0 and g.course_p > 0 and g.course_i > 0
        assert 0 < g.pitch_dc < 1
        assert g.course_wn == pytest.approx(g.roll_wn / 8.0)
    with pytest.raises(InputError, match="'switch_distance'"):
        AutopilotConfig(switch_distance=0.0)
    with pytest.raises(InputError, match="90 m/s is outside solar-uav's envelope"):
        Autopilot(PRESETS["solar-uav"], airspeed=90.0)
