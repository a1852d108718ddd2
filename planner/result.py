"""`PlanResult`: what a global planning run produced, typed and frozen (never a bare tuple)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from planner.problem import PlanningProblem
from planner.profile import sample_path
from terrain.cylinders import segment_cylinder_lengths, zones_arrays

FloatArray = npt.NDArray[np.float64]
Status = Literal["feasible", "infeasible"]


@dataclass(frozen=True)
class Violation:
    """One broken constraint: what, which segment, where (map metres), how much."""

    kind: Literal["terrain", "danger_zone"]
    segment: int
    x: float
    y: float
    z: float
    amount_m: float
    detail: str

    def as_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "segment": self.segment,
            "x": self.x,
            "y": self.y,
            "z": self.z,
            "amount_m": self.amount_m,
            "detail": self.detail,
        }


@dataclass(frozen=True)
class PlanResult:
    """Best path found (S, W_1..W_N, G), its cost terms, status and provenance."""

    status: Status
    waypoints: FloatArray
    terms: dict[str, float]
    algorithm: str
    params: dict[str, Any]
    seed: int | None
    iterations: int
    evaluations: int
    elapsed_s: float
    stop_reason: str
    history_best: FloatArray = field(repr=False)
    history_mean: FloatArray = field(repr=False)
    violations: tuple[Violation, ...] = ()

    @property
    def feasible(self) -> bool:
        return self.status == "feasible"

    def summary(self) -> str:
        """One human line: status, cost and the first violation, if any."""
        s = f"{self.status}: cost {self.terms['total']:.4f} after {self.iterations} iterations"
        if self.violations:
            s += f"; {self.violations[0].detail}"
            if len(self.violations) > 1:
                s += f" (and {len(self.violations) - 1} more)"
        return s


def find_violations(problem: PlanningProblem, path: FloatArray) -> tuple[Violation, ...]:
    """Where a path breaks its constraints: the deepest point below terrain + clearance of each
    colliding segment, and (with ``avoid_zones``) each zone a segment enters."""
    samples = sample_path(problem.grid, path)
    out: list[Violation] = []
    for i in range(len(path) - 1):
        on = samples.segment == i
        pts = samples.points[on]
        depth = problem.clearance - samples.clearance[on]
        k = int(np.argmax(depth))
        if depth[k] > 0:
            seg_len = float(np.linalg.norm(path[i + 1] - path[i]))
            below = float((depth > 0).mean() * seg_len)
            what = "terrain + clearance" if problem.clearance else "terrain"
            out.append(
                Violation(
                    "terrain",
                    i,
                    float(pts[k, 0]),
                    float(pts[k, 1]),
                    float(pts[k, 2]),
                    below,
                    f"segment {i} (waypoint {i} -> {i + 1}) runs about {below:.0f} m below {what}, "
                    f"{depth[k]:.0f} m deep at x={pts[k, 0]:.0f}, y={pts[k, 1]:.0f}",
                )
            )
    if problem.avoid_zones and problem.zones:
        z = zones_arrays(problem.zones)
        inside = segment_cylinder_lengths(path[:-1], path[1:], z.centers, z.radii, z.tops)
        for i, k in zip(*np.nonzero(inside > 0), strict=True):
            zone = problem.zones[int(k)]
            name = zone.id or f"#{int(k)}"
            out.append(
                Violation(
                    "danger_zone",
                    int(i),
                    zone.x,
                    zone.y,
                    float("nan") if zone.top is None else zone.top,
                    float(inside[i, k]),
                    f"segment {int(i)} enters danger zone {name} for {inside[i, k]:.0f} m",
                )
            )
    return tuple(out)
