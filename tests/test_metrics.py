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
