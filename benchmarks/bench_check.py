"""`terrapath check` speed (issue 35): a 100-waypoint mission over the largest shared map (SRTM3
N57E011, 64 x 113 km at 50 m), timed without the DEM load and the picture (target: under a
second). The mission is a seeded random walk of 100 waypoints, legs of 0.5-1.5 km turning at
most 90 degrees, each waypoint 150 m above its measured ground, flown by the aerosonde at
25 m/s with its fillets; the check is the command's (:func:`replay.preflight.feasibility`:
the flown path against the measured terrain, unknown terrain, the map and the vehicle's
preflight). The first call pays the vehicle's trim caches (its ceiling at the speed); the best
of the repeats is the figure.

Run: ``.venv/bin/python benchmarks/bench_check.py [--dem PATH] [--repeat 5] [--no-record]``
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._record import emit  # noqa: E402
from planner.mission import Mission, TerrainRef  # noqa: E402
from replay.flight.fixedwing.presets import PRESETS  # noqa: E402
from replay.preflight import feasibility  # noqa: E402
from terrain.load import load_dem  # noqa: E402

DEFAULT_DEM = ROOT.parent / "shared" / "maps" / "srtm3_N57E011" / "N57E011.hgt"


def random_mission(grid, n: int, seed: int) -> np.ndarray:  # type: ignore[no-untyped-def]
    """``n`` waypoints of a seeded random walk on the measured part of the map."""
    rng = np.random.default_rng(seed)
    safety = grid.safety()
    xmin, ymin, xmax, ymax = grid.bounds
    known = grid.known if grid.known is not None else np.ones(grid.shape, dtype=bool)
    rows, cols = np.nonzero(known)
    k = int(rng.integers(len(rows)))
    x, y = (float(v) for v in grid.index_to_xy(rows[k], cols[k]))
    heading = rng.uniform(0, 2 * np.pi)
    pts = [(x, y)]
    while len(pts) < n:
        turn = rng.uniform(-np.pi / 2, np.pi / 2)
        length = rng.uniform(500.0, 1500.0)
        h = heading + turn
        nx, ny = x + length * np.cos(h), y + length * np.sin(h)
        r, c = grid.cell_of(nx, ny)
        if not (xmin < nx < xmax and ymin < ny < ymax) or not known[int(r), int(c)]:
            heading += np.pi / 2  # turn away from the edge and try again
            continue
        x, y, heading = nx, ny, h
        pts.append((x, y))
    xy = np.array(pts)
    z = np.asarray(safety.height_at(xy[:, 0], xy[:, 1])) + 150.0
    return np.column_stack([xy, z])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dem", default=str(DEFAULT_DEM))
    ap.add_argument("--waypoints", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--no-record", action="store_true")
    args = ap.parse_args()
    t = time.perf_counter()
    grid = load_dem(args.dem)
    load_s = time.perf_counter() - t
    params = PRESETS["aerosonde"]
    w = random_mission(grid, args.waypoints, args.seed)
    mission = Mission(
        name="bench",
        waypoints=w,
        crs="EPSG:32632",
        terrain=TerrainRef((args.dem,)),
        vehicle="aerosonde",
        cruise_speed=25.0,
        cruise_altitude=float(w[0, 2]),
        turn_radius=params.performance(25.0).turn_radius,
    )
    times = []
    report = None
    for _ in range(args.repeat):
        t = time.perf_counter()
        report = feasibility(mission, grid, params, 25.0, clearance=100.0)
        times.append(time.perf_counter() - t)
    assert report is not None
    length = float(report.geometry.samples.distance[-1])
    rows = [
        (
            "map",
            f"{Path(args.dem).name}: {grid.shape[0]} x {grid.shape[1]} cells of "
            f"{grid.cell_size[0]:.0f} m (load {load_s:.2f} s, not timed)",
            "",
        ),
        (
            "mission",
            f"{args.waypoints} waypoints, {length / 1000:.1f} km as flown, "
            f"{len(report.geometry.samples.distance):,} samples, {len(report.findings)} "
            "violations found",
            "",
        ),
        ("check, first call (s)", f"{times[0]:.3f}", "< 1"),
        (f"check, best of {args.repeat} (s)", f"{min(times):.3f}", "< 1"),
    ]
    emit(
        "terrapath check: a 100-waypoint mission over the largest shared map (issue 35)",
        rows,
        f"seed {args.seed}; the DEM load and the picture not timed",
        args.no_record,
    )


if __name__ == "__main__":
    main()
