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
any change in the last bit shows. Beyond the golden files, a few replays of data/'s scenarios
cover every avoider (FGA, CTGA, the priority loop, PSO-CA), every sensor (cooperative,
rangefinder, a noisy radar) and the multirotor (their decisions hashed too, less compute times).
``--plans-only`` / ``--replays-only`` / ``--extra-only`` run one part. Exit status
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


def _outcome(m: Any) -> dict[str, Any]:
    """A replay's outcome (its metrics as the golden file holds them)."""
    return {
        "success": bool(m.success),
        "end_reason": m.end_reason,
        "min_separation": {k: v["value"] for k, v in m.min_separation.items()},
        "plr": m.plr,
        "waypoints_added": int(m.waypoints_added),
        "flight_time_s": m.flight_time_s,
        "min_terrain_clearance_m": m.min_terrain_clearance_m,
        "off_map_s": m.off_map_s,
    }


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
    from replay.run import run_replay

    try:
        from replay.threats.file import threats_from_records
    except ImportError:  # before the house was rearranged
        from replay.threat_file import threats_from_records  # type: ignore[no-redef]
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
        r = run_replay(_request(str(_mission_file(sc)), threats, {"avoid": avoid, "seed": SEED}))
        outcome = _outcome(r.metrics)
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


# beyond the golden replays: every avoider, every sensor, the multirotor, a noisy radar (the
# scenarios of the tests and benchmarks: data/)
EXTRA: tuple[tuple[str, str, str | None, dict[str, Any]], ...] = (
    (
        "fga-cooperative",
        "data/scenarios/seed004-mission.yaml",
        "data/scenarios/seed004-case9.yaml",
        {"avoid": "fga", "sensor": "cooperative", "margin": 30.0},
    ),
    (
        "ctga-cooperative",
        "data/scenarios/seed001-mission.yaml",
        "data/scenarios/seed001-simple-threats.yaml",
        {"avoid": "ctga", "sensor": "cooperative"},
    ),
    (
        "priority-rangefinder",
        "data/scenarios/priority-mission.yaml",
        "data/scenarios/priority-box.yaml",
        {"avoid": "priority", "sensor": "rangefinder"},
    ),
    (
        "pso-ca-noisy-radar",
        "data/missions/seed000-table4.yaml",
        "data/threats/seed000-table4.yaml",
        {"avoid": "pso-ca", "seed": 3, "radar_noise": 5.0},
    ),
    ("quadrotor", "data/scenarios/quadrotor-mission.yaml", None, {}),
)


EXTRA_OUTCOME = ("success", "end_reason", "min_separation", "plr", "flight_time_s")


def _request(source: str, threats: Any, settings: dict[str, Any]) -> Any:
    """A replay request in this checkout's API (settings in ReplayRequest itself before the
    house was rearranged, in its ReplayConfig after)."""
    from replay.run import ReplayRequest

    settings = {**settings, "terrain_mesh": False}
    if hasattr(ReplayRequest, "of"):
        if "radar_noise" in settings:
            settings["radar_noise_range"] = settings.pop("radar_noise")
        return ReplayRequest.of(source, threats=threats, **settings)
    return ReplayRequest(source, threats=threats, **settings)


def extra_hashes() -> dict[str, str]:
    from replay.run import run_replay

    out: dict[str, str] = {}
    for name, mission, threats, settings in EXTRA:
        t0 = time.perf_counter()
        r = run_replay(_request(mission, threats, settings))
        outcome = {k: v for k, v in _outcome(r.metrics).items() if k in EXTRA_OUTCOME}
        key = f"extra/{name}"
        out[key] = _digest(
            np.asarray(r.times),
            np.asarray(r.states),
            np.asarray(r.waypoints),
            _exact(outcome),
            _exact([{k: v for k, v in d.items() if k != "compute_s"} for d in r.decisions]),
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
    half.add_argument("--extra-only", action="store_true")
    args = ap.parse_args(argv)

    hashes: dict[str, str] = {}
    if not (args.replays_only or args.extra_only):
        print("golden plans:")
        hashes.update(plan_hashes())
    if not (args.plans_only or args.extra_only):
        print("golden replays:")
        hashes.update(replay_hashes())
    if not (args.plans_only or args.replays_only):
        print("every avoider, sensor and vehicle kind:")
        hashes.update(extra_hashes())
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
