"""Unknown terrain in the view: the cells a DEM did not measure (``grid.known`` False: filled
nodata holes, reprojection corners), greyed and hatched in the 2-D map and the 3D scene as the
pictures of :mod:`terrain.plot` do.

The map draws one filled trace with a hatch pattern over rectangles that together cover exactly
the unknown cells (:func:`unknown_rectangles`; a grid of more than :data:`MAX_BLOCKS` rows or
columns is taken in blocks, a block hatched when any of its cells is unknown: the hatch may then
reach into known cells, never leave an unknown one bare).  The 3D scene draws the filled heights
of the unknown cells as a grey surface with hatch lines draped over it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

UNKNOWN_NAME = "unknown terrain (filled, not measured)"
UNKNOWN_FILL = "rgba(120,120,120,0.55)"
UNKNOWN_LINE = "#303030"
MAX_BLOCKS = 600  # rows (and columns) of the mask the map's rectangles are cut from
HATCH_LINES = 40  # hatch lines across the 3D scene's longer side

BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]


def unknown_rectangles(unknown: BoolArray) -> IntArray:
    """(N, 4) ``row0, row1, col0, col1`` (half-open) of rectangles covering exactly the True
    cells of ``unknown``, none overlapping: each row's runs of True cells, a run merged with the
    same run of the rows below it."""
    out: list[tuple[int, int, int, int]] = []
    open_runs: dict[tuple[int, int], int] = {}  # (col0, col1) -> first row
    rows = unknown.shape[0]
    for r in range(rows + 1):
        runs: set[tuple[int, int]] = set()
        if r < rows:
            edge = np.diff(np.r_[0, unknown[r].astype(np.int8), 0])
            runs = set(
                zip(
                    np.flatnonzero(edge == 1).tolist(),
                    np.flatnonzero(edge == -1).tolist(),
                    strict=True,
                )
            )
        for run in [k for k in open_runs if k not in runs]:
            out.append((open_runs.pop(run), r, run[0], run[1]))
        for run in runs:
            open_runs.setdefault(run, r)
    return np.asarray(out, dtype=np.int64).reshape(-1, 4)


def _blocks(grid: Any) -> tuple[BoolArray, int]:
    """The unknown mask taken in blocks of ``step`` x ``step`` cells (any unknown: unknown)."""
    unknown = ~np.asarray(grid.known, dtype=bool)
    step = max(1, math.ceil(max(unknown.shape) / MAX_BLOCKS))
    if step == 1:
        return unknown, 1
    rows, cols = unknown.shape
    pad = np.zeros((math.ceil(rows / step) * step, math.ceil(cols / step) * step), dtype=bool)
    pad[:rows, :cols] = unknown
    blocks = pad.reshape(pad.shape[0] // step, step, pad.shape[1] // step, step).any(axis=(1, 3))
    return np.asarray(blocks, dtype=bool), step


def hatch_outline(grid: Any) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]] | None:
    """The map's hatched rectangles as one NaN-separated closed outline each (map metres), or
    None when every cell is measured."""
    if grid.known is None or not grid.has_unknown:
        return None
    blocks, step = _blocks(grid)
    rects = unknown_rectangles(blocks).astype(np.float64) * step
    xmin, _, _, ymax = grid.bounds
    dx, dy = grid.cell_size
    r0 = np.minimum(rects[:, 0], grid.rows)
    r1 = np.minimum(rects[:, 1], grid.rows)
    c0 = np.minimum(rects[:, 2], grid.cols)
    c1 = np.minimum(rects[:, 3], grid.cols)
    x0, x1 = xmin + dx * c0, xmin + dx * c1
    y0, y1 = ymax - dy * r0, ymax - dy * r1
    gap = np.full(len(rects), np.nan)
    xs = np.column_stack([x0, x1, x1, x0, x0, gap]).ravel()[:-1]
    ys = np.column_stack([y0, y0, y1, y1, y0, gap]).ravel()[:-1]
    return xs, ys


def map_hatch(grid: Any) -> Any:
    """The 2-D map's hatch trace (None: nothing unknown)."""
    import plotly.graph_objects as go

    outline = hatch_outline(grid)
    if outline is None:
        return None
    xs, ys = outline
    share = 100.0 * grid.unknown_count / (grid.rows * grid.cols)
    return go.Scatter(
        x=xs,
        y=ys,
        mode="lines",
        line={"width": 0, "color": UNKNOWN_LINE},
        fill="toself",
        fillcolor=UNKNOWN_FILL,
        fillpattern={
            "shape": "/",
            "fgcolor": UNKNOWN_LINE,
            "bgcolor": UNKNOWN_FILL,
            "size": 10,
            "solidity": 0.3,
            "fgopacity": 1.0,
        },
        name=f"{UNKNOWN_NAME}: {share:.1f} % of the map",
        hoverinfo="name",
        hoveron="fills",
        legendgroup="unknown",
    )


def scene_hatch(
    xs: npt.NDArray[np.float64],
    ys: npt.NDArray[np.float64],
    heights: npt.NDArray[np.float64],
    unknown: BoolArray,
    relief: float,
) -> list[Any]:
    """The 3D scene's unknown terrain over the decimated grid (``xs``, ``ys`` its centres,
    ``heights`` the filled heights, ``unknown`` its mask): a grey surface over the unknown
    cells and their neighbours (no seam with the measured surface) and diagonal hatch lines
    draped over it, lifted a little above it.  Empty when nothing is unknown."""
    import plotly.graph_objects as go
    from scipy.ndimage import binary_dilation

    if not unknown.any():
        return []
    near = binary_dilation(unknown, structure=np.ones((3, 3), dtype=bool))
    z = np.where(near, heights, np.nan)
    surface = go.Surface(
        x=xs,
        y=ys,
        z=z,
        surfacecolor=np.zeros_like(z),
        colorscale=[[0.0, "rgb(150,150,150)"], [1.0, "rgb(150,150,150)"]],
        showscale=False,
        opacity=1.0,
        name=UNKNOWN_NAME,
        legendgroup="unknown",
        showlegend=True,
        hovertemplate="x %{x:.0f} m, y %{y:.0f} m<br>unknown terrain (filled %{z:.0f} m)"
        "<extra></extra>",
        lighting={"ambient": 0.8, "diffuse": 0.5, "specular": 0.0},
    )
    rows, cols = unknown.shape
    every = max(1, math.ceil(max(rows, cols) / HATCH_LINES))
    lift = 0.004 * max(relief, 1.0)
    px: list[float] = []
    py: list[float] = []
    pz: list[float] = []
    for d in range(0, rows + cols - 1, every):
        r = np.arange(max(0, d - cols + 1), min(rows, d + 1))
        c = d - r
        zz = np.where(unknown[r, c], heights[r, c] + lift, np.nan)
        if not np.isfinite(zz).any():
            continue
        px += [*xs[c].tolist(), math.nan]
        py += [*ys[r].tolist(), math.nan]
        pz += [*zz.tolist(), math.nan]
    lines = go.Scatter3d(
        x=px,
        y=py,
        z=pz,
        mode="lines",
        line={"color": UNKNOWN_LINE, "width": 2},
        connectgaps=False,
        name=f"{UNKNOWN_NAME}: hatch",
        legendgroup="unknown",
        showlegend=False,
        hoverinfo="skip",
    )
    return [surface, lines]


__all__ = [
    "MAX_BLOCKS",
    "UNKNOWN_NAME",
    "hatch_outline",
    "map_hatch",
    "scene_hatch",
    "unknown_rectangles",
]
