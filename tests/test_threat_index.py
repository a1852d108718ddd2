"""Threat bookkeeping that scales with the threats near the aircraft (issue 38): the radar's index
of fixed points and its held answers (``replay.threats.index``, ``ThreatTable.radar_points``) and
the separation book (``replay.threats.book``) give exactly what asking every threat gives.

The references are the brute-force code: every threat's radar points tested at every scan
(``tests.test_threat_table.reference_radar_points``, ``ReferenceRadar``), and every threat's
separation measured at every sample (``ThreatTable.separations``, what the simulation fed the
judge before) -- on seeded random scenes with hundreds of threats of every kind (static, hills,
cylinders, bodies, intruders at a constant velocity and on routes, a subclass), half of them
pop-ups or with an end, flown through continuously so that the held answers and the index are
used, refreshed, and crossed at the range edge."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
import pytest

from replay.metrics import MetricsTracker, RunMetrics
from replay.sensors.radar import Radar
from replay.threats.book import SeparationBook
from replay.threats.index import BRUTE_MAX, NearIndex
from replay.threats.kinds import HillThreat, StaticThreat, Threat
from replay.threats.table import ThreatTable
from tests.test_threat_table import (
    T_END,
    X0,
    YC,
    ReferenceRadar,
    assert_same_picture,
    assert_same_points,
    random_scene,
    reference_radar_points,
)

FloatArray = npt.NDArray[np.float64]


def flight(rng: np.random.Generator, threats: tuple[Threat, ...], n: int, dt: float) -> FloatArray:
    """``n`` positions ``dt`` s apart along straight legs through the centres of a few of the
    fixed threats (so that the flight enters some of them), at about 150 m/s."""
    fixed = [th for th in threats if type(th) in (StaticThreat, HillThreat)]
    picks = rng.choice(len(fixed), size=min(6, len(fixed)), replace=False)
    wps = [np.array([X0 - 6000.0, YC - 5000.0, 400.0])]
    for i in picks.tolist():
        th = fixed[i]
        c = th.center if isinstance(th, StaticThreat) else th.points[0]
        wps.append(np.asarray(c, dtype=np.float64))
    w = np.array(wps)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(w, axis=0), axis=1))])
    along = np.minimum(np.arange(n) * 150.0 * dt, s[-1])
    return np.column_stack([np.interp(along, s, w[:, j]) for j in range(3)])


def nearest(ids: list[str], seps: FloatArray, k: int = 4) -> list[list[tuple[str, float]]]:
    """The ``k`` nearest active threats at every sample, as the recorder picks them (a stable
    sort of the finite separations)."""
    out = []
    for row in seps:
        live = np.flatnonzero(np.isfinite(row))
        order = live[np.argsort(row[live], kind="stable")[:k]]
        out.append([(ids[j], float(row[j])) for j in order.tolist()])
    return out


def same_minima(a: MetricsTracker, b: MetricsTracker) -> None:
    assert list(a.min_sep) == list(b.min_sep)
    for tid, (v, t) in a.min_sep.items():
        w, u = b.min_sep[tid]
        assert v == w, tid
        assert t == u or (math.isnan(t) and math.isnan(u)), tid


def finish(tracker: MetricsTracker) -> RunMetrics:
    return tracker.finish(T_END, True, False, "goal")


# -- the index ---------------------------------------------------------------------------------
def test_near_index_keeps_every_point_in_reach() -> None:
    rng = np.random.default_rng(0)
    pts = rng.uniform(-50_000, 50_000, (5000, 3))
    index = NearIndex(pts)
    own = np.zeros(3)
    refreshed = 0
    for _ in range(400):
        own = own + rng.normal(0.0, 150.0, 3)
        rows, fresh = index.near(own, 10_000.0)
        refreshed += fresh
        inside = np.flatnonzero(np.linalg.norm(pts - own, axis=-1) <= 10_000.0)
        assert np.isin(inside, rows).all()
        assert np.all(np.diff(rows) > 0)  # increasing: threat order
        assert index.margin(own) > 0.0
    assert 5 < refreshed < 200  # refreshed as it flies, not at every call
    assert len(NearIndex(pts[:BRUTE_MAX]).near(own, 1.0)[0]) == BRUTE_MAX


# -- the radar -----------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", range(2))
def test_radar_points_along_a_flight_equal_the_threat_by_threat_scan(seed: int) -> None:
    """Every kind, 380 threats (more than the index's brute-force size), flown through at small
    steps (held answers, index refreshes, points crossing the range edge, windows opening and
    closing), then random jumps and a step back in time."""
    rng = np.random.default_rng(500 + seed)
    extra = tuple(
        StaticThreat(
            id=f"x{i}", center=(*rng.uniform(X0 - 8000, X0 + 20000, 2), 300.0), radius=99.0
        )
        for i in range(300)
    )  # fixed points enough for the index (the scene's bodies make the reference slow)
    threats = tuple(rng.permutation(np.array(random_scene(rng, 80) + extra, dtype=object)))
    table = ThreatTable(threats)
    path = flight(rng, threats, 400, 0.5)
    seen = changes = 0
    last: list[str] | None = None
    for k, own in enumerate(path):
        t = 0.5 * k
        got = table.radar_points(t, own, 10_000.0)
        assert_same_points(got, reference_radar_points(threats, t, own, 10_000.0))
        seen += len(got[0])
        changes += last is not None and got[0] != last
        last = got[0]
    for t in [*rng.uniform(0.0, T_END, 20).tolist(), 3.0]:
        own = path[int(rng.integers(len(path)))] + rng.normal(0.0, 2000.0, 3)
        got = table.radar_points(t, own, 10_000.0)
        assert_same_points(got, reference_radar_points(threats, t, own, 10_000.0))
    assert seen > 1000 and changes > 20


@pytest.mark.parametrize("windows", [False, True])
@pytest.mark.parametrize("seed", range(2))
def test_static_scene_scans_along_a_flight_equal_the_reference_radar(
    seed: int, windows: bool
) -> None:
    """Seed 000's usual scene: static threats only (always there, or pop-ups), scanned at 1 Hz
    along a flight: the pictures (returns, ranges, bearings, classification) are identical to
    the reference radar's, with and without noise."""
    rng = np.random.default_rng(600 + seed)
    scene = [th for th in random_scene(rng, 800) if type(th) is StaticThreat]
    threats = tuple(
        th if windows else StaticThreat(id=th.id, center=th.center, radius=th.radius)
        for th in scene
    )
    assert len(threats) > BRUTE_MAX
    path = flight(rng, threats, 300, 0.5)
    for noise in (0.0, 5.0):
        fast = Radar(noise_range_m=noise, seed=seed)
        ref = ReferenceRadar(noise_range_m=noise, seed=seed)
        for k, own in enumerate(path):
            assert_same_picture(fast.scan(0.5 * k, own, threats), ref.scan(0.5 * k, own, threats))


# -- the separations -------------------------------------------------------------------------
@pytest.mark.parametrize("margin", [0.0, 150.0])
@pytest.mark.parametrize("seed", range(3))
def test_separation_book_judges_as_every_threat_at_every_sample(seed: int, margin: float) -> None:
    """The judge fed the book (its batches, then its smallest separations) and the judge fed
    every threat at every sample agree exactly: each threat's smallest separation and its
    time, every violation; and the four nearest threats at every sample (what is recorded) are
    the same."""
    rng = np.random.default_rng(700 + seed)
    threats = random_scene(rng, 200)
    table = ThreatTable(threats)
    ids = [th.id for th in threats]
    ts = np.arange(0.0, T_END + 20.0, 0.2)
    pos = flight(rng, threats, len(ts), 0.2)
    start, goal = pos[0], pos[-1]
    brute = MetricsTracker(ids, start, goal, margin)
    booked = MetricsTracker(ids, start, goal, margin)
    book = SeparationBook(table, margin)
    clearance = np.full(len(ts), 100.0)
    a = 0
    batches = 0
    while a < len(ts):
        b = min(len(ts), a + int(rng.integers(1, 120)))
        t, p = ts[a:b], pos[a:b]
        want_ids, want = table.separations(p, t)
        brute.update_columns(t, p, want_ids, want, clearance[a:b])
        got_ids, got = book.batch(t, p, booked.inside, nearest=4)
        booked.update_columns(t, p, got_ids, got, clearance[a:b])
        assert nearest(got_ids, got) == nearest(want_ids, want)
        for j, tid in enumerate(got_ids):  # a measured column is the column
            np.testing.assert_array_equal(got[:, j], want[:, want_ids.index(tid)])
        a, batches = b, batches + 1
    for tid, (v, t) in book.lowest().items():
        booked.lowest(tid, v, t)
    same_minima(brute, booked)
    x, y = finish(brute), finish(booked)
    assert x.violations == y.violations
    assert len(x.violations) > 0  # the flight entered threats
    assert book.measured < 0.5 * batches * len(threats)  # and left most of them alone


def test_separation_book_without_nearest_measures_only_what_can_matter() -> None:
    """Without the recording's nearest threats, a batch measures only the threats that can
    reach the margin: far static obstacles are put off, and their smallest separations still
    come out exactly."""
    rng = np.random.default_rng(9)
    threats = tuple(
        StaticThreat(id=f"s{i}", center=(*rng.uniform(-60_000, 60_000, 2), 300.0), radius=1000.0)
        for i in range(1000)
    )
    table = ThreatTable(threats)
    ts = np.arange(0.0, 2000.0, 0.1)
    pos = np.column_stack([-50_000.0 + 50.0 * ts, 20.0 * ts - 20_000.0, np.full(len(ts), 300.0)])
    book = SeparationBook(table)
    brute = MetricsTracker([th.id for th in threats], pos[0], pos[-1])
    booked = MetricsTracker([th.id for th in threats], pos[0], pos[-1])
    one = np.ones(600)
    for a in range(0, len(ts), 600):
        t, p = ts[a : a + 600], pos[a : a + 600]
        brute.update_columns(t, p, *table.separations(p, t), one[: len(t)])
        booked.update_columns(t, p, *book.batch(t, p, booked.inside), one[: len(t)])
    for tid, (v, t) in book.lowest().items():
        booked.lowest(tid, v, t)
    same_minima(brute, booked)
    assert finish(brute).violations == finish(booked).violations
    batches = -(-len(ts) // 600)
    assert book.measured < 0.25 * batches * len(threats)  # a few batches per threat, of 34
