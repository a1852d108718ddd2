"""Outcomes on the reference maps (issue 39): an avoider flown on the regression suite's
reference cases -- a real map's golden plan with its pop-up threats (a sphere, a cylinder, a
crossing intruder on the path) -- and compared with a baseline, as ``terrapath regress`` compares
(:mod:`replay.campaign.regress`: success, every threat's separation, the PLR, within the drift a
fresh install's library versions may bring).

A subclass names the avoider and the baseline it is held to::

    class TestMineOnTheMaps(ReferenceContract):
        avoider = "mine"
        baseline = Path(__file__).with_name("reference-baseline.json")

Write that baseline once, from the avoider you trust, with ``terrapath regress --avoid mine
--case rmnp --case jacksboro --baseline tests/reference-baseline.json --update-baseline`` (a
baseline file that does not exist yet is written where named); every later version of the
avoider must then meet it.  ``baseline = None`` holds the avoider to terrapath's shipped
baseline (its own avoiders'); ``against`` compares with another avoider's figures there (a
changed copy of a built-in).  The cases default to the maps a pip-installed terrapath carries
(RMNP, Jacksboro); the test flies in its own process (``--jobs 1``) and writes its table, JUnit
XML and pictures of what regressed into pytest's temporary folder, named in the failure.
"""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

import pytest


class ReferenceContract:
    """The avoider's outcomes on the reference maps meet its baseline."""

    avoider: ClassVar[str]
    baseline: ClassVar[str | Path | None] = None
    against: ClassVar[str | None] = None
    cases: ClassVar[tuple[str, ...]] = ("rmnp", "jacksboro")

    def test_meets_its_baseline_on_the_reference_maps(self, tmp_path: Path) -> None:
        from terrapath.cli import main

        argv = ["regress", "--avoid", self.avoider, "--jobs", "1", "-o", str(tmp_path)]
        argv += [f"--case={c}" for c in self.cases]
        if self.baseline is not None:
            argv += ["--baseline", str(self.baseline)]
        if self.against is not None:
            argv += ["--against", self.against]
        status = main(argv)
        table = tmp_path / "regress.md"
        said = table.read_text(encoding="utf-8") if table.is_file() else "(no table)"
        assert status == 0, f"{self.avoider} regressed on the reference maps:\n{said}"
        if not (tmp_path / "junit.xml").is_file():
            pytest.fail(f"terrapath regress wrote no JUnit XML into {tmp_path}")


__all__ = ["ReferenceContract"]
