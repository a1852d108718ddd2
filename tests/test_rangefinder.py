"""The rangefinders (issue 19, "Sensors"; seed 003 §III.A.2): exact first-hit distances against
every threat shape and the terrain, hand-computed; occlusion; the beams' bearings; the gimballed
and body mounts; noise by seed; the picture as radar returns for perception; a replay with
``sensor="rangefinder"`` whose MCAP holds the beams."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from replay.avoidance.perception import Perception, Scan
from replay.sensors.radar import RadarPicture
from replay.sensors.rangefinder import RangefinderPicture, Rangefinders
from replay.sensors.raycast import ray_cylinders, ray_prisms, ray_spheres, ray_superellipsoid
from replay.sim import ReplayConfig
from replay.threats.body import BodyThreat
from replay.threats.kinds import (
    CylinderThreat,
    HillThreat,
    IntruderThreat,
    PrismThreat,
    StaticThreat,
    Threat,
    ThreatSet,
)
from terrain.errors import InputError
from terrain.model import TerrainModel
from terrain.prisms import ring_edges
from tests.conftest import ROOT, make_grid

AC = np.array([1000.0, 2000.0, 50.0])  # the aircraft


def at(dx: float, dy: float, dz: float) -> np.ndarray:
    """A point relative to the aircraft."""
    return AC + np.array([dx, dy, dz], dtype=np.float64)


def tat(dx: float, dy: float, dz: float) -> tuple[float, float, float]:
    """A point relative to the aircraft, as a threat file gives it."""
    x, y, z = at(dx, dy, dz).tolist()
    return (x, y, z)


FRONT, RIGHT, BACK, LEFT = range(4)
# an L: the notch is the square (10..20, 10..20), its reflex corner at (10, 10)
ELL = [(0.0, 0.0), (20.0, 0.0), (20.0, 10.0), (10.0, 10.0), (10.0, 20.0), (0.0, 20.0)]
R2 = math.sqrt(2.0)


def state(phi: float = 0.0, theta: float = 0.0, psi: float = 0.0) -> np.ndarray:
    x = np.zeros(12)
    x[6:9] = phi, theta, psi
    return x


def unit(*v: float) -> np.ndarray:
    a = np.array(v, dtype=np.float64)
    return (a / np.linalg.norm(a)).reshape(1, 3)


def ell(dx: float, dy: float, bottom: float = 0.0, top: float = 60.0) -> PrismThreat:
    return PrismThreat(
        id="ell", footprint=tuple((x + dx, y + dy) for x, y in ELL), bottom=bottom, top=top
    )


# -- beams ----------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "beams, bearings",
    [
        (1, [0.0]),
        (4, [0.0, math.pi / 2, math.pi, -math.pi / 2]),
        (8, [0.0, 1, 2, 3, 4, -3, -2, -1]),
    ],
)
def test_beams_are_evenly_spaced_from_the_front(beams: int, bearings: list[float]) -> None:
    expected = np.array(bearings) * (math.pi / 4 if beams == 8 else 1.0)
    rf = Rangefinders(beams=beams)
    pic = rf.scan(0.0, AC, (), state=state(psi=3.0))
    assert np.allclose(pic.beam_bearings, expected, atol=1e-15)
    assert pic.yaw == 3.0 and pic.range_m == 20.0 and pic.beams == beams
    courses = (3.0 + expected + math.pi) % (2 * math.pi) - math.pi
    courses[np.isclose(courses, -math.pi)] = math.pi
    assert np.allclose(pic.beam_courses, courses)
    assert np.all((pic.beam_courses > -math.pi) & (pic.beam_courses <= math.pi))
    # gimballed: level, at the courses
    d = pic.beam_directions
    assert np.allclose(d[:, 2], 0.0) and np.allclose(np.arctan2(d[:, 0], d[:, 1]), pic.beam_courses)


def test_bad_settings_are_refused() -> None:
    for kwargs, match in (
        ({"beams": 0}, "beams must be an integer >= 1"),
        ({"beams": 2.5}, "beams must be an integer"),
        ({"mount": "nose"}, "mount must be one of gimballed, body"),
        ({"range_m": 0.0}, "range_m must be a finite number > 0"),
        ({"noise_m": -1.0}, "noise_m must be a finite number >= 0"),
        ({"seed": "x"}, "seed must be an integer or a numpy Generator"),
        ({"spread_deg": -1.0}, "spread_deg must be a finite number >= 0"),
        ({"spread_deg": 45.0}, "spread_deg must be below 45 deg"),
    ):
        with pytest.raises(InputError, match=match):
            Rangefinders(**kwargs)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="12-state vector"):
        Rangefinders().scan(0.0, AC, (), state=np.zeros(3))
    with pytest.raises(InputError, match="rangefinder_mount"):
        ReplayConfig(sensor="rangefinder", rangefinder_mount="nose")
    with pytest.raises(InputError, match="rangefinder_beams"):
        ReplayConfig(sensor="rangefinder", rangefinder_beams=0)


def test_due_every_period_and_reset() -> None:
    rf = Rangefinders(period_s=0.1)
    assert rf.due(0.0)
    rf.scan(0.0, AC, ())
    t = sum([0.01] * 10)  # 0.09999999999999999
    assert not rf.due(0.05) and rf.due(t)
    rf.reset()
    assert rf.due(0.0)


def test_a_cone_sees_what_stands_just_below_or_beside_its_axis() -> None:
    """Half-angle 6.34 deg = atan(2 / 18): a wall whose top is 1 m below the flight level, 10 m
    ahead, is missed by a line and met by the cone's lower ray at its horizontal distance; a
    post 1.5 m right of the front beam's line 16 m ahead (the rim is 1.78 m off there) by its
    right ray; flat ground 2 m below
    by the lower ray at 2 / tan(spread) = 18 m horizontally; the axis wins a tie."""
    spread = math.degrees(math.atan(2.0 / 18.0))
    low = PrismThreat(id="low", footprint=((AC[0] - 5, AC[1] + 10), (AC[0] + 5, AC[1] + 10),
                      (AC[0] + 5, AC[1] + 11), (AC[0] - 5, AC[1] + 11), (AC[0] - 5, AC[1] + 10)),
                      bottom=0.0, top=AC[2] - 1.0)  # fmt: skip
    line = Rangefinders().scan(0.0, AC, (low,))
    cone = Rangefinders(spread_deg=spread).scan(0.0, AC, (low,))
    assert line.beam_sources[FRONT] == "" and line.beam_reach[FRONT] == 20.0
    assert cone.beam_sources[FRONT] == "low"
    assert cone.beam_reach[FRONT] == pytest.approx(10.0, abs=1e-9)
    a = math.radians(spread)
    assert cone.beam_ranges[FRONT] == pytest.approx(10.0 / math.cos(a), abs=1e-9)
    assert cone.beam_directions[FRONT] == pytest.approx([0.0, math.cos(a), -math.sin(a)])
    assert cone.beam_ends[FRONT] == pytest.approx(at(0.0, 10.0, -10.0 * math.tan(a)))
    assert cone.positions[0] == pytest.approx(cone.beam_ends[FRONT])  # the return is the hit
    post = CylinderThreat(id="post", center=(AC[0] + 1.5 + 0.2, AC[1] + 16.0), radius=0.2,
                          bottom=0.0, top=100.0)  # fmt: skip
    assert Rangefinders().scan(0.0, AC, (post,)).beam_sources[FRONT] == ""
    seen = Rangefinders(spread_deg=spread).scan(0.0, AC, (post,))
    assert seen.beam_sources[FRONT] == "post" and 15.8 < seen.beam_reach[FRONT] < 16.2
    ground = Rangefinders(spread_deg=spread).scan(0.0, np.array([0.0, 0.0, 2.0]), ())
    assert ground.beam_sources == ("terrain",) * 4
    assert ground.beam_reach == pytest.approx([18.0] * 4, abs=1e-9)
    wall = CylinderThreat(id="wall", center=(AC[0], AC[1] + 108.0), radius=100.0, top=100.0)
    flat = Rangefinders(spread_deg=spread).scan(0.0, AC, (wall,))
    assert flat.beam_ranges[FRONT] == pytest.approx(8.0, abs=1e-9)  # the axis, not a rim ray
    assert flat.beam_directions[FRONT] == pytest.approx([0.0, 1.0, 0.0])


# -- exact distances, shape by shape ------------------------------------------------------------
def test_sphere_hill_and_intruder_hits() -> None:
    threats = (
        # front: a sphere 3 m off the beam, 10 m ahead, radius 5: (3, 4, 0) from its centre
        StaticThreat(id="s", center=tat(3.0, 10.0, 0.0), radius=5.0),
        # left: a hill's point 8 m away, 3 m up, radius 5 (p = 8, cc = 48: 8 - 4); a farther one
        HillThreat(id="hill", points=(tat(-20.0, 0, 0), tat(-8.0, 0, 3)), radii=(1.0, 5.0)),
        # back: an intruder coming north at 1 m/s from 30 m behind, radius 2
        IntruderThreat(id="uav", radius=2.0, start=tat(0.0, -30.0, 0.0), velocity_mps=(0, 1, 0)),
    )
    rf = Rangefinders()
    pic = rf.scan(10.0, AC, threats)
    assert pic.beam_ranges[FRONT] == pytest.approx(6.0, abs=1e-12)
    assert pic.beam_ranges[LEFT] == pytest.approx(4.0, abs=1e-12)
    assert pic.beam_ranges[BACK] == pytest.approx(18.0, abs=1e-12)  # at t = 10 it is 20 m behind
    assert pic.beam_ranges[RIGHT] == 20.0
    assert pic.beam_sources == ("s", "", "uav", "hill")
    assert pic.threat_ids == ("s#beam0", "uav#beam2", "hill/1#beam3")
    assert pic.threat_sources == ("s", "uav", "hill")
    assert np.allclose(pic.positions[0], at(0.0, 6.0, 0.0))
    assert not pic.extended.any() and (pic.moving_code == -1).all()
    early = rf.scan(0.0, AC, threats)  # the intruder is 28 m from the aircraft's surface then
    assert early.beam_sources[BACK] == "" and early.beam_ranges[BACK] == 20.0


def test_cylinder_side_top_and_bottom() -> None:
    rf = Rangefinders()
    cyl = CylinderThreat(id="cyl", center=(AC[0] + 12.0, AC[1]), radius=2.0, bottom=40.0, top=60.0)
    pic = rf.scan(0.0, AC, (cyl,))
    assert pic.beam_ranges[RIGHT] == pytest.approx(10.0, abs=1e-12)
    assert pic.beam_sources[RIGHT] == "cyl" and pic.extended.tolist() == [True]
    # rays down at 45 deg towards cylinders of radius 3 round (10, 0): the top at -8 is met at
    # x = 8 (s = 8 sqrt 2) before the side (s = 7 sqrt 2); with the top at -5 the side first
    down = unit(1.0, 0.0, -1.0)
    s = ray_cylinders(
        down,
        np.array([[10.0, 0.0], [10.0, 0.0]]),
        np.array([3.0, 3.0]),
        np.array([-np.inf, -np.inf]),
        np.array([-8.0, -5.0]),
    )
    assert s[0] == pytest.approx([8 * R2, 7 * R2], abs=1e-12)
    up = unit(1.0, 0.0, 1.0)  # the bottom cap, 8 m up
    s = ray_cylinders(
        up, np.array([[10.0, 0.0]]), np.array([3.0]), np.array([8.0]), np.array([100.0])
    )
    assert s[0, 0] == pytest.approx(8 * R2, abs=1e-12)
    # a vertical ray over the disc meets the top; one beside it nothing; one inside reads 0
    vertical = unit(0.0, 0.0, -1.0)
    c = np.array([[1.0, 0.0], [5.0, 0.0], [0.0, 0.0]])
    s = ray_cylinders(
        vertical,
        c,
        np.full(3, 3.0),
        np.array([-np.inf, -np.inf, -1.0]),
        np.array([-4.0, -4.0, 1.0]),
    )
    assert s[0].tolist() == [4.0, np.inf, 0.0]


def test_prism_edges_and_the_concave_corner() -> None:
    rf = Rangefinders()
    lshape = ell(AC[0] - 15.0, AC[1] - 30.0)  # the aircraft at (15, 30) of the L
    pic = rf.scan(0.0, AC, (lshape,))
    # back (south) through the empty notch to the edge y = 10
    assert pic.beam_ranges.tolist() == pytest.approx([20.0, 20.0, 20.0, 20.0])
    assert pic.beam_sources == ("", "", "ell", "")
    assert np.allclose(pic.positions[0], at(0.0, -20.0, 0.0))
    # from (17, 17) in the notch, facing south-west: the reflex corner (10, 10), a vertex
    own = at(2.0, -13.0, 0.0)
    pic = rf.scan(0.0, own, (lshape,), state=state(psi=-0.75 * math.pi))
    assert pic.beam_ranges[FRONT] == pytest.approx(7 * R2, abs=1e-12)
    assert pic.beam_sources == ("ell", "", "", "")
    # from (15, 15) facing west: the wall x = 10 of the notch; from (5, 30) facing south: y = 20
    assert rf.scan(
        0.0, own + np.array([-2.0, -2.0, 0]), (lshape,), state=state(psi=-0.5 * math.pi)
    ).beam_ranges[FRONT] == pytest.approx(5.0, abs=1e-12)
    assert rf.scan(0.0, at(-10.0, 0, 0), (lshape,), state=state(psi=math.pi)).beam_ranges[
        FRONT
    ] == pytest.approx(10.0, abs=1e-12)
    # above the roof (top 40 m < 50 m): nothing
    assert rf.scan(0.0, AC, (ell(AC[0] - 15.0, AC[1] - 30.0, top=40.0),)).beam_sources == ("",) * 4
    # an oblique edge, the roof and the floor, ray by ray (shapes relative to the ray's origin)
    square = ring_edges([(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)])
    off = np.array([0, 4])
    rays = np.vstack([unit(0.8, 0.6, 0.0), unit(0.6, 0.0, -0.8), unit(0.0, 0.0, 1.0)])
    # origin (-4, 2): x = 0 at s = 5 (y = 5); (2, 5) 4 m above the roof: at s = 5 over (5, 5);
    # (5, 5) 3 m under the floor, straight up: 3
    s = [
        ray_prisms(rays[:1], square - [-4, 2, -4, 2], off, np.array([-10.0]), np.array([10.0]))[
            0, 0
        ],
        ray_prisms(rays[1:2], square - [2, 5, 2, 5], off, np.array([-10.0]), np.array([-4.0]))[
            0, 0
        ],
        ray_prisms(rays[2:], square - [5, 5, 5, 5], off, np.array([3.0]), np.array([9.0]))[0, 0],
    ]
    assert s == pytest.approx([5.0, 5.0, 3.0], abs=1e-12)


def test_superellipsoid_body() -> None:
    rf = Rangefinders()
    # along an axis the surface is at the semi-axis whatever the exponents
    body = BodyThreat(
        id="b", center=tat(0.0, 12.0, 0.0), axes=(3.0, 4.0, 5.0), exponents=(3.0, 2.5, 1.0)
    )
    pic = rf.scan(0.0, AC, (body,))
    assert pic.beam_ranges[FRONT] == pytest.approx(8.0, abs=1e-9)
    assert pic.beam_sources == ("b", "", "", "") and pic.extended.tolist() == [True]
    # an ellipsoid (exponents 1) scaled to a sphere: the sphere's exact distance
    c = np.array([3.0, 10.0, 1.0])
    d = np.vstack([unit(0.0, 1.0, 0.0), unit(0.2, 1.0, 0.1), unit(1.0, 0.0, 0.0)])
    exact = ray_spheres(d, c[None, :], np.array([5.0]))[:, 0]
    got = ray_superellipsoid(d, c, np.full(3, 5.0), np.full(3, 2.0), 20.0)
    assert np.allclose(got, exact, atol=1e-9, rtol=0) and got[2] == np.inf
    # an oblique ray into a box-like body: Gamma is 1 at the hit and > 1 just before it
    box = BodyThreat(
        id="box", center=(4.0, 9.0, -1.0), axes=(2.0, 3.0, 2.5), exponents=(20.0, 20.0, 20.0)
    )
    ray = unit(0.3, 1.0, -0.1)
    s = ray_superellipsoid(
        ray, np.array(box.center), np.array(box.axes), 2 * np.array(box.exponents), 20.0
    )[0]
    assert math.isfinite(s)
    assert box.gamma(s * ray[0]) == pytest.approx(1.0, abs=1e-6)
    assert box.gamma((s - 1e-6) * ray[0]) > 1.0


def test_any_other_threat_by_sphere_tracing() -> None:
    class Ball(Threat):  # a threat kind the sensor does not know: only its separation
        def separation(self, p: object, t: object = 0.0) -> np.ndarray:
            return np.linalg.norm(np.asarray(p) - at(0.0, 0.0, -9.0), axis=-1) - 4.0

    pic = Rangefinders(mount="body").scan(
        0.0, AC, (Ball(id="ball"),), state=state(theta=-0.5 * math.pi)
    )
    assert pic.beam_ranges[FRONT] == pytest.approx(5.0, abs=1e-5)  # nose straight down
    assert pic.beam_sources[FRONT] == "ball"


# -- terrain -------------------------------------------------------------------------------------
def test_terrain_of_a_sloped_grid_and_flat_ground() -> None:
    # heights 100 + x / 2 (10 m cells from x = 0, y in [0, 1000]): a plane the mesh holds exactly
    cols = np.arange(200)
    heights = np.tile(100.0 + 0.5 * (5.0 + 10.0 * cols), (100, 1))
    model = TerrainModel.from_grid(make_grid(heights, cell=10.0, x0=0.0, y0=1000.0))
    rf = Rangefinders(range_m=150.0)
    own = np.array([500.0, 500.0, 400.0])
    pic = rf.scan(0.0, own, (), terrain_model=model, state=state(psi=0.5 * math.pi))
    # facing east: 100 + x / 2 = 400 at x = 600, 100 m ahead (float32 ray casting: mm)
    assert pic.beam_ranges[FRONT] == pytest.approx(100.0, abs=2e-3)
    assert pic.beam_sources == ("terrain", "", "", "")
    assert pic.terrain_cells.tolist() == [[600, 500]] and pic.ids == ("terrain/600/500",)
    assert pic.is_terrain.tolist() == [True] and pic.moving_code.tolist() == [0]
    # no terrain model: flat ground at 0 m; level beams never meet it
    assert Rangefinders().scan(0.0, AC, ()).beam_sources == ("",) * 4


def test_body_mount_tilts_with_the_vehicle_and_the_gimbal_does_not() -> None:
    own = np.array([0.0, 0.0, 5.0])
    pitched = state(theta=math.radians(-20.0), psi=0.3)  # nose 20 deg down, heading 0.3 rad
    body = Rangefinders(mount="body").scan(0.0, own, (), state=pitched)
    # the front beam dips 20 deg: flat ground at h / sin 20 = 2.92 h, 2.75 h ahead
    assert body.beam_ranges[FRONT] == pytest.approx(5.0 / math.sin(math.radians(20.0)), abs=1e-12)
    assert body.beam_sources == ("terrain", "", "", "")  # the back beam looks up, the sides level
    ahead = 5.0 / math.tan(math.radians(20.0))
    assert np.allclose(body.beam_ends[FRONT], [ahead * math.sin(0.3), ahead * math.cos(0.3), 0.0])
    assert body.beam_directions[BACK, 2] == pytest.approx(math.sin(math.radians(20.0)))
    level = Rangefinders().scan(0.0, own, (), state=pitched)
    assert level.beam_sources == ("",) * 4 and (level.beam_ranges == 20.0).all()
    # rolled 30 deg right wing down: the right beam meets the ground at h / sin 30
    rolled = Rangefinders(mount="body").scan(0.0, own, (), state=state(phi=math.radians(30.0)))
    assert rolled.beam_ranges[RIGHT] == pytest.approx(10.0, abs=1e-12)
    assert rolled.beam_sources == ("", "terrain", "", "")


# -- nearest, nothing, noise ------------------------------------------------------------------------
def test_the_nearest_of_two_obstacles_is_reported() -> None:
    near = StaticThreat(id="near", center=tat(0.0, 10.0, 0.0), radius=2.0)
    far = CylinderThreat(id="far", center=(AC[0], AC[1] + 15.0), radius=1.0, top=100.0)
    for threats in ((near, far), (far, near)):
        pic = Rangefinders().scan(0.0, AC, threats)
        assert pic.beam_ranges[FRONT] == pytest.approx(8.0) and pic.beam_sources[FRONT] == "near"
    # an obstacle behind the ground is hidden; the ground behind an obstacle too
    low = np.array([0.0, 0.0, 5.0])
    pitched = state(theta=math.radians(-30.0))  # the ground 10 m along the front beam
    ball = StaticThreat(id="ball", center=(0.0, 15.0, 5.0), radius=1.0)
    assert (
        Rangefinders(mount="body").scan(0.0, low, (ball,), state=pitched).beam_sources[FRONT]
        == "terrain"
    )
    close = StaticThreat(
        id="close", center=(0.0, 5.0 * math.cos(math.radians(30.0)), 2.5), radius=0.5
    )
    pic = Rangefinders(mount="body").scan(0.0, low, (close,), state=pitched)
    assert pic.beam_sources[FRONT] == "close" and pic.beam_ranges[FRONT] == pytest.approx(4.5)


def test_nothing_within_range() -> None:
    far = StaticThreat(id="far", center=tat(0.0, 30.0, 0.0), radius=5.0)  # 25 m
    later = StaticThreat(id="later", center=tat(0.0, 0.0, 0.0), radius=5.0, appears_at=60.0)
    pic = Rangefinders().scan(0.0, AC, (far, later))
    assert isinstance(pic, RangefinderPicture) and isinstance(pic, RadarPicture)
    assert (pic.beam_ranges == 20.0).all() and pic.beam_sources == ("",) * 4
    assert len(pic) == 0 and not pic.beam_hits.any()
    assert np.allclose(pic.beam_ends, AC + 20.0 * pic.beam_directions)
    inside = Rangefinders().scan(60.0, AC, (far, later))  # the aircraft inside a threat reads 0
    assert (inside.beam_ranges == 0.0).all() and inside.beam_sources == ("later",) * 4


def test_noise_is_reproducible_by_seed() -> None:
    threats = (StaticThreat(id="s", center=tat(0.0, 10.0, 0.0), radius=2.0),)
    a, b = Rangefinders(noise_m=0.5, seed=7), Rangefinders(noise_m=0.5, seed=7)
    ra = [a.scan(0.1 * k, AC, threats).beam_ranges for k in range(5)]
    rb = [b.scan(0.1 * k, AC, threats).beam_ranges for k in range(5)]
    assert np.array_equal(ra, rb)
    fronts = np.array(ra)[:, FRONT]
    assert len(set(fronts.tolist())) == 5 and np.all(np.abs(fronts - 8.0) < 3.0)
    assert (np.array(ra)[:, 1:] == 20.0).all()  # a miss stays a miss
    c = Rangefinders(noise_m=0.5, seed=np.random.default_rng(7))
    assert np.array_equal(c.scan(0.0, AC, threats).beam_ranges, ra[0])
    assert not np.array_equal(
        Rangefinders(noise_m=0.5, seed=8).scan(0.0, AC, threats).beam_ranges, ra[0]
    )
    # ranges are clipped to [0, R]; the return sits on its beam at the noisy range
    loud = Rangefinders(noise_m=8.0, seed=1)
    for k in range(20):
        pic = loud.scan(0.1 * k, AC, threats)
        assert 0.0 <= pic.beam_ranges[FRONT] <= 20.0
        assert np.allclose(np.linalg.norm(pic.positions - AC, axis=1), pic.ranges)


# -- as sensor returns ---------------------------------------------------------------------------
def test_perception_reads_the_hits_as_returns() -> None:
    threats = (
        StaticThreat(id="s", center=tat(0.0, 10.0, 0.0), radius=2.0),
        CylinderThreat(id="cyl", center=(AC[0] + 12.0, AC[1]), radius=2.0, top=60.0),
    )
    pic = Rangefinders(assume_static=True).scan(1.0, AC, threats)
    scan = Scan.of(pic)
    assert scan.sensor == "rangefinder" and scan.ids == ("s#beam0", "cyl#beam1")
    assert np.array_equal(scan.positions, pic.positions) and scan.extended.tolist() == [False, True]
    st = Perception().update(pic)
    assert st.sensor == "rangefinder"
    assert st.ids == ("s#beam0", f"cyl@{int((AC[0] + 10) // 100)}/{int(AC[1] // 100)}")
    assert len(st.stationary) == 2 and not st.tracks
    assert [st.sources[int(b.index[0])] for b in st.bodies] == ["s", "cyl"]
    # unclassified (the default): perception keeps them, the avoiders' stationary set is empty
    st = Perception().update(Rangefinders().scan(1.0, AC, threats))
    assert len(st) == 2 and not len(st.stationary) and (st.moving_code == -1).all()


def _first_hit(shape: PrismThreat | CylinderThreat, own: np.ndarray, d: np.ndarray) -> float:
    """The first hit of one ray from ``own`` along ``d`` (shapes with bottom and top)."""
    z0, z1 = np.array([shape.bottom - own[2]]), np.array([shape.top - own[2]])
    if isinstance(shape, PrismThreat):
        edges = ring_edges(shape.ring) - np.tile(own[:2], 2)
        return float(ray_prisms(d[None], edges, np.array([0, len(edges)]), z0, z1)[0, 0])
    c = np.array([shape.center]) - own[:2]
    return float(ray_cylinders(d[None], c, np.array([shape.radius]), z0, z1)[0, 0])


@given(
    st.floats(-15.0, 15.0),
    st.floats(-15.0, 15.0),
    st.floats(-3.0, 3.0),
    st.floats(-math.pi, math.pi),
    st.floats(-0.6, 0.6),
)
def test_a_hit_lies_on_the_surface_and_the_beam_before_it_outside(
    x: float, y: float, z: float, course: float, dip: float
) -> None:
    """Property: for an L prism and a cylinder, a hit is on the solid's surface (separation 0)
    and the beam up to it stays outside; a miss stays outside all the way."""
    shapes = (
        ell(-10.0, -10.0, bottom=-2.0, top=2.0),
        CylinderThreat(id="c", center=(6.0, -12.0), radius=3.0, top=1.0, bottom=-1.0),
    )
    own = np.array([x, y, z])
    if min(float(s.separation(own)) for s in shapes) <= 1e-9:
        return
    d = np.array(
        [math.cos(dip) * math.sin(course), math.cos(dip) * math.cos(course), math.sin(dip)]
    )
    for shape in shapes:
        s = _first_hit(shape, own, d)
        before = own + np.linspace(0.0, min(s, 60.0), 400)[:-1, None] * d
        assert (shape.separation(before) > -1e-9).all()
        if math.isfinite(s):
            assert abs(float(shape.separation(own + s * d))) < 1e-9


# -- in a replay ------------------------------------------------------------------------------------
def test_a_quadrotor_mission_with_rangefinders_records_the_beams(tmp_path: Path) -> None:
    """The quadrotor box mission (north along x = 0 first) past a tower 5 m east of its first
    leg: the right beam sees it at 5 m; every 0.1 s scan is in the MCAP as a line list."""
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
    from mcap.reader import make_reader

    from replay.record import topics as T
    from replay.record.reader import load_run
    from replay.run import ReplayRequest, run_replay

    tower = CylinderThreat(id="tower", center=(5.5, 75.0), radius=0.5, top=100.0, bottom=0.0)
    out = tmp_path / "rf.mcap"
    request = ReplayRequest.of(
        source=str(ROOT / "data" / "scenarios" / "quadrotor-mission.yaml"),
        threats=ThreatSet((tower,)),
        sensor="rangefinder",
    )
    res = run_replay(request, out)
    assert res.metrics.end_reason == "goal" and res.metrics.success
    run = load_run(out, with_states=False)
    assert json.loads(run.metadata["rangefinder"]) == {
        "range_m": 20.0,
        "period_s": 0.1,
        "beams": 4,
        "mount": "gimballed",
        "noise_m": 0.0,
        "spread_deg": 0.0,  # no avoider: lines
    }
    seen = [d for scan in run.detections for d in scan.detections]
    assert seen and {d["id"] for d in seen} == {"tower#beam1"}  # the right beam only
    assert min(d["range"] for d in seen) == pytest.approx(5.0, abs=0.1)  # abeam, the leg at x = 0
    with open(out, "rb") as f:
        beams = [
            SceneUpdate.FromString(m.data)
            for _, _, m in make_reader(f).iter_messages([T.RANGEFINDER_BEAMS])
        ]
    flight = res.metrics.flight_time_s
    assert abs(len(beams) - flight / 0.1) <= 2  # a scan every 0.1 s
    origin = json.loads(run.metadata["map_origin"])
    hits = [(u.entities[0].lines, u.entities[0].timestamp) for u in beams]
    red = [ln for lines, _ in hits for ln in lines if ln.color.r > 0.9]
    assert len(red) == len(run.detections)  # a scan with a hit: one red segment, one detection
    for ln in red:  # the segment runs from the aircraft to the tower's wall
        assert len(ln.points) == 2
        end = ln.points[1]
        assert math.hypot(end.x + origin[0] - 5.5, end.y + origin[1] - 75.0) == pytest.approx(
            0.5, abs=1e-6
        )
    green = [ln for lines, _ in hits for ln in lines if ln.color.g > 0.8]
    assert all(len(ln.points) in (6, 8) for ln in green)  # 3 or 4 beams at their full 20 m


def test_terrapath_replay_takes_the_rangefinder_options(tmp_path: Path) -> None:
    from replay.record.reader import load_run
    from terrapath.cli import main

    out = tmp_path / "rf.mcap"
    args = ["replay", str(ROOT / "data" / "scenarios" / "quadrotor-mission.yaml"), "--no-picture"]
    args += ["--sensor", "rangefinder", "--rangefinder-beams", "8", "--rangefinder-mount", "body"]
    args += ["--rangefinder-range", "300", "--duration", "20", "-o", str(out)]
    assert main(args) == 3  # cut short by --duration: recorded, not a success
    run = load_run(out, with_states=False)
    assert run.metadata["sensor"] == "rangefinder"
    assert json.loads(run.metadata["rangefinder"])["beams"] == 8
    assert run.topic_counts["/rangefinder/beams"] == pytest.approx(200, abs=2)
    # body-fixed, 300 m: the front beam of the quadrotor cruising 7.1 deg nose down at 30 m
    # meets the ground 30 / sin 7.1 deg = 242 m away (44 deg down when it sets off: 43 m)
    ranges = [d["range"] for s in run.detections for d in s.detections if d["kind"] == "terrain"]
    assert min(ranges) > 30.0 and min(ranges) == pytest.approx(
        30.0 / math.sin(math.radians(44.0)), abs=1.0
    )
    cruise = [r for r in ranges if 230.0 < r < 255.0]
    assert len(cruise) > 50
    assert main([*args[:-2], "--rangefinder-mount", "nose", "-o", str(out)]) == 2


def test_the_compiled_prisms_give_the_numpy_distances_bit_for_bit() -> None:
    """ray_prisms (a compiled loop) against ray_prisms_numpy (the (B, E) arrays it replaced):
    random footprints (convex and not), beams in every direction -- vertical, horizontal, along
    an edge, through a vertex -- slabs above, below, around the origin and unbounded below."""
    from replay.sensors.raycast import ray_prisms_numpy

    rng = np.random.default_rng(12)
    for trial in range(60):
        k = int(rng.integers(1, 6))
        rings, offsets = [], [0]
        for _ in range(k):
            n = int(rng.integers(3, 9))
            ang = np.sort(rng.uniform(0, 2 * np.pi, n))
            rad = rng.uniform(5, 60, n) * (1.0 if trial % 2 else rng.uniform(0.3, 1.0, n))
            c = rng.uniform(-150, 150, 2)
            pts = c + np.column_stack([rad * np.cos(ang), rad * np.sin(ang)])
            rings.append(np.hstack([pts, np.roll(pts, -1, axis=0)]))
            offsets.append(offsets[-1] + n)
        edges = np.vstack(rings)
        b = 50
        dirs = rng.normal(size=(b, 3))
        dirs[:5, :2] = 0.0  # vertical
        dirs[5:10, 2] = 0.0  # horizontal
        e0 = edges[0]
        dirs[10, :] = [e0[2] - e0[0], e0[3] - e0[1], 0.0]  # along an edge
        dirs[11, :] = [e0[0], e0[1], 0.0]  # through a vertex
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        bottoms = rng.uniform(-100, 50, k)
        bottoms[rng.random(k) < 0.3] = -np.inf
        tops = bottoms + rng.uniform(0, 200, k)
        tops[np.isinf(tops)] = rng.uniform(-50, 100)
        off = np.array(offsets)
        got = ray_prisms(dirs, edges, off, bottoms, tops)
        want = ray_prisms_numpy(dirs, edges, off, bottoms, tops)
        assert got.tobytes() == want.tobytes(), trial
