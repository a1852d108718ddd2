"""How the view tells things apart, the same in its three tabs: one colour and one marker symbol
per run (by its place among the sources), one line style per threat (by its place among the
threats of every run); the legends outside the plot area, below it, with a button that hides and
shows them; labels dark on a light box (WCAG contrast of at least 4.5:1 whatever lies under
them).
"""

from __future__ import annotations

from typing import Any

# runs stand out from the green-brown terrain and from the red of violations
RUN_COLOURS = ("#1f4fff", "#111111", "#c51b7d", "#00a5c8", "#ffb000", "#6a3d9a", "#8c564b")
# a distinct marker per run; names plotly's 2-D and 3D scatters both know
RUN_SYMBOLS = ("circle", "square", "diamond", "x", "cross", "circle-open", "square-open")
# one line style per threat (its outline on the map and in the scene, its separation lines)
THREAT_DASHES = ("solid", "dot", "dash", "dashdot", "longdashdot", "8px,3px,2px,3px,2px,3px")
THREAT_COLOUR = "#9467bd"
LABEL_TEXT = "#1a1a1a"
LABEL_BOX = "rgba(255,255,255,0.92)"  # over the darkest terrain: contrast above 14:1
LEGEND_GAP = 0.02  # between the plot area and the legend below it (a share of the plot's height)


def run_style(place: int) -> tuple[str, str]:
    """The colour and marker symbol of the run at ``place`` among the sources."""
    return RUN_COLOURS[place % len(RUN_COLOURS)], RUN_SYMBOLS[place % len(RUN_SYMBOLS)]


def threat_dash(place: int) -> str:
    return THREAT_DASHES[place % len(THREAT_DASHES)]


def label(**kw: Any) -> dict[str, Any]:
    """An annotation's look: dark text on a near-opaque white box with a thin border."""
    out: dict[str, Any] = {
        "font": {"color": LABEL_TEXT, "size": 12},
        "bgcolor": LABEL_BOX,
        "bordercolor": "#555555",
        "borderwidth": 1,
        "borderpad": 3,
    }
    out.update(kw)
    return out


def legend_below(y: float = -LEGEND_GAP) -> dict[str, Any]:
    """A horizontal legend under the plot area (it wraps to the figure's width and pushes the
    bottom margin: it never covers data), its groups toggled by a click."""
    return {
        "orientation": "h",
        "x": 0.0,
        "xanchor": "left",
        "y": y,
        "yanchor": "top",
        "bgcolor": "rgba(255,255,255,1)",
        "bordercolor": "#cccccc",
        "borderwidth": 1,
        "font": {"size": 11, "color": LABEL_TEXT},
        "groupclick": "togglegroup",
        "itemsizing": "constant",
        "title": {"text": "click an entry to hide or show it", "font": {"size": 11}, "side": "top"},
    }


def legend_button(x: float = 1.0, y: float = 1.0) -> dict[str, Any]:
    """A button (in the top margin, left of plotly's toolbar) that hides and shows the legend."""
    return {
        "type": "buttons",
        "showactive": False,
        "x": x,
        "y": y,
        "xanchor": "right",
        "yanchor": "bottom",
        "pad": {"r": 190, "b": 4},
        "bgcolor": "white",
        "bordercolor": "#888888",
        "font": {"size": 11, "color": LABEL_TEXT},
        "buttons": [
            {
                "label": "legend: hide / show",
                "method": "relayout",
                "args": [{"showlegend": False}],
                "args2": [{"showlegend": True}],
            }
        ],
    }


__all__ = [
    "LABEL_BOX",
    "LABEL_TEXT",
    "RUN_COLOURS",
    "RUN_SYMBOLS",
    "THREAT_COLOUR",
    "THREAT_DASHES",
    "label",
    "legend_below",
    "legend_button",
    "run_style",
    "threat_dash",
]
