"""Regenerate tests/golden/plans.json:  .venv/bin/python -m tests.golden.regen"""

from __future__ import annotations

import json

from tests.golden.scenarios import ALGORITHMS, GOLDEN, MAPS, SEED


def main() -> None:
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
