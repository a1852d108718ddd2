"""An editable install of the project prints no notice about "folders with the same name as your
package" (issue 37): setuptools' editable_wheel prints it when it installs a meta path finder
(``_TopLevelFinder``), which it picks for a flat layout unless ``package-dir`` names the root;
with ``package-dir = {"" = "."}`` (pyproject.toml) it writes a plain .pth of the root instead.

Checked against setuptools' own choice (a private function: if a setuptools release renames
it, this test says so rather than passing); measured by hand with setuptools 84.2.1:
``pip install -e .`` into a scratch venv prints neither that notice nor "Editable install will be
performed using a meta path finder"."""

from __future__ import annotations

import subprocess
import sys

from tests.conftest import ROOT

CHOICE = """
import os, sys, warnings
os.chdir(sys.argv[1])
warnings.simplefilter("ignore")  # setuptools' own notes on reading pyproject.toml
from setuptools.command.editable_wheel import editable_wheel
from setuptools.dist import Distribution
dist = Distribution()
dist.parse_config_files()
cmd = editable_wheel(dist)
cmd.ensure_finalized()
strategy = cmd._select_strategy("terrapath", "0.editable-py3-none-any", "build-lib")
print(type(strategy).__name__, *[str(p) for p in getattr(strategy, "path_entries", [])])
"""


def test_an_editable_install_is_a_plain_pth_of_the_root_without_the_notice() -> None:
    out = subprocess.run(
        [sys.executable, "-c", CHOICE, str(ROOT)], capture_output=True, text=True, check=True
    ).stdout.split()
    # _StaticPth: no meta path finder, so no "same name as your package" notice
    assert out == ["_StaticPth", "."], out
