"""Fingerprints of the golden regression results, to show that a change moves nothing a user can
measure: a SHA-256 of every golden plan's waypoints and cost terms (``tests/golden/scenarios.py``,
every map and algorithm) and of every golden replay's recorded arrays (times, 12 states, map
positions, final and initial waypoints) and outcome (``tests/golden/replays.py``, every map and
avoider).

Run it before and after a change on the same machine with the same lock file and compare:

    .venv/bin/python -m tools.golden_hashes -o build/hashes-before.json
    ... the change ...
    .venv/bin/python -m tools.golden_hashes -o build/hashes-after.json --compare build/hashes-before.json

Arrays are hashed bit for bit (dtype, shape and bytes); floats in the outcome through ``repr``, so
any change in the last bit shows. ``--plans-only`` / ``--replays-only`` run half of it. Exit status
1 when ``--compare`` finds a difference (each one listed), 0 otherwise.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np


def _digest(*parts: Any) -> str:
    h = hashlib.sha256()
    for part in parts:
        if isinstance(part, np.ndarray):
            a = np.ascontiguousarray(part)
            h.update(f"{a.dtype.str}{a.shape}".encode())
            h.update(a.tobytes())
        else:
            h.update(json.dumps(part, sort_keys=True, default=repr).encode())
    return h.hexdigest()


def _exact(value: Any) -> Any:
    """``value`` with every float as its repr (JSON would round-trip it anyway; this is explicit)."""
    if isinstance(value, dict):
        return {str(k): _exact(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_exact(v) for v in value]
    if isinstance(value, float | np.floating):
        return repr(float(value))
    if isinstance(value, np.integer):
        return int(value)
    return value


def plan_hashes() -> dict[str, str]:
    from tests.golden.scenarios import ALGORITHMS, MAPS

    out: dict[str, str] = {}
    for sc in MAPS:
        if not sc.available():
            print(f"  {sc.name}: map not found, skipped", file=sys.stderr)
            continue
        problem = sc.problem()
        for alg in ALGORITHMS:
            t0 = time.perf_counter()
            r = sc.run(alg, problem)
            key = f"plan/{sc.name}/{alg}"
            out[key] = _digest(
                np.asarray(r.waypoints, np.float64),
                np.asarray(r.path, np.float64),
                _exact(r.terms),
                r.status,
            )
            print(f"  {key:28s} {out[key][:16]}  ({time.perf_counter() - t0:.1f} s)")
    return out


def replay_hashes() -> dict[str, str]:
    from replay.run import ReplayRequest, run_replay
    from replay.threats.file import threats_from_records
    from tests.golden.replays import CASES, SEED, _mission_file, mission_of, threat_records

    out: dict[str, str] = {}
    for sc, avoid in CASES:
        if not sc.available():
            continue
        t0 = time.perf_counter()
        prepared = sc.prepared()
        threats = threats_from_records(
            threat_records(mission_of(sc)), prepared.grid, name=f"golden-{sc.name}"
        )
        r = run_replay(
            ReplayRequest.of(
                str(_mission_file(sc)), threats=threats, avoid=avoid, seed=SEED, terrain_mesh=False
            )
        )
        m = r.metrics
        outcome = {
            "success": bool(m.success),
            "end_reason": m.end_reason,
            "min_separation": {k: v["value"] for k, v in m.min_separation.items()},
            "plr": m.plr,
            "waypoints_added": int(m.waypoints_added),
            "flight_time_s": m.flight_time_s,
            "min_terrain_clearance_m": m.min_terrain_clearance_m,
            "off_map_s": m.off_map_s,
        }
        key = f"replay/{sc.name}/{avoid}"
        out[key] = _digest(
            np.asarray(r.times),
            np.asarray(r.states),
            np.asarray(r.positions),
            np.asarray(r.waypoints),
            np.asarray(r.initial_waypoints),
            _exact(outcome),
        )
        print(f"  {key:28s} {out[key][:16]}  ({time.perf_counter() - t0:.1f} s)")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", type=Path, help="write the hashes here (JSON)")
    ap.add_argument("--compare", type=Path, help="a JSON written earlier: list what differs")
    half = ap.add_mutually_exclusive_group()
    half.add_argument("--plans-only", action="store_true")
    half.add_argument("--replays-only", action="store_true")
    args = ap.parse_args(argv)

    hashes: dict[str, str] = {}
    if not args.replays_only:
        print("golden plans:")
        hashes.update(plan_hashes())
    if not args.plans_only:
        print("golden replays:")
        hashes.update(replay_hashes())
    if args.output:
        args.output.parent.mkdir(parents=True, exist_ok=True)
        tmp = args.output.with_name(args.output.name + ".part")
        tmp.write_text(json.dumps(hashes, indent=2, sort_keys=True) + "\n")
        tmp.replace(args.output)
        print(f"wrote {args.output}")
    if args.compare:
        before = json.loads(args.compare.read_text())
        keys = sorted(set(before) & set(hashes))
        differ = [k for k in keys if before[k] != hashes[k]]
        missing = sorted(set(before) ^ set(hashes))
        for k in differ:
            print(f"DIFFERS  {k}")
        for k in missing:
            print(f"ONLY IN {'before' if k in before else 'after'}  {k}")
        print(f"{len(keys) - len(differ)}/{len(keys)} identical, {len(missing)} not in both")
        return 1 if differ or missing else 0
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
