"""Campaign benchmarks (issue 17).

``sweep``: the seed 000 Table 6 sweep for PSO-CA with one optimiser (PSO): 11 obstacle counts
(1-100) plus "40 + 1 hill" and "40 + 2 intruders", 10 runs each: 130 eight-hour replays, end to
end (``terrapath bench seed000-table6`` into a fresh store, no MCAPs) on ``--jobs`` processes
(default 2). Target: <= 15 minutes on this 2-core machine (it took about 1.2 h before campaigns).
The table itself goes into benchmarks/SUMMARY.md, as ``terrapath bench`` writes it.

``overhead``: what an executor costs per run. ``--runs`` replays (default 8) of the seed 000
mission (8 h; ``--duration`` cuts it) with 40 obstacles -- the runs of a Table 6 row -- on 2
processes: flown in this process one after the other (the runs' own time), then through the
process pool and a local Dask cluster. Overhead per run = (jobs x wall time - the sum of the runs'
own times in that executor) / runs; its share is that over the mean run time. Target: < 5 %.
The Dask cluster's start-up is reported apart; each worker's warm-up (imports, compiled kernels:
``runner.warm_up``) is inside the wall time.

Run: ``.venv/bin/python benchmarks/bench_campaign.py sweep|overhead`` (``--no-record`` to print
only).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._record import record  # noqa: E402
from replay.campaign.runner import run_campaign  # noqa: E402
from replay.campaign.spec import load_spec  # noqa: E402
from replay.campaign.store import Store  # noqa: E402

MISSION = ROOT / "data" / "missions" / "seed000-table4.yaml"


def sweep(args: argparse.Namespace) -> None:
    from terrapath.cli import main

    with tempfile.TemporaryDirectory() as tmp:
        store = Path(tmp) / "t6.sqlite"
        cmd = ["bench", "seed000-table6", "--store", str(store), "--keep-mcap", "none"]
        cmd += ["--jobs", str(args.jobs)]  # the table goes into benchmarks/SUMMARY.md
        t0 = time.perf_counter()
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            rc = main(cmd)
        wall = time.perf_counter() - t0
        with Store(store, "bench") as db:
            rows = db.rows()
    if rc != 0:
        raise SystemExit(f"terrapath bench failed ({rc}): {err.getvalue()[-2000:]}")
    own = sum(r["wall_s"] for r in rows)
    ok = sum(bool(r["success"]) for r in rows)
    print(out.getvalue())
    figures = [
        ("replays", str(len(rows)), "130"),
        ("successful", f"{ok}/{len(rows)}", ""),
        ("end-to-end wall time (min)", f"{wall / 60:.1f}", "<= 15"),
        ("sum of the runs' own times (min)", f"{own / 60:.1f}", ""),
        ("mean run (s)", f"{own / len(rows):.1f}", ""),
        ("jobs", str(args.jobs), ""),
    ]
    if args.record:
        record(
            "campaign: seed 000 Table 6 sweep, PSO-CA with PSO (130 eight-hour replays)", figures
        )
    else:
        for f in figures:
            print(" | ".join(f))


def _spec(tmp: Path, runs: int, duration: float | None) -> Path:
    p = tmp / "overhead.yaml"
    p.write_text(
        "terrapath: 1\nname: executor-overhead\n"
        f"mission: {MISSION}\n"
        "threats: {generator: seed000-normal, counts: [40]}\n"
        "avoiders: [{name: pso-ca, options: {optimizer: pso}}]\n"
        f"sensor: radar\nruns: {runs}\nseed: 5\n" + (f"duration: {duration}\n" if duration else ""),
        encoding="utf-8",
    )
    return p


def overhead(args: argparse.Namespace) -> None:
    jobs = 2
    figures: list[tuple[str, str, str]] = []
    with tempfile.TemporaryDirectory() as tmp:
        spec = load_spec(_spec(Path(tmp), args.runs, args.duration))
        with Store(Path(tmp) / "warm.sqlite", "bench") as db:  # JIT caches and imports
            run_campaign(spec.narrowed(runs=1), db, version="bench", command="x", keep="none")
        base: float | None = None
        for executor in ("sequential", "pool", "dask-local"):
            with Store(Path(tmp) / f"{executor}.sqlite", "bench") as db:
                t0 = time.perf_counter()
                startup = 0.0
                if executor == "dask-local":
                    from replay.campaign import runner

                    t_start = time.perf_counter()
                    client = runner._dask_client(None, jobs)
                    startup = time.perf_counter() - t_start
                    client.close()
                    client.cluster.close()
                    t0 = time.perf_counter()
                run_campaign(
                    spec,
                    db,
                    version="bench",
                    command="x",
                    jobs=1 if executor == "sequential" else jobs,
                    executor="pool" if executor == "sequential" else executor,
                    keep="none",
                )
                wall = time.perf_counter() - t0 - (startup if executor == "dask-local" else 0.0)
                rows = db.rows()
            own = sum(r["wall_s"] for r in rows)
            mean = own / len(rows)
            if executor == "sequential":
                base = mean
                figures.append(("run, flown alone (s)", f"{mean:.2f}", ""))
                continue
            per_run = (jobs * wall - own) / len(rows)
            figures.append(
                (f"{executor}: wall for {len(rows)} runs on {jobs} (s)", f"{wall:.1f}", "")
            )
            figures.append((f"{executor}: run inside it (s)", f"{mean:.2f}", ""))
            figures.append(
                (
                    f"{executor}: overhead per run (s, share of a run)",
                    f"{per_run:.2f} ({100 * per_run / mean:.1f} %)",
                    "< 5 %",
                )
            )
            if base:
                figures.append((f"{executor}: run inside it / alone", f"{mean / base:.2f}", ""))
            if startup:
                figures.append(("dask-local: cluster start-up (s)", f"{startup:.1f}", ""))
    cut = f" cut to {args.duration / 3600:g} h" if args.duration else " (8 h)"
    title = (
        f"campaign executors: {args.runs} runs of the seed 000 mission{cut}, 40 obstacles, PSO-CA"
    )
    if args.record:
        record(title, figures)
    else:
        for f in figures:
            print(" | ".join(f))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    s = sub.add_parser("sweep")
    s.add_argument("--jobs", type=int, default=2)
    o = sub.add_parser("overhead")
    o.add_argument("--runs", type=int, default=8)
    o.add_argument("--duration", type=float, default=None, help="cut the flights (s)")
    for p in (s, o):
        p.add_argument("--no-record", dest="record", action="store_false")
    args = ap.parse_args()
    {"sweep": sweep, "overhead": overhead}[args.what](args)


if __name__ == "__main__":
    main()
