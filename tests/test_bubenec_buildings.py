"""The real Prague buildings as data: ``data/scenarios/bubenec-buildings.yaml`` (143 prisms written
by ``data/tools/bubenec_buildings.py`` from the shared maps' momepy_bubenec) reads with the threat
loader, every building a valid prism on the DTM; with the shared maps, the script writes exactly
the committed file and its heights follow the documented rule."""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from replay.threats.file import load_threats
from replay.threats.kinds import PrismThreat

ROOT = Path(__file__).resolve().parents[1]
FILE = ROOT / "data" / "scenarios" / "bubenec-buildings.yaml"
SCRIPT = ROOT / "data" / "tools" / "bubenec_buildings.py"
# the DTM's outer cell edges (EPSG:5514; momepy_bubenec/meta.json: 592 x 647 cells of 1 m)
DTM_BOUNDS = (-744171.0, -1041467.0, -743579.0, -1040820.0)


def script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("bubenec_buildings", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclass looks its module up
    spec.loader.exec_module(module)
    return module


def test_the_buildings_load_as_valid_prisms_on_the_dtm() -> None:
    ts = load_threats(FILE)
    assert len(ts) == 143 and ts.name == "bubenec-buildings"  # 144 features, one with a hole
    assert all(isinstance(t, PrismThreat) for t in ts)
    assert all(re.fullmatch(r"b\d+", t.id) for t in ts) and "b81" not in ts.ids
    xmin, ymin, xmax, ymax = DTM_BOUNDS
    for t in ts:
        assert isinstance(t, PrismThreat)
        ring = t.ring
        assert np.all((ring >= (xmin, ymin)) & (ring <= (xmax, ymax)))
        # the DTM spans 188-223 m; a building stands at least one 3 m floor, at most six
        assert 188.0 <= t.bottom < t.top <= 223.0 + 5.0 + 18.0
        assert 3.0 <= t.top - t.bottom <= 5.0 + 18.0
    text = FILE.read_text(encoding="utf-8")
    assert "default_rng(3)" in text and "3 m per floor" in text and "fid 81" in text


def test_the_script_writes_the_committed_file_by_its_rule(shared_maps: Path) -> None:
    gpkg = shared_maps / "momepy_bubenec" / "bubenec.gpkg"
    if not gpkg.is_file():
        pytest.skip("momepy_bubenec is not in the shared maps")
    mod = script()
    buildings, skipped = mod.convert(gpkg)
    assert skipped == ["fid 81 (uID 81): a footprint with 1 hole(s) (a prism has none)"]
    assert mod.render(buildings, skipped, gpkg.name, mod.SEED) == FILE.read_text(encoding="utf-8")
    grid = mod.read_dtm(gpkg)
    ts = load_threats(FILE, grid)  # on the map: every vertex inside the DTM
    for b, t in zip(buildings, ts, strict=True):
        assert isinstance(t, PrismThreat) and t.id == b.id
        lowest, highest = grid.lowest_under(t.ring), grid.highest_under(t.ring)
        assert t.bottom <= lowest < t.bottom + 0.01  # the ground, rounded down to the cm
        lo, hi = next((lo, hi) for below, lo, hi in mod.FLOORS_BY_AREA if b.area < below)
        assert lo <= b.floors <= hi
        assert t.top - 0.01 < highest + 3.0 * b.floors <= t.top
