"""Replay benchmark (issue: replay engine): the seed 000 mission (about 8 hours of flight), no
threats, 100 Hz dynamics, radar at 1 Hz, default logging (10 Hz state) — wall time (target
<= 30 s, i.e. >= 960x real time) and MCAP size; plus the same run without recording, and the
time to read the file back.

Run: ``.venv/bin/python benchmarks/bench_replay.py``
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._record import record  # noqa: E402
from planner.mission import load_mission  # noqa: E402
from replay.avoidance import NoAvoidance  # noqa: E402
from replay.reader import load_run  # noqa: E402
from replay.record import RunRecorder  # noqa: E402
from replay.sim import ReplayConfig, simulate  # noqa: E402
from replay.threats import ThreatSet  # noqa: E402
from replay.vehicle.presets import load_vehicle  # noqa: E402

MISSION = ROOT / "data" / "missions" / "seed000-table4.yaml"


def main() -> None:
    m = load_mission(MISSION)
    params = load_vehicle(m.vehicle)
    simulate(
        m, ThreatSet(()), NoAvoidance(), params, config=ReplayConfig(duration=5.0)
    )  # JIT warm-up
    t = time.perf_counter()
    bare = simulate(m, ThreatSet(()), NoAvoidance(), params, config=ReplayConfig(seed=0))
    t_bare = time.perf_counter() - t
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run.mcap"
        t = time.perf_counter()
        with RunRecorder(out, map_origin=(0.0, 0.0, 0.0), seed=0, command="bench_replay") as rec:
            res = simulate(
                m, ThreatSet(()), NoAvoidance(), params, config=ReplayConfig(seed=0), recorder=rec
            )
        t_rec = time.perf_counter() - t
        size = out.stat().st_size
        t = time.perf_counter()
        run = load_run(out)
        t_read = time.perf_counter() - t
    sim_s = res.metrics.flight_time_s
    record(
        "replay: seed 000 mission, 8 h, no threats, 100 Hz dynamics, radar 1 Hz",
        [
            ("simulated flight time", f"{sim_s:.0f} s ({sim_s / 60:.1f} min)", "480.9 min ± 2 %"),
            (
                "wall, with MCAP (default 10 Hz logging)",
                f"{t_rec:.1f} s ({sim_s / t_rec:.0f}x real time)",
                "<= 30 s (>= 960x)",
            ),
            (
                "wall, no recording",
                f"{t_bare:.1f} s ({bare.metrics.flight_time_s / t_bare:.0f}x real time)",
                "",
            ),
            (
                "MCAP size",
                f"{size / 2**20:.1f} MiB ({size / len(run.times):.0f} B per state sample)",
                "",
            ),
            ("read back (load_run, CRC checked)", f"{t_read:.1f} s, {len(run.times)} samples", ""),
        ],
        notes="solar-uav preset, RK4 at 100 Hz with the autopilot in the compiled loop",
    )


if __name__ == "__main__":
    main()
