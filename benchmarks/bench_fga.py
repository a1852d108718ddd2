"""FGA benchmark (issue 18): the vehicle's turn, the time of a decision, Table VIII's cases and
Table VII's comparison with a waypoint re-planner.

Run: ``.venv/bin/python benchmarks/bench_fga.py turn|decision-time|table8|table7``
(``--no-record`` to print only).  The Monte Carlo of Tables III and IV is ``terrapath bench
seed004-table3`` / ``seed004-table4`` (5000 cases each).

``turn``: the 6-DOF ``seed004-uas`` through a course step (:func:`replay.avoidance.fga.
measure_turn`): its steady turn radius against eq 3's, and ``t_res`` (eq 8) per step.

``decision-time``: every call of ``FgaAvoider.decide`` (10 Hz, including the calls that decide
nothing) timed over ``--cases`` Monte Carlo cases of each set (target: <= 0.5 ms a decision; the
paper: 5.6 ms per case).

``table8``: Table VIII cases 5-9 (``data/scenarios/seed004-case*.yaml``): the undisturbed least
distance, the manoeuvre FGA chooses and why, the least distance flown, the start time -- beside
the paper's.

``table7``: FGA and PSO-CA (seed 000's waypoint re-planner, cooperative sensor, its distances
scaled to d_m: :data:`PSO_CA_SEED004`) on the same cases (Table VIII's five): the re-planned length -- flown from the first avoidance command to
the goal, the paper's "updated path" -- and the whole flown length (the paper leaves out the
straight part before ``t_c``, which favours FGA), with success and the least separation.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._record import emit as _out  # noqa: E402
from planner.mission import mission_from_dict  # noqa: E402
from replay.avoidance.fga import FgaAvoider  # noqa: E402
from replay.campaign import seed004  # noqa: E402
from replay.campaign.generators import file_records  # noqa: E402
from replay.flight.fixedwing.stack import measure_turn  # noqa: E402
from replay.run import ReplayRequest, run_replay  # noqa: E402
from replay.sim import ReplayResult  # noqa: E402
from replay.threats.file import threats_from_records  # noqa: E402

SCEN = ROOT / "data" / "scenarios"
MISSION = SCEN / "seed004-mission.yaml"
D_M = seed004.D_M
# Table VIII: obstacles, detection distance, speed, original minimum, subroutine, updated
# minimum, avoidance start time (s)
PAPER_TABLE8 = {
    5: ("2 below", "90-120 m", "12-18 m/s", "3 V", "pitch up", "50 V", 1.82),
    6: ("2 above", "< 90 m", "12-15 m/s", "5 V", "pitch up", "50 V", 1.52),
    7: ("2 behind", "90-120 m", "12-20 m/s", "25 H", "steer left", "31 H", 2.35),
    8: ("2 ahead", "100-150 m", "10-12 m/s", "20 H", "steer left", "35 H", 0.92),
    9: ("2 behind, 1 ahead", "100-150 m", "10-17 m/s", "20 H", "steer right", "32 H", 0.36),
}
# Table VII: initial path 200 m; updated path length by the optimal method and by FGA (4 cases)
PAPER_TABLE7 = {"opt": (252, 241, 270, 305), "fga": (70.5, 65.3, 82.4, 91.7)}


# PSO-CA at seed 004's scale: its seed 000 distances (RS 1 km, intruders 2 km, acting within 8
# km) scaled to d_m = 30 m (RS and the intruders' radius d_m + 2 buffer_m, like FGA's steering)
PSO_CA_SEED004 = {
    "rs": 36.0,
    "mxrsk": 108.0,
    "leg_margin": 6.0,
    "moving_rs": 36.0,
    "act_range": 300.0,
    "moving_hold_s": 2.0,
    "retry_s": 1.0,
}


def fly(threats: Any, avoider: str, mission: Any = None) -> ReplayResult:
    return run_replay(
        ReplayRequest.of(
            mission if mission is not None else str(MISSION),
            threats=threats,
            avoid=avoider,
            avoid_options=PSO_CA_SEED004 if avoider == "pso-ca" else {},
            sensor="cooperative",
            margin=D_M,
            radar_range=seed004.SENSOR_RANGE_M,
        )
    )


def least(res: ReplayResult) -> tuple[float, str]:
    seps = res.metrics.min_separation
    key = min(seps, key=lambda k: seps[k]["value"])
    return float(seps[key]["value"]), key


def turn(no_record: bool) -> None:
    m = measure_turn("seed004-uas", 15.0)
    rows = [
        (
            "steady turn radius at 15 m/s",
            f"{m['radius_m']:.1f} m (eq 3 at 38 deg: {m['radius_eq3_m']:.1f} m)",
            "<= d_m = 30 m (+10 %)",
        ),
        ("turn rate", f"{m['max_rate_deg_s']:.1f} deg/s (ideal {m['ideal_rate_deg_s']:.1f})", "-"),
    ]
    rows += [
        (f"t_res, {deg:.0f} deg course step", f"{v:.2f} s", "<= 0.5 s (the default)")
        for deg, v in m["t_res"].items()
    ]
    _out("fga: the seed004-uas turn (eq 3, eq 5, t_res of eq 8)", rows, "", no_record)


def decision_time(cases: int, no_record: bool) -> None:
    times: list[float] = []
    original = FgaAvoider.decide

    def timed(self: FgaAvoider, ctx: Any) -> Any:
        t0 = time.perf_counter()
        out = original(self, ctx)
        times.append(time.perf_counter() - t0)
        return out

    FgaAvoider.decide = timed  # type: ignore[method-assign]
    try:
        fly(str(SCEN / "seed004-case9.yaml"), "fga")  # warm up
        times.clear()
        for dynamic in (False, True):
            for k in range(cases):
                _doc, records, _notes = seed004.seed004_case(np.random.default_rng(k), dynamic)
                threats = threats_from_records(file_records(records), name=f"case {k}")
                fly(threats, "fga", mission_from_dict(seed004.mission_doc()))
    finally:
        FgaAvoider.decide = original  # type: ignore[method-assign]
    ms = np.array(times) * 1e3
    rows = [
        ("decisions timed", f"{len(ms)} ({2 * cases} cases, 10 Hz)", "-"),
        ("median", f"{np.median(ms):.3f} ms", "<= 0.5 ms"),
        ("mean", f"{ms.mean():.3f} ms", "<= 0.5 ms"),
        ("99th percentile", f"{np.percentile(ms, 99):.3f} ms", "-"),
        ("max", f"{ms.max():.2f} ms", "-"),
        ("per case (all decisions)", f"{ms.sum() / (2 * cases):.1f} ms", "paper: 5.6 ms"),
    ]
    notes = (
        "every call of FgaAvoider.decide, including the perception update of a new scan; the "
        "paper's 5.6 ms is one computation per case"
    )
    _out("fga: the time of a decision", rows, notes, no_record)


def table8(no_record: bool) -> None:
    rows = []
    for case, paper in PAPER_TABLE8.items():
        threats = str(SCEN / f"seed004-case{case}.yaml")
        before, _ = least(fly(threats, "none"))
        res = fly(threats, "fga")
        after, key = least(res)
        start = next((d for d in res.decisions if d.get("fga") == "start"), None)
        chosen = "-" if start is None else start["why"]
        t0 = "-" if start is None else f"{start['t']:.2f} s"
        what, detect, speed, orig, sub, upd, t_paper = paper
        rows.append(
            (
                f"case {case} ({what}, {detect}, {speed})",
                f"undisturbed {before:.0f} m; {chosen}; flown {after:.0f} m ({key}); "
                f"started at {t0}; success {'yes' if res.metrics.success else 'NO'}",
                f"paper: {orig} -> {sub}, {upd}, at {t_paper} s",
            )
        )
    notes = (
        "separations from the obstacles' surfaces (1 m intruders), d_m = 30 m; the paper's "
        "vertical minima (V) assume a climb our 3 m/s aircraft does not have: with 3-6 m of "
        "vertical miss the climb to 30 m takes 10 s, so FGA steers; its case 6 'pitch up' for "
        "obstacles above would climb through them -- ours pitches down when pitch is chosen"
    )
    _out("fga: seed 004 Table VIII cases 5-9", rows, notes, no_record)


def replanned(res: ReplayResult) -> tuple[float, float]:
    """(flown length from the first avoidance command to the end, whole flown length)."""
    pos = res.positions
    steps = np.linalg.norm(np.diff(pos, axis=0), axis=1)
    first = next((d["t"] for d in res.decisions if d.get("command")), None)
    if first is None:
        return 0.0, float(steps.sum())
    i = int(np.searchsorted(res.times, first))
    return float(steps[i:].sum()), float(steps.sum())


def table7(no_record: bool) -> None:
    rows = []
    for case in PAPER_TABLE8:
        threats = str(SCEN / f"seed004-case{case}.yaml")
        for avoider in ("fga", "pso-ca"):
            res = fly(threats, avoider)
            part, whole = replanned(res)
            sep, _ = least(res)
            compute = [float(d["compute_s"]) for d in res.decisions]
            rows.append(
                (
                    f"case {case}: {avoider}",
                    f"re-planned {part:.0f} m, flown {whole:.0f} m, least separation {sep:.0f} m, "
                    f"success {'yes' if res.metrics.success else 'NO'}, "
                    f"{1e3 * statistics.fmean(compute) if compute else 0.0:.2f} ms a decision",
                    "paper (its cases 1-4): optimal 241-305 m, FGA 65-92 m of 200",
                )
            )
    notes = (
        "the same five cases for both (Table VIII's; Table VII's four are not described); "
        "'re-planned' is the flown length from the first avoidance command to the goal, "
        "'flown' the whole flight (1.2 km leg, ends 100 m before the goal)"
    )
    _out("fga: seed 004 Table VII, FGA against PSO-CA", rows, notes, no_record)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("what", choices=("turn", "decision-time", "table8", "table7"))
    ap.add_argument("--cases", type=int, default=100, help="decision-time: cases of each set")
    ap.add_argument("--no-record", action="store_true", help="print only")
    args = ap.parse_args(argv)
    if args.what == "turn":
        turn(args.no_record)
    elif args.what == "decision-time":
        decision_time(args.cases, args.no_record)
    elif args.what == "table8":
        table8(args.no_record)
    else:
        table7(args.no_record)
    return 0


if __name__ == "__main__":
    sys.exit(main())
