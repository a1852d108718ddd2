"""Terrain benchmark (issue: foundation): on Big Tujunga at 30 m

- load + grid time of ``bigtujunga.tif``;
- below-terrain length of a population of 100 paths x 10 segments of random 2-8 km segments
  (target <= 5 ms per population evaluation), numba kernel and its numpy twin;
- segment-in-cylinder lengths for the same population against 20 danger zones;
- TerrainModel build time and ray-casting throughput (target >= 1 M rays/s), beside bare open3d's
  ``cast_rays`` on the same rays in the same run (issue 38: >= 95 % of it).

Run: ``.venv/bin/python benchmarks/bench_terrain.py [--dem PATH] [--rays N] [--repeat K]``
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import open3d as o3d

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._record import emit  # noqa: E402
from terrain.cylinders import path_inside_lengths  # noqa: E402
from terrain.load import load_dem  # noqa: E402
from terrain.model import TerrainModel  # noqa: E402
from terrain.segments import path_below_lengths  # noqa: E402

DEFAULT_DEM = ROOT.parent / "shared" / "maps" / "topotoolbox_bigtujunga" / "bigtujunga.tif"


def best_of(fn, repeat: int) -> float:  # type: ignore[no-untyped-def]
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def population(grid, rng: np.random.Generator, p: int = 100, segs: int = 10) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Random polylines whose segments are 2-8 km long, kept inside the map."""
    xmin, ymin, xmax, ymax = grid.bounds
    pts = np.empty((p, segs + 1, 3))
    pts[:, 0, 0] = rng.uniform(xmin, xmax, p)
    pts[:, 0, 1] = rng.uniform(ymin, ymax, p)
    for k in range(1, segs + 1):
        length = rng.uniform(2000.0, 8000.0, p)
        ang = rng.uniform(0, 2 * np.pi, p)
        x = pts[:, k - 1, 0] + length * np.cos(ang)
        y = pts[:, k - 1, 1] + length * np.sin(ang)
        # reflect at the map edges so every segment keeps its length inside the map
        x = np.where(x < xmin, 2 * xmin - x, np.where(x > xmax, 2 * xmax - x, x))
        y = np.where(y < ymin, 2 * ymin - y, np.where(y > ymax, 2 * ymax - y, y))
        pts[:, k, 0], pts[:, k, 1] = x, y
    pts[:, :, 2] = rng.uniform(grid.zmin, grid.zmax + 200.0, (p, segs + 1))
    return pts


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dem", default=str(DEFAULT_DEM))
    ap.add_argument("--rays", type=int, default=1_000_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--no-record", action="store_true", help="print the figures, record nothing")
    ap.add_argument(
        "--repeat",
        type=int,
        default=5,
        help="ray casts timed, alternately with bare open3d's (best of each)",
    )
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)

    t = time.perf_counter()
    grid = load_dem(args.dem)
    t_load = time.perf_counter() - t
    t_load_warm = best_of(lambda: load_dem(args.dem), 3)

    paths = population(grid, rng)
    path_below_lengths(grid, paths)  # compile (or load from the numba cache)
    t_nb = best_of(lambda: path_below_lengths(grid, paths), 50)
    t_np = best_of(lambda: path_below_lengths(grid, paths, backend="numpy"), 5)
    xmin, ymin, xmax, ymax = grid.bounds
    k = 20
    centers = np.stack([rng.uniform(xmin, xmax, k), rng.uniform(ymin, ymax, k)], axis=1)
    radii = rng.uniform(500.0, 2000.0, k)
    tops = np.full(k, np.inf)
    t_cyl = best_of(lambda: path_inside_lengths(paths, centers, radii, tops), 20)

    t = time.perf_counter()
    model = TerrainModel.from_grid(grid)
    t_model = time.perf_counter() - t
    from terrain.model import airframe_sphere

    t = time.perf_counter()
    model.collides(airframe_sphere(5.0), (0.5 * (xmin + xmax), 0.5 * (ymin + ymax), grid.zmax + 10))
    t_bvh = time.perf_counter() - t
    n = args.rays
    origins = np.stack(
        [
            rng.uniform(xmin, xmax, n),
            rng.uniform(ymin, ymax, n),
            rng.uniform(grid.zmax + 100.0, grid.zmax + 2000.0, n),
        ],
        axis=1,
    )
    dirs = np.stack(
        [rng.normal(size=n), rng.normal(size=n), -np.abs(rng.normal(size=n)) - 0.2], axis=1
    )
    model.raycast(origins[:1000], dirs[:1000])  # build the scene
    # bare open3d on the same mesh and rays, already in its float32 layout: a scene of its own
    # and one cast_rays call; timed alternately with raycast (the machine's load shifts both)
    bare = o3d.t.geometry.RaycastingScene()
    local = np.asarray(model.mesh.vertices) - model.origin
    bare.add_triangles(
        o3d.core.Tensor.from_numpy(local.astype(np.float32)),
        o3d.core.Tensor.from_numpy(np.ascontiguousarray(model.mesh.faces, dtype=np.uint32)),
    )
    units = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    rays = o3d.core.Tensor.from_numpy(
        np.concatenate([origins - model.origin, units], axis=1).astype(np.float32)
    )
    bare.cast_rays(rays[:1000])
    t_ray = t_bare = np.inf
    for _ in range(args.repeat):
        t_bare = min(t_bare, best_of(lambda: bare.cast_rays(rays), 1))
        t_ray = min(t_ray, best_of(lambda: model.raycast(origins, dirs), 1))
    hits = np.isfinite(model.raycast(origins, dirs)).mean()

    segs = paths.shape[0] * (paths.shape[1] - 1)
    emit(
        "terrain: Big Tujunga 30 m",
        [
            ("grid", f"{grid.rows} x {grid.cols} cells of {grid.cell_size[0]:g} m", ""),
            ("load + grid (first, cold)", f"{t_load * 1e3:.1f} ms", ""),
            ("load + grid (warm, best of 3)", f"{t_load_warm * 1e3:.1f} ms", ""),
            (
                f"below-terrain length, 100 paths x 10 segments ({segs} segs, numba)",
                f"{t_nb * 1e3:.2f} ms",
                "<= 5 ms",
            ),
            ("same, pure-numpy twin", f"{t_np * 1e3:.1f} ms", ""),
            ("numpy / numba", f"{t_np / t_nb:.1f} x", ""),
            ("segment-in-cylinder, same population x 20 zones", f"{t_cyl * 1e3:.2f} ms", ""),
            ("TerrainModel.from_grid (trimesh mesh)", f"{t_model:.2f} s", ""),
            ("fcl BVH build (first collision query)", f"{t_bvh:.2f} s", ""),
            (
                f"ray casting, {n:,} rays ({hits:.0%} hit)",
                f"{n / t_ray / 1e6:.2f} M rays/s",
                ">= 1 M rays/s",
            ),
            (
                "bare open3d cast_rays, the same rays (float32, prepared)",
                f"{n / t_bare / 1e6:.2f} M rays/s",
                "",
            ),
            (
                "ray casting / bare open3d, same run",
                f"{100 * t_bare / t_ray:.1f} %",
                ">= 95 % (issue 38)",
            ),
        ],
        f"DEM {Path(args.dem).name}, seed {args.seed}",
        args.no_record,
    )


if __name__ == "__main__":
    main()
