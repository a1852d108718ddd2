"""``terrapath view``: one self-contained, interactive HTML view of plans and flights (a 3D scene
with a time slider, a 2-D map, time plots), drawn with plotly.  See :mod:`terrapath.view.page`."""

from terrapath.view.page import page_html, write_view

__all__ = ["page_html", "write_view"]
