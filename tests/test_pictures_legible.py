"""The static pictures read at a glance (issue 37): a plan or a run over a small part of a large map
is shown zoomed onto it with the colours of the heights shown (unknown terrain still greyed and
hatched), labels stand on a halo with a WCAG contrast of at least 4.5:1, the separation panel
shows how deep each violation went and for which threat, and "no threats" is said only when a run
had neither threats nor danger zones. Asserted on the matplotlib figures themselves."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from matplotlib.colors import to_rgba

from planner.plot import plan_figure
from replay.record.picture import RunView, run_figure
from replay.threats.kinds import StaticThreat
from terrain.grid import HeightGrid
from terrain.plot import SERIES_COLOURS, UNKNOWN_HATCH, UNKNOWN_LABEL
from terrain.synthetic import synthetic_terrain
from terrain.zones import DangerZone
from tests.browser import contrast

KM = 1000.0
FILLED = 9000.0  # the filled height of the unknown block: far above any measured height


def _worst_contrast(text: Any) -> float:
    """The text colour against its halo (a path effect's stroke) or its box; a translucent box
    counted over black and over white, whichever is worse."""
    fg = to_rgba(text.get_color())
    backs = []
    for effect in text.get_path_effects():
        # matplotlib keeps a Stroke's graphics-context settings (its foreground) in _gc
        stroke = getattr(effect, "_gc", {})
        if "foreground" in stroke:
            backs.append(to_rgba(stroke["foreground"]))
    box = text.get_bbox_patch()
    if box is not None:
        backs.append(box.get_facecolor())
    assert backs, f"label {text.get_text()!r} has neither a halo nor a box"
    worst = np.inf
    for back in backs:
        alpha = back[3]
        for under in (np.zeros(3), np.ones(3)):
            seen = alpha * np.asarray(back[:3]) + (1.0 - alpha) * under
            worst = min(worst, float(contrast(fg[:3], seen)))
    return worst


def _long_map() -> HeightGrid:
    """640 x 320 km of 1 km cells (a Rhine-sized map), UTM 32N, with a 6 x 4 km block of unknown
    terrain on the plan's way, filled far above every measured height."""
    g = synthetic_terrain(320, 640, 1000.0, seed=5, relief=2500.0, origin=(200e3, 5000e3),
                          crs="EPSG:32632")  # fmt: skip
    known = np.ones(g.shape, dtype=bool)
    r, c = g.cell_of(np.array([330e3]), np.array([5155e3]))
    known[int(r[0]) : int(r[0]) + 4, int(c[0]) : int(c[0]) + 6] = False
    heights = np.where(known, g.heights, FILLED)
    return HeightGrid(heights, g.transform, g.crs, known=known)


def _plan(grid: HeightGrid) -> np.ndarray:
    """A 65 km plan in the middle of the long map, 3000 m AMSL."""
    return np.array([[300e3, 5150e3, 3000.0], [330e3, 5160e3, 3000.0], [362e3, 5170e3, 3000.0]])


def _measured_in(grid: HeightGrid, xlim: Any, ylim: Any) -> tuple[float, float]:
    """Lowest and highest measured height of the cells that overlap the box."""
    x0, _, _, y1 = grid.bounds
    dx, dy = grid.cell_size
    cols = x0 + dx * np.arange(grid.cols)  # west edges
    rows = y1 - dy * np.arange(grid.rows)  # north edges
    in_x = (cols + dx > xlim[0]) & (cols < xlim[1])
    in_y = (rows > ylim[0]) & (rows - dy < ylim[1])
    win = np.ix_(in_y, in_x)
    assert grid.known is not None
    h = grid.heights[win][grid.known[win]]
    return float(h.min()), float(h.max())


def _assert_zoomed_with_its_colours(grid: HeightGrid, ax: Any, flight: np.ndarray) -> None:
    xmin, ymin, xmax, ymax = grid.bounds
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    # the flight inside the limits, the limits a small part of the map
    assert x0 <= flight[:, 0].min() and flight[:, 0].max() <= x1
    assert y0 <= flight[:, 1].min() and flight[:, 1].max() <= y1
    assert (x1 - x0) < 0.2 * (xmax - xmin) and (y1 - y0) < 0.4 * (ymax - ymin)
    image = ax.images[0]
    lo, hi = _measured_in(grid, (x0, x1), (y0, y1))
    assert image.get_clim() == pytest.approx((lo, hi), abs=1e-3)
    assert hi < FILLED  # the filled unknown block does not stretch the scale
    assert (hi - lo) < 0.8 * (grid.heights[grid.known].max() - grid.heights[grid.known].min())
    assert image.colorbar is not None  # the colour bar is the image's: its scale
    assert (image.colorbar.vmin, image.colorbar.vmax) == pytest.approx((lo, hi), abs=1e-3)
    # the shown part only is drawn (not the 640 km map behind the limits)
    ix0, ix1, iy0, iy1 = image.get_extent()
    assert ix0 <= x0 and x1 <= ix1 and iy0 <= y0 and y1 <= iy1
    assert ix1 - ix0 <= x1 - x0 + 2 * grid.cell_size[0]
    # unknown terrain greyed (every unknown cell of the block) and hatched in the zoomed window
    overlay = ax.images[1].get_array()
    assert int((overlay[..., 3] > 0).sum()) == int((~grid.known).sum()) == 24
    hatched = [c for c in ax.collections if UNKNOWN_HATCH in (getattr(c, "hatches", None) or [])]
    assert len(hatched) == 1
    assert UNKNOWN_LABEL in ax.get_legend_handles_labels()[1]


def test_a_65_km_plan_on_a_640_km_map_is_zoomed_with_the_colours_it_shows() -> None:
    grid = _long_map()
    path = _plan(grid)
    zones = (DangerZone(340e3, 5150e3, 4000.0, id="sam", top=4200.0),)
    fig = plan_figure(grid, path, zones, title="long")
    ax = fig.axes[0]
    _assert_zoomed_with_its_colours(grid, ax, path)
    (label,) = ax.texts
    assert label.get_text() == "sam top 4200 m" and _worst_contrast(label) >= 4.5
    assert "shown: " in ax.get_title() and "of the 640 km x 320 km map" in ax.get_title()

    # a plan across the map shows the whole map and its whole (measured) scale
    across = np.array([[210e3, 5010e3, 3000.0], [830e3, 5300e3, 3000.0]])
    ax = plan_figure(grid, across).axes[0]
    assert ax.get_xlim() == grid.bounds[0::2] and ax.get_ylim() == grid.bounds[1::2]
    measured = grid.heights[grid.known]
    assert ax.images[0].get_clim() == pytest.approx((measured.min(), measured.max()), abs=1e-3)


def test_a_flight_smaller_than_a_cell_is_shown_on_a_few_cells() -> None:
    grid = _long_map()
    hover = np.array([[500e3, 5150e3, 3000.0], [500e3, 5150.1e3, 3000.0]])  # 100 m, 1 km cells
    ax = plan_figure(grid, hover).axes[0]
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert x1 - x0 == pytest.approx(4 * KM) and y1 - y0 == pytest.approx(4 * KM)
    assert x0 < 500e3 < x1 and y0 < 5150e3 < 5150.1e3 < y1
    lo, hi = _measured_in(grid, (x0, x1), (y0, y1))
    assert ax.images[0].get_clim() == pytest.approx((lo, hi), abs=1e-3)


def _view(
    grid: HeightGrid | None,
    path: np.ndarray,
    threats: tuple[Any, ...] = (),
    zones: tuple[DangerZone, ...] = (),
    margin: float = 0.0,
) -> RunView:
    """A run flying ``path`` at 50 m/s, sampled every second."""
    legs = np.linalg.norm(np.diff(path, axis=0), axis=1)
    along = np.concatenate([[0.0], np.cumsum(legs)])
    t = np.arange(0.0, along[-1] / 50.0, 1.0)
    xyz = np.column_stack([np.interp(t * 50.0, along, path[:, k]) for k in range(3)])
    mission = SimpleNamespace(danger_zones=zones, terrain=None)
    return RunView("run.mcap: none, FAILED", mission, grid, "", threats, t, xyz, path, path,
                   (), margin, np.full(len(t), 50.0), np.zeros(len(t)))  # fmt: skip


def _panel(fig: Any) -> Any:
    (ax,) = [a for a in fig.axes if a.get_ylabel().startswith("separation")]
    return ax


def test_a_run_on_a_large_map_is_zoomed_and_its_threat_labels_read() -> None:
    grid = _long_map()
    path = _plan(grid)
    threats = (
        StaticThreat(id="drone", center=(315e3, 5155e3, 3000.0), radius=3000.0),
        StaticThreat(id="balloon", center=(346e3, 5166e3, 3400.0), radius=1500.0),
    )
    zone = DangerZone(340e3, 5150e3, 4000.0, id="sam")
    fig = run_figure(_view(grid, path, threats, (zone,)))
    ax = fig.axes[0]
    _assert_zoomed_with_its_colours(grid, ax, path)
    labels = {t.get_text(): t for t in ax.texts}
    assert {"drone", "balloon", "sam"} <= set(labels)
    for text in ax.texts:  # threat and zone labels over the terrain
        assert _worst_contrast(text) >= 4.5, text.get_text()
    # a threat's circle on the map in the colour of its line in the separation panel
    lines = {ln.get_label(): ln for ln in _panel(fig).get_lines()}
    for name in ("drone", "balloon"):
        assert to_rgba(labels[name].get_color()) == to_rgba(lines[name].get_color())
    for text in _panel(fig).texts:  # the labels at each minimum
        assert _worst_contrast(text) >= 4.5, text.get_text()


def test_the_series_colours_read_on_white_and_differ() -> None:
    assert len(set(SERIES_COLOURS)) == len(SERIES_COLOURS) >= 8
    for colour in SERIES_COLOURS:
        assert contrast(to_rgba(colour)[:3], (1, 1, 1)) >= 4.5, colour


def test_the_separation_panel_shows_how_deep_and_which_threat() -> None:
    path = np.array([[0.0, 0.0, 200.0], [0.0, 6000.0, 200.0]])
    threats = (  # on the path: 300 m deep; 100 m beside it: 150 m deep; a near miss
        StaticThreat(id="drone", center=(0.0, 1500.0, 200.0), radius=300.0),
        StaticThreat(id="balloon", center=(100.0, 3000.0, 200.0), radius=250.0),
        StaticThreat(id="kite", center=(400.0, 4500.0, 200.0), radius=250.0),
    )
    fig = run_figure(_view(None, path, threats, margin=20.0))
    ax = _panel(fig)
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    depth = {"drone": -300.0, "balloon": -150.0, "kite": 150.0}
    for name, low in depth.items():
        drawn = np.asarray(lines[name].get_ydata(), dtype=np.float64)
        assert np.nanmin(drawn) == pytest.approx(low, abs=1.0)  # the negative separations drawn
        label = [t for t in ax.texts if t.get_text().startswith(f"{name} ")]
        assert len(label) == 1 and label[0].get_text() == f"{name} {low:.0f} m"
        assert label[0].xy[1] == pytest.approx(low, abs=1.0)  # at its minimum
    colours = {to_rgba(lines[n].get_color()) for n in depth}
    assert len(colours) == 3  # each threat its own colour
    bottom, top = ax.get_ylim()
    assert bottom < -300.0 and top >= 0.3 * 300.0  # the deepest inside, room above the surface
    surface = lines["surface (safety radius)"]
    assert list(surface.get_ydata()) == [0.0, 0.0]
    assert list(lines["margin 20 m"].get_ydata()) == [20.0, 20.0]
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert {"drone", "balloon", "kite", "surface (safety radius)"} <= set(legend)

    # every threat violated (the panel was once capped just above zero): room above the surface
    # to see each approach, and the deepest still inside
    bottom, top = _panel(run_figure(_view(None, path, threats[:2]))).get_ylim()
    assert bottom < -300.0 and top >= 0.3 * 300.0


def _all_text(fig: Any) -> str:
    texts = [t.get_text() for t in fig.findobj(lambda a: hasattr(a, "get_text"))]
    return "\n".join(texts)


def test_no_threats_only_when_there_are_neither_threats_nor_zones() -> None:
    path = np.array([[0.0, 0.0, 200.0], [0.0, 6000.0, 200.0]])
    zones = (DangerZone(700.0, 3000.0, 1000.0, id="sam"),)
    fig = run_figure(_view(None, path, zones=zones))
    assert "no threats" not in _all_text(fig)
    ax = _panel(fig)
    assert ax.get_title() == "no pop-up threats; 1 danger zone"
    (line,) = [ln for ln in ax.get_lines() if ln.get_label() == "zone:sam"]
    assert np.nanmin(line.get_ydata()) == pytest.approx(700.0 - 500.0, abs=0.5)
    assert line.get_linestyle() == "--"  # a zone dashed, a threat solid

    bare = run_figure(_view(None, path))
    assert _panel(bare).texts[0].get_text() == "no threats"


def test_each_violation_is_labelled_with_its_depth() -> None:
    """A threat entered twice: the picture labels each entry's deepest point, and the view's
    separation labels come from the same rule."""
    from replay.record.picture import violation_lows

    v = np.array([5.0, -1.0, -3.0, 2.0, 4.0, -2.0, 1.0, np.nan, -0.5])
    assert violation_lows(v, 0.0) == [2, 5, 8]  # each run below the surface, deepest first
    assert violation_lows(v, 0.0, limit=2) == [2, 5]
    assert violation_lows(v, 1.5) == [2, 5, 8]  # 1.0 at 6 joins no run: 5 and 6 are one
    assert violation_lows(np.array([3.0, np.nan, 2.0]), 0.0) == []
    # a path through the same threat's sphere, out, and back through it
    path = np.array([[0.0, 0.0, 200.0], [0.0, 3000.0, 200.0], [3000.0, 3000.0, 200.0],
                     [3000.0, 1400.0, 200.0], [-400.0, 1400.0, 200.0]])  # fmt: skip
    threats = (StaticThreat(id="drone", center=(0.0, 1500.0, 200.0), radius=300.0),)
    ax = _panel(run_figure(_view(None, path, threats)))
    labels = sorted((t.get_text(), t.xy[0]) for t in ax.texts if t.get_text().startswith("drone "))
    # through the centre (300 m deep) on the first leg, 100 m off it (200 m deep) on the last
    assert [text for text, _ in labels] == ["drone -200 m", "drone -300 m"]
    assert labels[0][1] > labels[1][1]  # the second entry later
