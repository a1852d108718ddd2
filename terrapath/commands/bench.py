"""`terrapath bench`: a paper table reproduced as a campaign, our figures beside the paper's."""

from __future__ import annotations

import platform
import shlex
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import click

from terrapath.commands.campaign import errors_status, executor_options, fly


def added(spec: Any, names: tuple[str, ...]) -> tuple[Any, ...]:
    """``--avoid``'s avoiders for a bench's spec (no options: their defaults), each checked now:
    a known name, one the spec's sensor serves, not already in the spec."""
    from replay.avoidance.registry import avoider_entry, make_avoider
    from replay.campaign.spec import Avoider
    from terrain.errors import InputError

    out = []
    for n in dict.fromkeys(names):
        make_avoider(n)  # unknown names, plugins that cannot be imported: one line
        serves = avoider_entry(n).sensors
        if spec.sensor not in serves:
            raise InputError(
                f"--avoid {n}: this bench flies with the {spec.sensor} sensor ({spec.path.name}); "
                f"the {n} avoider works with {' or '.join(serves)} only"
            )
        if any(a.label == n for a in spec.avoiders):
            continue  # the bench flies it already
        out.append(Avoider(n))
    return tuple(out)


def _root() -> Path:
    import replay

    return Path(replay.__file__).resolve().parents[1]


@click.command("bench")
@click.argument("name", required=False)
@click.option("--list", "listing", is_flag=True, help="The benches and what each reproduces.")
@click.option(
    "--table",
    "remake_table",
    is_flag=True,
    help="Only regenerate the current-figures table of benchmarks/README.md from "
    "benchmarks/current.json (nothing flown).",
)
@click.option(
    "--runs", type=click.IntRange(min=1), default=None, help="Runs per line (a quick version)."
)
@click.option(
    "--optimizers",
    default=None,
    metavar="A,B,...",
    help="PSO-CA's optimisers to fly, or other avoiders by name (seed000-table6's default: pso; "
    "'all': every one in the spec).",
)
@click.option(
    "--avoid",
    "extra_avoiders",
    multiple=True,
    metavar="NAME",
    help="Also fly avoider NAME (repeatable; e.g. one an installed package gives: terrapath "
    "plugins) on the bench's missions and threats, beside its own. The table is then not the "
    "paper's: printed, written only where --summary says.",
)
@click.option(
    "--store",
    type=click.Path(dir_okay=False),
    default=None,
    help="SQLite store of the runs (default build/bench/NAME.sqlite: a second call resumes).",
)
@click.option(
    "--summary",
    type=click.Path(dir_okay=False),
    default=None,
    help="The Markdown file the table goes into (default benchmarks/SUMMARY.md of the checkout).",
)
@executor_options
def bench_cmd(
    name: str | None,
    listing: bool,
    remake_table: bool,
    runs: int | None,
    optimizers: str | None,
    extra_avoiders: tuple[str, ...],
    store: str | None,
    summary: str | None,
    jobs: int | None,
    dask_local: bool,
    scheduler: str | None,
    keep_mcap: str,
    mcap_dir: str | None,
) -> int:
    """Reproduce the paper table NAME: fly its campaign (resuming what an earlier call flew),
    print our figures beside the paper's with the ratio, and write the table into
    benchmarks/SUMMARY.md (replacing its previous version) and the dated log RESULTS.md.  A quick
    version (--runs) is printed only, unless --summary names a file for it."""
    from replay.campaign.benches import BENCHES, COMING, markdown, optimizer_of, update_summary
    from replay.campaign.spec import load_spec
    from terrain.atomic import output_folder
    from terrain.errors import InputError
    from terrapath import __version__, figures

    root = _root()
    bench_dir = root / "benchmarks"
    if remake_table:
        current, readme = bench_dir / "current.json", bench_dir / "README.md"
        if not current.is_file() or not readme.is_file():
            raise InputError(
                f"--table: expected {current} and {readme} (a checkout of terrapath's repository)"
            )
        click.echo(figures.remake_table(current, readme))
        return 0
    if listing or name is None:
        for b in BENCHES.values():
            click.echo(f"{b.name:<20} {b.title}")
        for n, why in COMING.items():
            click.echo(f"{n:<20} (not yet: {why})")
        return 0 if listing else 2
    if name not in BENCHES:
        if name in COMING:
            raise InputError(f"bench {name!r} is not built yet: {COMING[name]}")
        raise InputError(f"no bench {name!r}; valid: {', '.join(BENCHES)}")
    bench = BENCHES[name]
    chosen = None
    if optimizers != "all":
        chosen = tuple(optimizers.split(",")) if optimizers else bench.optimizers
        if chosen is not None and not optimizers:
            chosen = (*chosen, *extra_avoiders)  # the default choice and the avoiders added
    store_path = Path(store) if store else Path("build") / "bench" / f"{name}.sqlite"
    output_folder(store_path)
    if summary:
        output_folder(summary, create=False)  # made when the table is written, after the runs
    given = [
        name,
        *(["--runs", str(runs)] if runs else []),
        *(["--optimizers", optimizers] if optimizers else []),
        *(a for n in extra_avoiders for a in ("--avoid", n)),
    ]
    command = "terrapath bench " + " ".join(shlex.quote(a) for a in given)
    rows: list[dict[str, object]] = []
    flown = 0  # runs flown by this call: only then is there a new measurement for RESULTS.md
    if bench.plans is not None:
        lines = bench.plans(runs or 10)
        flown = 1
    for path in bench.spec_paths():
        spec = load_spec(path)
        avoiders = (*spec.avoiders, *added(spec, extra_avoiders))
        if chosen is not None:
            avoiders = tuple(a for a in avoiders if optimizer_of(a.label) in chosen)
            if not avoiders:
                known = sorted({optimizer_of(a.label) for a in spec.avoiders})
                raise InputError(f"--optimizers {optimizers!r}: none of {', '.join(known)}")
        spec = spec.narrowed(runs=runs, avoiders=avoiders)
        # each run records the command that flies it again (campaign --only KEY): a bench
        # has no --only
        refly = "terrapath campaign " + " ".join(
            shlex.quote(a) for a in (str(path), "--store", str(store_path))
        )
        got, fresh = fly(
            spec, str(store_path), refly, jobs, dask_local, scheduler, keep_mcap, mcap_dir
        )
        rows += got
        flown += len(fresh)
    if bench.plans is None:
        lines = bench.lines(rows)
    head = ("row", "avoider", "figure", "ours", *bench.columns)
    widths = [max(len(x[i]) for x in [head, *lines]) for i in range(6)]
    for line in [head, *lines]:
        click.echo("  ".join(c.ljust(w) for c, w in zip(line, widths, strict=True)).rstrip())
    now = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    runs_of = "the paper's runs" if bench.columns[0] == "paper" else "the spec's runs"
    per = f"{runs} runs a line (quick)" if runs else runs_of
    header = (
        f"{now}; terrapath {__version__}; {platform.processor() or platform.machine()}, "
        f"Python {platform.python_version()}; {per}; `{command}`; store {store_path}"
    )
    section = markdown(bench, lines, header)
    target = (
        Path(summary)
        if summary
        else (bench_dir if bench_dir.is_dir() else Path(".")) / "SUMMARY.md"
    )
    if extra_avoiders and summary is None:
        # another avoider's lines are no measurement of the paper's table either
        click.echo(
            f"with --avoid the table is not the paper's: it is not written into {target} "
            "(--summary FILE writes it there)"
        )
        return errors_status(rows)
    if runs and summary is None:
        # a quick version is no measurement of the paper's table: it never replaces the current one
        click.echo(
            f"a quick version (--runs {runs}): the table is not written into {target} "
            "(--summary FILE writes it there)"
        )
        return errors_status(rows)
    update_summary(target, bench, section)
    click.echo(f"wrote the table into {target}")
    current = bench_dir / "current.json"
    # the current figures are the full table's (a quick version has returned above): another
    # choice of optimisers goes into SUMMARY.md and the log only
    if summary is None and current.exists() and optimizers is None:
        readme = bench_dir / "README.md"
        updated = figures.record(
            current,
            readme if readme.exists() else None,
            f"bench {bench.name}: {bench.title}",
            figures.bench_rows(lines, bench.columns),
            date=now,
            machine=f"{platform.processor() or platform.machine()}, Python {platform.python_version()}",
            load=figures.load_average(),
            command=command,
            commit=figures.commit_of(root),
            source="SUMMARY.md",
        )
        if updated:
            click.echo(f"updated {', '.join(updated)} in {current} and its table")
    log = bench_dir / "RESULTS.md"
    if summary is None and log.exists() and flown:
        with log.open("a", encoding="utf-8") as f:
            f.write("\n" + section.replace(f"## {bench.name}:", f"## bench {bench.name}:", 1))
    return errors_status(rows)
