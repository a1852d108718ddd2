"""Constant-velocity least-squares fits and closest points of approach (replay.avoidance.tracking)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from replay.avoidance.tracking import Track, closest_approaches, fit_lines
from terrain.errors import InputError


def histories(
    p0: np.ndarray, v: np.ndarray, times: np.ndarray, noise: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Right-aligned histories (K, N) of constant-velocity objects p(t) = p0 + v t."""
    k = len(p0)
    t = np.broadcast_to(times, (k, len(times))).copy()
    p = p0[:, None, :] + v[:, None, :] * t[..., None]
    if noise is not None:
        p = p + noise
    return t, p, np.full(k, len(times), dtype=np.int64)


# -- the fit -------------------------------------------------------------------------------------
@settings(max_examples=100)
@given(
    st.lists(st.floats(-50.0, 50.0), min_size=3, max_size=3),
    st.lists(st.floats(-1e5, 1e5), min_size=3, max_size=3),
    st.integers(2, 8),
    st.floats(0.1, 5.0),
    st.floats(0.0, 3e4),
)
def test_a_constant_velocity_is_recovered_without_noise(
    v: list[float], p0: list[float], n: int, dt: float, t0: float
) -> None:
    times = t0 + dt * np.arange(n)
    t, p, c = histories(np.array([p0]), np.array([v]), times)
    fit = fit_lines(t, p, c)
    scale = 1e-9 * (1.0 + float(np.abs(p).max()))
    np.testing.assert_allclose(fit.velocity[0], v, atol=scale / dt)
    np.testing.assert_allclose(fit.position[0], p[0, -1], atol=scale)
    assert fit.residual[0] <= scale
    assert (fit.sigma[0] <= scale) if n > 2 else math.isnan(fit.sigma[0])


def test_two_fixes_are_their_difference_exactly() -> None:
    t = np.array([[3.0, 4.1]])
    p = np.array([[[100.3, -7.0, 200.0], [90.1, -2.5, 200.5]]])
    fit = fit_lines(t, p, np.array([2]))
    assert fit.velocity[0].tolist() == ((p[0, 1] - p[0, 0]) / (4.1 - 3.0)).tolist()
    assert fit.position[0].tolist() == p[0, 1].tolist()
    assert fit.residual[0] == 0.0 and math.isnan(fit.sigma[0])


def test_short_histories_use_their_own_fixes_only() -> None:
    """Histories are right-aligned; the NaN padding of a short one is never read."""
    t = np.array([[np.nan, np.nan, 0.0, 1.0, 2.0], [np.nan, np.nan, np.nan, np.nan, 7.0]])
    p = np.full((2, 5, 3), np.nan)
    p[0, 2:] = [[0.0, 0.0, 0.0], [1.0, 2.0, 0.0], [2.0, 4.0, 0.0]]
    p[1, 4] = [5.0, 5.0, 5.0]
    fit = fit_lines(t, p, np.array([3, 1]))
    np.testing.assert_allclose(fit.velocity[0], [1.0, 2.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(fit.position[0], [2.0, 4.0, 0.0], atol=1e-12)
    assert np.isnan(fit.velocity[1]).all() and np.isnan(fit.position[1]).all()


def test_bad_histories_are_refused() -> None:
    with pytest.raises(InputError, match=r"times \(K, N\), positions \(K, N, 3\)"):
        fit_lines(np.zeros((2, 3)), np.zeros((2, 3)), np.array([3, 3]))
    with pytest.raises(InputError, match=r"counts must lie in \[0, 3\]"):
        fit_lines(np.zeros((1, 3)), np.zeros((1, 3, 3)), np.array([4]))


def test_noisy_fits_follow_least_squares_statistics() -> None:
    """Gaussian position noise sigma on each axis, n fixes 1 s apart: each velocity error is
    N(0, sigma^2 / S_tt) and sigma^2 is estimated without bias.  4000 tracks, fixed seed."""
    rng = np.random.default_rng(2024)
    k, n, sigma = 4000, 5, 12.0
    times = np.arange(n, dtype=np.float64) * 1.0 + 100.0
    v = rng.uniform(-30, 30, (k, 3))
    p0 = rng.uniform(-1e4, 1e4, (k, 3))
    t, p, c = histories(p0, v, times, rng.normal(0.0, sigma, (k, n, 3)))
    fit = fit_lines(t, p, c)
    stt = float(((times - times.mean()) ** 2).sum())  # 10 s^2
    z = (fit.velocity - v) / (sigma / math.sqrt(stt))  # standard normal, 12000 values
    assert abs(z.mean()) < 4.0 / math.sqrt(z.size)
    assert z.std() == pytest.approx(1.0, abs=0.04)  # 4 standard errors of a sample std
    assert (np.abs(z) < 5.0).all()
    # sigma^2 unbiased (chi-square, 3 (n - 2) = 9 degrees of freedom per track)
    ratio = fit.sigma**2 / sigma**2
    assert ratio.mean() == pytest.approx(1.0, abs=4 * math.sqrt(2 / 9 / k))
    # the residual is the RMS distance: E[residual^2] = 3 (n - 2) sigma^2 / n
    assert (fit.residual**2).mean() == pytest.approx(3 * (n - 2) * sigma**2 / n, rel=0.03)


# -- tracks -----------------------------------------------------------------------------------------
def make_track(position: list[float], velocity: list[float], t: float = 10.0) -> Track:
    p = np.array(position, dtype=np.float64)
    v = np.array(velocity, dtype=np.float64)
    times = t - np.array([2.0, 1.0, 0.0])
    return Track(
        id="x",
        source="x",
        t=t,
        position=p,
        velocity=v,
        residual=0.0,
        sigma=0.0,
        n=3,
        since=t - 2.0,
        fitted=True,
        times=times,
        positions=p - v * (t - times)[:, None],
        ranges=np.zeros(3),
    )


def test_prediction_is_constant_velocity() -> None:
    tr = make_track([100.0, 200.0, 300.0], [10.0, -5.0, 1.0])
    np.testing.assert_allclose(tr.predict(15.0), [150.0, 175.0, 305.0])
    np.testing.assert_allclose(tr.predict(np.array([10.0, 8.0])), [[100, 200, 300], [80, 210, 298]])
    assert tr.speed == pytest.approx(math.sqrt(126.0))
    assert tr.velocity_sigma == 0.0


# -- closest point of approach --------------------------------------------------------------------
def test_head_on_closes_to_zero_at_the_meeting_time() -> None:
    """Own aircraft east at 15 m/s from the origin, intruder 3 km east flying west at 15 m/s."""
    a = closest_approaches([0, 0, 200], [15, 0, 0], [[3000, 0, 200]], [[-15, 0, 0]], t=7.0)
    assert a.time_to.tolist() == [100.0] and a.distance.tolist() == [0.0]
    np.testing.assert_allclose(a.own_at, [[1500, 0, 200]])
    np.testing.assert_allclose(a.other_at, [[1500, 0, 200]])
    assert a.t == 7.0


def test_crossing_at_right_angles_and_an_offset_pass() -> None:
    # intruder 4 km north of the crossing, flying south at 20 m/s; own 3 km west flying east at 15:
    # both reach the crossing at 200 s
    a = closest_approaches([-3000, 0, 0], [15, 0, 0], [[0, 4000, 0]], [[0, -20, 0]])
    assert a.time_to[0] == pytest.approx(200.0) and a.distance[0] == pytest.approx(0.0, abs=1e-9)
    # a parallel pass 500 m abeam: r = (x, 500), w = (-30, 0): closest when x = 0
    b = closest_approaches([0, 0, 0], [15, 0, 0], [[6000, 500, 0]], [[-15, 0, 0]])
    assert b.time_to[0] == pytest.approx(200.0) and b.distance[0] == pytest.approx(500.0)
    # general case against the formula tau = -r.w / |w|^2 (3D, vectorised over several)
    r = np.array([[1000.0, -2000.0, 300.0], [-500.0, 800.0, 0.0]])
    w = np.array([[-10.0, 25.0, -1.0], [3.0, -4.0, 0.5]])
    c = closest_approaches(np.zeros(3), np.zeros(3), r, w)
    tau = -(r * w).sum(1) / (w * w).sum(1)
    np.testing.assert_allclose(c.time_to, tau)
    np.testing.assert_allclose(c.distance, np.linalg.norm(r + w * tau[:, None], axis=1))


def test_not_closing_means_now() -> None:
    """Diverging, or no relative motion: the closest approach is the present distance."""
    a = closest_approaches(
        [0, 0, 0], [15, 0, 0], [[-1000, 0, 0], [0, 800, 0]], [[-5, 0, 0], [15, 0, 0]]
    )
    assert a.time_to.tolist() == [0.0, 0.0] and a.distance.tolist() == [1000.0, 800.0]


def test_horizon_and_horizontal() -> None:
    a = closest_approaches([0, 0, 0], [15, 0, 0], [[3000, 0, 0]], [[-15, 0, 0]], horizon=60.0)
    assert a.time_to[0] == 60.0 and a.distance[0] == pytest.approx(3000 - 60 * 30)
    # 300 m below, head-on: 3D distance 300 m, horizontal 0 m
    b = closest_approaches([0, 0, 500], [15, 0, 0], [[3000, 0, 200]], [[-15, 0, 0]])
    h = closest_approaches(
        [0, 0, 500], [15, 0, 0], [[3000, 0, 200]], [[-15, 0, 0]], horizontal=True
    )
    assert b.distance[0] == pytest.approx(300.0) and h.distance[0] == pytest.approx(0.0)
    assert b.time_to[0] == h.time_to[0] == pytest.approx(100.0)


def test_track_closest_approach_predicts_to_the_time_asked() -> None:
    """The intruder's last fix is at t = 10 s; asked at t = 20 s it is 100 m further west."""
    tr = make_track([3100.0, 0.0, 200.0], [-10.0, 0.0, 0.0], t=10.0)
    cpa = tr.closest_approach([0.0, 0.0, 200.0], [20.0, 0.0, 0.0], 20.0)
    assert cpa.time_to == pytest.approx(100.0) and cpa.t == pytest.approx(120.0)
    assert cpa.distance == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(cpa.other_at, [2000.0, 0.0, 200.0])


def test_bad_approach_input_is_refused() -> None:
    with pytest.raises(InputError, match="own_position must be 3 finite"):
        closest_approaches([0, 0], [0, 0, 0], [[0, 0, 0]], [[0, 0, 0]])
    with pytest.raises(InputError, match="must match"):
        closest_approaches([0, 0, 0], [0, 0, 0], [[0, 0, 0]], np.zeros((2, 3)))
    with pytest.raises(InputError, match="horizon"):
        closest_approaches([0, 0, 0], [0, 0, 0], [[0, 0, 0]], [[0, 0, 0]], horizon=-1.0)
