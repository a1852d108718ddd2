"""Perception reproduces PSO-CA's private obstacle memory and intruder tracks.

This pins the mapping by which PSO-CA moves onto :mod:`replay.perception` (issue 13): fed the same
radar pictures, with PSO-CA's terrain filter as ``keep`` and ``PerceptionConfig(memory_s=60,
body_cell_m=100, track_scans=2)``,

- the stationary obstacles, in order, are the keys of ``PsoCaAvoider._seen``, with the same
  positions and last-seen times -- except, for one scan, a remembered id the radar sees again
  after a gap (its code is -1 then): perception refreshes it, PSO-CA kept the old sighting;
- the tracks seen now and moving since an earlier scan are PSO-CA's intruders with a previous
  moving fix, with the same last two fixes and ranges, and velocity[:2] equal bit for bit to
  PSO-CA's ``(xy - prev.xy) / (t - prev.t)``; the tracks seen now are its ``moving_xy``, in order.

It reads PSO-CA's private state on purpose; delete it when PSO-CA reads perception.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from affine import Affine

from replay.avoidance.base import AvoidanceContext
from replay.avoidance.pso_ca import PsoCaAvoider
from replay.perception import Perception, PerceptionConfig
from replay.radar import Radar
from replay.threats import CylinderThreat, HillThreat, IntruderThreat, StaticThreat
from replay.vehicle.presets import load_vehicle
from terrain.grid import HeightGrid
from terrain.model import TerrainModel

X0, Y0 = 400_000.0, 3_800_000.0
YC = Y0 - 3000.0


@pytest.fixture(scope="module")
def ridge() -> TerrainModel:
    """A 20 km x 6 km map with a 700 m peak at (X0 + 12 km, YC) sloping 0.4 east-west."""
    cell, rows, cols = 50.0, 120, 400
    probe = HeightGrid(np.zeros((rows, cols), np.float32), Affine(cell, 0, X0, 0, -cell, Y0))
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    x, y = probe.index_to_xy(r, c)
    h = 100.0 + np.maximum(0.0, 600.0 - 0.4 * np.abs(x - X0 - 12000.0) - 0.2 * np.abs(y - YC))
    return TerrainModel.from_grid(HeightGrid(np.asarray(h, np.float32), probe.transform))


THREATS = (
    StaticThreat(id="s1", center=(X0 + 6000, YC + 300, 300), radius=500),
    StaticThreat(id="s2", center=(X0 + 9000, YC - 2500, 150), radius=500, appears_at=20),
    HillThreat(
        id="h",
        points=(
            (X0 + 13000, YC + 1500, 700),
            (X0 + 13500, YC + 1800, 700),
            (X0 + 14200, YC + 1900, 700),
        ),
        radii=(400,),
    ),
    CylinderThreat(id="c", center=(X0 + 8000, YC + 2500), radius=600, top=900),
    IntruderThreat(
        id="i", radius=200, start=(X0 + 15000, YC - 1000, 400), velocity_mps=(-15, 3, 0)
    ),
    IntruderThreat(
        id="j",
        radius=200,
        waypoints=(
            (X0 + 4000, YC + 4000, 400),
            (X0 + 4000, YC - 4000, 400),
            (X0 + 9000, YC - 4000, 400),
        ),
        speed=20,
        appears_at=30,
    ),
)


@pytest.mark.parametrize(("noise", "clearance"), [(0.0, 0.0), (1.0, 150.0)])
def test_perception_matches_pso_ca_private_memory(
    ridge: TerrainModel, noise: float, clearance: float
) -> None:
    radar = Radar(noise_range_m=noise, noise_bearing_rad=noise * 1e-5, seed=1)
    avoider = PsoCaAvoider()
    avoider.reset(np.zeros((2, 3)), np.random.default_rng(0))
    per = Perception(PerceptionConfig(memory_s=avoider.memory_s, body_cell_m=100.0, track_scans=2))
    own_v = np.array([40.0, 5.0, 0.0])
    vehicle = load_vehicle("solar-uav")
    counts = {"tracks": 0, "refreshed": 0, "stationary": 0}
    for k in range(300):
        t = float(k)
        own = np.array([X0 + 500 + 40.0 * t, YC - 1500 + 5.0 * t + 800 * math.sin(t / 40), 450.0])
        pic = radar.scan(t, own, THREATS, terrain_model=ridge, min_clearance=100.0)
        ctx = AvoidanceContext(
            t=t,
            state=np.zeros(12),
            position=own,
            velocity=own_v,
            airspeed=15.0,
            course=0.0,
            picture=pic,
            waypoints=np.zeros((2, 3)),
            next_index=1,
            vehicle=vehicle,
            terrain_clearance=clearance,
        )
        avoider._observe(ctx)
        # PSO-CA's terrain filter, moved to the caller as ``keep``
        n = pic.n_threat
        keep = np.ones(len(pic), dtype=bool)
        pts = pic.positions[n:]
        blocking = pts[:, 2] > own[2] - avoider.terrain_margin
        if clearance > 0:
            d = np.hypot(pts[:, 0] - own[0], pts[:, 1] - own[1])
            need = pts[:, 2] + clearance - own[2]
            blocking &= need > avoider.climb_share * d * avoider._climb_gradient(ctx)
        keep[n:] = blocking
        st = per.update(pic, keep=keep)

        keys = list(avoider._seen)
        rows = st.stationary
        assert [st.ids[i] for i in rows] == keys
        counts["stationary"] = max(counts["stationary"], len(keys))
        regained = {pic.ids[i] for i in np.flatnonzero(pic.moving_code[:n] == -1)}
        for key, row in zip(keys, rows.tolist(), strict=True):
            seen = avoider._seen[key]
            if key in regained and seen.t < t:
                assert st.last_seen[row] == t  # perception refreshes; PSO-CA kept the old fix
                counts["refreshed"] += 1
                continue
            assert st.positions[row, :2].tolist() == seen.xy.tolist()
            assert (st.positions[row, 2], st.last_seen[row]) == (seen.z, seen.t)

        mine = {tr.id: tr for tr in st.tracks if tr.t == t and tr.since < t}
        theirs = {
            ident: (tr, avoider._prev_tracks[ident])
            for ident, tr in avoider._tracks.items()
            if tr.t == t and ident in avoider._prev_tracks and avoider._prev_tracks[ident].t < t
        }
        assert set(mine) == set(theirs)
        for ident, (tr, prev) in theirs.items():
            m = mine[ident]
            assert m.positions[-1, :2].tolist() == tr.xy.tolist()
            assert m.positions[-2, :2].tolist() == prev.xy.tolist()
            assert m.ranges.tolist() == [prev.range, tr.range] and m.times.tolist() == [
                prev.t,
                tr.t,
            ]
            assert m.velocity[:2].tolist() == ((tr.xy - prev.xy) / (tr.t - prev.t)).tolist()
            counts["tracks"] += 1
        assert [tr.id for tr in st.tracks if tr.t == t] == [
            ident for ident, tr in avoider._tracks.items() if tr.t == t
        ]
    # the scenario exercises what it claims: tracks, occlusions, a large memory
    assert counts["tracks"] > 200 and counts["refreshed"] >= 1 and counts["stationary"] > 50
