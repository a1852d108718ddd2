"""Reference planning scenarios on real maps, shared by the golden test and its regeneration.

One fixed start/goal/zones scenario per map (``planner.reference``: jacksboro and rmnp from
data/maps, Big Tujunga and Christmas Island from ../shared/maps) and every algorithm at seed 0 with the `terrapath plan` defaults (the aerosonde at
its cruise speed, population 60, 200 iterations, 6 free waypoints, 50 m clearance, start and goal
150 m above the highest terrain around them, zones as hard constraints, up to 3 attempts from
derived seeds), built by the planning pipeline that `terrapath plan` runs.

Regenerate the golden file (only when a change is *meant* to move the figures; say why in the
commit):  ``.venv/bin/python -m tests.golden.regen``
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

from planner.pipeline import PlanRequest, Prepared, build_problem, plan_request
from planner.problem import PlanningProblem
from planner.reference import REFERENCE_MAPS, ReferenceMap
from replay.campaign.regress import PLAN_VEHICLE, reference_request

GOLDEN = Path(__file__).resolve().parent / "plans.json"
ALGORITHMS = ("ampso", "apso", "pso", "ga")
SEED = 0
VEHICLE = PLAN_VEHICLE  # the aerosonde (the golden plans' vehicle)


@dataclass(frozen=True)
class MapScenario(ReferenceMap):
    """A reference map (``planner.reference``) planned as ``terrapath plan`` does."""

    def request(self, algorithm: str = "ampso") -> PlanRequest:
        request: PlanRequest = reference_request(self, algorithm)
        return request

    def prepared(self) -> Prepared:
        return _prepared(self)

    def problem(self) -> PlanningProblem:
        return self.prepared().problem

    def run(self, algorithm: str, problem: PlanningProblem | None = None) -> Any:
        return plan_request(self.request(algorithm), problem or self.problem())


@cache
def _prepared(scenario: MapScenario) -> Prepared:
    return build_problem(scenario.request())


MAPS = tuple(MapScenario(m.name, m.dem, m.start, m.goal, m.zones) for m in REFERENCE_MAPS)
