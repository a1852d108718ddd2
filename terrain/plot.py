"""Pictures of a height grid: hillshade over hypsometric tint, in map coordinates.

Uses matplotlib's object API (``Figure`` + Agg canvas), never pyplot's global state, so it is safe
in tests, workers and headless machines.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from terrain.atomic import atomic_output
from terrain.grid import HeightGrid, crs_label


def hillshade(
    grid: HeightGrid, azimuth: float = 315.0, altitude: float = 45.0, exaggeration: float = 1.0
) -> npt.NDArray[np.float64]:
    """Illumination in [0, 1] of each cell for a sun at ``azimuth`` (deg clockwise from north) and
    ``altitude`` (deg above the horizon), from the terrain's true metric slopes."""
    dx, dy = grid.cell_size
    z = grid.heights.astype(np.float64) * exaggeration
    # rows run south, so d/dy(north) = -d/drow
    dz_drow, dz_dcol = np.gradient(z, dy, dx)
    gx, gy = dz_dcol, -dz_drow
    slope = np.arctan(np.hypot(gx, gy))
    aspect = np.arctan2(-gx, -gy)  # direction the slope faces, clockwise from north
    az, alt = np.radians(azimuth), np.radians(altitude)
    shade = np.sin(alt) * np.cos(slope) + np.cos(alt) * np.sin(slope) * np.cos(az - aspect)
    return np.asarray(np.clip(shade, 0.0, 1.0))


def draw_hillshade(fig: Any, ax: Any, grid: HeightGrid, title: str | None = None) -> None:
    """Draw the tinted hillshade of ``grid`` on ``ax`` in map metres, with an elevation colour bar."""
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    xmin, ymin, xmax, ymax = grid.bounds
    relief = max(grid.zmax - grid.zmin, 1e-6)
    norm = Normalize(grid.zmin, grid.zmin + relief)
    cmap = colormaps["gist_earth"]
    tint = cmap(norm(grid.heights))[..., :3]
    shade = hillshade(grid)[..., None]
    rgb = np.clip(tint * (0.35 + 0.65 * shade), 0.0, 1.0)
    ax.imshow(rgb, extent=(xmin, xmax, ymin, ymax), origin="upper", interpolation="bilinear")
    fig.colorbar(
        ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.8, label="elevation (m AMSL)"
    )
    ax.set_xlabel(f"x east (m, {crs_label(grid.crs)})")
    ax.set_ylabel("y north (m)")
    ax.ticklabel_format(style="plain", useOffset=False)
    ax.tick_params(axis="x", labelrotation=30)
    dx = grid.cell_size[0]
    ax.set_title(
        title
        or f"{', '.join(Path(s).name for s in grid.sources) or 'height grid'} — "
        f"{grid.rows} x {grid.cols} cells of {dx:.4g} m, {grid.zmin:.0f}–{grid.zmax:.0f} m"
    )
    ax.set_xlim(xmin, xmax)
    ax.set_ylim(ymin, ymax)


def new_figure(width: float, height: float) -> Any:
    """A matplotlib Figure on an Agg canvas (no pyplot state)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height))
    FigureCanvasAgg(fig)
    return fig


def new_map_figure(
    grid: HeightGrid, title: str | None = None, size: float = 8.0
) -> tuple[Any, Any]:
    """A figure with the tinted hillshade of ``grid`` drawn in map metres; returns (fig, ax)."""
    xmin, ymin, xmax, ymax = grid.bounds
    aspect = (ymax - ymin) / (xmax - xmin)
    fig = new_figure(size, max(3.0, min(size * aspect, 2.0 * size)) + 0.8)
    ax = fig.add_subplot(1, 1, 1)
    draw_hillshade(fig, ax, grid, title)
    return fig, ax


def _zone_label(zone: Any) -> str:
    """``id`` and the altitudes that bound the zone, e.g. ``sam 1200–4500 m``, ``top 800 m``."""
    floor, top = getattr(zone, "floor", None), getattr(zone, "top", None)
    if floor is not None and top is not None:
        alt = f"{floor:.0f}–{top:.0f} m"
    elif top is not None:
        alt = f"top {top:.0f} m"
    elif floor is not None:
        alt = f"floor {floor:.0f} m"
    else:
        alt = ""
    return " ".join(p for p in (getattr(zone, "id", None) or "", alt) if p)


def draw_zones(ax: Any, zones: Sequence[Any]) -> None:
    """Draw danger zones on a map axis: cylinders as circles, polygon zones as their rings (holes
    left open), each labelled with its id and its floor / top where set; the first zone carries
    the one legend entry "danger zone"."""
    from matplotlib.patches import Circle, PathPatch
    from matplotlib.path import Path as MplPath

    style = {"facecolor": (0.9, 0.1, 0.1, 0.25), "edgecolor": "red", "linewidth": 1.2}
    for i, z in enumerate(zones):
        label = "danger zone" if i == 0 else "_nolegend_"
        if getattr(z, "kind", "cylinder") == "polygon":
            verts, codes = [], []
            for ring in z.rings:  # exteriors counter-clockwise, holes clockwise: holes stay open
                verts.extend([*ring.tolist(), ring[0].tolist()])
                codes.extend(
                    [MplPath.MOVETO] + [MplPath.LINETO] * (len(ring) - 1) + [MplPath.CLOSEPOLY]
                )
            ax.add_patch(PathPatch(MplPath(verts, codes), label=label, **style))
        else:
            ax.add_patch(Circle((z.x, z.y), z.diameter / 2.0, label=label, **style))
        text = _zone_label(z)
        if text:
            cx, cy = z.centroid if hasattr(z, "centroid") else (z.x, z.y)
            ax.annotate(
                text,
                (cx, cy),
                ha="center",
                va="center",
                fontsize=7,
                color="darkred",
                annotation_clip=True,
                bbox={"boxstyle": "round,pad=0.15", "fc": (1, 1, 1, 0.6), "ec": "none"},
            )


def save_figure(fig: Any, path: str | Path, dpi: int = 130) -> Path:
    """Save a figure as PNG through a temporary name."""
    out = Path(path)
    with atomic_output(out) as tmp:
        fig.tight_layout()
        fig.savefig(tmp, dpi=dpi, format="png")
    return out


def save_hillshade(
    grid: HeightGrid, path: str | Path, zones: Sequence[Any] = (), title: str | None = None
) -> Path:
    """Write a tinted hillshade PNG of ``grid`` (with danger zones, if given)."""
    fig, ax = new_map_figure(grid, title)
    if zones:
        draw_zones(ax, zones)
    return save_figure(fig, path)
