"""`terrapath layout`: a Foxglove layout for terrapath's runs."""

from __future__ import annotations

import click

from terrapath.options import output_option


@click.command("layout")
@output_option("Write the layout to this JSON file (default: print it).", required=False)
def layout_cmd(output: str | None) -> None:
    """Print (or write) a Foxglove layout for replay MCAPs: a 3D panel in the map frame following
    the aircraft, with the terrain, threats, path, radar detections and the avoider's orbits;
    plots of altitude, airspeed and bank against their commands; the avoidance decisions.
    Import it in Foxglove with Layouts -> Import from file."""
    from replay.record.foxglove_layout import layout_json, write_layout

    if output is None:
        click.echo(layout_json(), nl=False)
        return
    if not output.lower().endswith(".json"):
        raise click.BadParameter(f"the layout must end in .json; got {output!r}", param_hint="-o")
    click.echo(f"wrote {write_layout(output)}")
