"""Perception shared by the avoiders: memory, classification, order, clusters, tracks."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from replay.avoidance.circles import min_enclosing_circle
from replay.avoidance.perception import Perception, PerceptionConfig, PerceptionState, Scan
from replay.sensors.cooperative import CooperativeSensor
from replay.sensors.radar import Radar
from replay.threats.kinds import CylinderThreat, HillThreat, IntruderThreat, StaticThreat
from terrain.errors import InputError

OWN = np.array([0.0, 0.0, 300.0])


def scan(t: float, rows: list[tuple[Any, ...]], own: np.ndarray = OWN) -> Scan:
    """A hand-made scan: rows (id, (x, y, z), moving code[, "terrain" | "extended"])."""
    n = len(rows)
    pos = np.array([r[1] for r in rows], dtype=np.float64).reshape(n, 3)
    flag = [r[3] if len(r) > 3 else "" for r in rows]
    return Scan(
        t=t,
        own_position=own,
        sensor="test",
        ids=tuple(r[0] for r in rows),
        sources=tuple(
            "terrain" if f == "terrain" else r[0].split("/")[0]
            for r, f in zip(rows, flag, strict=True)
        ),
        positions=pos,
        measured_at=np.full(n, t),
        ranges=np.linalg.norm(pos - own, axis=1),
        terrain=np.array([f == "terrain" for f in flag], dtype=bool),
        extended=np.array([f == "extended" for f in flag], dtype=bool),
        moving_code=np.array([r[2] for r in rows], dtype=np.int8),
        velocities=np.full((n, 3), np.nan),
        radii=np.full(n, np.nan),
        tops=np.full(n, np.nan),
    )


def stationary_ids(state: PerceptionState) -> list[str]:
    return [state.ids[i] for i in state.stationary]


# -- memory ----------------------------------------------------------------------------------------
def test_memory_keeps_what_was_seen_and_forgets_after_memory_s() -> None:
    per = Perception(PerceptionConfig(memory_s=10.0))
    per.update(scan(0.0, [("a", (1000, 0, 300), 0), ("b", (2000, 0, 300), 0)]))
    for t in range(1, 11):  # b unseen for 10 s: still remembered (forgotten only beyond)
        st = per.update(scan(float(t), [("a", (1000, 0, 300), 0)]))
    assert st.ids == ("a", "b")
    b = st.get("b")
    assert (b.last_seen, b.first_seen, b.moving, b.kind) == (0.0, 0.0, False, "threat")
    assert st.seen_now.tolist() == [True, False]
    st = per.update(scan(10.5, [("a", (1000, 0, 300), 0)]))
    assert st.ids == ("a",)
    with pytest.raises(KeyError):
        st.get("b")
    # seen again after being forgotten: a new entry
    st = per.update(scan(11.0, [("a", (1000, 0, 300), 0), ("b", (2500, 0, 300), -1)]))
    assert st.get("b").first_seen == 11.0 and st.get("b").moving is None
    assert st.get("b").position.tolist() == [2500, 0, 300]


def test_keep_leaves_returns_out_entirely() -> None:
    per = Perception()
    rows = [("a", (1000, 0, 300), 0), ("terrain/1/2", (150, 250, 900), 0, "terrain")]
    st = per.update(scan(0.0, rows), keep=np.array([True, False]))
    assert st.ids == ("a",)
    st = per.update(scan(1.0, rows), keep=np.array([False, True]))
    assert st.ids == ("a", "terrain/1/2") and st.get("a").last_seen == 0.0
    assert st.get("terrain/1/2").kind == "terrain" and st.get("terrain/1/2").moving is False
    with pytest.raises(InputError, match=r"keep must be a bool mask of shape \(2,\)"):
        per.update(scan(2.0, rows), keep=[1, 0])


def test_unclassified_returns_keep_the_classification_they_had() -> None:
    per = Perception()
    per.update(scan(0.0, [("a", (1000, 0, 300), -1)]))
    st = per.update(scan(1.0, [("a", (1000, 0, 300), 0)]))
    assert st.get("a").moving is False and st.get("a").since == 1.0
    st = per.update(scan(2.0, []))  # occluded
    st = per.update(scan(3.0, [("a", (1001, 0, 300), -1)]))  # back: the radar cannot say
    a = st.get("a")
    assert a.moving is False and a.since == 1.0 and a.last_seen == 3.0
    assert a.position.tolist() == [1001, 0, 300]
    st = per.update(scan(4.0, [("a", (1100, 0, 300), 1)]))
    assert st.get("a").moving is True and st.get("a").since == 4.0


def test_obstacles_are_listed_in_the_order_they_took_their_classification() -> None:
    """New entries at the end; an entry moves to the end when it gets or changes its class --
    so the stationary ones come in the order they were first seen stationary."""
    per = Perception()
    per.update(scan(0.0, [("a", (1, 0, 0), -1)]))
    st = per.update(
        scan(1.0, [("a", (1, 0, 0), 0), ("b", (2, 0, 0), -1), ("t/0", (3, 0, 0), 0, "terrain")])
    )
    assert st.ids == ("a", "b", "t/0") and stationary_ids(st) == ["a", "t/0"]
    st = per.update(
        scan(2.0, [("a", (1, 0, 0), 0), ("b", (2, 0, 0), 0), ("t/0", (3, 0, 0), 0, "terrain")])
    )
    assert stationary_ids(st) == ["a", "t/0", "b"]
    st = per.update(
        scan(3.0, [("a", (9, 0, 0), 1), ("b", (2, 0, 0), 0), ("t/0", (3, 0, 0), 0, "terrain")])
    )
    assert stationary_ids(st) == ["t/0", "b"] and [st.ids[i] for i in st.moving] == ["a"]
    st = per.update(
        scan(4.0, [("a", (9, 0, 0), 0), ("b", (2, 0, 0), 0), ("t/0", (3, 0, 0), 0, "terrain")])
    )
    assert stationary_ids(st) == ["t/0", "b", "a"]


def test_solid_body_returns_build_up_per_cell() -> None:
    """The nearest point of a cylinder slides as the aircraft flies past: one entry per 100 m cell,
    the surface seen over time; no tracks for them, however they were classified."""
    cyl = CylinderThreat(id="cyl", center=(0.0, 3000.0), radius=500.0, top=1000.0)
    radar, per = Radar(), Perception()
    for k in range(40):
        t = float(k)
        own = np.array([-2000.0 + 100.0 * t, 0.0, 300.0])
        st = per.update(radar.scan(t, own, (cyl,)))
    assert all(i.startswith("cyl@") for i in st.ids) and len(st) >= 5  # cells -3 .. 2
    assert not st.tracks
    pts = st.positions
    np.testing.assert_allclose(np.hypot(pts[:, 0], pts[:, 1] - 3000.0), 500.0, atol=1e-6)
    cells = {i.split("@")[1] for i in st.ids}
    assert cells == {f"{math.floor(x / 100)}/{math.floor(y / 100)}" for x, y in pts[:, :2]}
    assert all(o.extended and o.source == "cyl" for o in st.obstacles)
    # the stationary cells form one cluster whose circle approximates the cylinder's arc seen
    (cl,) = st.clusters(1000.0)
    assert cl.radius <= 500.0 + 1e-6 and cl.top == pytest.approx(300.0)


# -- clusters --------------------------------------------------------------------------------------
def test_clusters_by_link_distance_single_linkage_strictly_below() -> None:
    chain = [(f"p{k}", (5000.0 + 900.0 * k, 0.0, 300.0 + 50 * k), 0) for k in range(4)]
    lone = [("q", (5000.0, 2000.0, 300.0), 0), ("m", (5000.0, 500.0, 300.0), 1)]
    per = Perception()
    st = per.update(scan(0.0, chain + lone))
    groups = [c.members for c in st.clusters(1000.0)]
    assert groups == [("p0", "p1", "p2", "p3"), ("q",)]  # the moving return is not clustered
    assert [c.members for c in st.clusters(900.0)] == [("p0",), ("p1",), ("p2",), ("p3",), ("q",)]
    assert [c.members for c in st.clusters(2000.1)] == [("p0", "p1", "p2", "p3", "q")]
    c = st.clusters(1000.0)[0]
    assert c.center.tolist() == pytest.approx([5000.0 + 1350.0, 0.0])
    assert c.radius == pytest.approx(1350.0) and c.top == 450.0 and c.outer_radius == c.radius
    assert st.clusters(1000.0) is st.clusters(1000.0)  # computed once
    np.testing.assert_array_equal(c.index, [st.index[m] for m in c.members])


def test_clusters_horizontal_or_3d() -> None:
    stack = [("lo", (0.0, 3000.0, 200.0), 0), ("hi", (0.0, 3000.0, 1500.0), 0)]
    st = Perception().update(scan(0.0, stack))
    assert [c.members for c in st.clusters(1000.0)] == [("lo", "hi")]
    assert [c.members for c in st.clusters(1000.0, horizontal=False)] == [("lo",), ("hi",)]


def test_cluster_circle_is_the_minimum_enclosing_circle_and_outer_radius_holds_sizes() -> None:
    rng = np.random.default_rng(4)
    pts = rng.normal(size=(30, 2)) * 200.0 + [3000.0, 1000.0]
    hill = HillThreat(id="h", points=tuple((x, y, 400.0) for x, y in pts), radii=(250.0,))
    st = Perception().update(CooperativeSensor().scan(0.0, OWN, (hill,)))
    (cl,) = st.clusters(1000.0)
    mec = min_enclosing_circle(pts)
    np.testing.assert_allclose(cl.center, mec.center, atol=1e-9)
    assert cl.radius == pytest.approx(mec.radius, rel=1e-12)
    assert cl.outer_radius == pytest.approx(mec.radius + 250.0, rel=1e-12)  # equal sizes: exact
    assert cl.top == 650.0  # the reported tops (point z + safety radius)


def test_bodies_group_by_threat_whatever_the_distances() -> None:
    """A hill whose points are 1.5 km apart is one body (two link clusters at 1 km); a static
    point next to it is its own body although it joins the hill's cluster; terrain has none."""
    hill = HillThreat(
        id="h",
        points=((3000.0, 0.0, 300.0), (4500.0, 0.0, 300.0), (3750.0, 900.0, 300.0)),
        radii=(200.0,),
    )
    post = StaticThreat(id="s", center=(3000.0, 600.0, 300.0), radius=100.0)
    radar, per = Radar(), Perception()
    per.update(radar.scan(0.0, OWN, (hill, post)))
    st = per.update(radar.scan(1.0, OWN, (hill, post)))
    st = per.update(scan(2.0, [("terrain/5/5", (550.0, 550.0, 900.0), 0, "terrain")]))
    by_link = [c.members for c in st.clusters(1000.0)]
    assert by_link == [("h/0", "h/2", "s"), ("h/1",), ("terrain/5/5",)]
    bodies = st.bodies
    assert [b.members for b in bodies] == [("h/0", "h/1", "h/2"), ("s",)]
    h = bodies[0]
    np.testing.assert_allclose(h.circle.center, min_enclosing_circle(np.array(hill.points)).center)
    assert h.radius == pytest.approx(min_enclosing_circle(np.array(hill.points)).radius)
    assert bodies[1].radius == 0.0 and bodies[1].center.tolist() == [3000.0, 600.0]
    assert st.bodies is bodies


# -- tracks ----------------------------------------------------------------------------------------
def test_radar_track_of_a_constant_velocity_intruder_is_exact() -> None:
    intruder = IntruderThreat(
        id="i", radius=100.0, start=(8000, 3000, 300), velocity_mps=(-20, -5, 0.5)
    )
    radar, per = Radar(), Perception(PerceptionConfig(track_scans=5))
    own_v = np.array([15.0, 0.0, 0.0])
    seen = []
    for k in range(12):
        t = float(k)
        st = per.update(radar.scan(t, OWN + own_v * t, (intruder,)))
        seen.append(len(st.tracks))
    assert seen[:2] == [0, 1] and all(s == 1 for s in seen[1:])  # moving from the second scan
    (tr,) = st.tracks
    assert (tr.id, tr.source, tr.n, tr.t, tr.since, tr.fitted) == ("i", "i", 5, 11.0, 1.0, True)
    np.testing.assert_allclose(tr.velocity, [-20, -5, 0.5], atol=1e-9)
    np.testing.assert_allclose(tr.position, intruder.position(11.0), atol=1e-9)
    assert tr.residual < 1e-9 and tr.sigma < 1e-9
    np.testing.assert_allclose(tr.predict(40.0), intruder.position(40.0), atol=1e-8)
    np.testing.assert_allclose(
        tr.ranges, np.linalg.norm(tr.positions - (OWN + own_v * tr.times[:, None]), axis=1)
    )
    # CPA against the own aircraft, checked by brute force over time
    own_now = OWN + own_v * 11.0
    cpa = tr.closest_approach(own_now, own_v, 11.0)
    ts = np.linspace(0, 600, 600001)
    d = np.linalg.norm(intruder.position(11.0 + ts) - (own_now + own_v * ts[:, None]), axis=1)
    assert cpa.time_to == pytest.approx(ts[d.argmin()], abs=2e-3)
    assert cpa.distance == pytest.approx(d.min(), abs=1e-6)
    a = st.approaches(own_now, own_v)
    assert a.time_to.tolist() == [cpa.time_to] and a.distance.tolist() == [cpa.distance]


def test_noisy_tracks_are_within_the_least_squares_bound() -> None:
    """300 intruders reported with Gaussian position noise sigma (cooperative sensor, fixed seed):
    the fitted velocities' errors are N(0, sigma^2 / S_tt) per axis (S_tt = 10 s^2 for 5 scans
    1 s apart)."""
    rng = np.random.default_rng(99)
    k, sigma = 300, 15.0
    v = rng.uniform(-25, 25, (k, 3)) * [1, 1, 0.1]
    p = rng.uniform(-4000, 4000, (k, 3)) + np.array([0.0, 0.0, 1000.0])
    crowd = tuple(
        IntruderThreat(id=f"i{j}", radius=50.0, start=tuple(p[j]), velocity_mps=tuple(v[j]))
        for j in range(k)
    )
    sensor = CooperativeSensor(range_m=1e6, noise_position_m=sigma, seed=5)
    per = Perception(PerceptionConfig(track_scans=5))
    for t in range(5):
        st = per.update(sensor.scan(float(t), OWN, crowd))
    assert len(st.tracks) == k and all(tr.n == 5 and tr.fitted for tr in st.tracks)
    vel = np.array([tr.velocity for tr in st.tracks])
    truth = np.array([v[int(tr.id[1:])] for tr in st.tracks])
    z = (vel - truth) / (sigma / math.sqrt(10.0))
    assert np.abs(z).max() < 5.0
    assert abs(z.mean()) < 4 / math.sqrt(z.size) and z.std() == pytest.approx(1.0, abs=0.1)
    sig = np.array([tr.sigma for tr in st.tracks])
    assert (sig**2).mean() == pytest.approx(sigma**2, rel=4 * math.sqrt(2 / 9 / k))
    vs = np.array([tr.velocity_sigma for tr in st.tracks])
    np.testing.assert_allclose(vs, sig / math.sqrt(10.0))


def test_latency_shifts_the_fixes_not_the_prediction() -> None:
    """Reports 3 s late (not extrapolated) are fitted at their measurement times: the track's
    last fix is 3 s old and its prediction to now is the true position."""
    intruder = IntruderThreat(id="i", radius=100.0, start=(5000, 0, 300), velocity_mps=(-12, 7, 0))
    sensor, per = CooperativeSensor(latency_s=3.0), Perception()
    for k in range(3, 10):
        st = per.update(sensor.scan(float(k), OWN, (intruder,)))
    (tr,) = st.tracks
    assert tr.t == 6.0 and tr.times.tolist() == [2.0, 3.0, 4.0, 5.0, 6.0]
    np.testing.assert_allclose(tr.predict(9.0), intruder.position(9.0), atol=1e-9)
    assert st.get("i").measured_at == 6.0 and st.get("i").last_seen == 9.0


def test_cooperative_reports_give_sizes_and_a_track_at_first_sight() -> None:
    intruder = IntruderThreat(id="i", radius=100.0, start=(5000, 0, 300), velocity_mps=(-12, 7, 0))
    post = StaticThreat(id="s", center=(3000.0, 500.0, 250.0), radius=400.0)
    per = Perception()
    st = per.update(CooperativeSensor().scan(0.0, OWN, (intruder, post)))
    assert st.sensor == "cooperative"
    (tr,) = st.tracks
    assert not tr.fitted and tr.n == 1 and tr.velocity.tolist() == [-12, 7, 0]
    s = st.get("s")
    assert (s.moving, s.radius, s.top) == (False, 400.0, 650.0) and s.velocity.tolist() == [0, 0, 0]
    st = per.update(CooperativeSensor().scan(1.0, OWN, (intruder, post)))
    assert st.tracks[0].fitted and st.tracks[0].n == 2


def test_the_tracker_finds_a_target_too_slow_for_the_radar() -> None:
    """With 5 m range noise the radar calls a return moving above ~36 m per scan; a 10 m/s
    intruder stays 'stationary' for it.  With moving_speed_mps = 3 the tracker's 10-scan fit
    calls it moving; the static ones stay stationary."""
    slow = IntruderThreat(
        id="slow", radius=100.0, start=(4000, 2000, 300), velocity_mps=(0, -10, 0)
    )
    posts = tuple(
        StaticThreat(id=f"s{k}", center=(3000.0 * k - 6000, 5000.0, 300.0), radius=200.0)
        for k in range(5)
    )
    radar = Radar(noise_range_m=5.0, seed=3)
    by_radar = Perception(PerceptionConfig(track_scans=10))
    by_tracker = Perception(PerceptionConfig(track_scans=10, moving_speed_mps=3.0))
    for k in range(10):
        pic = radar.scan(float(k), OWN, (slow, *posts))
        a, b = by_radar.update(pic), by_tracker.update(pic)
    assert a.get("slow").moving is False and not a.tracks
    assert b.get("slow").moving is True
    (tr,) = b.tracks
    np.testing.assert_allclose(tr.velocity, [0, -10, 0], atol=2.0)
    assert all(b.get(f"s{k}").moving is False for k in range(5))


# -- bad input -------------------------------------------------------------------------------------
def test_scans_must_come_in_time_order() -> None:
    per = Perception()
    per.update(scan(5.0, []))
    with pytest.raises(InputError, match=r"time order; got t = 5\.0 after 5\.0"):
        per.update(scan(5.0, []))
    per.reset()
    assert per.update(scan(1.0, [])).t == 1.0


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"memory_s": 0.0}, "memory_s must be a positive number"),
        ({"memory_s": math.inf}, "memory_s must be a positive number"),
        ({"body_cell_m": -1.0}, "body_cell_m must be a positive number"),
        ({"track_scans": 1}, "track_scans must be an integer >= 2"),
        ({"track_scans": 2.5}, "track_scans must be an integer >= 2"),
        ({"moving_speed_mps": -1.0}, "moving_speed_mps must be None or a number >= 0"),
    ],
)
def test_bad_config_is_refused(kwargs: dict[str, Any], message: str) -> None:
    with pytest.raises(InputError, match=message):
        PerceptionConfig(**kwargs)


def test_the_state_is_read_only() -> None:
    per = Perception()
    per.update(scan(0.0, [("a", (1, 2, 3), -1)]))
    st = per.update(scan(1.0, [("a", (5, 2, 3), 1)]))
    for arr in (
        st.positions,
        st.moving_code,
        st.last_seen,
        st.tracks[0].velocity,
        st.get("a").position,
    ):
        with pytest.raises(ValueError, match="read-only"):
            arr[0] = 0
    with pytest.raises(InputError, match="link distance must be a positive number"):
        st.clusters(0.0)


def test_bad_scans_are_refused() -> None:
    good = scan(0.0, [("a", (1, 2, 3), 0)])
    with pytest.raises(InputError, match="unique"):
        scan(0.0, [("a", (1, 2, 3), 0), ("a", (1, 2, 3), 0)])
    with pytest.raises(InputError, match=r"positions must have shape \(1, 3\)"):
        Scan(**{**good.__dict__, "positions": np.zeros((2, 3))})
    with pytest.raises(InputError, match="finite"):
        Scan(**{**good.__dict__, "positions": np.full((1, 3), np.nan)})
    with pytest.raises(InputError, match="moving_code must be -1"):
        Scan(**{**good.__dict__, "moving_code": [2]})
    with pytest.raises(InputError, match="own_position must be 3 finite"):
        Scan(**{**good.__dict__, "own_position": [0, 0]})
    with pytest.raises(InputError, match="reads a RadarPicture, a CooperativePicture or a Scan"):
        Perception().update({"ids": ()})  # type: ignore[arg-type]


def test_a_noisy_radar_size_is_kept_with_two_standard_errors() -> None:
    """Issue 34: the radius the radar measures of a solid sphere is inflated by its uncertainty
    in what the avoiders read: with noise the kept radius covers the true one in at least 95 %
    of the scans (two standard errors); noise-free it is the radius itself."""
    from replay.sensors.radar import Radar
    from replay.threats.kinds import StaticThreat

    sphere = StaticThreat(id="s", center=(4000.0, 0.0, 100.0), radius=200.0, solid=True)
    own = np.array([0.0, 0.0, 100.0])
    exact = Scan.of(Radar().scan(0.0, own, (sphere,)))
    assert exact.radii[0] == 200.0
    radar = Radar(noise_range_m=10.0, noise_bearing_rad=0.003, seed=5)
    kept = np.array([Scan.of(radar.scan(float(k), own, (sphere,))).radii[0] for k in range(500)])
    sigma = math.sqrt(2.0 * (4000.0 * 0.003) ** 2 + 10.0**2)
    assert np.mean(kept >= 200.0) >= 0.95
    assert float(np.median(kept)) == pytest.approx(200.0 + 2.0 * sigma, abs=0.3 * sigma)
