"""`terrapath report`: a campaign store as Markdown tables and PNG plots."""

from __future__ import annotations

from pathlib import Path

import click

from terrapath.options import output_option


@click.command("report")
@click.argument("store", type=click.Path(dir_okay=False))
@output_option(
    "Folder for index.md, the tables and the plots (created if missing).", directory=True
)
@click.option(
    "--name", default=None, help="Only the campaign of this name (default: all in the store)."
)
def report_cmd(store: str, output: str, name: str | None) -> None:
    """Tables in the papers' layout (one line per row of the study and avoider: success rate with
    its Wilson 95 % interval, PLR, flight time, time per decision) and plots of them against the
    number of obstacles, linked from OUTPUT/index.md."""
    from replay.campaign.report import write_report
    from replay.campaign.store import Store
    from terrain.errors import InputError
    from terrapath import __version__

    if not Path(store).is_file():
        raise InputError(f"{store}: no such store")
    with Store(store, __version__) as db:
        rows = db.rows(spec_name=name)
    if not rows:
        which = f" of campaign {name!r}" if name else ""
        raise InputError(f"{store}: no runs{which} to report")
    index = write_report(rows, output, Path(store).name)
    click.echo(f"wrote {index} ({len(rows)} runs)")
