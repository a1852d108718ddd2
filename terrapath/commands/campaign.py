"""`terrapath campaign`: a Monte Carlo study of replays, on this machine or a Dask cluster,
resumable, every run in an SQLite store."""

from __future__ import annotations

import os
import shlex
import time
from collections.abc import Callable
from typing import Any, TypeVar

import click

from terrapath.options import decorate
from terrapath.progress import progress_bar
from terrapath.runtext import duration

EXIT_FAILED = 3  # --only: the re-flown run is not a success (as `replay`)
EXIT_ERRORS = 1  # some runs raised (stored as errors)
F = TypeVar("F", bound=Callable[..., Any])


def executor_options(f: F) -> F:
    """--jobs, --dask-local, --scheduler, --keep-mcap, --mcap-dir (campaign and bench)."""
    decorators = [
        click.option(
            "--jobs",
            type=click.IntRange(min=1),
            default=None,
            help="Processes (or Dask workers with --dask-local); default: the machine's cores.",
        ),
        click.option("--dask-local", is_flag=True, help="Run on a local Dask distributed cluster."),
        click.option(
            "--scheduler",
            default=None,
            metavar="tcp://HOST:PORT",
            help="Run on a running Dask scheduler (its workers need this terrapath installed).",
        ),
        click.option(
            "--keep-mcap",
            type=click.Choice(("none", "failures", "all")),
            default="failures",
            show_default=True,
            help="Which runs keep their MCAP recording.",
        ),
        click.option(
            "--mcap-dir",
            type=click.Path(file_okay=False),
            default=None,
            help="Where kept MCAPs go (default: the store's name + '-mcap' beside it).",
        ),
    ]
    return decorate(f, decorators)


@click.command("campaign")
@click.argument("spec", type=click.Path(dir_okay=False))
@click.option(
    "--store",
    required=True,
    type=click.Path(dir_okay=False),
    help="SQLite file of the results (created if missing; runs already in it are not flown again).",
)
@click.option(
    "--only",
    default=None,
    metavar="KEY",
    help="Fly this one run again (its key: mission/row/avoider/run, as the store lists it).",
)
@executor_options
def campaign_cmd(
    spec: str,
    store: str,
    only: str | None,
    jobs: int | None,
    dask_local: bool,
    scheduler: str | None,
    keep_mcap: str,
    mcap_dir: str | None,
) -> int:
    """Fly every run of the campaign SPEC (missions x threat rows x avoiders x runs, each with a
    seed derived from the spec's seed and the run's key) and write one row per run to --store
    as it finishes. Re-running the same command flies only the missing runs; --only KEY flies
    one again and gives the same result. Ends with a summary per row of the study: success
    rate with its Wilson 95 % interval, path-length ratio, flight time, time per decision.

    Exit status: 0 when every run was flown (failed flights are the study's results, counted
    and listed as FAILED), 1 when runs raised (stored as errors); with --only, 3 when that
    flight fails."""
    from replay.campaign.spec import load_spec

    s = load_spec(spec)
    if only is not None:
        s.find(only)  # a clear error before anything is flown
    command = "terrapath campaign " + " ".join(shlex.quote(a) for a in (spec, "--store", store))
    rows, flown = fly(s, store, command, jobs, dask_local, scheduler, keep_mcap, mcap_dir, only)
    for line in summary_lines(rows):
        click.echo(line)
    if only is not None:
        (row,) = flown
        if row["mcap"]:
            click.echo(f"recorded {row['mcap']}")
        if row["status"] == "error":
            click.echo(f"terrapath: run {only} raised: {row['error']}", err=True)
            return EXIT_ERRORS
        return 0 if row["success"] else EXIT_FAILED
    return errors_status(rows)


def errors_status(rows: list[dict[str, Any]]) -> int:
    """0, or EXIT_ERRORS with a line naming the first run that raised."""
    errs = [r for r in rows if r["status"] == "error"]
    if not errs:
        return 0
    click.echo(
        f"terrapath: {len(errs)} run(s) raised (stored as errors), e.g. {errs[0]['key']}: "
        f"{errs[0]['error']}",
        err=True,
    )
    return EXIT_ERRORS


def fly(
    spec: Any,
    store: str,
    command: str,
    jobs: int | None,
    dask_local: bool,
    scheduler: str | None,
    keep_mcap: str,
    mcap_dir: str | None,
    only: str | None = None,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Fly the spec's missing runs (or ``only``) with a progress bar (a line per run when stderr
    is not a terminal); returns (every row of the spec's runs, the rows flown now)."""
    from replay.campaign.runner import check_scheduler, require_dask, run_campaign
    from replay.campaign.store import Store
    from terrapath import __version__

    if dask_local and scheduler:
        raise click.UsageError("give --dask-local or --scheduler, not both")
    executor = "dask-local" if dask_local else "scheduler" if scheduler else "pool"
    n_jobs = jobs or os.cpu_count() or 1
    if executor != "pool":
        require_dask()  # before the store is created
    if scheduler:
        check_scheduler(scheduler)
    with Store(store, __version__) as db:
        runs = spec.all_runs()
        have = len(db.done(r.run_hash for r in runs))
        todo = 1 if only is not None else len(runs) - have
        where = f"({n_jobs} jobs)" if executor != "scheduler" else f"({scheduler})"
        click.echo(
            f"campaign {spec.name!r}: {len(runs)} runs ({len(spec.missions)} mission(s) x "
            f"{len(spec.rows)} row(s) x {len(spec.avoiders)} avoider(s) x {spec.runs}); {have} "
            f"already in {store}; flying {todo} on {executor} {where}",
            err=True,
        )
        t0 = time.perf_counter()
        failed = errors = 0
        with progress_bar(max(todo, 1), "runs") as bar:

            def report(row: dict[str, Any], done: int, total: int) -> None:
                nonlocal failed, errors
                errors += row["status"] == "error"
                failed += row["status"] == "ok" and not row["success"]
                el = time.perf_counter() - t0
                eta = el / done * (total - done)
                text = f"{done}/{total} runs, {failed} failed, {errors} errors, ETA {duration(eta)}"
                if bar is not None:
                    bar(done, text)
                else:
                    click.echo(f"[{text}] {row['key']}: {_outcome(row)}", err=True)

            _, flown = run_campaign(
                spec,
                db,
                version=__version__,
                command=command,
                jobs=n_jobs,
                executor=executor,
                scheduler=scheduler,
                only=only,
                keep=keep_mcap,
                mcap_dir=mcap_dir,
                report=report,
            )
        rows = db.rows(hashes=[r.run_hash for r in runs])
    return rows, flown


def summary_lines(rows: list[dict[str, Any]]) -> list[str]:
    """A table per row of the study (``report.line_of``, as ``terrapath report`` tabulates it):
    runs, successes with their Wilson 95 % interval, the mean PLR of the successful runs, the
    mean flight time and time per decision of its finished runs."""
    from replay.campaign.report import line_of, row_order

    groups: dict[tuple[str, str, str], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["mission"], r["row"], r["avoider"]), []).append(r)
    head = (
        *("mission", "row", "avoider", "runs", "success (95 % CI)"),
        *("PLR", "flight", "decision", "errors"),
    )
    table = [head]

    def order(kv: tuple[tuple[str, str, str], Any]) -> tuple[str, tuple[int, str], str]:
        mission, row, avoider = kv[0]
        return (mission, row_order(row), avoider)

    for (mission, row, avoider), rs in sorted(groups.items(), key=order):
        f = line_of(rs)
        lo, hi = f["ci"]
        plr, flight, dec = f["plr"], f["flight_min"], f["decision_ms"]
        table.append(
            (
                mission,
                row,
                avoider,
                str(f["runs"]),
                f"{f['successes']}/{f['finished']} ({100 * lo:.0f}-{100 * hi:.0f} %)"
                if f["finished"]
                else "-",
                f"{plr[0]:.3f}" if plr is not None else "-",
                duration(60.0 * flight[0]) if flight is not None else "-",
                f"{dec[0]:.2f} ms" if dec is not None else "-",
                str(f["errors"]),
            )
        )
    widths = [max(len(t[i]) for t in table) for i in range(len(head))]
    return ["  ".join(c.ljust(w) for c, w in zip(t, widths, strict=True)).rstrip() for t in table]


def _outcome(row: dict[str, Any]) -> str:
    """A run's outcome in a few words (a failure says which volumes it entered)."""
    if row["status"] == "error":
        return f"error: {row['error']}"
    if row["success"]:
        return "success"
    entered = sorted({v["threat"] for v in row["metrics"].get("violations", [])})
    why = f"entered {', '.join(entered)}" if entered else row["end_reason"]
    return f"FAILED ({why})"
