"""Shared fixtures: where the reference maps are, and small grids built from arrays."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from affine import Affine
from hypothesis import settings

from terrain.grid import HeightGrid

# JIT compilation makes first calls slow and CI machines are noisy: no per-example deadline.
# In CI (CI=true) the examples are derandomized so a run is reproducible; locally Hypothesis keeps
# exploring new examples.
settings.register_profile(
    "terrapath", deadline=None, print_blob=True, derandomize=bool(os.environ.get("CI"))
)
settings.load_profile("terrapath")

ROOT = Path(__file__).resolve().parents[1]
DATA_MAPS = ROOT / "data" / "maps"
SHARED_MAPS = ROOT.parent / "shared" / "maps"


def meta(folder: Path) -> dict[str, Any]:
    return dict(json.loads((folder / "meta.json").read_text()))


def make_grid(
    heights: Any, cell: float = 30.0, x0: float = 400000.0, y0: float = 3800000.0, crs: Any = None
) -> HeightGrid:
    """A grid whose top-left corner is (x0, y0), cells of ``cell`` metres."""
    return HeightGrid(np.asarray(heights, dtype=np.float32), Affine(cell, 0, x0, 0, -cell, y0), crs)


@pytest.fixture
def shared_maps() -> Path:
    if not SHARED_MAPS.is_dir():
        pytest.skip("../shared/maps is not beside the checkout")
    return SHARED_MAPS
