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


X0, Y0 = 376313.655, 3807917.83  # Big Tujunga area, UTM 11N: the corner of ``utm_grid``


@pytest.fixture
def local_grid() -> HeightGrid:
    """100 x 200 cells of 10 m, no CRS: x in [0, 2000], y in [0, 1000], flat at 0 m."""
    return HeightGrid(np.zeros((100, 200), np.float32), Affine(10, 0, 0, 0, -10, 1000), crs=None)


@pytest.fixture
def utm_grid() -> HeightGrid:
    """300 x 300 cells of 30 m from (X0, Y0) in UTM 11N (9 km x 9 km), flat at 800 m."""
    from rasterio.crs import CRS

    heights = np.full((300, 300), 800.0, np.float32)
    return HeightGrid(heights, Affine(30, 0, X0, 0, -30, Y0), crs=CRS.from_epsg(32611))


@pytest.fixture
def shared_maps() -> Path:
    if not SHARED_MAPS.is_dir():
        pytest.skip("../shared/maps is not beside the checkout")
    return SHARED_MAPS


# The longest test files first (longest-processing-time scheduling): `make test` runs
# pytest-xdist's ``--dist loadfile --no-loadscope-reorder``, which hands whole files to the
# workers in collection order as they run out of work (xdist's own order, by the number of tests
# in a file, put the 4-minute docs file and the slow flights wherever their counts fell).  The
# order: seconds per file in a quiet `make test` profile (2 workers, 2026-11-29); the files not
# named keep their order after them, and within a file the order is unchanged (the pages of
# test_docs run in order, in one folder).
LONGEST_FIRST = (
    "test_docs.py",
    "test_avoidance_contract.py",
    "test_view.py",
    "test_own_scenarios.py",
    "test_campaign.py",
    "test_golden_replay.py",
    "test_pso_ca.py",
    "test_wind.py",
    "test_threat_table.py",
    "test_replay.py",
    "test_priority.py",
    "test_launch.py",
    "test_threat_index.py",
    "test_golden_flight.py",
    "test_ctga.py",
    "test_mission_import.py",
    "test_plan_multirotor.py",
    "test_judge.py",
    "test_replay_zones.py",
    "test_own_buildings.py",
    "test_hostile.py",
    "test_plan_terms.py",
    "test_spiral.py",
    "test_plan_cli.py",
    "test_golden.py",
    "test_fga.py",
    "test_plugins.py",  # 17 s: pip builds the example plugin, which flies in subprocesses
)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    rank = {name: k for k, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))
