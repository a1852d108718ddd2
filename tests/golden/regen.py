"""Regenerate tests/golden/plans.json:  .venv/bin/python -m tests.golden.regen
and tests/golden/replays.json (the golden plans flown with pop-up threats by each avoider):
.venv/bin/python -m tests.golden.regen --replays"""

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


def main() -> None:
    if "--replays" in sys.argv[1:]:
        replays()
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
