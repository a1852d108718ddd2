"""Write a run in the recording format of the checkout it runs in, and what its reader reads
(tests/data/README.md). Not a test: kept to show how ``run-format1.*`` were made."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from replay.record.reader import load_run, summary
from replay.run import ReplayRequest, run_replay


def main(out: Path, duration: float) -> None:
    root = Path("data/scenarios")
    req = ReplayRequest.of(
        str(root / "seed001-mission.yaml"),
        threats=str(root / "seed001-simple-threats.yaml"),
        avoid="ctga",
        seed=1,
        command="tests fixture: format 1",
        duration=duration,
    )
    run_replay(req.but(terrain_mesh=False), out)
    rec = load_run(out)
    extras = {"extra_" + k: v for k, v in rec.extras.items()}
    np.savez_compressed(
        out.with_suffix(".npz"),
        times_ns=rec.times_ns,
        states=rec.states,
        controls=rec.controls,
        **extras,
    )
    out.with_suffix(".json").write_text(json.dumps(summary(rec), indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main(Path(sys.argv[1]), float(sys.argv[2]))
