"""Replay benchmark (issue: replay engine): the seed 000 mission (about 8 hours of flight), no
threats, 100 Hz dynamics, radar at 1 Hz, default logging (10 Hz state) — wall time (target
<= 30 s, i.e. >= 960x real time) and MCAP size; plus the same run without recording, and the
time to read the file back.

Run: ``.venv/bin/python benchmarks/bench_replay.py [--repeats N]`` (the 8-h flight) or ``... obstacles``
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._record import record  # noqa: E402
from planner.mission import load_mission  # noqa: E402
from replay.record.reader import load_run  # noqa: E402
from replay.run import ReplayRequest, run_replay  # noqa: E402
from replay.threats.file import load_threats  # noqa: E402

MISSION = ROOT / "data" / "missions" / "seed000-table4.yaml"


def bench_empty(repeats: int = 1) -> None:
    """The 8-h flight without recording and with, ``repeats`` interleaved pairs (the medians'
    ratio: another process on the machine slows one run of a pair more than the other)."""
    request = ReplayRequest.of(str(MISSION), seed=0, command="bench_replay")
    run_replay(request.but(duration=5.0))  # JIT warm-up
    load_before = _load()
    bares, recs = [], []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run.mcap"
        for _ in range(repeats):
            t = time.perf_counter()
            bare = run_replay(request)
            bares.append(time.perf_counter() - t)
            t = time.perf_counter()
            res = run_replay(request, out)
            recs.append(time.perf_counter() - t)
        size = out.stat().st_size
        t = time.perf_counter()
        run = load_run(out)
        t_read = time.perf_counter() - t
    t_bare, t_rec = _median(bares), _median(recs)
    pairs = f" (pairs: {', '.join(f'{r / b:.3f}' for b, r in zip(bares, recs, strict=True))})"
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
                "wall with MCAP / without (this run)",
                f"{t_rec / t_bare:.3f}" + (pairs if repeats > 1 else ""),
                "<= 1.3 (issue 38)",
            ),
            (
                "MCAP size",
                f"{size / 2**20:.1f} MiB ({size / len(run.times):.0f} B per state sample)",
                "",
            ),
            ("read back (load_run, CRC checked)", f"{t_read:.1f} s, {len(run.times)} samples", ""),
        ],
        notes="solar-uav preset, RK4 at 100 Hz with the autopilot in the compiled loop; the run "
        f"without recording, then with ({repeats} pair(s), medians); load average (1/5/15 min) {load_before} before, "
        f"{_load()} after",
    )


# -- obstacles: what threats cost ---------------------------------------------------------------
NEAR_M, FAR_M = 2500.0, 8000.0  # distance of an obstacle from the polyline (radar range 10 km)
OBSTACLE_RS_M = 1000.0  # seed 000 §5.1: safety radius


def distance_to_polyline(points: npt.ArrayLike, waypoints: npt.ArrayLike) -> npt.NDArray[Any]:
    """Horizontal distance (m) of points (N, 2) from the polyline through waypoints (W, >= 2)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    w = np.asarray(waypoints, dtype=np.float64)[:, :2]
    a, b = w[:-1], w[1:]
    ab = b - a
    t = np.einsum("nlk,lk->nl", p[:, None, :] - a, ab) / np.einsum("lk,lk->l", ab, ab)
    foot = a + np.clip(t, 0.0, 1.0)[..., None] * ab
    return np.asarray(np.linalg.norm(p[:, None, :] - foot, axis=-1).min(axis=1))


def obstacle_records(
    waypoints: npt.ArrayLike, count: int, seed: int, altitude: float
) -> list[dict[str, Any]]:
    """``count`` static obstacles beside the legs: a leg chosen with probability proportional
    to its length, a point along it, then an offset across it of +-U(NEAR_M, FAR_M); a draw
    nearer than NEAR_M to any leg (at a corner) is drawn again."""
    w = np.asarray(waypoints, dtype=np.float64)[:, :2]
    legs = np.linalg.norm(np.diff(w, axis=0), axis=1)
    rng = np.random.default_rng(seed)
    out: list[dict[str, Any]] = []
    while len(out) < count:
        leg = int(rng.choice(len(legs), p=legs / legs.sum()))
        a, b = w[leg], w[leg + 1]
        u = (b - a) / legs[leg]
        side = 1.0 if rng.random() < 0.5 else -1.0
        p = (
            a
            + rng.uniform() * (b - a)
            + side * rng.uniform(NEAR_M, FAR_M) * np.array([-u[1], u[0]])
        )
        if distance_to_polyline(p, w)[0] < NEAR_M:
            continue
        out.append(
            {
                "id": f"obs{len(out) + 1}",
                "kind": "static",
                "position": [round(float(p[0]), 1), round(float(p[1]), 1), altitude],
                "radius": OBSTACLE_RS_M,
            }
        )
    return out


def _cli_replay(
    threats: Path | None, out: Path, extra: Sequence[str] = (), ok: int = 0
) -> dict[str, Any]:
    """``terrapath replay MISSION --avoid none [--threats FILE] -o out --json`` in this process:
    the printed report; the exit status must be ``ok``."""
    from terrapath.cli import main

    args = ["replay", str(MISSION), "--avoid", "none", "-o", str(out), "--json", *extra]
    if threats is not None:
        args += ["--threats", str(threats)]
    text, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(text), contextlib.redirect_stderr(err):
        rc = main(args)
    if rc != ok:
        raise SystemExit(f"terrapath replay failed ({rc}): {err.getvalue()}")
    report: dict[str, Any] = json.loads(text.getvalue())
    return report


def _timed(fn: Callable[[], Any]) -> tuple[float, float, Any]:
    """(wall seconds, CPU seconds of this process, result) of one call."""
    wall, cpu = time.perf_counter(), time.process_time()
    out = fn()
    return time.perf_counter() - wall, time.process_time() - cpu, out


def _median(values: Sequence[float]) -> float:
    return float(statistics.median(values))


def _runs(values: Sequence[float]) -> str:
    return ", ".join(f"{v:.2f}" for v in values)


def _load() -> str:
    try:
        return "/".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:
        return "n/a"


def bench_obstacles(count: int, repeats: int, seed: int, note: str = "") -> None:
    m = load_mission(MISSION)
    recs = obstacle_records(m.waypoints, count, seed, float(m.cruise_altitude))
    cases = ("none", "obstacles")
    # (kind of run, case) -> wall and CPU seconds of each repeat
    wall: dict[tuple[str, str], list[float]] = {(k, c): [] for k in ("cli", "lib") for c in cases}
    cpu: dict[tuple[str, str], list[float]] = {key: [] for key in wall}
    reports: dict[str, dict[str, Any]] = {}
    flights: dict[str, float] = {}
    load_before = _load()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        path = folder / "obstacles.yaml"
        doc = {"terrapath": 1, "name": f"{count} obstacles, seed {seed}", "threats": recs}
        path.write_text(yaml.safe_dump(doc, sort_keys=False))
        threats = load_threats(path)
        # warm-up: imports and JIT compilation (a short replay, cut: exit status 3)
        _cli_replay(path, folder / "warm.mcap", ("--duration", "5"), ok=3)
        for k in range(repeats):
            for case in cases:
                file = path if case == "obstacles" else None
                w, c, reports[case] = _timed(partial(_cli_replay, file, folder / f"{case}.mcap"))
                wall["cli", case].append(w)
                cpu["cli", case].append(c)
                lib = ReplayRequest.of(str(MISSION), threats=threats if file else None)
                w, c, res = _timed(partial(run_replay, lib))
                wall["lib", case].append(w)
                cpu["lib", case].append(c)
                flights[case] = res.metrics.flight_time_s
                if reports[case]["metrics"]["flight_time_s"] != flights[case]:
                    raise SystemExit(f"{case}: the CLI and the library flew different times")
                print(
                    f"run {k + 1}/{repeats} {case}: terrapath replay {wall['cli', case][-1]:.2f} s, "
                    f"no recording {w:.2f} s (load {_load()})",
                    file=sys.stderr,
                )
    seen = reports["obstacles"]["metrics"]["min_separation"]
    if not all(r["metrics"]["success"] for r in reports.values()) or len(seen) != count:
        raise SystemExit("a benchmark run was not a clean success with every obstacle measured")
    if flights["none"] != flights["obstacles"]:
        raise SystemExit(f"the two runs flew different times: {flights}")
    closest = min(v["value"] for v in seen.values())
    rows = []
    for kind, label, target in (
        ("cli", "terrapath replay --avoid none (MCAP)", "<= 1.3"),
        ("lib", "no recording (replay.run.run_replay)", ""),
    ):
        a, b = _median(wall[kind, "none"]), _median(wall[kind, "obstacles"])
        ca, cb = _median(cpu[kind, "none"]), _median(cpu[kind, "obstacles"])
        rows += [
            (f"{label}, no obstacles", f"{a:.2f} s (runs {_runs(wall[kind, 'none'])})", ""),
            (
                f"{label}, {count} obstacles",
                f"{b:.2f} s (runs {_runs(wall[kind, 'obstacles'])})",
                "",
            ),
            (f"{label}, wall-time ratio", f"{b / a:.3f}", target),
            (f"{label}, CPU-time ratio", f"{cb / ca:.3f} ({cb:.2f} / {ca:.2f} s)", ""),
        ]
    rows.append(
        (
            "simulated flight time (both)",
            f"{flights['none']:.0f} s; closest obstacle surface {closest:.0f} m",
            "same; > 0",
        )
    )
    record(
        f"replay: seed 000 mission, {count} static obstacles vs none, --avoid none",
        rows,
        notes=f"obstacles seed {seed}, {NEAR_M / 1000:g}-{FAR_M / 1000:g} km from the path, "
        f"radius {OBSTACLE_RS_M:g} m; medians of {repeats} interleaved runs "
        f"(none, obstacles, ...), each in this process after a warm-up; load average "
        f"(1/5/15 min) {load_before} before, {_load()} after" + (f"; {note}" if note else ""),
    )


def main(argv: Sequence[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else None)
    sub = ap.add_subparsers(dest="command")
    ob = sub.add_parser("obstacles", help="wall time with static obstacles vs none")
    ob.add_argument("--count", type=int, default=100)
    ob.add_argument("--repeats", type=int, default=3)
    ob.add_argument("--seed", type=int, default=13)
    ob.add_argument("--note", default="", help="added to the notes of the record")
    ap.add_argument("--repeats", type=int, default=1, help="8-h runs: pairs (median)")
    args = ap.parse_args(argv)
    if args.command == "obstacles":
        bench_obstacles(args.count, args.repeats, args.seed, args.note)
    else:
        bench_empty(args.repeats)


if __name__ == "__main__":
    main()
