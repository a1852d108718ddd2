"""How ``terrapath view`` draws a run's rangefinder beams (seed 003; ``/rangefinder/beams``,
written by :meth:`replay.record.recorder.RunRecorder.write_beams`): the beams of the scans nearest to
:data:`BEAM_SCANS` evenly spaced times of the recording, each a segment from the aircraft to
where the beam ended -- red where it hit something, green where it reached its full range.

The topic is a Foxglove line list per scan in the ``map`` frame, whose origin is the run's
``map_origin`` metadata (map CRS metres): it is added back here, so the beams lie where the
flown track does.  Only the chosen scans are decoded.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import numpy.typing as npt

from terrapath.view.decisions import Mark

FloatArray = npt.NDArray[np.float64]
BEAM_SCANS = 60  # scans drawn per run (a 10 Hz rangefinder records thousands)
HIT_COLOUR = "#d62728"
CLEAR_COLOUR = "#2ca02c"


def beam_marks(path: str | Path, scans: int = BEAM_SCANS) -> list[Mark]:
    """The beams of ``scans`` scans of the run at ``path`` spread over its recording (none when
    it recorded no rangefinder): a :class:`Mark` of the beams that hit, one of the others."""
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
    from mcap.reader import make_reader

    from replay.record import topics as T

    with open(path, "rb") as f:
        reader = make_reader(f)
        meta = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
        origin = np.asarray(
            json.loads(meta.get(T.RUN_METADATA, {}).get("map_origin", "[0, 0, 0]")),
            dtype=np.float64,
        )
        recorded = [
            (m.log_time, bytes(m.data))
            for _, _, m in reader.iter_messages([T.RANGEFINDER_BEAMS], log_time_order=True)
        ]
    if not recorded:
        return []
    ns = np.array([t for t, _ in recorded], dtype=np.int64)
    wanted = np.linspace(float(ns[0]), float(ns[-1]), min(scans, len(ns)))
    chosen = np.unique(np.abs(ns[None, :] - wanted[:, None]).argmin(axis=1))
    parts: dict[bool, list[FloatArray]] = {True: [], False: []}
    texts: dict[bool, list[str]] = {True: [], False: []}
    gap = np.full((1, 3), np.nan)
    for k in chosen:
        t = ns[k] / 1e9
        for entity in SceneUpdate.FromString(recorded[k][1]).entities:
            for line in entity.lines:
                hit = line.color.r > 0.9  # write_beams: red (1, 0.15, 0.1), green (0.2, 0.85, 0.3)
                pts = np.array([[p.x, p.y, p.z] for p in line.points]) + origin
                for a, b in zip(pts[0::2], pts[1::2], strict=True):  # a line list: segments
                    parts[hit] += [a[None, :], b[None, :], gap]
                    label = "hit" if hit else "clear"
                    texts[hit] += [f"beam ({label}) at t {t:.1f} s"] * 2 + [""]
    out = []
    for hit, name, colour in ((True, "hit", HIT_COLOUR), (False, "clear", CLEAR_COLOUR)):
        if parts[hit]:
            xyz = np.vstack(parts[hit][:-1])
            text = tuple(texts[hit][:-1])
            out.append(
                Mark(
                    f"rangefinder beams: {name}",
                    xyz,
                    "lines",
                    colour,
                    text,
                    width=1.0,
                    group="rangefinder beams",
                )
            )
    return out


__all__ = ["BEAM_SCANS", "beam_marks"]
