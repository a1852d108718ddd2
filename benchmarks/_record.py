"""Append a benchmark's figures to benchmarks/RESULTS.md with the machine, date and command, and
update its headline figures in benchmarks/current.json and the table of benchmarks/README.md
(:mod:`terrapath.figures`)."""

from __future__ import annotations

import datetime as _dt
import os
import platform
import shlex
import sys
from pathlib import Path

from terrapath import figures

HERE = Path(__file__).resolve().parent

RESULTS = HERE / "RESULTS.md"
CURRENT = HERE / "current.json"
README = HERE / "README.md"


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = ""
    try:
        with open("/proc/meminfo") as f:
            kb = int(f.readline().split()[1])
            mem = f", {kb / 2**20:.0f} GiB"
    except (OSError, ValueError, IndexError):
        pass
    return f"{cpu}, {os.cpu_count()} cores{mem}, Python {platform.python_version()}"


def command_line(argv: list[str]) -> str:
    """The command that ran, its script named from the checkout's root when it lies inside it
    (``python benchmarks/bench_x.py ...`` wherever it was started from)."""
    script = Path(argv[0]).resolve() if argv else None
    first = argv[0] if argv else ""
    if script is not None and script.is_relative_to(HERE.parent):
        first = script.relative_to(HERE.parent).as_posix()
    return "python " + " ".join(shlex.quote(a) for a in [first, *argv[1:]])


def record(
    title: str,
    rows: list[tuple[str, str, str]],
    notes: str = "",
    *,
    results: Path | None = None,
    current: Path | None = None,
    readme: Path | None = None,
) -> list[str]:
    """Print the figures and append them as a Markdown table (figure, value, target) to
    RESULTS.md; then update the headline figures of current.json this record measured, and the
    table of README.md.  Returns the ids of the figures updated (``results``, ``current``,
    ``readme``: other files than the checkout's, for the tests)."""
    results = results or RESULTS
    current = current or CURRENT
    readme = readme or README
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    command = command_line(sys.argv)
    where, load, commit = machine(), figures.load_average(), figures.commit_of(HERE.parent)
    lines = [
        f"\n## {title} — {now}\n",
        f"- machine: {where}",
        f"- load: {load or 'not known'}",
        f"- commit: {commit or 'not known'}",
        f"- command: `{command}`",
    ]
    if notes:
        lines.append(f"- notes: {notes}")
    lines += ["", "| figure | value | target |", "|---|---|---|"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    text = "\n".join(lines) + "\n"
    print(text)
    if not results.exists():
        results.write_text("# Benchmark results\n\nAppended by the scripts in this folder.\n")
    with results.open("a") as f:
        f.write(text)
    if not current.exists():
        return []
    return figures.record(
        current,
        readme if readme.exists() else None,
        title,
        rows,
        date=now,
        machine=where,
        load=load,
        command=command,
        commit=commit,
        source="RESULTS.md",
    )


def emit(title: str, rows: list[tuple[str, str, str]], notes: str, no_record: bool) -> None:
    """:func:`record` the figures, or with ``no_record`` only print them as Markdown."""
    if no_record:
        print(f"\n## {title}\n- notes: {notes}\n\n| figure | value | target |\n|---|---|---|")
        for a, b, c in rows:
            print(f"| {a} | {b} | {c} |")
    else:
        record(title, rows, notes)
