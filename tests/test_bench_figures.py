"""benchmarks/README.md's table of the current figures: made from benchmarks/current.json alone,
one row at least for every benchmark, every command one that runs, every value the log's, and a
benchmark's record (``_record.record``, ``terrapath bench NAME``) updates the file and the table."""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import importlib
import json
import re
import shlex
import shutil
import sys
from pathlib import Path

import click
import pytest

from benchmarks import _record
from replay.campaign import benches as B
from terrain.errors import InputError
from terrapath import figures as F
from terrapath.cli import cli, main

ROOT = Path(__file__).resolve().parents[1]
HERE = ROOT / "benchmarks"
CURRENT, README = HERE / "current.json", HERE / "README.md"
SCRIPTS = sorted(
    p.name
    for pattern in ("bench_*.py", "compare_*.py", "validate_*.py")
    for p in HERE.glob(pattern)
)


def _figures() -> list[F.Figure]:
    return F.read(CURRENT)


def test_the_table_is_the_one_current_json_makes_byte_for_byte() -> None:
    text = README.read_text(encoding="utf-8")
    assert text.count(F.START) == 1 and text.count(F.END) == 1
    assert F.with_table(text, _figures(), str(README)) == text
    # and it is a table of every figure, in the file's order
    inside = text.split(F.START)[1].split(F.END)[0].strip().splitlines()
    assert len(inside) == 2 + len(_figures())
    for line, f in zip(inside[2:], _figures(), strict=True):
        assert line.startswith(f"| {f.label} | ")
        assert f"`{f.command}`" in line and f"| {f.date[:10]} |" in line


def test_every_benchmark_script_and_paper_table_has_a_row() -> None:
    assert len(SCRIPTS) >= 16  # bench_* (13), compare_* (2), validate_jsbsim
    run = {shlex.split(f.command)[1] for f in _figures() if f.command.startswith("python ")}
    assert sorted(s for s in SCRIPTS if f"benchmarks/{s}" not in run) == []
    benched = {
        shlex.split(f.command)[2] for f in _figures() if f.command.startswith("terrapath bench ")
    }
    assert sorted(set(B.BENCHES) - benched) == []


class _Parsed(Exception):
    """Raised in place of running the benchmark once its arguments parsed."""


def test_every_command_in_the_table_is_accepted(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each script's own parser takes the command's arguments (sub-command, flags, choices,
    types), stopped there: nothing is run; a terrapath command parses with click and names a
    bench that exists."""
    real = argparse.ArgumentParser.parse_args

    def parse_then_stop(self, args=None, namespace=None):  # type: ignore[no-untyped-def]
        real(self, args, namespace)
        raise _Parsed

    monkeypatch.setattr(argparse.ArgumentParser, "parse_args", parse_then_stop)
    checked = 0
    for f in _figures():
        argv = shlex.split(f.command)
        if argv[0] == "python":
            script = Path(argv[1])
            assert script.parent.as_posix() == "benchmarks" and (ROOT / script).is_file(), f.id
            module = importlib.import_module(f"benchmarks.{script.stem}")
            monkeypatch.setattr(sys, "argv", [str(ROOT / script), *argv[2:]])
            with pytest.raises(_Parsed):
                module.main()
        else:
            assert argv[0] == "terrapath", f.id
            ctx = cli.make_context("terrapath", argv[1:], resilient_parsing=False)
            name, cmd, rest = cli.resolve_command(ctx, argv[1:])
            assert cmd is not None, f.id
            with cmd.make_context(name or "", rest, parent=ctx) as sub:
                if name == "bench":
                    assert sub.params["name"] in B.BENCHES, f.id
                if name == "campaign":
                    assert (ROOT / sub.params["spec"]).is_file(), f.id
        checked += 1
    assert checked == len(_figures())


def test_a_bad_flag_is_refused_by_that_check(monkeypatch: pytest.MonkeyPatch) -> None:
    """The check above can fail: a flag the script does not have ends its parse with an error."""
    module = importlib.import_module("benchmarks.bench_check")
    monkeypatch.setattr(sys, "argv", ["bench_check.py", "--no-such-flag"])
    with pytest.raises(SystemExit) as exc:
        module.main()
    assert exc.value.code == 2
    with pytest.raises(click.UsageError):
        ctx = cli.make_context("terrapath", ["bench", "--no-such-flag"])
        name, cmd, rest = cli.resolve_command(ctx, ["bench", "--no-such-flag"])
        assert cmd is not None
        cmd.make_context(name or "", rest, parent=ctx)


def _log_records() -> dict[tuple[str, str], str]:
    log = (HERE / "RESULTS.md").read_text(encoding="utf-8")
    heads = list(re.finditer(r"^## (.+?) — (\d{4}-\d\d-\d\d \d\d:\d\d UTC)\n", log, re.M))
    out = {}
    for k, m in enumerate(heads):
        end = heads[k + 1].start() if k + 1 < len(heads) else len(log)
        out[(m.group(1), m.group(2))] = log[m.end() : end]
    return out


def _summary_sections() -> dict[str, tuple[str, list[tuple[str, ...]], tuple[str, str]]]:
    text = (HERE / "SUMMARY.md").read_text(encoding="utf-8")
    out = {}
    for part in text.split("\n## ")[1:]:
        lines = part.splitlines()
        head = re.search(r"^\| row \| avoider \| figure \| ours \| (.+?) \| (.+?) \|$", part, re.M)
        assert head is not None
        rows = [
            tuple(c.strip() for c in line.strip().strip("|").split(" | "))
            for line in lines
            if line.startswith("| ") and not line.startswith("| row ")
        ]
        out[f"bench {lines[0]}"] = (lines[2], rows, (head.group(1), head.group(2)))
    return out


def test_every_value_is_the_one_its_log_record_gives() -> None:
    """An entry read from RESULTS.md is a row of the record of that title and date, with that
    value; one read from SUMMARY.md is the section of that title, date and command."""
    records, sections = _log_records(), _summary_sections()
    elsewhere = []
    for f in _figures():
        if f.source == "RESULTS.md":
            body = records.get((f.title, f.date))
            assert body is not None, f"{f.id}: no record '## {f.title} — {f.date}'"
            assert f"\n| {f.row} | {f.value} |" in body, f.id
            assert f.command.removeprefix("python ") in body, f.id
        elif f.source == "SUMMARY.md":
            meta, lines, columns = sections[f.title]
            assert meta.startswith(f.date + ";") and f"`{f.command}`" in meta, f.id
            got = {row: value for row, value, _ in F.bench_rows(lines, columns)}
            assert got[f.row] == f.value, f.id
        else:
            elsewhere.append(f.id)
    # only the multirotor figures (rotorpy is an extra; run with --no-record) are not in the log
    assert elsewhere == ["multirotor.hover", "multirotor.top-speed"]


@pytest.fixture
def copies(tmp_path: Path) -> tuple[Path, Path, Path]:
    for name in ("current.json", "README.md"):
        shutil.copy(HERE / name, tmp_path / name)
    results = tmp_path / "RESULTS.md"
    results.write_text("# Benchmark results\n", encoding="utf-8")
    return tmp_path / "current.json", tmp_path / "README.md", results


def test_a_record_updates_its_figures_and_the_table(
    copies: tuple[Path, Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    current, readme, results = copies
    before = {f.id: f for f in F.read(current)}
    title = before["check.best"].title
    monkeypatch.setattr(sys, "argv", [str(HERE / "bench_check.py"), "--repeat", "3"])
    rows = [
        ("map", "N57E011.hgt", ""),
        ("check, first call (s)", "0.654", "< 1"),
        ("check, best of 5 (s)", "0.0871", "< 0.5 (a new target)"),
    ]
    updated = _record.record(title, rows, "a test", results=results, current=current, readme=readme)
    assert updated == ["check.best", "check.first"]  # the file's order
    after = {f.id: f for f in F.read(current)}
    now = dt.datetime.now(dt.UTC)
    for fid, value in (("check.best", "0.0871"), ("check.first", "0.654")):
        f = after[fid]
        assert f.value == value and f.source == "RESULTS.md"
        assert f.command == "python benchmarks/bench_check.py --repeat 3"
        assert f.target == before[fid].target == "< 1"  # the entry's target stays
        assert abs(dt.datetime.strptime(f.date, "%Y-%m-%d %H:%M UTC").replace(tzinfo=dt.UTC) - now) < dt.timedelta(minutes=2)  # fmt: skip
        assert f.machine == _record.machine() and f.commit == F.commit_of(ROOT)
        assert f.load == F.load_average()
    assert {k: v for k, v in after.items() if k not in updated} == {
        k: v for k, v in before.items() if k not in updated
    }
    text = readme.read_text(encoding="utf-8")
    assert F.with_table(text, list(after.values()), "") == text
    assert "| 0.0871 | < 1 |" in text and "| 0.096 |" not in text
    log = results.read_text(encoding="utf-8")
    assert f"## {title} — {after['check.best'].date}" in log
    assert "| check, best of 5 (s) | 0.0871 | < 0.5 (a new target) |" in log
    assert "- command: `python benchmarks/bench_check.py --repeat 3`" in log


def test_a_record_of_another_title_changes_nothing(copies: tuple[Path, Path, Path]) -> None:
    current, readme, results = copies
    old = current.read_bytes(), readme.read_bytes()
    title = "terrapath check: a 100-waypoint mission (another protocol)"
    rows = [("check, best of 5 (s)", "9.9", "< 1")]
    assert _record.record(title, rows, results=results, current=current, readme=readme) == []
    assert (current.read_bytes(), readme.read_bytes()) == old
    assert "| check, best of 5 (s) | 9.9 | < 1 |" in results.read_text(encoding="utf-8")


def test_a_paper_bench_updates_its_headline(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``terrapath bench NAME`` (a planning table: no replays) records its rows and totals."""
    folder = tmp_path / "benchmarks"
    folder.mkdir()
    shutil.copy(README, folder / "README.md")
    fake = B.Bench(
        "fake-table",
        "a fake table",
        (),
        lambda rows: [],
        plans=lambda runs: [
            ("a", "ampso", "success", "2/2", "2/2", "-"),
            ("b", "ampso", "success", f"{runs - 1}/{runs}", "1/2", "-"),
            ("b", "ampso", "cost", "0.5", "0.6", "0.833"),
        ],
    )
    monkeypatch.setitem(B.BENCHES, fake.name, fake)
    monkeypatch.setattr("terrapath.commands.bench._root", lambda: tmp_path)
    base = _figures()[0]
    title = "bench fake-table: a fake table"
    entries = [
        dataclasses.replace(
            base, id="fake.all", title=title, row="all / ampso / success", target=""
        ),
        dataclasses.replace(base, id="fake.cost", title=title, row="b / ampso / cost", target=""),
        base,
    ]
    F.save(folder / "current.json", entries)
    monkeypatch.chdir(tmp_path)
    old = (folder / "current.json").read_bytes(), (folder / "README.md").read_bytes()
    assert main(["bench", "fake-table", "--runs", "3"]) == 0  # a quick version: not current
    assert ((folder / "current.json").read_bytes(), (folder / "README.md").read_bytes()) == old
    # nor the paper table's: a quick version is printed, SUMMARY.md is not touched
    assert not (folder / "SUMMARY.md").exists()
    assert main(["bench", "fake-table"]) == 0  # the table's own runs (plans(10))
    got = {f.id: f for f in F.read(folder / "current.json")}
    assert (got["fake.all"].value, got["fake.all"].target) == ("11/12", "paper 3/4")
    assert (got["fake.cost"].value, got["fake.cost"].target) == ("0.5", "paper 0.6")
    assert got["fake.all"].command == "terrapath bench fake-table"
    assert got["fake.all"].source == "SUMMARY.md"
    assert got[base.id] == base
    text = (folder / "README.md").read_text(encoding="utf-8")
    assert F.with_table(text, list(got.values()), "") == text
    assert "| 11/12 | paper 3/4 |" in text


def test_terrapath_bench_table_regenerates_it(
    copies: tuple[Path, Path, Path],
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    current, readme, _ = copies
    folder = current.parent / "benchmarks"
    folder.mkdir()
    data = json.loads(current.read_text(encoding="utf-8"))
    data["figures"][0]["value"] = "42 ms"
    (folder / "current.json").write_text(json.dumps(data), encoding="utf-8")
    shutil.copy(readme, folder / "README.md")
    monkeypatch.setattr("terrapath.commands.bench._root", lambda: current.parent)
    assert main(["bench", "--table"]) == 0
    text = (folder / "README.md").read_text(encoding="utf-8")
    assert f"| {data['figures'][0]['label']} | 42 ms |" in text
    assert F.with_table(text, F.read(folder / "current.json"), "") == text
    assert "wrote the table of" in capsys.readouterr().out
    assert main(["bench", "--table"]) == 0  # a second time: nothing to change
    assert "kept the table of" in capsys.readouterr().out


def test_bench_rows_totals() -> None:
    lines = [
        ("r1", "x", "success", "1/1", "1/1", "-"),
        ("r2", "x", "success", "0/1", "-", "-"),
        ("r1", "y", "outcome", "goal", "goal", "right"),
        ("r2", "y", "outcome", "goal", "stop", "wrong"),
        ("r3", "y", "outcome", "stop", "stop", "right"),
    ]
    rows = F.bench_rows(lines, ("right outcome", "ours right?"))
    assert rows[0] == ("r1 / x / success", "1/1", "right outcome 1/1")
    assert rows[1] == ("r2 / x / success", "0/1", "")
    assert ("all / x / success", "1/2", "") in rows  # a row without the paper's count: no total
    assert ("all / y / right", "2/3", "3/3") in rows
    assert len(rows) == len(lines) + 2


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda e: e.update(colour="red"), "figures[1] (terrain.rays): unknown field 'colour'"),
        (lambda e: e.pop("target"), "figures[1] (terrain.rays): field 'target' missing"),
        (lambda e: e.update(value=""), "figures[1] (terrain.rays): field 'value': expected text"),
        (lambda e: e.update(date=3), "figures[1] (terrain.rays): field 'date': expected text"),
        (lambda e: e.update(id="terrain.below-terrain"), "id 'terrain.below-terrain' used twice"),
    ],
)
def test_a_bad_entry_is_one_line_naming_the_file_entry_and_field(
    tmp_path: Path, change, message: str
) -> None:  # type: ignore[no-untyped-def]
    data = json.loads(CURRENT.read_text(encoding="utf-8"))
    change(data["figures"][1])
    bad = tmp_path / "current.json"
    bad.write_text(json.dumps(data), encoding="utf-8")
    with pytest.raises(InputError) as exc:
        F.read(bad)
    assert str(exc.value).startswith(f"{bad}: ") and message in str(exc.value)
    assert "\n" not in str(exc.value)


def test_a_readme_without_the_markers_is_refused(tmp_path: Path) -> None:
    readme = tmp_path / "README.md"
    readme.write_text("# Benchmarks\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"README\.md: expected the markers"):
        F.write_table(readme, _figures())
    assert readme.read_text(encoding="utf-8") == "# Benchmarks\n"
