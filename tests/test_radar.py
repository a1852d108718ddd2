"""Tests of `replay.sensors.radar.Radar`: range, terrain occlusion, terrain returns, noise, classification."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from affine import Affine

from replay.sensors.radar import Radar, RadarPicture
from replay.threats.body import BodyThreat
from replay.threats.kinds import CylinderThreat, HillThreat, IntruderThreat, StaticThreat, Threat
from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrain.model import TerrainModel

X0, Y0 = 400_000.0, 3_800_000.0  # north-west corner of the synthetic maps
CELL = 50.0
ROWS, COLS = 60, 200  # 3 km north-south, 10 km east-west
YC = Y0 - ROWS * CELL / 2
XR = X0 + 5000.0  # ridge crest line (north-south)


def grid_of(f: object) -> HeightGrid:
    probe = HeightGrid(np.zeros((ROWS, COLS), np.float32), Affine(CELL, 0, X0, 0, -CELL, Y0))
    r, c = np.meshgrid(np.arange(ROWS), np.arange(COLS), indexing="ij")
    x, y = probe.index_to_xy(r, c)
    heights = f(x, y)  # type: ignore[operator]
    return HeightGrid(np.asarray(heights, np.float32), probe.transform)


# a 600 m ridge (slope 1/2) on a 100 m floor
RIDGE = grid_of(lambda x, y: 100.0 + np.maximum(0.0, 500.0 - 0.5 * np.abs(x - XR)))
FLAT = grid_of(lambda x, y: np.full_like(x, 100.0))


@pytest.fixture(scope="module")
def ridge() -> TerrainModel:
    return TerrainModel.from_grid(RIDGE)


@pytest.fixture(scope="module")
def flat() -> TerrainModel:
    return TerrainModel.from_grid(FLAT)


def static(ident: str, x: float, y: float, z: float, **kw: Any) -> StaticThreat:
    return StaticThreat(id=ident, center=(x, y, z), **{"radius": 100.0, **kw})


# -- range, occlusion, activity -------------------------------------------------------------------
def test_range_limit_is_10_km() -> None:
    own = np.array([0.0, 0.0, 200.0])
    near = static("near", 9900.0 * math.sin(0.3), 9900.0 * math.cos(0.3), 200.0)
    far = static("far", 0.0, -10100.0, 200.0)
    edge = static("edge", 6000.0, 8000.0, 200.0)  # exactly 10 km: in range
    pic = Radar().scan(0.0, own, [near, far, edge])
    assert pic.ids == ("near", "edge")
    d = pic.get("near")
    assert d.kind == "threat" and d.source == "near" and d.moving is None
    assert d.range == pytest.approx(9900.0, rel=1e-14)
    assert d.bearing == pytest.approx(0.3, rel=1e-13)  # clockwise from north
    assert d.elevation == 0.0
    np.testing.assert_array_equal(d.position, near.center)


def test_bearing_and_elevation_conventions() -> None:
    own = np.array([1000.0, 1000.0, 500.0])
    east = static("east", 2000.0, 1000.0, 500.0)
    south_up = static("south_up", 1000.0, 0.0, 1500.0)
    pic = Radar().scan(0.0, own, [east, south_up])
    assert pic.get("east").bearing == pytest.approx(math.pi / 2)
    assert pic.get("south_up").bearing == pytest.approx(math.pi)
    assert pic.get("south_up").elevation == pytest.approx(math.pi / 4)


def test_threat_behind_a_ridge_is_hidden_until_the_aircraft_climbs(ridge: TerrainModel) -> None:
    target = static("sam", XR + 4000.0, YC, 300.0)
    radar = Radar()
    low = radar.scan(0.0, [XR - 4000.0, YC, 300.0], [target], ridge)
    assert "sam" not in low.threat_ids
    # the segment's midpoint is over the 600 m crest: at 650 m when the aircraft is at 1000 m
    high = radar.scan(1.0, [XR - 4000.0, YC, 1000.0], [target], ridge)
    assert high.threat_ids == ("sam",)
    # without a terrain model nothing is occluded
    assert Radar().scan(0.0, [XR - 4000.0, YC, 300.0], [target]).threat_ids == ("sam",)


def test_occlusion_uses_one_batched_line_of_sight_call(
    ridge: TerrainModel, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = []
    original = ridge.line_of_sight

    def spy(a: np.ndarray, b: np.ndarray, tolerance: float = 0.01) -> np.ndarray:
        calls.append(np.shape(b))
        return original(a, b, tolerance)

    monkeypatch.setattr(ridge, "line_of_sight", spy)
    threats = [static(f"s{i}", XR + 100.0 * i, YC + 500.0, 900.0) for i in range(5)]
    hill = HillThreat(id="h", points=((XR - 3000, YC, 300.0), (XR - 2500, YC, 300.0)), radii=(1.0,))
    pic = Radar(terrain_azimuths=0).scan(0.0, [XR - 4000.0, YC, 800.0], [*threats, hill], ridge)
    assert calls == [(7, 3)]
    assert set(pic.threat_ids) == {"s0", "s1", "s2", "s3", "s4", "h/0", "h/1"}


def test_threats_are_seen_only_while_active() -> None:
    t = static("pop", 1000.0, 0.0, 200.0, appears_at=30.0, disappears_at=60.0)
    radar = Radar()
    seen = [
        len(radar.scan(s, [0.0, 0.0, 200.0], [t]).threat_ids) for s in (0.0, 29.9, 30.0, 59.0, 60.0)
    ]
    assert seen == [0, 0, 1, 1, 0]


def test_hill_points_cylinders_and_bodies(flat: TerrainModel) -> None:
    own = np.array([X0 + 1000.0, YC, 500.0])
    hill = HillThreat(
        id="hill", points=((X0 + 3000, YC, 300.0), (X0 + 3800, YC, 300.0)), radii=(500.0,)
    )
    cyl = CylinderThreat(id="sam", center=(X0 + 1000.0, YC + 3000.0), radius=1000.0, top=400.0)
    tower = BodyThreat(
        id="tower",
        center=(X0 + 4000.0, YC - 3000.0, 100.0),
        axes=(80, 80, 400),
        exponents=(1, 1, 4),
    )
    pic = Radar(terrain_azimuths=0).scan(0.0, own, [hill, cyl, tower], flat)
    solid = ("sam", "sam#left", "sam#right", "tower", "tower#left", "tower#right")
    assert pic.threat_ids == ("hill/0", "hill/1", *solid)
    assert [d.source for d in pic.threats()] == ["hill", "hill", *(["sam"] * 3), *(["tower"] * 3)]
    # solid shapes are seen at their point nearest to the aircraft, and at their outline's edges:
    # the tangent points of the section at the aircraft's altitude (clipped to the body)
    np.testing.assert_allclose(pic.get("sam").position, [X0 + 1000.0, YC + 2000.0, 400.0])
    half = math.asin(1000.0 / 3000.0)
    length = math.sqrt(3000.0**2 - 1000.0**2)
    for ident, sign in (("sam#left", -1), ("sam#right", 1)):
        want = [X0 + 1000.0 + length * math.sin(sign * half), YC + length * math.cos(sign * half)]
        np.testing.assert_allclose(pic.get(ident).position, [*want, 400.0], atol=1e-6)
    near_z = pic.get("tower").position[2]  # the tower narrows to its top at 500 m: lower
    for ident in ("tower#left", "tower#right"):  # on its surface, level with the nearest point
        p = pic.get(ident).position
        assert float(tower.gamma(p)) == pytest.approx(1.0, abs=1e-6) and p[2] == near_z
    np.testing.assert_allclose(pic.get("tower").position, tower.nearest_point(own))
    assert pic.get("tower").range == pytest.approx(float(tower.separation(own)), rel=1e-9)
    # inside the cylinder the nearest point is the aircraft itself
    inside = Radar().scan(0.0, [X0 + 1000.0, YC + 3000.0, 300.0], [cyl])
    assert inside.get("sam").range == 0.0


# -- terrain returns ------------------------------------------------------------------------------
def test_terrain_returns_show_a_ridge_higher_than_the_aircraft(ridge: TerrainModel) -> None:
    own = np.array([XR - 4000.0, YC, 300.0])
    radar = Radar()  # clearance 100 m: terrain above 200 m counts
    pic = radar.scan(0.0, own, [], ridge)
    terrain = pic.terrain()
    assert len(terrain) > 20 and len(pic.threat_ids) == 0
    pts = np.array([d.position for d in terrain])
    assert np.all(pts[:, 2] >= 200.0 - 1e-3)
    assert np.all(np.abs(pts[:, 0] - XR) <= 800.0 + 1.0)  # where the ridge rises above 200 m
    assert np.all(pts[:, 0] <= XR + 1.0)  # the far side is hidden behind the crest
    assert np.all(pic.ranges[pic.is_terrain] <= 10000.0)
    assert np.all(ridge.line_of_sight(own, pts, tolerance=1.0))
    # the nearest return straight ahead is where the ridge crosses own altitude - clearance
    ahead = min(terrain, key=lambda d: abs(d.bearing - math.pi / 2) + d.range * 1e-9)
    assert ahead.position[0] == pytest.approx(XR - 800.0, abs=1.0)
    assert all(d.moving is False and d.source == "terrain" for d in terrain)
    assert all(d.id.startswith("terrain/") for d in terrain)
    # one return per 100 m cell, the id is the cell
    cells = {
        (math.floor(d.position[0] / 100.0), math.floor(d.position[1] / 100.0)) for d in terrain
    }
    assert len(cells) == len(terrain)
    assert {f"terrain/{i}/{j}" for i, j in cells} == {d.id for d in terrain}
    # a few returns' ids, asked before and after the scan has named them all (the recording's
    # way: its threat returns and nearest terrain returns), are those of the list
    rows = np.array([len(pic) - 1, 3, 0, len(pic) // 2])
    fresh = radar.scan(0.0, own, [], ridge)
    assert "ids" not in fresh.__dict__
    assert fresh.ids_of(rows) == [pic.ids[i] for i in rows.tolist()]
    assert fresh.ids_of(rows) == [fresh.ids[i] for i in rows.tolist()]
    # a second scan 15 m further on sees mostly the same cells
    again = radar.scan(1.0, own + np.array([15.0, 0.0, 0.0]), [], ridge)
    same = set(again.ids) & set(pic.ids)
    assert len(same) >= 0.8 * len(pic)


def test_no_terrain_returns_for_low_terrain(flat: TerrainModel, ridge: TerrainModel) -> None:
    assert len(Radar().scan(0.0, [X0 + 1000.0, YC, 300.0], [], flat)) == 0
    # above the crest by more than the clearance: nothing either
    assert len(Radar().scan(0.0, [XR - 4000.0, YC, 701.0], [], ridge)) == 0
    # ... but a larger clearance brings the crest back
    assert len(Radar().scan(0.0, [XR - 4000.0, YC, 701.0], [], ridge, min_clearance=300.0)) > 0


# -- noise and classification ---------------------------------------------------------------------
def fly(
    radar: Radar, threats: list[Threat], n: int, model: TerrainModel | None = None
) -> list[RadarPicture]:
    """n scans at 1 Hz from an aircraft flying east at 15 m/s."""
    return [radar.scan(float(k), [X0 + 15.0 * k, YC, 500.0], threats, model) for k in range(n)]


def stationary_set() -> list[Threat]:
    return [
        static("obs", X0 + 5000.0, YC + 300.0, 500.0),
        HillThreat(
            id="hill",
            points=((X0 + 3000, YC - 2000, 400.0), (X0 + 3500, YC - 2500, 400.0)),
            radii=(300.0,),
        ),
        CylinderThreat(id="sam", center=(X0 + 800.0, YC + 1500.0), radius=1000.0, top=900.0),
        BodyThreat(
            id="tower",
            center=(X0 + 1200.0, YC - 600.0, 100.0),
            axes=(80, 80, 600),
            exponents=(1, 1, 4),
        ),
    ]


def test_classification_without_noise() -> None:
    intruder = IntruderThreat(
        id="uav", radius=50.0, start=(X0 + 6000, YC, 500.0), velocity_mps=(-15.0, 0.0, 0.0)
    )
    pics = fly(Radar(), [*stationary_set(), intruder], 3)
    assert all(d.moving is None for d in pics[0].threats())  # first sighting: unknown
    for pic in pics[1:]:
        moving = {d.id: d.moving for d in pic.threats()}
        assert moving == {
            "obs": False,
            "hill/0": False,
            "hill/1": False,
            "sam": False,
            "sam#left": False,
            "sam#right": False,
            "tower": False,
            "tower#left": False,
            "tower#right": False,
            "uav": True,
        }


def test_no_false_moving_with_noise_over_100_scans() -> None:
    """The aircraft flies past the cylinder and the tower, whose nearest points slide along."""
    radar = Radar(noise_range_m=10.0, noise_bearing_rad=2e-3, seed=20240607)
    pics = fly(radar, stationary_set(), 100)
    codes = np.concatenate([p.moving_code[: len(p.threat_ids)] for p in pics[1:]])
    assert len(codes) == 99 * 9  # 5 returns and the outline edges of the cylinder and the tower
    assert np.all(codes == 0)
    # the noise is really there
    obs = np.array([p.get("obs").position for p in pics])
    assert 3.0 < np.std(obs[:, 0]) < 30.0


def test_fast_intruder_is_moving_despite_noise() -> None:
    # threshold at 5 km: 5 sqrt(2) sqrt(5^2 + (5000 * 1e-3)^2) + 1 = 51 m per scan; it flies 120 m
    intruder = IntruderThreat(
        id="uav",
        radius=50.0,
        waypoints=((X0 + 7000, YC + 3000, 600.0), (X0 + 7000, YC - 3000, 600.0)),
        speed=120.0,
        loop=True,
    )
    pics = fly(Radar(noise_range_m=5.0, noise_bearing_rad=1e-3, seed=5), [intruder], 40)
    assert pics[0].get("uav").moving is None
    assert all(p.get("uav").moving is True for p in pics[1:])


def test_same_seed_same_picture(ridge: TerrainModel) -> None:
    threats = stationary_set()

    def run(seed: int) -> list[RadarPicture]:
        return fly(Radar(noise_range_m=5.0, noise_bearing_rad=1e-3, seed=seed), threats, 5, ridge)

    a, b, c = run(1), run(1), run(2)
    for pa, pb in zip(a, b, strict=True):
        assert pa.ids == pb.ids
        np.testing.assert_array_equal(pa.positions, pb.positions)
        np.testing.assert_array_equal(pa.moving_code, pb.moving_code)
    assert not np.array_equal(a[0].positions, c[0].positions)
    # a generator may be passed in instead of a seed
    g = fly(
        Radar(noise_range_m=5.0, noise_bearing_rad=1e-3, seed=np.random.default_rng(1)),
        threats,
        1,
        ridge,
    )
    np.testing.assert_array_equal(g[0].positions, a[0].positions)


def test_noise_free_positions_are_exact(ridge: TerrainModel) -> None:
    pic = Radar().scan(0.0, [XR - 4000.0, YC, 300.0], [static("s", XR - 2000, YC, 700.0)], ridge)
    np.testing.assert_array_equal(pic.get("s").position, [XR - 2000, YC, 700.0])


# -- timing and validation ------------------------------------------------------------------------
def test_scans_fall_due_every_period() -> None:
    radar = Radar(period_s=1.0)
    assert radar.due(0.0)
    due = []
    t = 0.0
    for _ in range(300):  # 3 s of 100 Hz steps, summed the way a simulation loop sums them
        if radar.due(t):
            radar.scan(t, [0.0, 0.0, 100.0], [])
            due.append(round(t, 6))
        t += 0.01
    assert due == [0.0, 1.0, 2.0]
    radar.reset()
    assert radar.due(2.5) and radar.previous is None


@pytest.mark.parametrize(
    "kwargs",
    [
        {"range_m": 0.0},
        {"period_s": -1.0},
        {"noise_range_m": -1.0},
        {"noise_bearing_rad": math.nan},
        {"seed": 1.5},
        {"terrain_azimuths": -1},
        {"terrain_elevations_deg": (95.0,)},
        {"terrain_cell_m": 0.0},
    ],
)
def test_bad_settings_are_refused(kwargs: dict[str, object]) -> None:
    with pytest.raises(InputError, match="radar"):
        Radar(**kwargs)  # type: ignore[arg-type]


def test_bad_own_position_is_refused() -> None:
    with pytest.raises(InputError, match="own position"):
        Radar().scan(0.0, [0.0, math.nan, 0.0], [])


@pytest.mark.slow
def test_scan_cost_on_a_real_map(shared_maps: Path) -> None:
    """Report the cost of a scan with terrain returns at 10 km on Big Tujunga (30 m, 1.5 M
    triangles); the budget is 5 ms, the assertion is loose because CI machines are shared."""
    from terrain.load import load_dem

    grid = load_dem(shared_maps / "topotoolbox_bigtujunga" / "bigtujunga.tif")
    model = TerrainModel.from_grid(grid)
    xmin, ymin, xmax, ymax = grid.bounds
    x, y = (xmin + xmax) / 2, (ymin + ymax) / 2
    ground = float(grid.height_at(x, y))
    threats: list[Threat] = [static("s", x + 3000.0, y, ground + 300.0)]
    results = {}
    for agl in (100.0, 300.0):
        radar = Radar(noise_range_m=5.0, noise_bearing_rad=1e-3, seed=0)
        radar.scan(0.0, [x, y, ground + agl], threats, model)  # builds the ray-casting scene
        times = []
        for k in range(1, 41):
            start = time.perf_counter()
            pic = radar.scan(float(k), [x + 15.0 * k, y, ground + agl], threats, model)
            times.append(time.perf_counter() - start)
        results[agl] = (float(np.median(times)) * 1e3, int(pic.is_terrain.sum()))
    print(f"radar scan on bigtujunga (ms, terrain returns): {results}")
    assert all(ms < 50.0 for ms, _ in results.values())
    assert all(n > 0 for _, n in results.values())


def test_static_threats_in_one_array_keep_order_windows_and_range() -> None:
    """Static point threats are tested as one array; the returns must be exactly those of the
    threat-by-threat rule, in the order the threats are given, interleaved with other kinds."""
    from replay.threats.file import threats_from_records

    threats = threats_from_records(
        [
            {"id": "a", "kind": "static", "position": [5000, 0, 200], "radius": 100},
            {
                "id": "i",
                "kind": "intruder",
                "position": [0, 3000, 200],
                "velocity": [10, 0, 0],
                "radius": 50,
            },
            {"id": "far", "kind": "static", "position": [20000, 0, 200], "radius": 100},
            {
                "id": "late",
                "kind": "static",
                "position": [0, -4000, 200],
                "radius": 100,
                "appears_at": 50,
            },
            {
                "id": "gone",
                "kind": "static",
                "position": [-3000, 0, 200],
                "radius": 100,
                "disappears_at": 20,
            },
            {"id": "b", "kind": "static", "position": [0, 9999, 200], "radius": 100},
        ]
    ).threats
    radar = Radar()
    own = np.array([0.0, 0.0, 200.0])
    assert radar.scan(10.0, own, threats).threat_ids == ("a", "i", "gone", "b")
    assert radar.scan(60.0, own, threats).threat_ids == ("a", "i", "late", "b")
    pic = radar.scan(61.0, own, threats)
    np.testing.assert_allclose(pic.positions[0], [5000.0, 0.0, 200.0])
    np.testing.assert_allclose(pic.positions[2], [0.0, -4000.0, 200.0])


def test_a_solid_sphere_is_measured_whole_a_point_threat_is_not() -> None:
    """Issue 34: a ``solid`` static sphere or intruder gives its centre and radius (the radius
    with the cross-range error only); seed 000's point threats give no radius."""
    solid = StaticThreat(id="s", center=(3000.0, 0.0, 100.0), radius=250.0, solid=True)
    point = StaticThreat(id="p", center=(0.0, 3000.0, 100.0), radius=250.0)
    plane = IntruderThreat(
        id="i", radius=80.0, start=(0.0, -2000.0, 100.0), velocity_mps=(20.0, 0.0, 0.0), solid=True
    )
    own = np.array([0.0, 0.0, 100.0])
    exact = Radar()
    pic = exact.scan(0.0, own, (solid, point, plane))
    assert pic.radii is not None
    assert pic.radii[pic.index["s"]] == 250.0 and pic.radii[pic.index["i"]] == 80.0
    assert math.isnan(pic.radii[pic.index["p"]])
    np.testing.assert_allclose(pic.get("s").position, solid.center)  # the centre, not the surface
    pic = exact.scan(1.0, own, (solid, point, plane))
    assert pic.get("i").moving is True and pic.get("s").moving is False
    assert Radar().scan(0.0, own, (point,)).radii is None  # nothing measured: no array
    sigma = 0.002
    noisy = Radar(noise_bearing_rad=sigma, seed=3)
    errs = []
    for k in range(400):
        radii = noisy.scan(float(k), own, (solid,)).radii
        assert radii is not None
        errs.append(float(radii[0]) - 250.0)
    assert abs(float(np.mean(errs))) < 4.0 * 3000.0 * sigma / math.sqrt(400)
    assert float(np.std(errs)) == pytest.approx(3000.0 * sigma, rel=0.15)


def test_a_solid_sphere_behind_a_ridge_is_seen_by_its_top(ridge: TerrainModel) -> None:
    """The centre is hidden by the 600 m crest, the top of a 700 m sphere is not: seen (whole);
    the same sphere as seed 000's point stays hidden."""
    own = [XR - 4000.0, YC, 300.0]
    for solid in (True, False):
        sphere = static("cloud", XR + 4000.0, YC, 300.0, radius=700.0, solid=solid)
        pic = Radar().scan(0.0, own, [sphere], ridge)
        assert pic.threat_ids == (("cloud",) if solid else ())
        if solid:
            assert pic.radii is not None and pic.radii[0] == 700.0


def test_terrain_ids_name_their_cells_however_often_they_are_seen(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from replay.sensors import radar

    monkeypatch.setattr(radar, "_TERRAIN_IDS_KEPT", 50)  # the memo emptied every few scans
    rng = np.random.default_rng(4)
    for _ in range(20):
        cells = rng.integers(-40, 40, (int(rng.integers(0, 30)), 2)).astype(np.int64)
        want = tuple(f"terrain/{i}/{j}" for i, j in cells.tolist())
        assert radar._terrain_ids(cells) == want
        assert radar._terrain_ids(cells) == want  # again, from the memo
    assert len(radar._TERRAIN_IDS) <= 50 + 30
