"""`terrapath info`: what a DEM becomes once loaded."""

from __future__ import annotations

import json
from typing import Any

import click

from terrapath.options import dem_options, json_option, load_grid


@click.command("info")
@dem_options
@json_option
def info(as_json: bool, dem: tuple[str, ...], **opts: Any) -> None:
    """Summarise DEM tile(s): CRS, size, cell size, elevation range (display, safety and raw
    maxima), unknown (filled) cells, bounds and the footprint's corners in lon/lat."""
    grid = load_grid(dem, **opts)
    s = grid.summary()
    if as_json:
        click.echo(json.dumps(s, indent=2))
        return
    click.echo("\n".join(info_lines(s)))


def info_lines(s: dict[str, Any]) -> list[str]:
    """The text form of :meth:`terrain.grid.HeightGrid.summary`."""
    dx, dy = s["cell_size_m"]
    e = s["elevation_m"]
    u = s["unknown"]
    cells = s["rows"] * s["cols"]
    raw = "unknown" if e["max_source"] is None else f"{e['max_source']:.1f} m"
    lines = [
        f"sources        {', '.join(s['sources'])}",
        f"crs            {s['crs']}",
        f"size           {s['rows']} rows x {s['cols']} cols",
        f"cell size      {dx:.3f} x {dy:.3f} m",
        f"elevation      {e['min']:.1f} .. {e['max']:.1f} m (mean {e['mean']:.1f})",
        f"highest        {raw} source, {e['max']:.1f} m grid (display), "
        f"{e['max_safety']:.1f} m safety grid (clearance checks)",
        f"nodata filled  {u['nodata_filled']} cells"
        f" ({100.0 * u['nodata_filled'] / cells:.1f} %): holes inside the source",
        f"outside source {u['outside_source']} cells"
        f" ({100.0 * u['outside_source'] / cells:.1f} %): beyond every source's footprint",
        f"unknown        {u['cells']} of {cells} cells ({100.0 * u['share']:.1f} %) "
        + ("have filled, not measured, heights" if u["cells"] else "(every cell is measured)"),
        "bounds (map)   x {:.2f} .. {:.2f}, y {:.2f} .. {:.2f} m".format(
            s["bounds_map"][0], s["bounds_map"][2], s["bounds_map"][1], s["bounds_map"][3]
        ),
    ]
    ll = s["bounds_lonlat"]
    if ll:
        lines.append(
            f"bounds (lon/lat) lon {ll[0]:.5f} .. {ll[2]:.5f}, lat {ll[1]:.5f} .. {ll[3]:.5f} "
            "(envelope)"
        )
        corners = "; ".join(
            f"{name} {lon:.5f}, {lat:.5f}"
            for name, (lon, lat) in zip(
                ("SW", "SE", "NE", "NW"), s["footprint_lonlat"], strict=True
            )
        )
        lines.append(f"footprint (lon/lat) {corners}")
    else:
        lines.append("bounds (lon/lat) none: local metres, no georeference")
    return lines
