"""``terrapath view``'s page: one self-contained HTML file (plotly.js embedded once, no CDN, no
server) with three tabs -- the 3D scene, the 2-D map, the time plots
(:mod:`terrapath.view.figures`) -- under a header naming each source, its outcome and what was
decimated for display.  Each figure is embedded as JSON and drawn when its tab is first shown
(the page opens with the 3D scene only: the others cost nothing until asked for).  Written
through a temporary name.
"""

from __future__ import annotations

import html
from pathlib import Path
from typing import Any

from terrain.errors import InputError
from terrapath.view.sources import Source, read_sources

TABS = (("scene", "3D scene"), ("map", "2-D map"), ("plots", "time plots"))

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 0; color: #222; }
header { padding: 8px 16px; background: #f4f4f4; border-bottom: 1px solid #ddd; }
header h1 { font-size: 18px; margin: 0 0 4px 0; }
header ul { margin: 2px 0; padding-left: 18px; font-size: 13px; }
header .notes { font-size: 12px; color: #555; }
nav button { font-size: 14px; padding: 6px 14px; margin: 6px 4px 0 0; border: 1px solid #bbb;
             background: white; cursor: pointer; border-radius: 4px 4px 0 0; }
nav button.on { background: #1f77b4; color: white; border-color: #1f77b4; }
.tab { display: none; padding: 4px 8px; }
.tab.on { display: block; }
.failed { color: #d62728; font-weight: bold; }
"""

_SCRIPT = """
// the 3D canvas at the screen's own resolution (plotly draws it at 2x by default: four times
// the pixels on an ordinary screen, for nothing)
const terrapathConfig = {displaylogo: false, responsive: true,
  plotGlPixelRatio: Math.max(1, Math.min(2, window.devicePixelRatio || 1))};
function terrapathDraw(name) {
  const div = document.getElementById('plot-' + name);
  if (div.dataset.drawn) { Plotly.Plots.resize(div); return; }
  div.dataset.drawn = '1';
  const fig = JSON.parse(document.getElementById('figure-' + name).textContent);
  // data-ready: drawn with its frames (what a script driving a browser waits for)
  Plotly.newPlot(div, fig.data, fig.layout, terrapathConfig).then(function () {
    return fig.frames ? Plotly.addFrames(div, fig.frames) : null;
  }).then(function () { div.dataset.ready = '1'; });
}
function terrapathTab(name) {
  for (const el of document.querySelectorAll('.tab')) el.classList.toggle('on', el.id === 'tab-' + name);
  for (const el of document.querySelectorAll('nav button')) el.classList.toggle('on', el.dataset.tab === name);
  terrapathDraw(name);
}
// view.html#map (or #plots) opens on that tab
window.addEventListener('DOMContentLoaded', function () {
  const asked = location.hash.slice(1);
  terrapathTab(document.getElementById('tab-' + asked) ? asked : 'scene');
});
"""


def _figure_html(fig: Any, key: str) -> str:
    """The figure's div and its JSON (plotly's encoding: numpy arrays as typed-array base64)."""
    text = fig.to_json().replace("</", "<\\/")  # nothing in the JSON may close the script
    height = int(fig.layout.height or 700)
    return (
        f'<div id="plot-{key}" class="plotly-graph-div" style="height:{height}px;width:100%"></div>'
        f'<script type="application/json" id="figure-{key}">{text}</script>'
    )


def _source_line(s: Source) -> str:
    text = html.escape(s.label)
    if s.run is not None and not s.run.success:
        text = text.replace("FAILED", '<span class="failed">FAILED</span>')
    extra = html.escape(s.note.strip(" ()")) if s.note else ""
    return f"<li>{text}{' — ' + extra if extra else ''}</li>"


def page_html(sources: list[Source], exaggeration: float = 2.0, color_by: str | None = None) -> str:
    """The whole page as text."""
    import plotly.offline

    from terrapath.view.figures import map_figure, scene_figure, time_figure

    scene, notes = scene_figure(sources, exaggeration, color_by)
    figures = {"scene": scene, "map": map_figure(sources), "plots": time_figure(sources)}
    grid = sources[0].grid
    if grid is not None:
        where = ", ".join(Path(t).name for t in grid.sources) or "height grid"
        notes.insert(
            0, f"map: {where}, {grid.rows} x {grid.cols} cells of {grid.cell_size[0]:.4g} m"
        )
    else:
        notes.insert(0, "flat ground: no DEM (the mission names none, or its tiles were not found)")
    title = " · ".join(s.path.name for s in sources)
    tabs = "".join(
        f'<button data-tab="{key}" class="{"on" if i == 0 else ""}" '
        f"onclick=\"terrapathTab('{key}')\">{label}</button>"
        for i, (key, label) in enumerate(TABS)
    )
    body = "".join(
        f'<div class="tab{" on" if i == 0 else ""}" id="tab-{key}">'
        f"{_figure_html(figures[key], key)}</div>"
        for i, (key, _label) in enumerate(TABS)
    )
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>terrapath view: {html.escape(title)}</title>"
        f"<style>{_STYLE}</style>"
        f"<script>{plotly.offline.get_plotlyjs()}</script>"
        f"<script>{_SCRIPT}</script></head><body>"
        f"<header><h1>terrapath view</h1><ul>{''.join(_source_line(s) for s in sources)}</ul>"
        f'<details class="notes"><summary>what is drawn</summary>'
        f"{'<br>'.join(html.escape(n) for n in notes)}</details>"
        f"<nav>{tabs}</nav></header>{body}</body></html>\n"
    )


def write_view(
    paths: list[str],
    out: str | Path,
    *,
    exaggeration: float = 2.0,
    color_by: str | None = None,
    dem: tuple[str, ...] = (),
) -> Path:
    """Read the SOURCEs (``dem``: the DEM of missions of other tools), build the page, write it
    to ``out`` through a temporary name."""
    from terrain.atomic import atomic_output, output_folder

    target = Path(out)
    output_folder(target, create=False)  # made when the view is written
    if target.is_dir():
        raise InputError(f"{target}: is a folder; give a file name ending in .html")
    sources = read_sources(paths, dem)
    text = page_html(sources, exaggeration, color_by)
    try:
        with atomic_output(target) as tmp:
            tmp.write_text(text, encoding="utf-8")
    except PermissionError:
        raise InputError(f"{target}: cannot write the view there (permission denied)") from None
    return target


__all__ = ["TABS", "page_html", "write_view"]
