"""Run metrics: violation intervals across chunks, minimum separation, PLR."""

from __future__ import annotations

import math

import numpy as np
import pytest

from replay.metrics import MetricsTracker


def _feed(tracker: MetricsTracker, t: np.ndarray, sep: np.ndarray, chunk: int) -> None:
    pos = np.stack([t * 10.0, np.zeros_like(t), np.full_like(t, 100.0)], axis=1)
    for i in range(0, len(t), chunk):
        sl = slice(i, i + chunk)
        tracker.update(t[sl], pos[sl], {"a": sep[sl]}, np.full(len(t[sl]), 50.0))


@pytest.mark.parametrize("chunk", [1, 3, 7, 1000])
def test_violation_intervals_do_not_depend_on_chunking(chunk: int) -> None:
    t = np.arange(0.0, 100.0, 0.5)
    sep = np.cos(t / 5.0) * 100.0 + 20.0  # dips below zero periodically
    tr = MetricsTracker(["a"], np.zeros(3), np.array([1000.0, 0.0, 100.0]))
    _feed(tr, t, sep, chunk)
    m = tr.finish(float(t[-1]), reached_goal=True, terrain_contact=False, end_reason="goal")
    inside = sep < 0
    enters = np.flatnonzero(inside & ~np.concatenate([[False], inside[:-1]]))
    assert [v.t_enter for v in m.violations] == pytest.approx(t[enters].tolist())
    for v in m.violations:
        mask = (t >= v.t_enter) & (t < (v.t_exit if v.t_exit is not None else math.inf))
        assert v.min_separation == pytest.approx(sep[mask].min())
        assert (sep[mask] < 0).all()
    assert m.min_separation["a"]["value"] == pytest.approx(sep.min())
    assert not m.success and m.reached_goal


def test_clean_run_metrics() -> None:
    t = np.arange(0.0, 10.0, 0.1)
    tr = MetricsTracker(["a"], np.zeros(3), np.array([99.0, 0.0, 100.0]))
    _feed(tr, t, np.full_like(t, 500.0), 10)
    tr.decision(0.002, waypoints_added=1)
    m = tr.finish(10.0, reached_goal=True, terrain_contact=False, end_reason="goal")
    assert m.success and not m.violations
    assert m.flown_length_m == pytest.approx(99.0)
    assert m.plr == pytest.approx(99.0 / np.hypot(99.0, 100.0))
    assert m.waypoints_added == 1 and m.decisions == 1
    assert m.min_terrain_clearance_m == 50.0
    d = m.as_dict()
    assert d["min_separation"]["a"]["value"] == 500.0


def test_still_inside_at_the_end_is_an_open_violation() -> None:
    t = np.arange(0.0, 5.0, 1.0)
    tr = MetricsTracker(["a"], np.zeros(3), np.ones(3))
    _feed(tr, t, np.array([5.0, 1.0, -1.0, -3.0, -2.0]), 2)
    m = tr.finish(5.0, True, False, "goal")
    assert len(m.violations) == 1 and m.violations[0].t_exit is None
    assert m.violations[0].t_enter == 2.0 and m.violations[0].min_separation == -3.0


class ReferenceTracker(MetricsTracker):
    """The threat-by-threat update the array form replaced."""

    def update(
        self,
        times: np.ndarray,
        positions: np.ndarray,
        separations: dict[str, np.ndarray],
        clearance: np.ndarray,
    ) -> None:
        pts = positions if self.last is None else np.vstack([self.last[None, :], positions])
        self.length += float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
        self.last = positions[-1].copy()
        k = int(np.argmin(clearance))
        if clearance[k] < self.min_clear[0]:
            self.min_clear = (float(clearance[k]), float(times[k]))
        for tid, sep in separations.items():
            j = int(np.argmin(sep))
            if sep[j] < self.min_sep.get(tid, (math.inf, math.nan))[0]:
                self.min_sep[tid] = (float(sep[j]), float(times[j]))
            self._track_violation(tid, times, sep)


@pytest.mark.parametrize("seed", range(6))
def test_array_update_equals_the_threat_by_threat_update(seed: int) -> None:
    """Many threats entering and leaving, inactive stretches (inf), ties, a threat not known at
    the start, chunks of every size: the same metrics, violations in the same order."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 300.0, 0.1)
    ids = [f"th{i}" for i in range(12)]
    sep = np.round(
        np.sin(t[:, None] / rng.uniform(2.0, 20.0, 12) + rng.uniform(0, 6, 12)) * 100.0
        + rng.uniform(-50.0, 150.0, 12),
        0,
    )  # rounded: equal minima at several samples
    sep[rng.random(sep.shape) < 0.05] = np.inf
    sep[:500, 3] = np.inf  # appears late
    pos = np.stack([t * 15.0, np.sin(t), np.full_like(t, 200.0)], axis=1)
    clearance = 100.0 + np.cos(t) * 50.0
    a = MetricsTracker(ids[:-1], pos[0], pos[-1])  # the last id is not announced
    b = ReferenceTracker(ids[:-1], pos[0], pos[-1])
    i = 0
    while i < len(t):
        j = min(len(t), i + int(rng.integers(1, 700)))
        keep = [c for c in range(12) if np.isfinite(sep[i:j, c]).any()]
        cols = {ids[c]: sep[i:j, c] for c in keep}
        a.update_columns(
            t[i:j], pos[i:j], [ids[c] for c in keep], sep[i:j][:, keep], clearance[i:j]
        )
        b.update(t[i:j], pos[i:j], cols, clearance[i:j])
        i = j
    ma = a.finish(float(t[-1]), True, False, "goal")
    mb = b.finish(float(t[-1]), True, False, "goal")
    assert ma.violations and ma == mb
    assert list(ma.min_separation) == list(mb.min_separation)
