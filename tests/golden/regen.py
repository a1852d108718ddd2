"""Regenerate tests/golden/plans.json:  .venv/bin/python -m tests.golden.regen
and tests/golden/replays.json (the golden plans flown with pop-up threats by each avoider):
.venv/bin/python -m tests.golden.regen --replays
and the reference suite of `terrapath regress` (each map's golden plan as a mission file and its
threat set, replay/campaign/suites/reference/): .venv/bin/python -m tests.golden.regen --suite"""

from __future__ import annotations

import json
import sys

from tests.golden.scenarios import ALGORITHMS, GOLDEN, MAPS, SEED


def replays() -> None:
    from tests.golden.replays import CASES, GOLDEN_REPLAYS, fly

    data: dict[str, object] = {}
    for sc, avoid in CASES:
        if not sc.available():
            raise SystemExit(f"{sc.dem} not found: every map is needed to regenerate")
        figures = fly(sc, avoid)
        data[f"{sc.name}/{avoid}"] = figures
        seps = ", ".join(f"{k} {v:.0f} m" for k, v in figures["min_separation"].items())
        print(
            f"{sc.name:10s} {avoid:6s} success {figures['success']!s:5s} PLR {figures['plr']:.3f} {seps}"
        )
    GOLDEN_REPLAYS.write_text(json.dumps(data, indent=2) + "\n")
    print(f"wrote {GOLDEN_REPLAYS}")


def suite() -> None:
    """The golden plans and threat sets as the files of `terrapath regress`'s reference suite:
    ``<map>.yaml`` (its DEM named relative to the maps' folder, ``maps/<folder>/<file>``, which
    regress resolves) and ``<map>-threats.yaml``."""
    import tempfile
    from pathlib import Path

    import yaml

    from planner.mission import save_mission
    from replay.campaign.regress import SUITES_DIR
    from tests.golden.replays import mission_of, threat_records

    out = SUITES_DIR / "reference"
    out.mkdir(parents=True, exist_ok=True)
    for sc in MAPS:
        if not sc.available():
            raise SystemExit(f"{sc.dem} not found: every map is needed to regenerate")
        with tempfile.TemporaryDirectory() as tmp:
            path = save_mission(mission_of(sc), Path(tmp) / f"{sc.name}.yaml")
            doc = yaml.safe_load(path.read_text(encoding="utf-8"))
        doc["terrain"]["dem"] = [f"maps/{sc.dem.parent.name}/{sc.dem.name}"]
        head = (
            f"# terrapath regress, reference suite: the golden AMPSO plan of {sc.name} (seed 0,\n"
            "# tests/golden/scenarios.py); its DEM is looked up under the maps' folders\n"
            "# (terrapath regress --data).  Regenerate: python -m tests.golden.regen --suite\n"
        )
        (out / f"{sc.name}.yaml").write_text(
            head + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=100),
            encoding="utf-8",
        )
        records = json.loads(json.dumps(threat_records(mission_of(sc)), default=float))
        threats = {"terrapath": 1, "threats": records}
        (out / f"{sc.name}-threats.yaml").write_text(
            f"# the golden threat set of {sc.name} (tests/golden/replays.py)\n"
            + yaml.safe_dump(threats, sort_keys=False, default_flow_style=None, width=100),
            encoding="utf-8",
        )
        print(f"wrote {out / sc.name}.yaml and its threats")


def main() -> None:
    if "--replays" in sys.argv[1:]:
        replays()
        return
    if "--suite" in sys.argv[1:]:
        suite()
        return
    data: dict[str, dict[str, object]] = {}
    for sc in MAPS:
        problem = sc.problem()
        for alg in ALGORITHMS:
            r = sc.run(alg, problem)
            data[f"{sc.name}/{alg}"] = {
                "seed": SEED,
                "status": r.status,
                "cost": r.terms["total"],
                "attempt_seeds": r.params["attempt_seeds"],
            }
            print(f"{sc.name:10s} {alg:6s} {r.status:10s} cost {r.terms['total']:.5f}")
    GOLDEN.write_text(json.dumps(data, indent=2) + "\n")
    print(f"wrote {GOLDEN}")


if __name__ == "__main__":
    main()
