"""The benchmarks' current figures: ``benchmarks/current.json`` and the table made from it.

``benchmarks/RESULTS.md`` is the append-only log (every run of a benchmark, dated);
``current.json`` holds one entry per headline figure -- its newest value, target, date, machine,
load, command and commit -- and the table between the markers of ``benchmarks/README.md`` is
made from it alone (:func:`table`), so the README cannot say anything the file does not.

An entry names the log record it is read from: ``title`` (the record's heading, without its date)
and ``row`` (the figure's name in that record's table).  A benchmark recording its figures
(``benchmarks/_record.record``, ``terrapath bench NAME``) updates every entry whose title and row
it measured, and the table with it (:func:`record`); a figure that a run with other arguments
measures under another title is left alone.
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from terrain.atomic import atomic_output
from terrain.errors import InputError

START = "<!-- current figures: made by `terrapath bench --table` from current.json; do not edit -->"
END = "<!-- end of the current figures -->"
Row = tuple[str, str, str]  # figure, value, target: a record's table row


@dataclass(frozen=True)
class Figure:
    """One headline figure, as ``current.json`` keeps it."""

    id: str  # stable name, e.g. "replay.wall-mcap"
    label: str  # what the table calls it
    title: str  # the log record's heading (without the date) it is read from
    row: str  # the figure's name in that record's table
    value: str
    target: str  # "" when there is none
    date: str  # "YYYY-MM-DD HH:MM UTC"
    machine: str
    load: str  # the machine's load average when measured ("" when not noted)
    command: str  # the command that measures it again
    commit: str  # the checkout's commit when measured (seeded entries: the commit that logged it)
    source: str  # where the value was read: "RESULTS.md", "SUMMARY.md" or a sentence


FIELDS = tuple(f.name for f in dataclasses.fields(Figure))


def read(path: str | os.PathLike[str]) -> list[Figure]:
    """The figures of ``path`` in their order; a malformed file is one line naming the entry and
    the field."""
    where = str(path)
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise InputError(f"{where}: not JSON ({exc.msg}, line {exc.lineno})") from None
    entries = data.get("figures") if isinstance(data, dict) else None
    if not isinstance(entries, list):
        raise InputError(f"{where}: expected an object with a list 'figures'")
    out: list[Figure] = []
    seen: set[str] = set()
    for k, e in enumerate(entries):
        if not isinstance(e, dict):
            raise InputError(f"{where}: figures[{k}]: expected an object")
        name = f"figures[{k}] ({e.get('id', 'no id')})"
        unknown = sorted(set(e) - set(FIELDS))
        if unknown:
            raise InputError(
                f"{where}: {name}: unknown field {unknown[0]!r}; allowed: {', '.join(FIELDS)}"
            )
        for f in FIELDS:
            if f not in e:
                raise InputError(f"{where}: {name}: field {f!r} missing")
            if not isinstance(e[f], str):
                raise InputError(f"{where}: {name}: field {f!r}: expected text, found {e[f]!r}")
        for f in ("id", "label", "title", "row", "value", "date", "command"):
            if not e[f].strip():
                raise InputError(f"{where}: {name}: field {f!r}: expected text, found ''")
        if e["id"] in seen:
            raise InputError(f"{where}: {name}: id {e['id']!r} used twice")
        seen.add(e["id"])
        out.append(Figure(**e))
    return out


def save(path: str | os.PathLike[str], figures: Sequence[Figure]) -> None:
    """Write the figures to ``path`` (through a temporary name)."""
    data = {
        "about": "The benchmarks' current headline figures (terrapath/figures.py): updated by "
        "each benchmark's record, one entry per figure; benchmarks/README.md's table is made "
        "from this file (terrapath bench --table).",
        "figures": [dataclasses.asdict(f) for f in figures],
    }
    with atomic_output(path) as tmp:
        tmp.write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")


def _cell(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|") or "-"


def table(figures: Sequence[Figure]) -> str:
    """The Markdown table of the figures (figure, value, target, date, command), in their order."""
    lines = [
        "| figure | value | target | date | command |",
        "|---|---|---|---|---|",
    ]
    for f in figures:
        lines.append(
            f"| {_cell(f.label)} | {_cell(f.value)} | {_cell(f.target)} | {f.date[:10]} "
            f"| `{_cell(f.command)}` |"
        )
    return "\n".join(lines) + "\n"


def with_table(text: str, figures: Sequence[Figure], where: str) -> str:
    """``text`` (a README) with the table between its markers replaced."""
    head, start, rest = text.partition(START)
    _, end, tail = rest.partition(END)
    if not start or not end:
        raise InputError(f"{where}: expected the markers {START!r} and {END!r} around the table")
    return f"{head}{START}\n{table(figures)}{END}{tail}"


def write_table(readme: str | os.PathLike[str], figures: Sequence[Figure]) -> bool:
    """Regenerate the table in ``readme``; True when its text changed."""
    old = Path(readme).read_text(encoding="utf-8")
    new = with_table(old, figures, str(readme))
    if new != old:
        with atomic_output(readme) as tmp:
            tmp.write_text(new, encoding="utf-8")
    return new != old


def remake_table(current: str | os.PathLike[str], readme: str | os.PathLike[str]) -> str:
    """Regenerate ``readme``'s table from ``current`` (``terrapath bench --table``,
    ``python -m benchmarks.table``); what was done, in one line."""
    listed = read(current)
    changed = write_table(readme, listed)
    return f"{'wrote' if changed else 'kept'} the table of {len(listed)} figures in {readme}"


def record(
    current: str | os.PathLike[str],
    readme: str | os.PathLike[str] | None,
    title: str,
    rows: Sequence[Row],
    *,
    date: str,
    machine: str,
    load: str,
    command: str,
    commit: str,
    source: str,
) -> list[str]:
    """Update the entries of ``current`` read from the record ``title`` with the ``rows`` it
    measured (value, date, machine, load, command, commit; the target is the entry's, the row's
    only when the entry has none: targets named by the issues or the papers stay), then the table
    of ``readme``
    (when given).  Returns the ids updated; nothing is written when there are none."""
    values = {figure: (value, target) for figure, value, target in rows}
    figures = read(current)
    updated: list[str] = []
    out: list[Figure] = []
    for f in figures:
        if f.title == title and f.row in values:
            value, target = values[f.row]
            f = dataclasses.replace(
                f,
                value=value,
                target=f.target or target,
                date=date,
                machine=machine,
                load=load,
                command=command,
                commit=commit,
                source=source,
            )
            updated.append(f.id)
        out.append(f)
    if updated:
        save(current, out)
        if readme is not None:
            write_table(readme, out)
    return updated


def bench_rows(lines: Sequence[Sequence[str]], columns: tuple[str, str]) -> list[Row]:
    """A paper table's lines (row, avoider, figure, ours, paper, ratio) as record rows named
    ``"row / avoider / figure"`` (the target: the paper's value), and for each avoider its
    totals over the rows: ``"all / AVOIDER / success"`` (``ours`` and ``paper`` summed where both
    are counts ``a/b``) and, in a table judged right or wrong, ``"all / AVOIDER / right"``."""
    rows: list[Row] = []
    success: dict[str, list[int]] = {}
    right: dict[str, list[int]] = {}
    for row, avoider, figure, ours, paper, judged in lines:
        target = "" if paper in ("", "-") else f"{columns[0]} {paper}"
        rows.append((f"{row} / {avoider} / {figure}", ours, target))
        if figure == "success":
            ours_n, paper_n = _count(ours), _count(paper)
            s = success.setdefault(avoider, [0, 0, 0, 0, 1])
            if ours_n:
                s[0] += ours_n[0]
                s[1] += ours_n[1]
            if paper_n:
                s[2] += paper_n[0]
                s[3] += paper_n[1]
            else:
                s[4] = 0  # a row without the paper's count: no paper total
        if judged in ("right", "wrong"):
            r = right.setdefault(avoider, [0, 0])
            r[0] += judged == "right"
            r[1] += 1
    for avoider, (a, b, pa, pb, whole) in success.items():
        paper_total = f"{columns[0]} {pa}/{pb}" if whole and pb else ""
        rows.append((f"all / {avoider} / success", f"{a}/{b}", paper_total))
    for avoider, (a, b) in right.items():
        rows.append((f"all / {avoider} / right", f"{a}/{b}", f"{b}/{b}"))
    return rows


def _count(text: str) -> tuple[int, int] | None:
    a, sep, b = text.partition("/")
    if not sep or not a.strip().isdigit() or not b.strip().isdigit():
        return None
    return int(a), int(b)


def commit_of(root: str | os.PathLike[str]) -> str:
    """The checkout's short commit, with "+ changes" when files tracked by git differ from it
    ("" outside a git checkout)."""
    try:
        head = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return ""
    return f"{head} + changes" if dirty else head


def load_average() -> str:
    """The 1, 5 and 15-minute load averages ("" where the system has none)."""
    try:
        return "/".join(f"{x:.2f}" for x in os.getloadavg()) + " (1/5/15 min)"
    except OSError:
        return ""


__all__ = [
    "END",
    "FIELDS",
    "START",
    "Figure",
    "bench_rows",
    "commit_of",
    "load_average",
    "read",
    "record",
    "remake_table",
    "save",
    "table",
    "with_table",
    "write_table",
]
