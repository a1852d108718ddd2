"""Append a benchmark's figures to benchmarks/RESULTS.md with the machine, date and command."""

from __future__ import annotations

import datetime as _dt
import os
import platform
import shlex
import sys
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "RESULTS.md"


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


def record(title: str, rows: list[tuple[str, str, str]], notes: str = "") -> None:
    """Print the figures and append them as a Markdown table (figure, value, target)."""
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    command = "python " + " ".join(shlex.quote(a) for a in sys.argv)
    lines = [
        f"\n## {title} — {now}\n",
        f"- machine: {machine()}",
        f"- command: `{command}`",
    ]
    if notes:
        lines.append(f"- notes: {notes}")
    lines += ["", "| figure | value | target |", "|---|---|---|"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    text = "\n".join(lines) + "\n"
    print(text)
    if not RESULTS.exists():
        RESULTS.write_text("# Benchmark results\n\nAppended by the scripts in this folder.\n")
    with RESULTS.open("a") as f:
        f.write(text)


def emit(title: str, rows: list[tuple[str, str, str]], notes: str, no_record: bool) -> None:
    """:func:`record` the figures, or with ``no_record`` only print them as Markdown."""
    if no_record:
        print(f"\n## {title}\n- notes: {notes}\n\n| figure | value | target |\n|---|---|---|")
        for a, b, c in rows:
            print(f"| {a} | {b} | {c} |")
    else:
        record(title, rows, notes)
