"""Tests of `replay.record.encoding.ScanEncoder`'s scans given as arrays (every return written at
once): the messages of the same scans given as detection dicts, byte for byte, with terrain
returns that move every scan, ids holding ``%``, every kind of return and zero offsets."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from mcap.reader import make_reader

from replay.record.recorder import RunRecorder

ORIGIN = (440_271.0, 4_467_545.0, 0.0)


def radar_messages(path: Path) -> list[tuple[str, int, bytes]]:
    with open(path, "rb") as f:
        return [
            (ch.topic, m.log_time, m.data)
            for _, ch, m in make_reader(f, validate_crcs=True).iter_messages()
            if "radar" in ch.topic
        ]


def test_scans_of_moving_terrain_returns_are_the_dict_scans(tmp_path: Path) -> None:
    rng = np.random.default_rng(11)
    scans = []
    own = np.array([ORIGIN[0] - 9000.0, ORIGIN[1] - 10_000.0, 3000.0])
    for k in range(80):
        own = own + np.array([20.0, 22.0, 0.5])
        n_threat, n_ground = int(rng.integers(0, 4)), int(rng.integers(0, 60))
        n = n_threat + n_ground
        pos = own + rng.uniform(-10_000.0, 10_000.0, (n, 3)) * [1.0, 1.0, 0.1]
        if n and k % 7 == 0:  # offsets of +0.0 and -0.0 from the origin in some rows
            pos[rng.integers(0, n), rng.integers(0, 3)] = ORIGIN[0]
            pos[rng.integers(0, n)] = [ORIGIN[0], ORIGIN[1], -0.0]
        ids = [f"{'%' * (i % 3)}th%d{k}/{i}%r%%" for i in range(n_threat)]
        ids += [f"terrain/{int(x // 100)}/{int(y // 100)}" for x, y in pos[n_threat:, :2]]
        terrain = np.arange(n) >= n_threat
        moving = rng.random(n) < 0.4  # also "moving" terrain, which the dicts can say
        ranges = np.linalg.norm(pos - own, axis=1)
        scans.append((ids, pos, ranges, terrain, moving))
        if k % 5 == 0:  # the same returns again: new ranges only
            scans.append((ids, pos.copy(), ranges * 1.0001, terrain, moving))
    paths = tmp_path / "dicts.mcap", tmp_path / "arrays.mcap"
    for path in paths:
        with RunRecorder(path, map_origin=ORIGIN) as rec:
            for k, (ids, pos, dist, terrain, moving) in enumerate(scans):
                if path.name == "arrays.mcap":
                    rec.write_detection_arrays(float(k), ids, pos, dist, terrain, moving)
                    continue
                rec.write_detections(
                    float(k),
                    [
                        {
                            "id": ids[i],
                            "position": pos[i].tolist(),
                            "range": float(dist[i]),
                            "kind": "terrain" if terrain[i] else "threat",
                            "moving": bool(moving[i]),
                        }
                        for i in range(len(ids))
                    ],
                )
    dicts, arrays = (radar_messages(p) for p in paths)
    assert len(dicts) > len(scans) + 50  # most scans write their markers
    assert arrays == dicts
