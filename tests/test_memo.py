"""Results remembered on disk (terrain.memo): the exact bytes of the answer, asked again when the
code or the question changes, and never an error when the folder cannot be used."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from replay.flight.fixedwing import trim as trim_module
from replay.flight.fixedwing.presets import PRESETS
from terrain.memo import DiskMemo, cache_dir

ROOT = Path(__file__).resolve().parents[1]


def _memo(tmp_path: Path, text: str = "def answer(): ...") -> DiskMemo:
    src = tmp_path / "code.py"
    src.write_text(text, encoding="utf-8")
    return DiskMemo("test", [src])


def test_an_answer_is_remembered_as_its_bytes_and_asked_again_when_the_code_changes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("TERRAPATH_CACHE_DIR", str(tmp_path / "cache"))
    calls = []

    def compute() -> np.ndarray:
        calls.append(1)
        return np.array([0.1, -math.pi, math.inf])

    memo = _memo(tmp_path)
    first = memo.floats(b"q", compute, 3)
    again = memo.floats(b"q", compute, 3)
    assert len(calls) == 1 and first.tobytes() == again.tobytes()
    memo.floats(b"another question", compute, 3)
    assert len(calls) == 2
    _memo(tmp_path, "def answer(): return 2").floats(b"q", compute, 3)  # new code: asked again
    assert len(calls) == 3
    entries = list((tmp_path / "cache" / "test").rglob("*.bin"))
    assert len(entries) == 3 and not list((tmp_path / "cache").rglob("*.part"))
    for e in entries:
        e.write_bytes(b"\0" * 5)  # truncated: computed again, and written whole
    assert _memo(tmp_path).floats(b"q", compute, 3).tobytes() == first.tobytes()
    assert len(calls) == 4


def test_an_unusable_folder_or_an_empty_setting_only_means_computing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("", encoding="utf-8")
    monkeypatch.setenv("TERRAPATH_CACHE_DIR", str(blocker / "cache"))  # cannot be made
    assert _memo(tmp_path).floats(b"q", lambda: np.ones(3), 3).tolist() == [1.0, 1.0, 1.0]
    monkeypatch.setenv("TERRAPATH_CACHE_DIR", "")
    assert cache_dir() is None
    assert _memo(tmp_path).floats(b"q", lambda: np.zeros(3), 3).tolist() == [0.0, 0.0, 0.0]
    monkeypatch.setenv("TERRAPATH_CACHE_DIR", str(tmp_path / "cache"))
    gone = DiskMemo("test", [tmp_path / "no-such-source.py"])  # its code cannot be read
    assert gone.floats(b"q", lambda: np.ones(3), 3).tolist() == [1.0, 1.0, 1.0]
    assert not (tmp_path / "cache").exists()
    monkeypatch.delenv("TERRAPATH_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_dir() == tmp_path / "xdg" / "terrapath"


def test_a_trim_read_from_disk_in_another_process_is_the_solved_one(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("TERRAPATH_CACHE_DIR", str(tmp_path / "cache"))
    p = PRESETS["aerosonde"]
    fresh = trim_module._solve_now(p, p.pack(), 23.0, 1234.5, 0.03, -400.0, None)
    code = (
        "import math, sys; from replay.flight.fixedwing.presets import PRESETS; "
        "from replay.flight.fixedwing.trim import trim; p = PRESETS['aerosonde']; "
        "x, u = trim(p, 23.0, 1234.5, gamma=0.03, turn_radius=-400.0); "
        "sys.stdout.write((x.tobytes() + u.tobytes()).hex())"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    run = [sys.executable, "-c", code]
    first = subprocess.run(run, env=env, capture_output=True, text=True, check=True).stdout
    entries = list((tmp_path / "cache" / "trim").rglob("*.bin"))
    assert entries
    for e in entries:  # another angle of attack: a process that reads them flies it
        zr = np.frombuffer(e.read_bytes(), dtype=np.float64).copy()
        zr[0] += 1e-3
        e.write_bytes(zr.tobytes())
    second = subprocess.run(run, env=env, capture_output=True, text=True, check=True).stdout
    assert second != first  # the second process read the disk's answer
    for e in entries:
        e.unlink()
    third = subprocess.run(run, env=env, capture_output=True, text=True, check=True).stdout
    assert third == first  # solved again: the same bytes
    trim_module._solved.cache_clear()
    x, u = trim_module.trim(p, 23.0, 1234.5, gamma=0.03, turn_radius=-400.0)
    assert (x.tobytes() + u.tobytes()).hex() == first
    z, r = trim_module._solve(p, p.pack(), 23.0, 1234.5, 0.03, -400.0, None)
    np.testing.assert_array_equal(z, fresh[0])
    assert r == fresh[1]


def test_a_filled_grid_is_read_back_bit_for_bit_and_a_big_one_is_not_kept(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from terrain import load

    monkeypatch.setenv("TERRAPATH_CACHE_DIR", str(tmp_path / "cache"))
    rng = np.random.default_rng(7)
    heights = rng.uniform(100.0, 900.0, (60, 45)).astype(np.float32)
    heights[rng.random(heights.shape) < 0.2] = np.nan
    heights[:10, :12] = np.nan  # a corner the reprojection left empty
    want = load._fill_now(heights.copy())
    assert np.isfinite(want).all()
    calls = []
    fill_now = load._fill_now
    monkeypatch.setattr(load, "_fill_now", lambda h: calls.append(1) or fill_now(h))
    first = load.fill_nodata(heights.copy())
    again = load.fill_nodata(heights.copy())
    assert len(calls) == 1
    assert first.tobytes() == want.tobytes() == again.tobytes() and first.dtype == np.float32
    assert again.flags.writeable
    other = heights.copy()
    other[30, 30] = 555.0 if np.isnan(other[30, 30]) else np.nan  # another question
    load.fill_nodata(other)
    assert len(calls) == 2
    monkeypatch.setattr(load, "FILL_MEMO_CELLS", heights.size - 1)
    load.fill_nodata(heights.copy())
    load.fill_nodata(heights.copy())
    assert len(calls) == 4  # above the size: filled each time, nothing kept
    assert len(list((tmp_path / "cache" / "fill").rglob("*.bin"))) == 2


def test_the_folder_keeps_to_its_size_forgetting_the_entries_used_longest_ago(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("TERRAPATH_CACHE_DIR", str(tmp_path / "cache"))
    src = tmp_path / "code.py"
    src.write_text("code", encoding="utf-8")
    block = 4096  # an entry of 4 KB takes one block (or its size where blocks are not told)
    memo = DiskMemo("sized", [src], max_bytes=3 * block)
    memo.PRUNE_EVERY = 1  # every write (a process prunes on its first, then every 1000th)
    calls = []

    def answer(q: bytes) -> bytes:
        calls.append(q)
        return q * (block // len(q))

    folder = tmp_path / "cache" / "sized"
    for q in (b"a", b"b", b"c"):
        memo.get(q, lambda q=q: answer(q), block)
    entries = sorted(folder.rglob("*.bin"))
    assert len(entries) == 3
    for k, e in enumerate(sorted(entries, key=lambda e: e.stat().st_mtime_ns)):
        os.utime(e, ns=(10**18 + k, 10**18 + k))  # written in order, a second apart
    memo.get(b"a", lambda: answer(b"a"), block)  # read: "a" used now
    assert calls == [b"a", b"b", b"c"]
    memo.get(b"d", lambda: answer(b"d"), block)  # a fourth: "b", used longest ago, goes
    assert len(list(folder.rglob("*.bin"))) == 3
    memo.get(b"c", lambda: answer(b"c"), block)
    memo.get(b"a", lambda: answer(b"a"), block)
    assert calls == [b"a", b"b", b"c", b"d"]  # "a" and "c" were kept
    memo.get(b"b", lambda: answer(b"b"), block)
    assert calls[-1] == b"b"  # forgotten: computed again
