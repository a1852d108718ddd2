"""Scale benchmark (issue 38, "big DEMs"): peak memory and wall time of ``terrapath plan`` and
``terrapath check`` against the number of cells of the DEM.

One 40 x 40 km synthetic map (``terrain.synthetic_terrain``, seed 1, UTM 11N) written as a
GeoTIFF at 80 / 40 / 20 / 10 / 4 m cells (0.25 / 1 / 4 / 16 / 100 M cells) under ``--dem-dir``
(a scratch folder, never committed; a file already there is reused).  For each size, in a fresh
subprocess each: ``terrapath plan DEM --map-coords --start 402000,3702000 --goal 438000,3738000
--seed 1``, then ``terrapath check`` of the mission it wrote.  Peak memory is the child's peak
resident set size (``os.wait4``'s rusage, ``ru_maxrss``); wall time is measured round the child, CPU time (user + system) from its rusage.

Bytes a cell (the issue's formula): (peak RSS - the same command's peak on the 0.25 M-cell map)
/ (cells - 0.25 M); the target is <= 40 B a cell.  Time a cell: the CPU time over the cells
(and the added CPU time over the added cells); the wall time is printed beside it.

``--code DIR`` runs another checkout (e.g. a baseline worktree of the old code) with the same
DEMs; ``--json FILE`` writes the figures, ``--compare FILE`` adds an earlier ``--json`` run's
figures (the old code's) to the record.

A first, unmeasured run of the smallest size fills the caches (``--no-warmup`` to skip it).

Run: ``.venv/bin/python benchmarks/bench_scale.py [--cells 0.25,1,4,16,100] [--no-record]``
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._record import emit  # noqa: E402

SIDE = 40_000.0  # metres
ORIGIN = (400_000.0, 3_700_000.0)
CRS = "EPSG:32611"
START = "402000,3702000"
GOAL = "438000,3738000"
TITLE = "scale: plan and check of a 40 x 40 km synthetic map against its cells"
TARGET_BYTES = 40.0

GENERATE = """
import sys
from terrain.synthetic import synthetic_terrain
n, cell, out = int(sys.argv[1]), float(sys.argv[2]), sys.argv[3]
g = synthetic_terrain(n, n, cell, seed=1, origin=({x0!r}, {y0!r}), crs={crs!r})
g.to_geotiff(out)
"""


def cell_size(mcells: float) -> float:
    """The cell (m) giving about ``mcells`` million cells on the 40 km map."""
    return SIDE / round(math.sqrt(mcells * 1e6))


def dem_path(dem_dir: Path, mcells: float) -> Path:
    return dem_dir / f"synth40k_{cell_size(mcells):g}m.tif"


def make_dem(dem_dir: Path, mcells: float) -> Path:
    """The map's GeoTIFF at this size, written by this checkout in a subprocess if missing."""
    path = dem_path(dem_dir, mcells)
    if path.exists():
        return path
    dem_dir.mkdir(parents=True, exist_ok=True)
    n = round(math.sqrt(mcells * 1e6))
    code = GENERATE.format(x0=ORIGIN[0], y0=ORIGIN[1], crs=CRS)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    subprocess.run([sys.executable, "-c", code, str(n), str(cell_size(mcells)), str(path)],
                   check=True, env=env)  # fmt: skip
    return path


def measured(argv: list[str], code: Path, cwd: Path) -> dict[str, float | int]:
    """Run ``argv`` in a fresh process on ``code``'s packages: its exit status, wall time (s),
    CPU time (user + system, s: less disturbed than the wall time by other work on the machine)
    and peak resident set size (bytes, the child's own rusage)."""
    env = dict(os.environ, PYTHONPATH=str(code), MPLBACKEND="Agg")
    t0 = time.perf_counter()
    with open(cwd / "log.txt", "ab") as log:
        proc = subprocess.Popen(argv, env=env, cwd=cwd, stdout=log, stderr=log)
        _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    cpu = usage.ru_utime + usage.ru_stime
    return {"status": proc.returncode, "wall": wall, "cpu": cpu, "rss": usage.ru_maxrss * 1024}


def run_size(mcells: float, dem: Path, code: Path, out: Path, python: str) -> dict[str, object]:
    """plan, then check of its mission, on one DEM."""
    work = out / f"{mcells:g}M"
    work.mkdir(parents=True, exist_ok=True)
    mission = work / "mission.yaml"
    for old in work.glob("mission*"):
        old.unlink()
    cli = [python, "-m", "terrapath.cli"]
    plan = measured(
        [*cli, "plan", str(dem), "--map-coords", "--start", START, "--goal", GOAL,
         "--seed", "1", "-o", str(mission)],
        code, work,
    )  # fmt: skip
    check = measured([*cli, "check", str(mission)], code, work) if mission.exists() else None
    import rasterio

    with rasterio.open(dem) as src:
        cells = src.width * src.height
    return {"mcells": mcells, "cells": cells, "plan": plan, "check": check}


def per_cell(runs: list[dict], what: str) -> list[tuple[float, float, float]]:
    """(bytes a cell by the issue's formula, CPU µs a cell, added CPU µs an added cell) per run,
    the first run being the 0.25 M-cell reference.  CPU time (the wall time when a run has none):
    on a machine shared with other work the wall time says more about the others."""
    ref = runs[0]
    out = []
    for r in runs:
        m = r[what]
        if m is None:
            out.append((math.nan, math.nan, math.nan))
            continue
        added = r["cells"] - ref["cells"]
        b = (m["rss"] - ref[what]["rss"]) / added if added else math.nan
        t, t0 = m.get("cpu", m["wall"]), ref[what].get("cpu", ref[what]["wall"])
        us = 1e6 * t / r["cells"]
        dus = 1e6 * (t - t0) / added if added else math.nan
        out.append((b, us, dus))
    return out


def _fmt(m: dict | None, stats: tuple[float, float, float]) -> str:
    if m is None:
        return "not run (no mission)"
    b, us, dus = stats
    ok = {0: "ok", 3: "infeasible"}.get(int(m["status"]), f"exit {m['status']}")
    cpu = f", cpu {m['cpu']:.1f} s" if "cpu" in m else ""
    text = f"{m['rss'] / 2**20:,.0f} MiB, {m['wall']:.1f} s{cpu} ({ok})"
    if not math.isnan(b):
        text += f"; {b:.1f} B/cell, cpu {us:.2f} µs/cell ({dus:.2f} µs per added cell)"
    else:
        text += f"; cpu {us:.2f} µs/cell (reference)"
    return text


def rows_of(runs: list[dict], old: list[dict] | None) -> list[tuple[str, str, str]]:
    """A row per command and size: the figures, and the old code's beside them where measured."""
    rows: list[tuple[str, str, str]] = []
    olds = {r["mcells"]: r for r in old or []}
    for what in ("plan", "check"):
        stats = per_cell(runs, what)
        old_stats = dict(zip([r["mcells"] for r in old or []], per_cell(old, what) if old else [],
                             strict=True))  # fmt: skip
        for r, s in zip(runs, stats, strict=True):
            label = f"{what}, {r['mcells']:g} M cells ({cell_size(r['mcells']):g} m)"
            target = f"<= {TARGET_BYTES:g} B/cell" if r is not runs[0] else "reference (0.25 M)"
            value = _fmt(r[what], s)
            o = olds.get(r["mcells"])
            if o is not None:
                value += f" — old code: {_fmt(o[what], old_stats[r['mcells']])}"
            rows.append((label, value, target))
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cells", default="0.25,1,4,16,100",
                    help="sizes in millions of cells, the first the reference")  # fmt: skip
    ap.add_argument("--dem-dir", default="/work/scratch/s29/dem")
    ap.add_argument("--out", default="/work/scratch/s29/scale")
    ap.add_argument("--code", default=str(ROOT), help="the checkout whose terrapath runs")
    ap.add_argument("--json", help="write the figures here")
    ap.add_argument("--compare", help="an earlier --json run (the old code) to set beside")
    ap.add_argument("--note", default="")
    ap.add_argument("--no-record", action="store_true")
    ap.add_argument("--no-warmup", action="store_true", help="measure the first run too")
    args = ap.parse_args()
    sizes = [float(v) for v in args.cells.split(",")]
    code = Path(args.code).resolve()
    out = Path(args.out) / code.name
    runs = []
    if not args.no_warmup:  # a first run fills the caches (numba's, the files'), not measured
        run_size(sizes[0], make_dem(Path(args.dem_dir), sizes[0]), code, out, sys.executable)
    for mcells in sizes:
        dem = make_dem(Path(args.dem_dir), mcells)
        r = run_size(mcells, dem, code, out, sys.executable)
        runs.append(r)
        print(json.dumps(r), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(runs, indent=1))
    old = json.loads(Path(args.compare).read_text()) if args.compare else None
    load = os.getloadavg()
    notes = (
        f"code {code}; DEMs in {args.dem_dir}; peak RSS of each command in a fresh process "
        f"(os.wait4 rusage); load at the end {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} (2 cores "
        "shared with other work: times are noisy)" + (f"; {args.note}" if args.note else "")
    )
    emit(TITLE, rows_of(runs, old), notes, args.no_record)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
