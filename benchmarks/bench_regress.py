"""Issue 39: ``terrapath regress``'s default suite (the reference maps with every avoider, the
papers' scenarios, own scenarios, the maps planned by every optimiser) timed from the command
line, as CI runs it; target <= 2 min on 2 cores.  The suite's groups, those without regression
and the wall time are recorded.

Run: ``.venv/bin/python benchmarks/bench_regress.py [--jobs N]``
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._record import record  # noqa: E402


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else None)
    ap.add_argument("--jobs", type=int, default=None)
    args = ap.parse_args(argv)
    cmd = [sys.executable, "-m", "terrapath.cli", "regress"]
    if args.jobs:
        cmd += ["--jobs", str(args.jobs)]
    load = "/".join(f"{v:.2f}" for v in os.getloadavg())
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        done = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True)
        wall = time.perf_counter() - t
    summary = re.search(r"(\d+) groups: (\d+) without regression, (\d+) regressed", done.stderr)
    if summary is None:
        raise SystemExit(
            f"terrapath regress said no summary (exit {done.returncode}):\n{done.stderr}"
        )
    groups, fine, regressed = summary.groups()
    print(done.stdout)
    record(
        "regress: the default suite (terrapath regress)",
        [
            ("wall, from the command line", f"{wall:.0f} s", "<= 120 s on 2 cores (issue 39)"),
            ("groups / without regression", f"{groups} / {fine}", f"all (exit {done.returncode})"),
        ],
        notes=f"{os.cpu_count()} jobs unless --jobs; load before {load}; {regressed} regressed",
    )


if __name__ == "__main__":
    main()
