"""The cooperative (ADS-B-like) sensor: what is reported, range, activity, noise, latency, seeds."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from replay.avoidance.base import AvoidanceContext
from replay.avoidance.pso_ca import PsoCaAvoider
from replay.flight.fixedwing.presets import load_vehicle
from replay.guidance import FollowWaypoints
from replay.sensors.cooperative import CooperativePicture, CooperativeSensor
from replay.sensors.radar import Radar
from replay.threats.body import BodyThreat
from replay.threats.kinds import (
    EDGE_SUFFIXES,
    CylinderThreat,
    HillThreat,
    IntruderThreat,
    StaticThreat,
)
from terrain.errors import InputError

OWN = np.array([1000.0, 2000.0, 300.0])


def static(ident: str, x: float, y: float, z: float = 300.0, **kw: Any) -> StaticThreat:
    return StaticThreat(id=ident, center=(x, y, z), radius=kw.pop("radius", 250.0), **kw)


def many_statics(k: int, seed: int = 0) -> tuple[StaticThreat, ...]:
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-5000, 5000, (k, 2)) + OWN[:2]
    return tuple(static(f"s{i}", x, y) for i, (x, y) in enumerate(xy))


KINDS = (
    static("s", 4000.0, 2000.0, radius=600.0),
    HillThreat(id="h", points=((1000.0, 6000.0, 500.0), (1400.0, 6000.0, 450.0)), radii=(300.0,)),
    IntruderThreat(id="i", radius=150.0, start=(6000.0, 2000.0, 320.0), velocity_mps=(-12, 5, 1)),
    CylinderThreat(id="c", center=(-3000.0, 2000.0), radius=700.0, top=900.0),
    BodyThreat(id="b", center=(1000.0, -1000.0, 0.0), axes=(400, 300, 600), exponents=(1, 1, 1)),
)


# -- what is reported ------------------------------------------------------------------------------
def test_each_kind_reports_its_true_state_and_size() -> None:
    pic = CooperativeSensor().scan(10.0, OWN, KINDS)
    assert isinstance(pic, CooperativePicture) and pic.sensor == "cooperative"
    assert pic.ids == ("s", "h/0", "h/1", "i", "c", "b")
    assert pic.sources == ("s", "h", "h", "i", "c", "b")
    s, h0, h1, i, c, b = pic.reports
    assert s.position.tolist() == [4000, 2000, 300] and (s.radius, s.top) == (600, 900)
    assert h1.position.tolist() == [1400, 6000, 450] and (h1.radius, h1.top) == (300, 750)
    assert i.position.tolist() == [6000 - 120, 2050, 330] and i.velocity.tolist() == [-12, 5, 1]
    assert (i.radius, i.top, i.moving) == (150, 480, True)
    assert c.position.tolist() == [-3000, 2000, 900] and (c.radius, c.top) == (700, 900)
    # seed 001 eq 3: the body's section at the aircraft's altitude (ellipse: its larger semi-axis)
    assert b.position.tolist() == [1000, -1000, 0] and b.top == 600
    assert b.radius == pytest.approx(400 * math.sqrt(1 - (300 / 600) ** 2), rel=1e-12)
    assert not any(r.moving for r in (s, h0, h1, c, b))
    assert (pic.measured_at == 10.0).all() and pic.t == 10.0
    np.testing.assert_allclose(pic.ranges, np.linalg.norm(pic.positions - OWN, axis=1))
    assert pic.bearings[0] == pytest.approx(math.pi / 2)  # east
    assert pic.elevations[0] == 0.0


def test_same_ids_and_order_as_the_radar() -> None:
    """Without terrain and noise the radar sees the same points under the same names, but for
    a solid's outline edges: a report is the solid's centre and size."""
    coop = CooperativeSensor().scan(5.0, OWN, KINDS)
    radar = Radar().scan(5.0, OWN, KINDS)
    keep = [i for i, ident in enumerate(radar.ids) if not ident.endswith(EDGE_SUFFIXES)]
    assert coop.ids == tuple(radar.ids[i] for i in keep)
    assert coop.sources == tuple(radar.sources[i] for i in keep)
    # the picture reads like the radar's: the parallel arrays a radar consumer uses
    for name in ("positions", "ranges", "bearings", "elevations", "moving_code", "extended"):
        assert len(getattr(coop, name)) == len(coop) == coop.n_threat
    assert coop.terrain_cells.shape == (0, 2) and not coop.is_terrain.any()
    assert coop.get("i").source == "i"


def test_an_avoider_written_for_the_radar_reads_it() -> None:
    """PSO-CA, which reads radar pictures, acts on a cooperative one -- at the first report,
    since a report is classified at once (the radar needs two scans)."""
    wps = np.array([[0.0, 0.0, 200.0], [20000.0, 0.0, 200.0]])
    avoider = PsoCaAvoider()
    avoider.reset(wps, np.random.default_rng(0))
    own = np.array([0.0, 0.0, 200.0])
    pic = CooperativeSensor().scan(0.0, own, (static("s", 8000.0, 0.0, 200.0, radius=1000.0),))
    ctx = AvoidanceContext(
        t=0.0,
        state=np.zeros(12),
        position=own,
        velocity=np.array([15.0, 0.0, 0.0]),
        airspeed=15.0,
        course=math.pi / 2,
        picture=pic,
        waypoints=wps,
        next_index=1,
        vehicle=load_vehicle("solar-uav"),
    )
    decision = avoider.decide(ctx)
    assert decision is not None and isinstance(decision.command, FollowWaypoints)
    assert decision.info["obstacles"] == ["s"] and decision.info["feasible"]
    wps_new = decision.command.waypoints
    new = wps_new[1]
    assert math.hypot(new[0] - 8000.0, new[1]) > 1000.0 and wps_new.shape == (3, 3)


def test_range_limit_counts_from_the_surface_of_solids() -> None:
    far = 10_000.0
    edge = static("edge", OWN[0] + 6000.0, OWN[1] + 8000.0)  # exactly 10 km: heard
    out = static("out", OWN[0], OWN[1] - far - 1.0)
    # cylinder centre 10.5 km away, its side 9.8 km: heard (the centre is reported)
    cyl = CylinderThreat(id="cyl", center=(OWN[0] - 10_500.0, OWN[1]), radius=700.0, top=900.0)
    # body centre 10.3 km away, surface 9.9 km
    body = BodyThreat(
        id="body",
        center=(OWN[0], OWN[1] + 10_300.0, 300.0),
        axes=(400, 400, 400),
        exponents=(1, 1, 1),
    )
    body_far = BodyThreat(
        id="bfar",
        center=(OWN[0], OWN[1] + 10_500.0, 300.0),
        axes=(400, 400, 400),
        exponents=(1, 1, 1),
    )
    hill = HillThreat(
        id="hill",
        points=((OWN[0] + 9000.0, OWN[1], 300.0), (OWN[0] + 11000.0, OWN[1], 300.0)),
        radii=(200.0,),
    )
    pic = CooperativeSensor(range_m=far).scan(0.0, OWN, (edge, out, cyl, body, body_far, hill))
    assert pic.ids == ("edge", "cyl", "body", "hill/0")
    assert pic.get("cyl").position.tolist() == [OWN[0] - 10_500.0, OWN[1], 900.0]
    assert CooperativeSensor(range_m=9000.0).scan(0.0, OWN, (hill,)).ids == ("hill/0",)
    assert CooperativeSensor(range_m=8999.0).scan(0.0, OWN, (hill,)).ids == ()


def test_activity_windows_shift_by_the_latency() -> None:
    """A threat is heard when it was active latency_s ago: from appears_at + L, until
    disappears_at + L (exclusive)."""
    th = (static("w", 3000.0, 2000.0, appears_at=10.0, disappears_at=20.0),)
    times = np.arange(0.0, 30.0, 0.5)
    for latency, first, last in ((0.0, 10.0, 19.5), (2.5, 12.5, 22.0)):
        sensor = CooperativeSensor(latency_s=latency)
        heard = [t for t in times if len(sensor.scan(float(t), OWN, th))]
        assert (
            heard[0] == first and heard[-1] == last and len(heard) == int((last - first) / 0.5) + 1
        )


def test_moving_classification_uses_the_reported_speed() -> None:
    stop = IntruderThreat(
        id="stop", radius=100.0, start=(2000, 2000, 300), velocity_mps=(10, 0, 0), stops_at=5.0
    )
    slow = IntruderThreat(id="slow", radius=100.0, start=(0, 2000, 300), velocity_mps=(0.4, 0, 0))
    sensor = CooperativeSensor()
    assert sensor.moving_threshold_mps == 0.5
    assert sensor.scan(1.0, OWN, (stop, slow)).moving_code.tolist() == [1, 0]
    assert sensor.scan(6.0, OWN, (stop, slow)).moving_code.tolist() == [0, 0]
    noisy = CooperativeSensor(noise_velocity_mps=2.0)
    assert noisy.moving_threshold_mps == 10.5
    statics = many_statics(2000)
    for t in range(5):  # 10 000 stationary reports: none called moving (P ~ 1.4e-5 each)
        assert not noisy.scan(float(t), OWN, statics).moving_code.any()


# -- noise, latency, seeds ---------------------------------------------------------------------------
def test_noise_statistics() -> None:
    statics = many_statics(3000)
    truth = np.array([s.center for s in statics])
    sensor = CooperativeSensor(range_m=1e6, noise_position_m=8.0, noise_velocity_mps=0.7, seed=11)
    pic = sensor.scan(0.0, OWN, statics)
    err_p = pic.positions - truth
    err_v = pic.velocities
    for err, sigma in ((err_p, 8.0), (err_v, 0.7)):
        assert np.abs(err.mean(axis=0)).max() < 4 * sigma / math.sqrt(len(err))
        np.testing.assert_allclose(err.std(axis=0), sigma, rtol=0.06)  # 4.6 standard errors
    # errors are independent across axes and between position and velocity
    corr = np.corrcoef(np.hstack([err_p, err_v]).T)
    assert np.abs(corr - np.eye(6)).max() < 4 / math.sqrt(len(err_p))
    # sizes are exact
    assert (pic.radii == 250.0).all()


def test_latency_without_and_with_extrapolation() -> None:
    th = KINDS[2]  # constant velocity intruder
    assert isinstance(th, IntruderThreat)
    t, lat = 30.0, 4.0
    late = CooperativeSensor(latency_s=lat).scan(t, OWN, (th,))
    np.testing.assert_array_equal(late.positions[0], th.position(t - lat))
    assert late.measured_at.tolist() == [t - lat]
    ex = CooperativeSensor(latency_s=lat, extrapolate=True).scan(t, OWN, (th,))
    np.testing.assert_allclose(ex.positions[0], th.position(t), atol=1e-9)
    assert ex.measured_at.tolist() == [t]
    # with noise, dead reckoning adds latency * velocity error: variance sp^2 + (L sv)^2 per axis
    crowd = tuple(
        IntruderThreat(
            id=f"i{k}", radius=50.0, start=(OWN[0] + k, OWN[1], 300.0), velocity_mps=(5, 5, 0)
        )
        for k in range(3000)
    )
    sp, sv = 3.0, 1.5
    pic = CooperativeSensor(
        noise_position_m=sp, noise_velocity_mps=sv, latency_s=lat, extrapolate=True, seed=4
    ).scan(t, OWN, crowd)
    err = pic.positions - np.array([c.position(t) for c in crowd])
    np.testing.assert_allclose(err.std(axis=0), math.sqrt(sp**2 + (lat * sv) ** 2), rtol=0.06)


def test_same_seed_same_pictures_different_seed_different() -> None:
    def run(seed: int | np.random.Generator) -> list[np.ndarray]:
        sensor = CooperativeSensor(noise_position_m=5.0, noise_velocity_mps=0.3, seed=seed)
        out = []
        for t in range(4):
            pic = sensor.scan(float(t), OWN + np.array([15.0 * t, 0, 0]), KINDS)
            out += [pic.positions, pic.velocities, pic.moving_code]
        return out

    a, b, c = run(7), run(7), run(8)
    g = run(np.random.default_rng(7))
    for x, y, z in zip(a, b, g, strict=True):
        np.testing.assert_array_equal(x, y)
        np.testing.assert_array_equal(x, z)
    assert any(not np.array_equal(x, y) for x, y in zip(a, c, strict=True))


def test_noise_free_sensor_draws_nothing() -> None:
    rng = np.random.default_rng(3)
    state = rng.bit_generator.state
    CooperativeSensor(seed=rng).scan(0.0, OWN, KINDS)
    assert rng.bit_generator.state == state


def test_due_follows_the_period() -> None:
    sensor = CooperativeSensor(period_s=2.0)
    assert sensor.due(0.0)
    sensor.scan(0.0, OWN, ())
    assert not sensor.due(1.99) and sensor.due(2.0 - 1e-7)
    sensor.reset()
    assert sensor.due(0.5)


# -- bad input -----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"noise_position_m": -1.0}, "noise_position_m must be a finite number >= 0; got -1.0"),
        ({"noise_velocity_mps": -0.1}, "noise_velocity_mps must be a finite number >= 0"),
        ({"latency_s": -2.0}, "latency_s must be a finite number >= 0"),
        ({"range_m": 0.0}, "range_m must be a finite number > 0"),
        ({"range_m": -5.0}, "range_m must be a finite number > 0"),
        ({"period_s": 0.0}, "period_s must be a finite number > 0"),
        ({"latency_s": math.nan}, "latency_s"),
        ({"noise_position_m": True}, "noise_position_m"),
        ({"seed": 1.5}, "seed must be an integer or a numpy Generator"),
        ({"extrapolate": "yes"}, "extrapolate must be true or false"),
    ],
)
def test_bad_parameters_are_refused_in_one_line(kwargs: dict[str, Any], message: str) -> None:
    with pytest.raises(InputError, match=message) as err:
        CooperativeSensor(**kwargs)
    assert "\n" not in str(err.value) and str(err.value).startswith("cooperative sensor ")


def test_bad_own_position_is_refused() -> None:
    with pytest.raises(InputError, match="own position must be 3 finite"):
        CooperativeSensor().scan(0.0, [0.0, np.nan, 0.0], KINDS)
