"""The `terrapath` command: one click group, one module per subcommand.

Errors that terrapath raises on purpose (:class:`terrain.errors.TerrapathError`) are printed as
one line on stderr and exit with status 1; usage errors exit with 2 (click's convention).
"""

from __future__ import annotations

import logging
import os
import sys

import click

from terrain.errors import TerrapathError
from terrapath import __version__
from terrapath.commands.bench import bench_cmd
from terrapath.commands.campaign import campaign_cmd
from terrapath.commands.hillshade import hillshade
from terrapath.commands.info import info
from terrapath.commands.inspect import inspect_cmd
from terrapath.commands.layout import layout_cmd
from terrapath.commands.plan import plan_cmd
from terrapath.commands.replay import replay_cmd
from terrapath.commands.report import report_cmd
from terrapath.commands.view import view_cmd

EXIT_ERROR = 1


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="terrapath")
@click.option("-v", "--verbose", count=True, help="More log output (repeatable).")
@click.option("-q", "--quiet", is_flag=True, help="Only errors.")
def cli(verbose: int, quiet: bool) -> None:
    """Terrain-aware path planning and 6-DOF replay for fixed-wing UAVs."""
    level = (
        logging.ERROR
        if quiet
        else (logging.DEBUG if verbose > 1 else logging.INFO if verbose else logging.WARNING)
    )
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")


cli.add_command(info)
cli.add_command(hillshade)
cli.add_command(plan_cmd)
cli.add_command(replay_cmd)
cli.add_command(inspect_cmd)
cli.add_command(layout_cmd)
cli.add_command(view_cmd)
cli.add_command(campaign_cmd)
cli.add_command(report_cmd)
cli.add_command(bench_cmd)


def main(argv: list[str] | None = None) -> int:
    """Console entry point: run the group, turn TerrapathError into a one-line message."""
    try:
        rv = cli.main(args=argv, prog_name="terrapath", standalone_mode=False)
    except TerrapathError as exc:
        click.echo(f"terrapath: error: {exc}", err=True)
        return EXIT_ERROR
    except click.exceptions.Abort:
        click.echo("terrapath: aborted", err=True)
        return 130
    except click.ClickException as exc:
        exc.show()
        return exc.exit_code
    except OSError as exc:  # an unexpected I/O problem still gets one line, not a traceback
        if os.environ.get("TERRAPATH_DEBUG"):
            raise
        click.echo(f"terrapath: error: {exc}", err=True)
        return EXIT_ERROR
    return rv if isinstance(rv, int) else 0


def run() -> None:  # pragma: no cover - thin wrapper for the console script
    sys.exit(main())


if __name__ == "__main__":  # pragma: no cover
    run()
