"""`terrapath hillshade`: a picture of a DEM."""

from __future__ import annotations

from typing import Any

import click

from terrapath.options import dem_options, load_grid, output_option, refuse_overwriting


@click.command("hillshade")
@dem_options
@output_option("PNG file to write.")
@click.option(
    "--zones",
    type=click.Path(dir_okay=False),
    default=None,
    help="Danger zones (YAML or GeoJSON) to draw.",
)
def hillshade(dem: tuple[str, ...], output: str, zones: str | None, **opts: Any) -> None:
    """Write a tinted hillshade PNG of DEM tile(s)."""
    from terrain.plot import save_hillshade
    from terrain.zone_file import load_zones

    refuse_overwriting([output], {"DEM": dem, "--zones": [zones] if zones else []})
    grid = load_grid(dem, **opts)
    zlist = load_zones(zones, grid) if zones else ()
    out = save_hillshade(grid, output, zones=zlist)
    click.echo(f"wrote {out}")
