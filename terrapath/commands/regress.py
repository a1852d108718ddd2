"""`terrapath regress`: fly a regression suite with the avoiders named and compare each result with
its baseline (:mod:`replay.campaign.regress`)."""

from __future__ import annotations

import json
import shlex
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import click

from terrapath.progress import progress_bar
from terrapath.runtext import duration

EXIT_REGRESSED = 3  # as a failed replay: the outcome is a failure, not an error of input


@click.command("regress")
@click.argument("suite", default="reference")
@click.option(
    "--avoid",
    "avoid",
    default=None,
    metavar="A,B,...",
    help="The avoiders to fly (built-in or plugin; default: the suite's, unless only "
    "--optimizer is given).",
)
@click.option(
    "--optimizer",
    "optimizer",
    default=None,
    metavar="A,B,...",
    help="The optimisers to plan the suite's reference maps with (built-in or plugin; default: "
    "the suite's, unless only --avoid is given).",
)
@click.option(
    "--data",
    "data",
    multiple=True,
    type=click.Path(file_okay=False, exists=True),
    help="A folder of maps (<folder>/<file> or maps/<folder>/<file>), repeatable; then the "
    "checkout's data/maps and ../shared/maps.",
)
@click.option(
    "-o",
    "--out",
    "out",
    type=click.Path(file_okay=False),
    default=None,
    help="Where the table, junit.xml, pictures and the runs' store go (default out/regress-SUITE).",
)
@click.option(
    "--baseline",
    "baseline",
    type=click.Path(dir_okay=False),
    default=None,
    help="The baseline to compare with (default: the suite's, SUITE-baseline.json beside it).",
)
@click.option(
    "--against",
    default=None,
    metavar="AVOIDER",
    help="Compare the avoiders flown with AVOIDER's baseline figures (a changed copy of an "
    "avoider, installed under another name, against the original's).",
)
@click.option(
    "--update-baseline",
    is_flag=True,
    help="Write these figures as a new baseline beside the one compared with (a dated name; "
    "never over it); a --baseline that does not exist yet is written where named.",
)
@click.option(
    "--case",
    "only",
    multiple=True,
    metavar="NAME",
    help="Fly only this case of the suite (repeatable; --list names them).",
)
@click.option(
    "--jobs", type=click.IntRange(min=1), default=None, help="Processes (default: cores)."
)
@click.option("--list", "listing", is_flag=True, help="The suites and their cases.")
def regress_cmd(
    suite: str,
    avoid: str | None,
    optimizer: str | None,
    data: tuple[str, ...],
    out: str | None,
    baseline: str | None,
    against: str | None,
    update_baseline: bool,
    only: tuple[str, ...],
    jobs: int | None,
    listing: bool,
) -> int:
    """Fly the regression SUITE (default: reference) and compare every group of runs (case,
    mission, row, avoider) with the baseline: a lost success, a threat entered or passed closer
    than the tolerance, a longer path, a success rate below the baseline's beyond its confidence
    interval, an error -- each a regression.  Prints the table and writes it with JUnit XML and a
    picture of each regressed run into --out.  Exit status 0 when nothing regressed, 3 when
    something did."""
    from planner.plan import check_algorithm
    from replay.avoidance.registry import avoider_names
    from replay.campaign import regress as R
    from replay.campaign.spec import load_spec
    from terrain.atomic import atomic_output
    from terrain.errors import InputError
    from terrapath import __version__

    if listing:
        for name in R.suite_names():
            s = R.load_suite(name)
            click.echo(f"{s.name:<12} {s.title}")
            for doc in s.cases:
                click.echo(f"  {doc['name']}")
        return 0
    s = R.load_suite(suite)
    if only:
        s = R.only_cases(s, only)
    avoiders = tuple(avoid.split(",")) if avoid else () if optimizer else s.avoiders
    optimizers = tuple(optimizer.split(",")) if optimizer else () if avoid else s.optimizers
    for name in optimizers:
        check_algorithm(name)  # built-in and installed
    known = avoider_names()  # built-in and installed
    unknown = [a for a in avoiders if a not in known]
    if unknown:
        raise InputError(
            f"--avoid: unknown avoider(s) {', '.join(map(repr, unknown))}; "
            f"known: {', '.join(known)}"
        )
    base_path = Path(baseline) if baseline else s.baseline
    first = baseline is not None and not base_path.exists() and update_baseline
    if baseline and not base_path.is_file() and not first:
        raise InputError(f"--baseline {baseline}: no such file")
    base = R.read_baseline(base_path)
    folder = Path(out) if out else Path("out") / f"regress-{s.name}"
    folder.mkdir(parents=True, exist_ok=True)
    maps = [Path(d) for d in data]
    cases = R.prepare(s, avoiders, folder / "specs", maps, named=bool(avoid)) if avoiders else []
    given = [
        s.name,
        *(["--avoid", avoid] if avoid else []),
        *(["--optimizer", optimizer] if optimizer else []),
        *(f"--data={d}" for d in data),
        *(f"--case={c}" for c in only),
        *([f"--against={against}"] if against else []),
    ]
    command = "terrapath regress " + " ".join(shlex.quote(a) for a in given)
    store = folder / "runs.sqlite"
    t0 = time.perf_counter()
    specs = {c.name: load_spec(c.spec) for c in cases if c.spec is not None}
    for c in cases:
        if c.spec is None:
            click.echo(f"{c.name}: skipped ({c.skipped})", err=True)
        for a, why in c.unfit:
            click.echo(f"{c.name}: {a} not flown ({why})", err=True)
    found: dict[str, R.Group] = {}
    for name, rows in (_fly(specs, store, jobs, __version__) if specs else {}).items():
        found.update(R.groups(name, rows))
    for m in s.plans if optimizers else ():
        for alg in optimizers:
            t = time.perf_counter()
            got = R.plan_group(m, alg, maps)
            if isinstance(got, str):
                cases.append(R.Case(f"plan/{m}", None, got))
                click.echo(f"plan/{m}: skipped ({got})", err=True)
                break
            found[got.key] = got
            state = "error" if got.errors else "feasible" if got.successes else "infeasible"
            cost = f", cost {got.plr:.4f}" if got.plr is not None else ""
            click.echo(f"plan/{m}/{alg}: {state}{cost} ({time.perf_counter() - t:.1f} s)", err=True)
    seconds = time.perf_counter() - t0
    if against is not None and not any(k.endswith(f"/{against}") for k in base):
        raise InputError(f"--against {against}: the baseline {base_path} holds no {against!r}")
    compared = {k: base.get(R.baseline_key(k, against)) for k in found}
    verdicts = {k: R.compare(g, compared[k]) for k, g in found.items()}
    held = {k: v for k, v in compared.items() if v is not None}
    rows_t = R.table(found, verdicts, held, base)
    click.echo(R.format_table(rows_t))
    skipped = [c for c in cases if c.spec is None]
    regressed = [k for k, v in verdicts.items() if v.failed]
    for k in regressed:
        click.echo(f"REGRESSED {k}: {'; '.join(verdicts[k].reasons)}")
    pictures = _pictures(found, verdicts, specs, maps, folder / "failures")
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    head = (
        f"# terrapath regress {s.name}\n\n{stamp}; terrapath {__version__}; `{command}`; "
        f"baseline {base_path.name if base else '(none)'}; {seconds:.0f} s\n\n"
    )
    with atomic_output(folder / "regress.md") as tmp:
        tmp.write_text(head + R.markdown(rows_t), encoding="utf-8")
    with atomic_output(folder / "junit.xml") as tmp:
        tmp.write_bytes(R.junit_xml(s, found, verdicts, skipped, seconds, cases))
    if update_baseline:
        # a baseline named that does not exist yet is written there; else beside, never over
        new = base_path if first else R.new_baseline_path(base_path)
        meta = {"version": __version__, "created_utc": stamp, "command": command}
        doc = R.baseline_doc(s, found, base, meta)
        try:
            with atomic_output(new) as tmp:
                tmp.write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n", encoding="utf-8")
        except OSError as exc:
            raise InputError(f"--update-baseline: cannot write {new} ({exc})") from None
        click.echo(f"wrote the new baseline {new} (compare with it: --baseline {new})", err=True)
    n_ok = len(found) - len(regressed)
    click.echo(
        f"{len(found)} groups: {n_ok} without regression, {len(regressed)} regressed, "
        f"{len(skipped)} case(s) skipped; {len(pictures)} picture(s); "
        f"wrote {folder / 'regress.md'} and {folder / 'junit.xml'}",
        err=True,
    )
    return EXIT_REGRESSED if regressed else 0


def _fly(
    specs: dict[str, Any], store: Path, jobs: int | None, version: str
) -> dict[str, list[dict[str, Any]]]:
    """Every case's missing runs in one process pool, with a progress bar; each case's rows (its
    every run's, flown now or before)."""
    import os

    from replay.campaign.runner import run_campaigns
    from replay.campaign.store import Store

    runs = {name: spec.all_runs() for name, spec in specs.items()}
    commands = [
        f"terrapath campaign {shlex.quote(str(spec.path))} --store {shlex.quote(str(store))}"
        for spec in specs.values()
    ]
    n_jobs = jobs or os.cpu_count() or 1
    with Store(str(store), version) as db:
        total = sum(len(r) for r in runs.values())
        click.echo(f"regress: {total} runs in {len(specs)} campaigns ({n_jobs} jobs)", err=True)
        t0 = time.perf_counter()
        with progress_bar(max(total, 1), "runs") as bar:

            def report(row: dict[str, Any], done: int, todo: int) -> None:
                el = time.perf_counter() - t0
                text = f"{done}/{todo} runs, ETA {duration(el / done * (todo - done))}"
                if bar is not None:
                    bar(done, text)
                else:
                    click.echo(f"[{text}] {row['key']}", err=True)

            run_campaigns(
                list(specs.values()),
                db,
                version=version,
                commands=commands,
                jobs=n_jobs,
                report=report,
            )
        return {
            name: list(db.rows(hashes=[r.run_hash for r in case_runs]))
            for name, case_runs in runs.items()
        }


def _pictures(
    found: dict[str, Any],
    verdicts: dict[str, Any],
    specs: dict[str, Any],
    maps: list[Path],
    folder: Path,
) -> list[Path]:
    """A picture of each regressed single run, flown again with its recording (the runs are
    flown without one), and of each regressed plan, planned again (``terrapath plan``'s
    picture); drawn beside the table."""
    from replay.campaign import regress as R
    from replay.campaign.runner import execute, mcap_name
    from replay.record.picture import run_picture

    out: list[Path] = []
    for key, g in found.items():
        if verdicts[key].status != "regressed" or g.runs != 1:
            continue
        folder.mkdir(parents=True, exist_ok=True)
        if g.case == "plan":
            _, m, alg = key.split("/")
            made = R.plan_picture(m, alg, maps, folder / f"plan__{m}__{alg}.png")
            out += [made] if made is not None else []
            continue
        spec = specs[g.case]
        run = next((r for r in spec.all_runs() if r.key == g.run_keys[0]), None)
        if run is None:
            continue
        row = execute(run, spec.name, spec.spec_hash, "", "", "all", str(folder))
        if row.get("mcap"):
            png = folder / mcap_name(run).replace(".mcap", ".png")
            out.append(run_picture(row["mcap"], png))
    return out
