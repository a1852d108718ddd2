"""`terrapath view`: an interactive HTML view of missions and replays."""

from __future__ import annotations

import click

from terrapath.options import dem_tiles_option, output_option
from terrapath.view.figures import COLOR_BY


@click.command("view")
@click.argument("sources", nargs=-1, required=True, type=click.Path(dir_okay=False))
@output_option("The HTML file to write.", default="view.html")
@click.option(
    "--exaggeration",
    type=click.FloatRange(min=0.1, max=50.0),
    default=2.0,
    show_default=True,
    help="Vertical exaggeration of the 3D scene (1: true aspect); hover values stay true.",
)
@click.option(
    "--color-by",
    type=click.Choice(COLOR_BY),
    default=None,
    help="Colour the flown trajectory by time, by height above the terrain, or by run "
    "(default: time for one run, run for several).",
)
@dem_tiles_option(
    "DEM tile of a mission of another tool (.plan, .waypoints, GeoJSON, KML; repeat for "
    "several tiles)."
)
def view_cmd(
    sources: tuple[str, ...],
    output: str,
    exaggeration: float,
    color_by: str | None,
    dem_tiles: tuple[str, ...],
) -> None:
    """Write one self-contained HTML file that opens offline in any browser: the terrain in 3D
    with danger zones, the planned path, each flown trajectory, the threats (from their
    appearance time) and the avoiders' decisions, with a time slider and play button; a 2-D map
    tab; a tab of time plots (altitude and terrain, airspeed, bank, separation to each threat).

    SOURCES are mission YAMLs (from terrapath plan), missions of other tools (a
    QGroundControl .plan, a .waypoints file, a GeoJSON or KML path: give --dem) or replay MCAPs
    of one map: several runs of one scenario (e.g. with different avoiders) are drawn together
    to compare."""
    from terrapath.view.page import write_view

    if not output.lower().endswith((".html", ".htm")):
        raise click.BadParameter(f"the view must end in .html; got {output!r}", param_hint="-o")
    out = write_view(
        list(sources),
        output,
        exaggeration=exaggeration,
        color_by=color_by,
        dem=tuple(dem_tiles),
    )
    size = out.stat().st_size / 1e6
    click.echo(f"wrote {out} ({size:.1f} MB): open it in a browser")
