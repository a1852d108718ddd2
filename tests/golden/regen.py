"""Regenerate tests/golden/plans.json:  .venv/bin/python -m tests.golden.regen"""

from __future__ import annotations

import json

from tests.golden.scenarios import GOLDEN, SCENARIOS


def main() -> None:
    data = {}
    for sc in SCENARIOS:
        runs = sc.run()
        costs = [float(r["cost"]) for r in runs]
        data[sc.name] = {
            "runs": runs,
            "mean_cost": sum(costs) / len(costs),
            "feasible": sum(bool(r["feasible"]) for r in runs),
        }
        print(
            f"{sc.name:22s} mean cost {data[sc.name]['mean_cost']:.5f}  feasible {data[sc.name]['feasible']}/{len(runs)}"
        )
    GOLDEN.write_text(json.dumps(data, indent=2) + "\n")
    print(f"wrote {GOLDEN}")


if __name__ == "__main__":
    main()
