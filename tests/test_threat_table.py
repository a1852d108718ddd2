"""`replay.threats.table.ThreatTable` and the radar scan built on it: every threat at once, bit for
bit what the threats say one by one.

The references below are the threat-by-threat code the table replaced (the radar's candidate
loop and its classification, the simulation's separation loop), run on random scenes with every
kind, subclasses, activity windows, terrain occlusion and radar noise."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest
from affine import Affine

from replay.sensors.radar import Radar, RadarPicture
from replay.threats.body import BodyThreat
from replay.threats.kinds import (
    EDGE_SUFFIXES,
    CylinderThreat,
    HillThreat,
    IntruderThreat,
    StaticThreat,
    Threat,
)
from replay.threats.table import ThreatTable, norm3
from terrain.grid import HeightGrid
from terrain.model import TerrainModel

FloatArray = npt.NDArray[np.float64]

X0, Y0 = 400_000.0, 3_800_000.0  # north-west corner of the ridge map
CELL, ROWS, COLS = 50.0, 120, 240  # 6 km north-south, 12 km east-west
YC, XR = Y0 - ROWS * CELL / 2, X0 + 6000.0  # middle row, ridge crest line (north-south)
T_END = 200.0  # the scenes' activity windows lie in [0, T_END]


@dataclass(frozen=True, kw_only=True)
class TwinStatic(StaticThreat):
    """A subclass the table must ask through its own methods: two returns, the second 50 m up."""

    def radar_points(
        self, t: float, observer: npt.ArrayLike, max_range: float = math.inf
    ) -> tuple[list[str], FloatArray]:
        c = np.array(self.center)
        return [f"{self.id}/a", f"{self.id}/b"], np.array([c, c + np.array([0.0, 0.0, 50.0])])


def _window(rng: np.random.Generator) -> dict[str, Any]:
    out: dict[str, Any] = {}
    if rng.random() < 0.5:
        out["appears_at"] = float(rng.uniform(0.0, T_END / 2))
    if rng.random() < 0.4:
        out["disappears_at"] = out.get("appears_at", 0.0) + float(rng.uniform(1.0, T_END / 2))
    return out


def random_scene(rng: np.random.Generator, n: int = 40) -> tuple[Threat, ...]:
    """``n`` threats of every kind (and the subclass) over the ridge map and 8 km around it,
    shuffled, half of them with activity windows."""

    def xy() -> tuple[float, float]:
        return float(rng.uniform(X0 - 8000, X0 + 20000)), float(rng.uniform(YC - 8000, YC + 8000))

    def xyz() -> tuple[float, float, float]:
        return (*xy(), float(rng.uniform(50.0, 1000.0)))

    out: list[Threat] = []
    for i in range(n):
        ident, win = f"k{i}", _window(rng)
        kind = i % 8
        if kind in (0, 1):
            out.append(StaticThreat(id=ident, center=xyz(), radius=rng.uniform(50, 800), **win))
        elif kind == 2:
            m = int(rng.integers(1, 7))
            radii = tuple(rng.uniform(50, 500, 1 if rng.random() < 0.5 else m))
            pts = tuple(xyz() for _ in range(m))
            out.append(HillThreat(id=ident, points=pts, radii=radii, **win))
        elif kind == 3:
            top = float(rng.uniform(300, 1200))
            bottom = -math.inf if rng.random() < 0.5 else top - float(rng.uniform(100, 500))
            radius = float(rng.uniform(100, 1500))
            out.append(
                CylinderThreat(id=ident, center=xy(), radius=radius, top=top, bottom=bottom, **win)
            )
        elif kind == 4:
            axes = tuple(rng.uniform(100, 800, 3))
            exps = tuple(rng.choice([0.5, 1.0, 1.5, 2.0, 3.0], 3))
            out.append(BodyThreat(id=ident, center=xyz(), axes=axes, exponents=exps, **win))
        elif kind == 5:
            stop = None if rng.random() < 0.5 else win.get("appears_at", 0.0) + rng.uniform(0, 100)
            vel = tuple(rng.normal(0.0, 20.0, 3))
            out.append(
                IntruderThreat(
                    id=ident, radius=rng.uniform(50, 500), start=xyz(), velocity_mps=vel,
                    stops_at=stop, **win,
                )
            )  # fmt: skip
        elif kind == 6:
            wps = tuple(xyz() for _ in range(int(rng.integers(2, 5))))
            out.append(
                IntruderThreat(
                    id=ident, radius=rng.uniform(50, 500), waypoints=wps,
                    speed=rng.uniform(10, 60), loop=bool(rng.random() < 0.5), **win,
                )
            )  # fmt: skip
        else:
            out.append(TwinStatic(id=ident, center=xyz(), radius=rng.uniform(50, 800), **win))
    order = rng.permutation(len(out))
    return tuple(out[i] for i in order)


# -- the references: the threat-by-threat code the table replaced ---------------------------------
def reference_radar_points(
    threats: tuple[Threat, ...], t: float, own: FloatArray, max_range: float
) -> tuple[list[str], list[str], FloatArray, npt.NDArray[np.bool_]]:
    ids: list[str] = []
    sources: list[str] = []
    chunks: list[FloatArray] = [np.zeros((0, 3))]
    ext: list[bool] = []
    for threat in threats:
        if not threat.active(t):
            continue
        tids, tp = threat.radar_points(t, own, max_range)
        inside = np.linalg.norm(tp - own, axis=-1) <= max_range
        for k in np.flatnonzero(inside).tolist():
            ids.append(tids[k])
            sources.append(threat.id)
            ext.append(threat.extended)
        chunks.append(tp[inside])
    return ids, sources, np.vstack(chunks), np.array(ext, dtype=bool)


def reference_separations(
    threats: tuple[Threat, ...], pos: FloatArray, ts: FloatArray
) -> dict[str, FloatArray]:
    out = {}
    for th in threats:
        active = np.array([th.active(float(t)) for t in ts], dtype=bool)
        v = np.where(active, th.separation(pos, ts), np.inf)
        if np.isfinite(v).any():
            out[th.id] = v
    return out


class ReferenceRadar(Radar):
    """The radar with the candidate loop and the classification it had before the table."""

    def _threat_points(self, t: float, own: FloatArray, threats: Any) -> Any:
        return reference_radar_points(tuple(threats), t, own, self.range_m)

    def _measure(
        self,
        t: float,
        own: FloatArray,
        ids: tuple[str, ...],
        sources: tuple[str, ...],
        cells: npt.NDArray[np.int64],
        true_pts: FloatArray,
        ext: npt.NDArray[np.bool_],
    ) -> RadarPicture:
        pic = super()._measure(t, own, ids, sources, cells, true_pts, ext)
        moving = np.full(len(true_pts), -1, dtype=np.int8)
        moving[len(ids) :] = 0
        prev = self.previous
        if prev is not None and len(ids):
            pairs = [(i, prev.threat_index.get(ident, -1)) for i, ident in enumerate(ids)]
            a = np.array([i for i, j in pairs if j >= 0], dtype=np.int64)
            b = np.array([j for i, j in pairs if j >= 0], dtype=np.int64)
            if len(a):
                step = float(np.linalg.norm(own - prev.own_position))
                moved = np.linalg.norm(pic.positions[a] - prev.positions[b], axis=-1)
                r = np.maximum(pic.ranges[a], prev.ranges[b])
                sigma = np.sqrt(self.noise_range_m**2 + (r * self.noise_bearing_rad) ** 2)
                limit = self.moving_sigmas * math.sqrt(2.0) * sigma + self.moving_floor_m
                limit = limit + np.where(ext[a], step, 0.0)
                moving[a] = (moved > limit).astype(np.int8)
        for i, ident in enumerate(ids):  # a solid's outline edges take its nearest point's verdict
            if ident.endswith(EDGE_SUFFIXES):
                near = ids.index(sources[i]) if sources[i] in ids else -1
                moving[i] = moving[near] if near >= 0 else -1
        pic.moving_code[:] = moving
        return pic


def assert_same_points(got: Any, want: Any) -> None:
    assert got[0] == want[0] and got[1] == want[1]
    np.testing.assert_array_equal(got[2].reshape(-1, 3), want[2].reshape(-1, 3))
    np.testing.assert_array_equal(got[3], want[3])


def assert_same_picture(a: RadarPicture, b: RadarPicture) -> None:
    assert a.t == b.t and a.ids == b.ids and a.sources == b.sources
    for name in ("own_position", "positions", "ranges", "bearings", "elevations", "moving_code"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    np.testing.assert_array_equal(a.extended, b.extended)
    np.testing.assert_array_equal(a.terrain_cells, b.terrain_cells)


# -- tests --------------------------------------------------------------------------------------
def test_norm3_is_numpys_norm_bit_for_bit() -> None:
    rng = np.random.default_rng(0)
    d = rng.normal(size=(200_000, 3)) * 10.0 ** rng.uniform(-8, 8, (200_000, 3))
    d[:1000, 1] = 0.0
    d[1000:2000] = -d[1000:2000]
    want = np.linalg.norm(d, axis=-1)
    got = norm3(d[:, 0].copy(), d[:, 1].copy(), d[:, 2].copy())
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("seed", range(12))
def test_radar_points_equal_the_threat_by_threat_scan(seed: int) -> None:
    rng = np.random.default_rng(seed)
    threats = random_scene(rng)
    table = ThreatTable(threats)
    seen = 0
    for _ in range(60):
        t = float(rng.choice([rng.uniform(0.0, T_END), rng.integers(0, T_END)]))
        own = np.array([rng.uniform(X0 - 4000, X0 + 16000), rng.uniform(YC - 4000, YC + 4000), 0.0])
        own[2] = rng.uniform(0.0, 1500.0)
        got = table.radar_points(t, own, 10_000.0)
        assert_same_points(got, reference_radar_points(threats, t, own, 10_000.0))
        seen += len(got[0])
    assert seen > 100  # the scenes are seen, not only missed


@pytest.mark.parametrize("seed", range(3))
def test_radar_points_of_static_threats_only(seed: int) -> None:
    """The usual scene (seed 000's obstacles): static threats only, with and without windows."""
    rng = np.random.default_rng(300 + seed)
    threats = tuple(th for th in random_scene(rng, 400) if type(th) is StaticThreat)
    table = ThreatTable(threats)
    seen = 0
    for t in rng.uniform(0.0, T_END, 60).tolist():
        own = np.array([rng.uniform(X0, X0 + 12000), rng.uniform(YC - 3000, YC + 3000), 300.0])
        got = table.radar_points(t, own, 10_000.0)
        assert_same_points(got, reference_radar_points(threats, t, own, 10_000.0))
        seen += len(got[0])
    assert len(threats) == 100 and seen > 1000


def test_radar_points_at_the_window_edges_and_the_range_edge() -> None:
    """Active from appears_at (included) to disappears_at (excluded), every kind; 10 km exactly
    is in range."""
    win = {"appears_at": 10.0, "disappears_at": 20.0}
    threats = (
        StaticThreat(id="a", center=(6000.0, 8000.0, 0.0), radius=1.0, appears_at=10.0),
        HillThreat(id="h", points=((0.0, 10_000.0, 0.0), (0.0, 10_001.0, 0.0)), radii=(1.0,)),
        StaticThreat(id="s", center=(0.0, 1.0, 0.0), radius=1.0, **win),
        HillThreat(id="hw", points=((0.0, 2.0, 0.0),), radii=(1.0,), **win),
        CylinderThreat(id="c", center=(0.0, 3000.0), radius=100.0, top=50.0, **win),
        BodyThreat(
            id="b", center=(3000.0, 0.0, 0.0), axes=(10, 20, 30), exponents=(1, 1, 1), **win
        ),
        IntruderThreat(
            id="i", radius=1.0, start=(-3000.0, 0.0, 0.0), velocity_mps=(1, 0, 0), **win
        ),
        IntruderThreat(
            id="w", radius=1.0, waypoints=((0, -3000, 0), (0, -4000, 0)), speed=5, **win
        ),
        TwinStatic(id="tw", center=(-100.0, -100.0, 0.0), radius=1.0, **win),
    )
    table = ThreatTable(threats)
    own = np.zeros(3)
    for t in (9.999, 10.0, 19.999, 20.0):
        got = table.radar_points(t, own, 10_000.0)
        assert_same_points(got, reference_radar_points(threats, t, own, 10_000.0))
    windowed = ["s", "hw/0", "c", "c#left", "c#right", "b", "b#left", "b#right", "i", "w", "tw/a"]
    windowed.append("tw/b")
    assert table.radar_points(9.999, own, 10_000.0)[0] == ["h/0"]
    assert table.radar_points(10.0, own, 10_000.0)[0] == ["a", "h/0", *windowed]
    assert table.radar_points(19.999, own, 10_000.0)[0] == ["a", "h/0", *windowed]
    assert table.radar_points(20.0, own, 10_000.0)[0] == ["a", "h/0"]
    edges = np.array([9.999, 10.0, 19.999, 20.0])
    assert table.active_at(edges).tolist() == [[th.active(t) for th in threats] for t in edges]
    plain = ThreatTable(threats[:2])  # no windows: active from t = 0 on
    for t in (-1.0, 0.0):
        got = plain.radar_points(t, own, 10_000.0)
        assert_same_points(got, reference_radar_points(threats[:2], t, own, 10_000.0))
    assert plain.radar_points(-1.0, own, 10_000.0)[0] == []
    assert plain.radar_points(0.0, own, 10_000.0)[0] == ["h/0"]


@pytest.mark.parametrize("seed", range(12))
def test_separations_equal_the_threat_by_threat_loop(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    threats = random_scene(rng)
    table = ThreatTable(threats)
    t = 0.0
    for k in (1, 2, 37, 600, 1500):  # batches of one sample to several blocks
        ts = t + np.cumsum(rng.uniform(0.0, 0.3, k))
        t = float(ts[-1])
        start = np.array([rng.uniform(X0, X0 + 12000), rng.uniform(YC - 3000, YC + 3000), 400.0])
        pos = start + np.cumsum(rng.normal(0.0, 30.0, (k, 3)), axis=0)
        ids, seps = table.separations(pos, ts)
        want = reference_separations(threats, pos, ts)
        assert ids == list(want)
        np.testing.assert_array_equal(seps, np.column_stack(list(want.values())))
    assert t > T_END / 2  # the batches crossed activity windows


def test_separations_of_nothing_active() -> None:
    late = StaticThreat(id="late", center=(0.0, 0.0, 0.0), radius=1.0, appears_at=100.0)
    ts = np.array([0.0, 1.0])
    ids, seps = ThreatTable((late,)).separations(np.zeros((2, 3)), ts)
    assert ids == [] and seps.shape == (2, 0)
    ids, seps = ThreatTable(()).separations(np.zeros((2, 3)), ts)
    assert ids == [] and seps.shape == (2, 0)


def test_activity_and_motion_flags() -> None:
    threats = random_scene(np.random.default_rng(5))
    table = ThreatTable(threats)
    edges = [th.appears_at for th in threats] + [th.disappears_at or 0.0 for th in threats]
    for t in [*np.linspace(0.0, T_END, 41).tolist(), *edges]:
        assert table.active(t).tolist() == [th.active(t) for th in threats]
    assert table.moving.tolist() == [bool(getattr(th, "moving", False)) for th in threats]
    assert table.ids == tuple(th.id for th in threats)


@pytest.fixture(scope="module")
def ridge() -> TerrainModel:
    """A 600 m ridge (slope 1/2) on a 100 m floor, crest line x = XR."""
    probe = HeightGrid(np.zeros((ROWS, COLS), np.float32), Affine(CELL, 0, X0, 0, -CELL, Y0))
    r, c = np.meshgrid(np.arange(ROWS), np.arange(COLS), indexing="ij")
    x, _ = probe.index_to_xy(r, c)
    heights = 100.0 + np.maximum(0.0, 500.0 - 0.5 * np.abs(x - XR))
    return TerrainModel.from_grid(HeightGrid(np.asarray(heights, np.float32), probe.transform))


@pytest.mark.parametrize("noise", [True, False])
@pytest.mark.parametrize("seed", range(3))
def test_scans_equal_the_reference_radar_with_occlusion_and_noise(
    ridge: TerrainModel, seed: int, noise: bool
) -> None:
    """Forty scans across the ridge, every kind of threat, noise from one seed (or none): the
    pictures (ids, positions, ranges, bearings, classification, terrain returns) are identical."""
    rng = np.random.default_rng(200 + seed)
    threats = random_scene(rng, 60)
    settings: dict[str, Any] = {
        "noise_range_m": 5.0 * noise,
        "noise_bearing_rad": 1e-3 * noise,
        "seed": seed,
        "terrain_azimuths": 90,
    }
    fast, ref = Radar(**settings), ReferenceRadar(**settings)
    hidden, kinds = 0, set()
    for k in range(40):
        t = 5.0 * k
        own = np.array([X0 + 300.0 * k, YC + 40.0 * k, 250.0 + 15.0 * k])
        a = fast.scan(t, own, threats, ridge)
        b = ref.scan(t, own, threats, ridge)
        assert_same_picture(a, b)
        hidden += len(reference_radar_points(threats, t, own, 10_000.0)[0]) - a.n_threat
        kinds |= {type(th).__name__ for th in threats if th.id in a.threat_sources}
    assert hidden > 0  # the ridge hid returns
    assert kinds == {c.__name__ for c in (StaticThreat, HillThreat, CylinderThreat, BodyThreat)} | {
        "IntruderThreat",
        "TwinStatic",
    }
