"""A path sampled densely over the terrain: the one place that walks a polyline every half cell
(used for the true clearance of a plan, the location of its violations and its profile picture).
Unlike the Bresenham walk of the cost, this compares with the bilinear terrain surface."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from terrain.grid import HeightGrid

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class PathSamples:
    """Samples of a polyline: ``segment`` index (K,), horizontal ``distance`` along the path (K,),
    the map ``points`` (K, 3) and the terrain height ``ground`` under each (K,)."""

    segment: npt.NDArray[np.int64]
    distance: FloatArray
    points: FloatArray
    ground: FloatArray

    @property
    def clearance(self) -> FloatArray:
        return self.points[:, 2] - self.ground


def sample_path(grid: HeightGrid, path: npt.ArrayLike, step: float | None = None) -> PathSamples:
    """Every segment sampled at most ``step`` apart horizontally (default half the smallest cell),
    both ends included."""
    p = np.asarray(path, dtype=np.float64)
    step = step or 0.5 * min(grid.cell_size)
    segs, dist, pts = [], [], []
    s0 = 0.0
    for i in range(len(p) - 1):
        a, b = p[i], p[i + 1]
        horiz = float(np.linalg.norm(b[:2] - a[:2]))
        n = max(2, int(np.ceil(horiz / step)) + 1)
        t = np.linspace(0.0, 1.0, n)
        segs.append(np.full(n, i, dtype=np.int64))
        dist.append(s0 + t * horiz)
        pts.append(a[None, :] + t[:, None] * (b - a)[None, :])
        s0 += horiz
    points = np.concatenate(pts)
    ground = np.asarray(grid.height_at(points[:, 0], points[:, 1]), dtype=np.float64)
    return PathSamples(np.concatenate(segs), np.concatenate(dist), points, ground)
