"""The own scenario suite's report (issue 34): success per avoider x sensor x map, the scenarios
each exclusion rule dropped, every failure with its reason, and the decision times.

The suite is a campaign per sensor (``benchmarks/own/own-scenarios-radar.yaml``, ``-cooperative``;
the generator :mod:`replay.campaign.own`), flown into a store each:

    terrapath campaign benchmarks/own/own-scenarios-radar.yaml --store own-radar.sqlite
    terrapath campaign benchmarks/own/own-scenarios-cooperative.yaml --store own-coop.sqlite
    terrapath campaign benchmarks/own/own-planned-radar.yaml --store own-planned-radar.sqlite
    terrapath campaign benchmarks/own/own-planned-cooperative.yaml --store own-planned-coop.sqlite
    .venv/bin/python benchmarks/bench_own_scenarios.py own-*.sqlite

(the stores of one sensor are reported together; a planned mission's rows read "MAP (planned)").

A scenario (mission/row/run index: the same for every avoider of a store) is dropped when the case
generator's geometric rules flag it (its notes' ``excluded``) or when its ``none`` run succeeds
("none survives": nothing to avoid).  The sensor of a store is read from its spec's name.  The
figures go to benchmarks/RESULTS.md (``--no-record``: printed only); every failure, with its end
reason and failures, to ``benchmarks/own/failures.md`` (overwritten: the current list).
"""

from __future__ import annotations

import argparse
import json
import sqlite3
import sys
from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._record import emit  # noqa: E402
from replay.campaign.buildings import EXCLUSIONS as BUILDING_EXCLUSIONS  # noqa: E402
from replay.campaign.own import EXCLUSIONS as OWN_EXCLUSIONS  # noqa: E402
from replay.campaign.runner import wilson  # noqa: E402
from terrapath.runtext import failure_summary  # noqa: E402

FAILURES = ROOT / "benchmarks" / "own" / "failures.md"
# each avoider's decision time on its paper's scenarios, as RESULTS.md last recorded it (the
# figure the suite's is set beside; machines differ: compare ratios)
PAPER_SCENARIO_MS = {
    "pso-ca": "paper scenario: 11.5 ms a run (seed000-table4, PSO, 2026-11-28)",
    "ctga": "paper scenario: 0.12-0.27 ms a decision (seed 001's three, bench_ctga compare)",
    "fga": "paper scenario: 0.16-0.26 ms mean a decision (seed004-table3/4, 2026-11-24)",
}
# issue 34: every fixed-wing avoider (cooperative, radar); the priority loop on its buildings
TARGETS = {"cooperative": 0.95, "radar": 0.90, "rangefinder": 0.95}
EXCLUSIONS = tuple(dict.fromkeys([*OWN_EXCLUSIONS, *BUILDING_EXCLUSIONS]))
NONE_SURVIVES = "none survives"
NO_WAY = "no way round"  # own-buildings: no wide way at the flight level


def load(store: str) -> tuple[str, list[dict[str, Any]]]:
    """(sensor, rows) of a campaign store."""
    con = sqlite3.connect(f"file:{store}?mode=ro", uri=True)
    con.row_factory = sqlite3.Row
    rows = [dict(r) for r in con.execute("SELECT * FROM runs")]
    con.close()
    for r in rows:
        r["metrics"] = json.loads(r["metrics"]) if r["metrics"] else None
    names = {str(r["spec_name"]) for r in rows}
    sensor = next(
        (s for s in ("cooperative", "radar", "rangefinder") if any(s in n for n in names)), "?"
    )
    return sensor, rows


def scenario_of(row: dict[str, Any]) -> str:
    return f"{row['mission']}/{row['row']}/{row['run']}"


def analyse(sensor: str, rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Exclusions, success per avoider and map, failures and decision times of one store."""
    by_scenario: dict[str, dict[str, dict[str, Any]]] = defaultdict(dict)
    for r in rows:
        by_scenario[scenario_of(r)][r["avoider"]] = r
    dropped: Counter[str] = Counter()
    kept: set[str] = set()
    no_way: set[str] = set()
    for sc, runs in by_scenario.items():
        notes = next(
            (
                r["metrics"]["case"]
                for r in runs.values()
                if r["metrics"] and "case" in r["metrics"]
            ),
            None,
        )
        rules = list(notes.get("excluded", [])) if notes else []
        if NO_WAY in rules:
            no_way.add(sc)
        none = runs.get("none")
        if none is not None and none["status"] == "ok" and none["success"]:
            rules.append(NONE_SURVIVES)
        for rule in rules:
            dropped[rule] += 1
        if rules:
            dropped["any rule"] += 1
        else:
            kept.add(sc)
    table: dict[tuple[str, str], list[int]] = defaultdict(lambda: [0, 0])
    failures: list[str] = []
    times: dict[str, list[float]] = defaultdict(list)
    no_way_outcomes: dict[str, Counter[str]] = defaultdict(Counter)
    for r in rows:
        av = r["avoider"]
        if av == "none":
            continue
        if scenario_of(r) in no_way:
            # no wide way at the flight level: dropped, its outcomes counted apart
            outcome = (
                "error"
                if r["status"] != "ok"
                else "goal"
                if r["success"]
                else str(r["end_reason"] or "?").removeprefix("ended the run: ")
            )
            no_way_outcomes[av][outcome] += 1
        if scenario_of(r) not in kept:
            continue
        ok = r["status"] == "ok" and bool(r["success"])
        row = r["row"] + (" (planned)" if r["mission"] == "own-planned" else "")
        for key in ((av, row), (av, "all maps")):
            table[key][0] += int(ok)
            table[key][1] += 1
        m = r["metrics"] or {}
        times[av] += list(m.get("decision_times_ms") or [])
        if not ok:
            case = m.get("case", {})
            why = (
                r["error"]
                if r["status"] != "ok"
                else "; ".join(failure_summary(m)) or str(r["end_reason"])
            )
            drawn = ", ".join(
                t["kind"] + " " + str(t["size_turns"]) + " r" for t in case.get("threats", [])
            ) or ", ".join(f"{n} {k}" for k, n in case.get("buildings", {}).items())
            failures.append(
                f"| {sensor} | {r['key']} | {case.get('vehicle', '?')} | {drawn} | {why} |"
            )
    return {
        "sensor": sensor,
        "scenarios": len(by_scenario),
        "kept": len(kept),
        "dropped": dropped,
        "table": table,
        "failures": failures,
        "times": times,
        "no_way": no_way_outcomes,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "stores", nargs="+", help="campaign stores of the suite (per sensor: straight, planned)"
    )
    ap.add_argument("--no-record", action="store_true", help="print only")
    args = ap.parse_args()
    figures: list[tuple[str, str, str]] = []
    failures: list[str] = []
    by_sensor: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for store in args.stores:  # a sensor's stores (straight and planned missions) together
        sensor, rows = load(store)
        by_sensor[sensor] += rows
    for sensor, rows in by_sensor.items():
        a = analyse(sensor, rows)
        figures.append(
            (
                f"{sensor}: scenarios kept / drawn",
                f"{a['kept']} / {a['scenarios']} (dropped: "
                + ", ".join(
                    f"{k} {a['dropped'][k]}"
                    for k in (*EXCLUSIONS, "any rule")
                    if k in a["dropped"] or k in (NONE_SURVIVES, "any rule")
                )
                + ")",
                ">= 300 drawn" if sensor in ("cooperative", "radar") else "",
            )
        )
        for (av, row), (ok, n) in sorted(
            a["table"].items(), key=lambda kv: (kv[0][0], kv[0][1] != "all maps", kv[0][1])
        ):
            lo, hi = wilson(ok, n)
            target = (
                f">= {100 * TARGETS[sensor]:.0f} %"
                if row == "all maps" and sensor in TARGETS
                else ""
            )
            figures.append(
                (
                    f"{sensor}: {av} on {row}",
                    f"{ok}/{n} ({100 * ok / max(n, 1):.1f} %, 95 % CI {100 * lo:.0f}-{100 * hi:.0f} %)",
                    target,
                )
            )
        for av, outcomes in sorted(a["no_way"].items()):
            figures.append(
                (
                    f"{sensor}: {av}'s outcomes where no way round (dropped)",
                    ", ".join(f"{k} {n}" for k, n in outcomes.most_common()),
                    "",
                )
            )
        for av, t in sorted(a["times"].items()):
            if t:
                figures.append(
                    (
                        f"{sensor}: {av} decision time (ms)",
                        f"mean {np.mean(t):.2f}, p99 {np.percentile(t, 99):.2f}, max {np.max(t):.2f} "
                        f"({len(t)} decisions)",
                        PAPER_SCENARIO_MS.get(av, ""),
                    )
                )
        failures += a["failures"]
    emit(
        "Own scenario suite (issue 34)",
        figures,
        f"{len(failures)} failures listed in benchmarks/own/failures.md",
        args.no_record,
    )
    if not args.no_record:
        FAILURES.write_text(
            "# Failures of the own scenario suite\n\nWritten by `benchmarks/bench_own_scenarios.py` "
            "(the current list; the figures are in RESULTS.md).\n\n"
            "| sensor | run | vehicle | threats | reason |\n|---|---|---|---|---|\n"
            + "\n".join(failures)
            + "\n"
        )


if __name__ == "__main__":
    main()
