"""Campaigns (issue 17): the spec at the edge, the seeds, the generators' protocols, the store
(resumable, kill-safe, shared), and the same rows from the process pool and a Dask cluster.

The campaigns here fly seed 001's 4.5 km mission (flat ground, 90 s at 50 m/s) with CTGA and the
cooperative sensor, so a run takes a fraction of a second."""

from __future__ import annotations

import multiprocessing
import os
import re
import shlex
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from planner.mission import load_mission
from replay.campaign.generators import GENERATORS, HILL_SPACING_M, Params, intruder_records
from replay.campaign.runner import run_campaign, wilson
from replay.campaign.spec import derive_seed, load_spec
from replay.campaign.store import Store
from replay.metrics import WALL_CLOCK_METRICS
from replay.record.reader import load_run
from terrain.errors import InputError
from terrapath.cli import main

ROOT = Path(__file__).resolve().parents[1]
MISSION = ROOT / "data" / "scenarios" / "seed001-mission.yaml"
SEED000 = ROOT / "data" / "missions" / "seed000-table4.yaml"
# measured, so never the same twice: everything else in a row is
TIMINGS = ("wall_s", "finished_utc", "mcap")
TIMED_METRICS = WALL_CLOCK_METRICS

SPEC = f"""terrapath: 1
name: test-campaign
mission: {MISSION}
threats: {{generator: uniform, counts: [0, 3], radius: 150, keep_clear: 500, sigma: 400}}
avoiders: [{{name: ctga}}, {{name: none}}]
sensor: cooperative
runs: 3
seed: 7
"""


def _spec(tmp_path: Path, text: str = SPEC, name: str = "spec.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def _comparable(rows: list[dict]) -> list[dict]:
    out = []
    for r in rows:
        r = {k: v for k, v in r.items() if k not in TIMINGS}
        if r["metrics"] is not None:
            r["metrics"] = {k: v for k, v in r["metrics"].items() if k not in TIMED_METRICS}
        out.append(r)
    return sorted(out, key=lambda r: r["key"])


def _rows(store: Path) -> list[dict]:
    with Store(store, "test") as s:
        return s.rows()


# -- seeds and keys ---------------------------------------------------------------------------


def test_seeds_are_stable_and_the_scenario_is_shared_by_the_avoiders(tmp_path: Path) -> None:
    # SHA-256 of "7|seed001-mission/3/ctga/0": the same on every machine and Python
    assert derive_seed(7, "seed001-mission/3/ctga/0") == 767464361373244518
    assert derive_seed(1, "a") == 6151358694578356606
    spec = load_spec(_spec(tmp_path))
    runs = spec.all_runs()
    assert len(runs) == 2 * 2 * 3 and len({r.key for r in runs}) == len(runs)
    by = {r.key: r for r in runs}
    a, b = by["seed001-mission/3/ctga/1"], by["seed001-mission/3/none/1"]
    assert a.scenario_seed == b.scenario_seed and a.seed != b.seed
    assert by["seed001-mission/3/ctga/0"].scenario_seed != a.scenario_seed
    # more runs or another count keep the identity of the runs already there
    more = load_spec(
        _spec(tmp_path, SPEC.replace("runs: 3", "runs: 5").replace("[0, 3]", "[0, 3, 5]"), "b.yaml")
    )
    assert {r.run_hash for r in runs} < {r.run_hash for r in more.all_runs()}
    assert more.spec_hash != spec.spec_hash


# -- generators ---------------------------------------------------------------------------------


def test_seed000_generators_follow_the_papers_protocol() -> None:
    mission = load_mission(SEED000)
    wps = np.asarray(mission.waypoints)
    p = Params()
    recs = GENERATORS["seed000-normal"](mission, 200, np.random.default_rng(3), p)
    xy = np.array([r["position"][:2] for r in recs])
    assert len(recs) == 200 and all(r["radius"] == 1000.0 for r in recs)
    assert all(r["position"][2] == mission.cruise_altitude for r in recs)
    ends = np.linalg.norm(xy[:, None, :] - wps[[0, -1], None, :2].transpose(1, 0, 2), axis=-1)
    assert ends.min() >= 1500.0  # the clear zone round the start and the goal
    nearest = np.linalg.norm(xy[:, None, :] - wps[None, :, :2], axis=-1).min(axis=1)
    assert np.median(nearest) < 3000.0 * 1.5  # drawn round the waypoints (sigma 3 km)
    again = GENERATORS["seed000-normal"](mission, 200, np.random.default_rng(3), p)
    assert again == recs
    hill = GENERATORS["seed000-hill"](mission, 5, np.random.default_rng(4), p)[-1]
    pts = np.asarray(hill["points"])
    assert hill["kind"] == "hill" and len(pts) == 6
    np.testing.assert_allclose(np.linalg.norm(np.diff(pts[:, :2], axis=0), axis=1), HILL_SPACING_M)
    intruders = [
        r
        for r in GENERATORS["seed000-intruders"](mission, 5, np.random.default_rng(5), p)
        if r["kind"] == "intruder"
    ]
    assert len(intruders) == 2


def test_intruders_meet_the_undisturbed_aircraft() -> None:
    mission = load_mission(SEED000)
    for rec in intruder_records(mission.waypoints, 15.0, np.random.default_rng(11)):
        t = rec["meet_t"] - rec["appears_at"]
        at = np.asarray(rec["position"]) + t * np.asarray(rec["velocity"])
        np.testing.assert_allclose(at[:2], rec["meet_xy"], atol=1e-6)


def test_uniform_stays_in_its_box() -> None:
    mission = load_mission(MISSION)
    box = (-500.0, 500.0, 2500.0, 3500.0)
    recs = GENERATORS["uniform"](
        mission, 50, np.random.default_rng(0), Params(box=box, keep_clear=300.0)
    )
    xy = np.array([r["position"][:2] for r in recs])
    assert (xy >= box[:2]).all() and (xy <= box[2:]).all()


# -- a campaign end to end ---------------------------------------------------------------------


def test_campaign_flies_every_run_resumes_and_reflies_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = _spec(tmp_path)
    store = tmp_path / "r.sqlite"
    assert main(["campaign", str(spec), "--store", str(store), "--jobs", "2"]) == 0
    out = capsys.readouterr()
    rows = _rows(store)
    assert len(rows) == 12 and all(r["status"] == "ok" for r in rows)
    from terrapath import __version__

    assert all(r["spec_name"] == "test-campaign" and r["version"] == __version__ for r in rows)
    by = {r["key"]: r for r in rows}
    # no threats: everyone succeeds; three 150 m spheres round the path: flying straight on
    # enters one in most scenarios, CTGA keeps clear in most (run 2 grazes obs2 by 25 m)
    for av in ("ctga", "none"):
        assert all(by[f"seed001-mission/0/{av}/{i}"]["success"] for i in range(3))
    ctga = sum(by[f"seed001-mission/3/ctga/{i}"]["success"] for i in range(3))
    none = sum(by[f"seed001-mission/3/none/{i}"]["success"] for i in range(3))
    assert ctga >= 2 and none <= 1
    assert "success (95 % CI)" in out.out and "seed001-mission  3    ctga" in out.out
    # a failed run kept its MCAP (default: failures), the successes did not
    failed = [r for r in rows if not r["success"]]
    assert failed and all(r["mcap"] and Path(r["mcap"]).exists() for r in failed)
    assert all(r["mcap"] is None for r in rows if r["success"])
    # again: nothing to fly
    assert main(["campaign", str(spec), "--store", str(store)]) == 0
    assert "12 already in" in capsys.readouterr().err
    # one run again, alone: the same row
    key = failed[0]["key"]
    assert main(["campaign", str(spec), "--store", str(store), "--only", key]) == 3  # a failure
    assert _comparable([r for r in _rows(store) if r["key"] == key]) == _comparable([failed[0]])


def test_pool_and_dask_give_the_same_rows(tmp_path: Path) -> None:
    spec = load_spec(_spec(tmp_path))
    rows = {}
    for executor in ("pool", "dask-local"):
        with Store(tmp_path / f"{executor}.sqlite", "test") as store:
            run_campaign(
                spec, store, version="test", command="x", jobs=2, executor=executor, keep="none"
            )
            rows[executor] = _comparable(store.rows())
    assert len(rows["pool"]) == 12 and rows["pool"] == rows["dask-local"]


def test_a_run_that_raises_is_stored_and_the_campaign_goes_on(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import replay.campaign.runner as runner

    real = runner.scenario

    def flaky(run):  # type: ignore[no-untyped-def]
        if run.key.endswith("/3/ctga/1"):
            raise RuntimeError("boom")
        return real(run)

    monkeypatch.setattr(runner, "scenario", flaky)
    spec = load_spec(_spec(tmp_path))
    with Store(tmp_path / "e.sqlite", "test") as store:
        _, flown = run_campaign(spec, store, version="test", command="x", jobs=1, keep="none")
        rows = store.rows()
    assert len(flown) == len(rows) == 12
    (bad,) = [r for r in rows if r["status"] == "error"]
    assert bad["key"] == "seed001-mission/3/ctga/1" and bad["error"] == "RuntimeError: boom"
    assert bad["seed"] == derive_seed(7, bad["key"])


def _campaign_process(spec: Path, store: Path) -> subprocess.Popen[bytes]:
    """``terrapath campaign`` in its own process; its stderr goes to ``<spec>.stderr`` (read by
    :func:`_stderr` when it fails)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "terrapath.cli", "campaign", str(spec), "--store", str(store)]
    with spec.with_suffix(".stderr").open("wb") as err:
        return subprocess.Popen(
            [*cmd, "--jobs", "1", "--keep-mcap", "none"],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=err,
        )


def _stderr(spec: Path) -> str:
    """The last lines a campaign process of :func:`_campaign_process` wrote to stderr."""
    return "\n".join(spec.with_suffix(".stderr").read_text(errors="replace").splitlines()[-15:])


def test_killed_half_way_and_resumed_equals_straight_through(tmp_path: Path) -> None:
    spec = _spec(tmp_path, SPEC.replace("runs: 3", "runs: 6"))
    straight, killed = tmp_path / "straight.sqlite", tmp_path / "killed.sqlite"
    assert (
        main(
            ["campaign", str(spec), "--store", str(straight), "--jobs", "2", "--keep-mcap", "none"]
        )
        == 0
    )
    proc = _campaign_process(spec, killed)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        time.sleep(0.05)
        if killed.exists():
            try:
                n = (
                    sqlite3.connect(killed, timeout=5)
                    .execute("SELECT count(*) FROM runs")
                    .fetchone()[0]
                )
            except sqlite3.OperationalError:
                continue
            if n >= 5:
                break
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    partial = len(_rows(killed))
    assert 5 <= partial < 24  # killed half-way
    assert (
        main(["campaign", str(spec), "--store", str(killed), "--jobs", "2", "--keep-mcap", "none"])
        == 0
    )
    assert _comparable(_rows(killed)) == _comparable(_rows(straight))
    db = sqlite3.connect(killed)
    assert db.execute("PRAGMA integrity_check").fetchone()[0] == "ok"


def test_two_campaigns_share_one_store(tmp_path: Path) -> None:
    a = _spec(tmp_path, SPEC, "a.yaml")
    b = _spec(
        tmp_path,
        SPEC.replace("name: test-campaign", "name: other").replace("seed: 7", "seed: 8"),
        "b.yaml",
    )
    store = tmp_path / "shared.sqlite"
    procs = [_campaign_process(a, store), _campaign_process(b, store)]
    codes = [p.wait(timeout=300) for p in procs]
    assert codes == [0, 0], "\n".join(_stderr(s) for s in (a, b))
    rows = _rows(store)
    assert len(rows) == 24 and {r["spec_name"] for r in rows} == {"test-campaign", "other"}
    assert sqlite3.connect(store).execute("PRAGMA integrity_check").fetchone()[0] == "ok"


def _open_store(path: Path, barrier: Any) -> str:
    barrier.wait()
    try:
        Store(path, "test").close()
    except InputError as exc:
        return str(exc)
    return ""


def test_processes_opening_a_new_store_together_all_get_it(tmp_path: Path) -> None:
    # SQLite answers "database is locked" at once (not after its busy timeout) when connections
    # open a new file together while one switches it to WAL: 11 of 30 such starts failed before
    # the store retried its opening (the CI failure of test_two_campaigns_share_one_store).
    context = multiprocessing.get_context("fork")
    with context.Manager() as manager, context.Pool(4) as pool:
        for trial in range(12):
            barrier = manager.Barrier(4)
            store = tmp_path / f"s{trial}.sqlite"
            errors = pool.starmap(_open_store, [(store, barrier)] * 4)
            assert errors == [""] * 4
            assert _rows(store) == []


def test_wilson_interval() -> None:
    lo, hi = wilson(10, 10)
    assert lo == pytest.approx(0.7225, abs=1e-4) and hi == 1.0
    lo, hi = wilson(0, 10)
    assert lo == 0.0 and hi == pytest.approx(0.2775, abs=1e-4)
    lo, hi = wilson(5, 10)
    assert lo == pytest.approx(0.2366, abs=1e-4) and hi == pytest.approx(0.7634, abs=1e-4)


# -- bad input -----------------------------------------------------------------------------------


def test_the_sensor_is_implied_by_the_avoiders_when_only_one_fits(tmp_path: Path) -> None:
    def sensor(avoiders: str) -> str:
        text = SPEC.replace("sensor: cooperative\n", "").replace(
            "avoiders: [{name: ctga}, {name: none}]", f"avoiders: {avoiders}"
        )
        assert "sensor" not in text
        return load_spec(_spec(tmp_path, text)).sensor

    assert sensor("[{name: priority}]") == "rangefinder"
    assert sensor("[{name: none}, {name: priority}]") == "rangefinder"  # none sees anything
    assert sensor("[{name: ctga}, {name: none}]") == "radar"  # any fits: the default


@pytest.mark.parametrize(
    ("change", "expect"),
    [
        (
            ("generator: uniform", "generator: gaussian"),
            "unknown generator 'gaussian'; valid: seed000-normal, seed000-hill, seed000-intruders, "
            "uniform, seed004-table2",
        ),
        (
            ("generator: uniform", "generator: seed004-table2"),
            "field 'mission': the generator 'seed004-table2' makes each case's mission",
        ),
        (
            ("radius: 150", "radius: 150, dynamic: [true]"),
            "field 'threats.dynamic': only a case generator takes it, not 'uniform'",
        ),
        (("runs: 3", "runs: 0"), "field 'runs': expected a whole number >= 1, found 0"),
        (
            ("[0, 3]", "[0, -3]"),
            "field 'threats.counts[1]': expected a whole number >= 0, found -3",
        ),
        (
            ("{name: none}", "{name: dodge}"),
            "unknown avoider 'dodge'; valid: none, pso-ca, ctga, fga",
        ),
        (
            ("{name: ctga}", "{name: ctga, options: {r_safe: 10, warp: 9}}"),
            "avoider 'ctga' has no option 'warp'",
        ),
        (
            ("sensor: cooperative", "sensor: sonar"),
            "field 'sensor': expected one of radar, cooperative",
        ),
        (
            ("avoiders: [{name: ctga}, {name: none}]", "avoiders: [{name: priority}]"),
            "field 'sensor': cooperative: the priority avoider works with rangefinder only; "
            "give that sensor or leave the sensor out (it is implied)",
        ),
        (("seed: 7", "seed: 7\ncolour: red"), "unknown key(s) 'colour'"),
        (("terrapath: 1", "terrapath: 2"), "field 'terrapath': expected 1"),
    ],
)
def test_bad_specs_get_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], change: tuple[str, str], expect: str
) -> None:
    assert SPEC.count(change[0]) == 1
    spec = _spec(tmp_path, SPEC.replace(*change))
    store = tmp_path / "r.sqlite"
    assert main(["campaign", str(spec), "--store", str(store)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and expect in err and "spec.yaml" in err
    assert not store.exists()


def test_bad_stores_keys_and_schedulers(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path)
    text = tmp_path / "notes.sqlite"
    text.write_text("not a database\n")
    assert main(["campaign", str(spec), "--store", str(text)]) == 1
    assert "not a terrapath campaign store" in capsys.readouterr().err
    assert text.read_text() == "not a database\n"
    old = tmp_path / "old.sqlite"
    db = sqlite3.connect(old)
    db.executescript(
        "CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT); INSERT INTO meta VALUES ('format', '0'), ('created_by', '0.0.1');"
    )
    db.commit()
    db.close()
    assert main(["campaign", str(spec), "--store", str(old)]) == 1
    err = capsys.readouterr().err
    assert "written by terrapath 0.0.1" in err and "format '0'" in err and "reads format '1'" in err
    other = tmp_path / "other.sqlite"
    sqlite3.connect(other).execute("CREATE TABLE t (x)").connection.commit()
    assert main(["campaign", str(spec), "--store", str(other)]) == 1
    assert "not a terrapath campaign store" in capsys.readouterr().err
    assert (
        main(["campaign", str(spec), "--store", str(tmp_path / "s.sqlite"), "--only", "nope/0/x/1"])
        == 1
    )
    assert "no run 'nope/0/x/1' in this campaign" in capsys.readouterr().err
    t0 = time.monotonic()
    store = tmp_path / "never.sqlite"
    assert (
        main(["campaign", str(spec), "--store", str(store), "--scheduler", "tcp://127.0.0.1:9"])
        == 1
    )
    assert time.monotonic() - t0 < 10.0
    err = capsys.readouterr().err
    assert "tcp://127.0.0.1:9 does not answer: nothing listens there" in err
    assert err.count("\n") == 1
    assert not store.exists()


@pytest.mark.parametrize(
    ("generator", "ctga_at_least", "straight_at_most"),
    [
        ("seed000-normal", 10, 7),
        # 4, not the 9 of issue 17: those runs ended "at the goal" when the aircraft crossed the
        # goal's plane mid-arc, up to 4.5 km from it; since issue 18 an arrival is an arrival,
        # and CTGA's arcs round a ridge near the goal fail (an open problem, see the notes)
        ("seed000-hill", 4, 2),
        ("seed000-intruders", 10, 0),
        ("uniform", 10, 5),
    ],
)
def test_a_small_campaign_per_generator(
    tmp_path: Path, generator: str, ctga_at_least: int, straight_at_most: int
) -> None:
    """Ten scenarios of each generator, scaled to seed 001's 4.5 km mission (five 300 m
    spheres drawn 700 m about the waypoints; the hill's six overlap; two intruders): CTGA keeps
    clear in at least ``ctga_at_least`` of 10, while flying straight on gets through at most
    ``straight_at_most`` (the scenarios are in the way)."""
    text = (
        SPEC.replace(
            "{generator: uniform, counts: [0, 3], radius: 150, keep_clear: 500, sigma: 400}",
            f"{{generator: {generator}, counts: [5], radius: 300, keep_clear: 700, sigma: 700}}",
        )
        .replace("runs: 3", "runs: 10")
        .replace("seed: 7", "seed: 3")
    )
    spec = load_spec(_spec(tmp_path, text))
    with Store(tmp_path / "g.sqlite", "test") as store:
        run_campaign(spec, store, version="test", command="x", jobs=2, keep="none")
        rows = store.rows()
    assert len(rows) == 20 and all(r["status"] == "ok" for r in rows)
    wins = {
        av: sum(bool(r["success"]) for r in rows if r["avoider"] == av) for av in ("ctga", "none")
    }
    assert wins["ctga"] >= ctga_at_least and wins["none"] <= straight_at_most


def test_report_tables_and_plots(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from matplotlib.image import imread

    spec = load_spec(_spec(tmp_path))
    store = tmp_path / "r.sqlite"
    with Store(store, "test") as s:
        run_campaign(spec, s, version="test", command="x", jobs=2, keep="none")
        rows = s.rows()
    out = tmp_path / "report"
    assert main(["report", str(store), "-o", str(out)]) in (0, None)
    assert "wrote" in capsys.readouterr().out
    index = (out / "index.md").read_text(encoding="utf-8")
    for avoider in ("ctga", "none"):
        runs = [r for r in rows if r["row"] == "3" and r["avoider"] == avoider]
        k = sum(bool(r["success"]) for r in runs)
        lo, hi = wilson(k, len(runs))
        line = f"| 3 | {avoider} | 3 | {k}/3 | {100 * lo:.0f}–{100 * hi:.0f} % |"
        assert line in index
    plr = [r["metrics"]["plr"] for r in rows if r["row"] == "0" and r["avoider"] == "ctga"]
    assert f"| {np.mean(plr):.3f} ± {np.std(plr, ddof=1):.3f} |" in index
    (png,) = out.glob("*.png")
    assert f"]({png.name})" in index
    img = imread(png)[..., :3]
    assert img.shape[0] > 600 and float(img.std()) > 0.05
    assert main(["report", str(tmp_path / "none.sqlite"), "-o", str(out)]) == 1
    assert "no such store" in capsys.readouterr().err
    assert main(["report", str(store), "-o", str(out), "--name", "other"]) == 1
    assert "no runs of campaign 'other'" in capsys.readouterr().err


def test_bench_seed001_scenarios_beside_the_paper(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    summary = tmp_path / "SUMMARY.md"
    args = [
        "bench",
        "seed001-scenarios",
        "--store",
        str(tmp_path / "b.sqlite"),
        "--summary",
        str(summary),
    ]
    assert main([*args, "--keep-mcap", "all"]) == 0
    out = capsys.readouterr().out
    # each recording names the command that flies it again (a bench has no --only: the campaign)
    mcap = sorted((tmp_path / "b-mcap").glob("*ctga*.mcap"))[0]
    command = shlex.split(load_run(str(mcap)).metadata["command"])
    assert command[:2] == ["terrapath", "campaign"] and "--only" in command
    assert main(command[1:]) == 0  # CTGA's runs succeed (below)
    assert "flying 1 on" in capsys.readouterr().err
    # CTGA passes every obstacle of the three scenarios (the paper: at about R_safe = 100 m)
    for scenario in ("simple", "complex", "moving"):
        assert re.search(rf"^{scenario} +ctga +success +1/1", out, re.M)
        sep = float(
            re.search(
                rf"^{scenario} +ctga +smallest separation \(m\) +([-\d.]+) +100\.0 ", out, re.M
            ).group(1)
        )
        assert sep > 50.0
    text = summary.read_text(encoding="utf-8")
    assert text.count("## seed001-scenarios:") == 1 and "| simple | ctga | success | 1/1 |" in text
    assert main(args) == 0  # again: resumed (nothing flown), the section replaced, not repeated
    assert "6 already in" in capsys.readouterr().err
    assert summary.read_text(encoding="utf-8").count("## seed001-scenarios:") == 1
    assert main(["bench", "nope"]) == 1
    assert (
        "no bench 'nope'; valid: seed000-table4, seed000-table6, seed002-table2, seed001-scenarios, "
        "seed004-table3, seed004-table4, seed003-uncharted" in capsys.readouterr().err
    )
    assert (
        main(
            [
                "bench",
                "seed000-table4",
                "--optimizers",
                "adam",
                "--store",
                str(tmp_path / "c.sqlite"),
            ]
        )
        == 1
    )
    assert "--optimizers 'adam': none of ga, mafoa, pso, sa" in capsys.readouterr().err


def test_dask_missing_names_the_extra(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "dask.distributed", None)  # import fails as if not installed
    spec = _spec(tmp_path)
    assert main(["campaign", str(spec), "--store", str(tmp_path / "s.sqlite"), "--dask-local"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pip install 'terrapath[cluster]'" in err
    assert not (tmp_path / "s.sqlite").exists()


def test_bench_seed002_table2_ranks_the_planners(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    summary = tmp_path / "S.md"
    args = ["bench", "seed002-table2", "--runs", "1", "--summary", str(summary)]
    assert main([*args, "--store", str(tmp_path / "s.sqlite")]) == 0
    out = capsys.readouterr().out
    for name in ("rmnp", "jacksboro"):  # the maps of data/maps: always there
        ranks = re.findall(
            rf"^{name} +(\w+) +rank of the mean \(1 best\) +(\d) +(\d/\d/\d)", out, re.M
        )
        assert sorted(int(r[1]) for r in ranks) == [1, 2, 3, 4]
        # the paper's ranks: AMPSO first on Dakrong and LangCo, second on Daklak
        assert dict((a, p) for a, _, p in ranks)["ampso"] == "2/1/1"
        # one run each: the best run is within 2 % of itself, so at least one algorithm has 1/1
        near = re.findall(
            rf"^{name} +(\w+) +runs within 2 % of the map's best \((0\.\d+)\) +(\d)/1", out, re.M
        )
        assert len(near) == 4 and len({b for _, b, _ in near}) == 1
        assert any(k == "1" for _, _, k in near)
    assert "| rmnp | ampso | cost mean ± sd |" in summary.read_text(encoding="utf-8")


def test_report_plots_keep_one_colour_per_avoider(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An avoider without decisions ('none') is absent from the decision-time panel: the next
    one keeps its own colour there."""
    import terrain.plot
    from replay.campaign import report

    figs: list = []
    monkeypatch.setattr(terrain.plot, "save_figure", lambda fig, out: figs.append(fig) or Path(out))

    def run(avoider: str, decisions: int) -> dict:
        m = {
            "plr": 1.0,
            "flight_time_s": 60.0,
            "decisions": decisions,
            "decision_time_mean_s": 0.001,
        }
        return {"status": "ok", "success": True, "metrics": m, "avoider": avoider, "row": "3"}

    by_line = {("3", "a-none"): [run("a-none", 0)], ("3", "b-ctga"): [run("b-ctga", 4)]}
    report._plot(by_line, tmp_path / "x.png", "t")
    (fig,) = figs
    success, _, decision, _ = fig.axes
    colour = {c.get_label(): c.lines[0].get_color() for c in success.containers}
    (only,) = decision.containers
    assert only.get_label() == "b-ctga" and only.lines[0].get_color() == colour["b-ctga"]
    assert colour["a-none"] != colour["b-ctga"]


# -- seed 004's cases ----------------------------------------------------------------------------
CASES = """terrapath: 1
name: fga-cases
threats: {generator: seed004-table2, dynamic: [false, true]}
avoiders: [{name: fga}]
sensor: cooperative
sensor_range: 1500
margin: 30
runs: 2
seed: 4
"""


def test_a_case_generator_makes_the_mission_too(tmp_path: Path) -> None:
    """``seed004-table2`` names no mission: each run is a whole case (the leg and its obstacles)
    drawn from its scenario seed; the rows are the static and the dynamic set; the number of
    true hazards is stored with the run; a second call flies nothing."""
    from replay.campaign.benches import BENCHES

    spec_path = _spec(tmp_path, CASES)
    spec = load_spec(spec_path)
    assert [r.label for r in spec.rows] == ["static", "dynamic"]
    keys = [r.key for r in spec.all_runs()]
    assert keys[0] == "seed004-table2/static/fga/0" and len(keys) == 4
    store = tmp_path / "cases.sqlite"
    assert main(["campaign", str(spec_path), "--store", str(store), "--jobs", "1"]) == 0
    rows = _rows(store)
    assert len(rows) == 4 and all(r["status"] == "ok" and r["success"] for r in rows)
    for r in rows:
        case = r["metrics"]["case"]
        assert 0 <= case["hazards"] <= 4 and case["dynamic"] == (r["row"] == "dynamic")
        assert r["metrics"]["margin_m"] == 30.0
        assert r["metrics"]["avoider_calls"] > 0
    lines = BENCHES["seed004-table3"].lines([r for r in rows if r["row"] == "static"])
    assert ("all", "fga", "cases", "2", "5000", "-") in lines
    assert main(["campaign", str(spec_path), "--store", str(store), "--jobs", "1"]) == 0
    assert len(_rows(store)) == 4


@pytest.mark.parametrize(
    ("change", "expect"),
    [
        (("dynamic: [false, true]", "counts: [3]"), "draws its own obstacles: give 'dynamic'"),
        (("dynamic: [false, true]", "dynamic: [yes, 2]"), "expected a list like [false, true]"),
        (("dynamic: [false, true]", "dynamic: [true, true]"), "a set is repeated"),
        (("name: fga-cases", f"name: fga-cases\nmission: {MISSION}"), "makes each case's mission"),
        (("sensor_range: 1500", "sensor_range: -1"), "field 'sensor_range'"),
    ],
)
def test_bad_case_specs_get_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], change: tuple[str, str], expect: str
) -> None:
    spec = _spec(tmp_path, CASES.replace(*change))
    assert main(["campaign", str(spec), "--store", str(tmp_path / "r.sqlite")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and expect in err


def test_rows_per_wind_share_their_scenarios(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``winds:`` flies every threat row in each wind (rows ``3@calm``, ``3@8-90``...): the same
    scenarios in every wind (still air keeps the seeds of a spec without winds), each run with
    its own identity; a run in a wind is flown and stored; a bad wind is a one-line error naming
    the field."""
    text = SPEC.replace("counts: [0, 3]", "counts: [3]").replace("runs: 3", "runs: 1")
    text += 'winds: [calm, "8,90", {speed: 12, from: 0, turbulence: light}]\n'
    spec = load_spec(_spec(tmp_path, text))
    assert [r.label for r in spec.rows] == ["3@calm", "3@8-90", "3@12-0-light"]
    runs = [r for r in spec.all_runs() if r.avoider.name == "ctga"]
    assert len({r.scenario_seed for r in runs}) == 1 and len({r.run_hash for r in runs}) == 3
    # still air keeps the scenario seed of a spec without winds
    plain = load_spec(_spec(tmp_path, SPEC, "plain.yaml"))
    base = next(r for r in plain.all_runs() if r.key == "seed001-mission/3/ctga/0")
    assert runs[0].scenario_seed == base.scenario_seed
    store = tmp_path / "w.sqlite"
    key = "seed001-mission/3@8-90/none/0"
    assert main(["campaign", str(_spec(tmp_path, text)), "--store", str(store), "--only", key]) in (
        0,
        3,
    )
    (row,) = [r for r in _rows(store) if r["key"] == key]
    assert row["status"] == "ok" and row["metrics"]["flight_time_s"] > 0
    bad = text.replace('"8,90"', '"8"')
    with pytest.raises(InputError, match=r"winds\[1\].*expected SPEED,FROM_DEG"):
        load_spec(_spec(tmp_path, bad, "bad.yaml"))
