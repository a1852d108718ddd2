"""The picture of a plan: the path over the tinted hillshade (with zones, start and goal; unknown
terrain hatched; a lon/lat graticule on a georeferenced map) and its altitude profile over the
terrain beneath it (display heights, the safety grid's highest cells, unknown ground hatched).
Legends sit below their panels so they never hide the path, the start or the goal."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.profile import PathSamples, sample_path
from terrain.grid import HeightGrid
from terrain.plot import (
    UNKNOWN_FACE,
    UNKNOWN_HATCH,
    UNKNOWN_LABEL,
    draw_hillshade,
    draw_zones,
    halo,
    legend_below,
    map_window,
    new_figure,
    save_figure,
)
from terrain.zones import Zone


def save_plan_picture(
    grid: HeightGrid,
    path: npt.NDArray[np.float64],
    out: str | Path,
    zones: tuple[Zone, ...] = (),
    title: str = "",
    clearance: float = 0.0,
    feasible: bool = True,
    flown: npt.NDArray[np.float64] | None = None,
    explored: list[npt.NDArray[np.float64]] | None = None,
) -> Path:
    """Write the map + profile PNG of a planned path (:func:`plan_figure`)."""
    fig = plan_figure(grid, path, zones, title, clearance, feasible, flown, explored)
    return save_figure(fig, out)


def plan_figure(
    grid: HeightGrid,
    path: npt.NDArray[np.float64],
    zones: tuple[Zone, ...] = (),
    title: str = "",
    clearance: float = 0.0,
    feasible: bool = True,
    flown: npt.NDArray[np.float64] | None = None,
    explored: list[npt.NDArray[np.float64]] | None = None,
) -> Any:
    """The map + profile figure of a planned path: the waypoints, and the path the aircraft
    flies through them (``flown``, legs joined by turn fillets; default the polyline itself),
    which the profile follows; ``explored``: the seeds the map search gave the swarm, each the
    free waypoints of a route (drawn thin and dashed, start and goal joined on). A plan over a
    small part of a large map is shown zoomed onto it and its routes
    (:func:`terrain.plot.map_window`), coloured by the heights shown."""
    track = path if flown is None else np.asarray(flown, dtype=np.float64)
    framed = [np.asarray(path, dtype=np.float64)[:, :2], track[:, :2]]
    framed += [np.asarray(seed, dtype=np.float64)[:, :2] for seed in explored or ()]
    fig, ax, ax2 = _map_and_profile(grid, title, zones, np.vstack(framed))
    _draw_explored(ax, path, explored)
    _draw_path(ax, path, track, feasible)
    legend_below(ax)

    samples = sample_path(grid, track)
    _draw_ground(ax2, grid, samples)
    _draw_profile(ax2, samples, clearance)
    legend_below(ax2)
    return fig


def _map_and_profile(
    grid: HeightGrid, title: str, zones: tuple[Zone, ...], framed: npt.NDArray[np.float64]
) -> Any:
    """(figure, map axes with the hillshade and zones, profile axes below it); the map shows
    the window round ``framed`` (x, y points) when they cover a small part of it."""
    window = map_window(grid, framed)
    xmin, ymin, xmax, ymax = window
    aspect = (ymax - ymin) / (xmax - xmin)
    width = 9.0
    map_h = max(3.5, min(width * aspect, 12.0))
    fig = new_figure(width, map_h + 3.4)
    gs = fig.add_gridspec(2, 1, height_ratios=[map_h, 2.6])
    ax = fig.add_subplot(gs[0])
    draw_hillshade(fig, ax, grid, title or None, window)
    if zones:
        draw_zones(ax, zones)
    return fig, ax, fig.add_subplot(gs[1])


def _draw_explored(
    ax: Any, path: npt.NDArray[np.float64], explored: list[npt.NDArray[np.float64]] | None
) -> None:
    """The routes the map search seeded the swarm with, start and goal joined on."""
    for j, seed in enumerate(explored or ()):
        route = np.vstack([path[:1, :2], np.asarray(seed)[:, :2], path[-1:, :2]])
        ax.plot(route[:, 0], route[:, 1], "--", color="#444444", lw=0.9, zorder=3,
                label="explored routes (the swarm's seeds)" if j == 0 else None)  # fmt: skip


def _draw_path(
    ax: Any, path: npt.NDArray[np.float64], track: npt.NDArray[np.float64], feasible: bool
) -> None:
    """The flown path (red when infeasible), the free waypoints, the start and the goal."""
    from matplotlib.patheffects import Normal, Stroke

    colour = "#d62728" if not feasible else "#ffffff"
    # the black outline is a path effect of the same line, so the legend shows it too
    ax.plot(
        track[:, 0],
        track[:, 1],
        "-",
        color=colour,
        lw=1.6,
        zorder=4,
        label="flown path",
        path_effects=[Stroke(linewidth=3.2, foreground="black"), Normal()],
    )
    if len(path) > 2:
        ax.plot(
            path[1:-1, 0],
            path[1:-1, 1],
            "o",
            color=colour,
            mec="black",
            ms=5,
            zorder=4,
            label="waypoints",
        )
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


def _draw_ground(ax2: Any, grid: HeightGrid, samples: PathSamples) -> None:
    """The terrain under the path in the profile (unknown ground hatched) and the safety grid's
    highest cells."""
    d, g = samples.distance, samples.ground
    floor = grid.zmin - 0.02 * (grid.zmax - grid.zmin + 1)
    ax2.fill_between(d / 1000.0, floor, g, color="#8c6d46", alpha=0.8, label="terrain")
    cells = grid.cell_of(samples.points[:, 0], samples.points[:, 1])
    if grid.known is not None and grid.has_unknown:
        unknown = ~grid.known[cells]
        if unknown.any():
            ax2.fill_between(
                d / 1000.0,
                floor,
                g,
                where=unknown,
                facecolor=UNKNOWN_FACE,
                edgecolor="0.2",
                hatch=UNKNOWN_HATCH,
                lw=0,
                label=UNKNOWN_LABEL,
            )
    if grid.upper is not None:
        ax2.plot(
            d / 1000.0,
            grid.upper[cells],
            "-",
            color="#4a3520",
            lw=0.8,
            label="highest source cell (safety)",
        )


def _draw_profile(ax2: Any, samples: PathSamples, clearance: float) -> None:
    """The path's altitude along it, the clearance line over the terrain and the samples below
    it; the profile's axes."""
    d, z, g = samples.distance, samples.points[:, 2], samples.ground
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


def save_check_picture(
    grid: HeightGrid,
    check: Any,
    waypoints: npt.NDArray[np.float64],
    findings: Any,
    out: str | Path,
    title: str,
    clearance: float,
    zones: tuple[Zone, ...] = (),
) -> Path:
    """The picture of ``terrapath check`` (:mod:`planner.check`): the path as flown over the
    hillshade (red where it is not feasible) with the danger zones, and its altitude profile
    over the terrain beneath it (terrain-frame legs at their height above the ground), each
    violation marked and numbered as the report ranks it on both."""
    ok = not findings
    track = check.flown.points
    framed = np.vstack([np.asarray(waypoints, dtype=np.float64)[:, :2], track[:, :2]])
    fig, ax, ax2 = _map_and_profile(grid, title, zones, framed)
    _draw_path(ax, np.asarray(waypoints, dtype=np.float64), track, ok)
    s = check.samples
    shown = PathSamples(
        s.segment,
        s.distance,
        s.points,
        np.asarray(grid.height_at(s.points[:, 0], s.points[:, 1]), dtype=np.float64),
    )
    _draw_ground(ax2, grid, shown)
    _draw_profile(ax2, PathSamples(s.segment, s.distance, s.points, s.ground), clearance)
    marked = [f for f in findings if np.isfinite(f.x) and np.isfinite(f.y)]
    for n, f in enumerate(marked):
        label = "violation (as ranked)" if n == 0 else None
        ax.plot(f.x, f.y, "X", color="#d62728", mec="black", ms=10, zorder=6, label=label)
        ax.annotate(str(findings.index(f) + 1), (f.x, f.y), xytext=(6, 6),
                    textcoords="offset points", fontsize=9, weight="bold", zorder=7,
                    path_effects=halo())  # fmt: skip
        k = int(np.argmin(np.hypot(s.points[:, 0] - f.x, s.points[:, 1] - f.y)))
        ax2.plot(s.distance[k] / 1000.0, f.z if np.isfinite(f.z) else s.points[k, 2], "X",
                 color="#d62728", mec="black", ms=9, zorder=6)  # fmt: skip
        ax2.annotate(str(findings.index(f) + 1), (s.distance[k] / 1000.0, s.points[k, 2]),
                     xytext=(5, 5), textcoords="offset points", fontsize=8)  # fmt: skip
    legend_below(ax)
    legend_below(ax2)
    return save_figure(fig, out)
