"""The picture of a plan: the path over the tinted hillshade (with zones, start and goal) and its
altitude profile over the terrain beneath it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt

from planner.profile import sample_path
from terrain.grid import HeightGrid
from terrain.plot import draw_hillshade, draw_zones, new_figure, save_figure
from terrain.zones import Zone


def save_plan_picture(
    grid: HeightGrid,
    path: npt.NDArray[np.float64],
    out: str | Path,
    zones: tuple[Zone, ...] = (),
    title: str = "",
    clearance: float = 0.0,
    feasible: bool = True,
) -> Path:
    """Write the map + profile PNG of a planned path."""
    xmin, ymin, xmax, ymax = grid.bounds
    aspect = (ymax - ymin) / (xmax - xmin)
    width = 9.0
    map_h = max(3.5, min(width * aspect, 12.0))
    fig = new_figure(width, map_h + 3.4)
    gs = fig.add_gridspec(2, 1, height_ratios=[map_h, 2.6])
    ax = fig.add_subplot(gs[0])
    draw_hillshade(fig, ax, grid, title or None)
    if zones:
        draw_zones(ax, zones)
    colour = "#d62728" if not feasible else "#ffffff"
    ax.plot(path[:, 0], path[:, 1], "-", color="black", lw=3.2, zorder=3)
    ax.plot(path[:, 0], path[:, 1], "-o", color=colour, lw=1.6, ms=4, zorder=4, label="path")
    ax.plot(
        *path[0, :2],
        marker="^",
        color="#2ca02c",
        ms=11,
        mec="black",
        zorder=5,
        ls="",
        label="start",
    )
    ax.plot(
        *path[-1, :2],
        marker="*",
        color="#ffdd00",
        ms=15,
        mec="black",
        zorder=5,
        ls="",
        label="goal",
    )
    ax.legend(loc="upper right", fontsize=8, framealpha=0.85)

    ax2 = fig.add_subplot(gs[1])
    samples = sample_path(grid, path)
    d, z, g = samples.distance, samples.points[:, 2], samples.ground
    ax2.fill_between(
        d / 1000.0,
        grid.zmin - 0.02 * (grid.zmax - grid.zmin + 1),
        g,
        color="#8c6d46",
        alpha=0.8,
        label="terrain",
    )
    if clearance > 0:
        ax2.plot(
            d / 1000.0,
            g + clearance,
            "--",
            color="#8c6d46",
            lw=1,
            label=f"terrain + {clearance:g} m",
        )
    ax2.plot(d / 1000.0, z, "-", color="#1f77b4", lw=2, label="path")
    below = z < g + clearance
    if below.any():
        ax2.plot(
            d[below] / 1000.0,
            z[below],
            ".",
            color="#d62728",
            ms=3,
            label="below terrain + clearance" if clearance > 0 else "below terrain",
        )
    ax2.set_xlabel("distance along the path (km)")
    ax2.set_ylabel("altitude (m AMSL)")
    ax2.set_xlim(0, d[-1] / 1000.0 if d[-1] > 0 else 1)
    ax2.grid(alpha=0.3)
    ax2.legend(loc="upper right", fontsize=8, ncol=4)
    return save_figure(fig, out)
