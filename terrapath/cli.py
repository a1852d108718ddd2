"""The `terrapath` command: one click group, one module per subcommand.

Errors that terrapath raises on purpose (:class:`terrain.errors.TerrapathError`) are printed as
one line on stderr and exit with status 1; usage errors exit with 2 (click's convention).

Signals: SIGINT (Ctrl-C), SIGTERM and SIGHUP all end a command the same way -- as an interrupt
(:class:`Terminated` is a ``KeyboardInterrupt``), so every output being written is removed
(``terrain.atomic``: no ``.part`` is left) and a campaign ends its workers -- and exit with the
shell's status for the signal: 130 (SIGINT), 143 (SIGTERM), 129 (SIGHUP).
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
import threading
from collections.abc import Iterator

import click

from terrain.errors import TerrapathError
from terrapath import __version__
from terrapath.commands.bench import bench_cmd
from terrapath.commands.campaign import campaign_cmd
from terrapath.commands.check import check_cmd
from terrapath.commands.hillshade import hillshade
from terrapath.commands.info import info
from terrapath.commands.inspect import inspect_cmd
from terrapath.commands.layout import layout_cmd
from terrapath.commands.plan import plan_cmd
from terrapath.commands.plugins import plugins_cmd
from terrapath.commands.regress import regress_cmd
from terrapath.commands.replay import replay_cmd
from terrapath.commands.report import report_cmd
from terrapath.commands.view import view_cmd

EXIT_ERROR = 1
EXIT_SIGNAL_BASE = 128  # the shell's convention: 128 + the signal's number
# SIGHUP is POSIX only
ENDING_SIGNALS = tuple(getattr(signal, n) for n in ("SIGTERM", "SIGHUP") if hasattr(signal, n))


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised where the program is, as Ctrl-C raises KeyboardInterrupt."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def _raise_terminated(signum: int, frame: object) -> None:
    raise Terminated(signum)


@contextlib.contextmanager
def _signals_interrupt() -> Iterator[None]:
    """SIGTERM and SIGHUP raise :class:`Terminated` while a command runs (the previous handlers
    are put back after it: tests call :func:`main` in their own process)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {sig: signal.signal(sig, _raise_terminated) for sig in ENDING_SIGNALS}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="terrapath")
@click.option("-v", "--verbose", count=True, help="More log output (repeatable).")
@click.option("-q", "--quiet", is_flag=True, help="Only errors.")
def cli(verbose: int, quiet: bool) -> None:
    """Terrain-aware path planning and 6-DOF replay for fixed-wing and multirotor UAVs."""
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
cli.add_command(check_cmd)
cli.add_command(inspect_cmd)
cli.add_command(layout_cmd)
cli.add_command(view_cmd)
cli.add_command(campaign_cmd)
cli.add_command(report_cmd)
cli.add_command(bench_cmd)
cli.add_command(regress_cmd)
cli.add_command(plugins_cmd)


def main(argv: list[str] | None = None) -> int:
    """Console entry point: run the group, turn TerrapathError into a one-line message."""
    try:
        with _signals_interrupt():
            rv = cli.main(args=argv, prog_name="terrapath", standalone_mode=False)
    except TerrapathError as exc:
        click.echo(f"terrapath: error: {exc}", err=True)
        return EXIT_ERROR
    except (click.exceptions.Abort, KeyboardInterrupt) as exc:
        cause = exc if isinstance(exc, Terminated) else exc.__cause__
        if isinstance(cause, Terminated):
            click.echo(f"terrapath: terminated ({signal.Signals(cause.signum).name})", err=True)
            return EXIT_SIGNAL_BASE + cause.signum
        click.echo("terrapath: aborted", err=True)
        return EXIT_SIGNAL_BASE + signal.SIGINT
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
