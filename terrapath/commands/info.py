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
    """Summarise DEM tile(s): CRS, size, cell size, elevation range, filled nodata, bounds."""
    grid = load_grid(dem, **opts)
    s = grid.summary()
    if as_json:
        click.echo(json.dumps(s, indent=2))
        return
    dx, dy = s["cell_size_m"]
    e = s["elevation_m"]
    lines = [
        f"sources        {', '.join(s['sources'])}",
        f"crs            {s['crs']}",
        f"size           {s['rows']} rows x {s['cols']} cols",
        f"cell size      {dx:.3f} x {dy:.3f} m",
        f"elevation      {e['min']:.1f} .. {e['max']:.1f} m (mean {e['mean']:.1f})",
        f"nodata filled  {s['nodata_filled']} cells"
        f" ({100.0 * s['nodata_filled'] / (s['rows'] * s['cols']):.1f} %)",
        "bounds (map)   x {:.2f} .. {:.2f}, y {:.2f} .. {:.2f} m".format(
            s["bounds_map"][0], s["bounds_map"][2], s["bounds_map"][1], s["bounds_map"][3]
        ),
    ]
    ll = s["bounds_lonlat"]
    lines.append(
        f"bounds (lon/lat) lon {ll[0]:.5f} .. {ll[2]:.5f}, lat {ll[1]:.5f} .. {ll[3]:.5f}"
        if ll
        else "bounds (lon/lat) none: local metres, no georeference"
    )
    click.echo("\n".join(lines))
