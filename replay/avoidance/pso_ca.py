"""PSO-CA (seed 000, Krishnan & Manimala 2020) as an avoider of the replay engine — first version.

After every radar scan (Fig. 4 / Fig. 5):

1. the threat returns are grouped — returns closer than 1 km form one continuous obstacle (Fig. 8,
   §5.3) — and taken closest first;
2. the current leg (aircraft -> next waypoint) is tested against each group's safety spheres
   (line–sphere test, eqs 22–26, :func:`segment_hits_sphere`);
3. if the next waypoint itself lies within 1 km of the obstacle it is unsafe and skipped (Fig. 9,
   Fig. 23); the new waypoint then leads to the waypoint after it;
4. ten particles are seeded round the safety circle from the tangent construction (eq 27), and
   planner.optim's PSO with Table 2's parameters minimises f = Wt f1 + Wo f2 under g1–g4
   (:class:`~replay.avoidance.pso_ca_geometry.WaypointProblem`), stopping after 30 iterations or
   when the best fitness changes by less than 200 for 5 iterations (§5.5);
5. the new waypoint (at the altitude of the waypoint it leads to) is inserted and flown "direct to"
   from the aircraft's position; the decision records the obstacle, the waypoint, its cost terms,
   the constraints and the evaluations.

Not yet here (issue 5 continues): moving intruders (Figs 13, §5.7: confirm from two scans, act
under 8 km, 2 km sphere, turn by heading), terrain returns as obstacles, and re-checking earlier
inserted waypoints against later-seen obstacles (§5.3).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from planner.optim import make_optimizer
from planner.optim.pso import SEED000_PSO
from planner.optim.termination import MaxIterations, Stall
from replay.avoidance.base import AVOIDERS, AvoidanceContext, AvoidanceDecision
from replay.avoidance.pso_ca_geometry import (
    PsoCaParams,
    WaypointProblem,
    closest_first,
    group_obstacles,
    near_end_waypoint,
    segment_hits_sphere,
    tangent_seed_points,
)
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
STALL_ITERATIONS = 5
STALL_TOLERANCE = 200.0  # §5.5: fitness change below 200 for 5 consecutive iterations
CA_OPTIMIZERS = ("pso", "ga", "sa", "mafoa", "gcpso", "mpso")


class PsoCaAvoider:
    """Radar-driven waypoint re-planning of seed 000 (see the module docstring)."""

    name = "pso-ca"

    def __init__(self, optimizer: str = "pso", params: PsoCaParams | None = None) -> None:
        if optimizer not in CA_OPTIMIZERS:
            raise InputError(
                f"unknown PSO-CA optimiser {optimizer!r}; choose one of {', '.join(CA_OPTIMIZERS)}"
            )
        self.optimizer = optimizer
        self.params = params or PsoCaParams()
        self.rng = np.random.default_rng(0)

    def reset(self, waypoints: FloatArray, rng: np.random.Generator) -> None:
        self.rng = rng

    def _optimizer(self) -> Any:
        if self.optimizer == "pso":
            return make_optimizer("pso", **SEED000_PSO)
        if self.optimizer == "ga":
            from planner.optim import GA

            return GA.seed000()
        return make_optimizer(self.optimizer)

    def decide(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        pic = ctx.picture
        n = pic.n_threat
        if n == 0 or ctx.next_index >= len(ctx.waypoints):
            return None
        points = np.asarray(pic.positions[:n], dtype=np.float64)
        pos = ctx.position
        wps = ctx.waypoints
        target_i = ctx.next_index
        groups = group_obstacles(points)
        # closest group first (by its closest member)
        order = closest_first(
            pos[:2],
            np.array([points[g][closest_first(pos[:2], points[g][:, :2])[0], :2] for g in groups]),
        )
        rs = self.params.rs
        for gi in order:
            members = points[groups[int(gi)]]
            target = wps[target_i]
            hits = segment_hits_sphere(pos[:2], target[:2], members[:, :2], rs)
            if not np.any(hits):
                continue
            skipped = 0
            while near_end_waypoint(
                members[:, :2], wps[target_i][:2], rs
            ).any() and target_i + 1 < len(wps):
                target_i += 1  # Fig. 9: the waypoint is inside the danger area; lead past it
                skipped += 1
            target = wps[target_i]
            others = np.delete(points, groups[int(gi)], axis=0)[:, :2]
            problem = WaypointProblem(
                pos[:2],
                target[:2],
                members[:, :2],
                others,
                PsoCaParams(**{**self.params.__dict__, "speed": max(ctx.airspeed, 1.0)}),
            )
            nearest = members[closest_first(pos[:2], members[:, :2])[0], :2]
            seeds = tangent_seed_points(pos[:2], nearest, rs + self.params.tolerance, 10, self.rng)
            lo, hi = problem.bounds()
            opt = self._optimizer()
            res = opt.run(
                problem,
                lo,
                hi,
                seed=self.rng,
                termination=MaxIterations(30) | Stall(STALL_ITERATIONS, STALL_TOLERANCE),
                x0=np.clip(seeds, lo, hi)[: opt.max_seed_points()],
            )
            xy = np.asarray(res.x, dtype=np.float64)
            terms = problem.terms(xy[None, :])
            report = terms.report
            new = np.array([xy[0], xy[1], target[2]])
            new_list = np.vstack([wps[: ctx.next_index], new[None, :], wps[target_i:]])
            return AvoidanceDecision(
                waypoints=new_list,
                next_index=ctx.next_index,
                direct=True,
                reason=f"inserted 1 for obstacle group of {len(members)}"
                + (f", skipped {skipped}" if skipped else ""),
                info={
                    "obstacles": [pic.threat_ids[i] for i in groups[int(gi)]],
                    "new_waypoint": new.tolist(),
                    "f": float(terms.f[0]),
                    "f1": float(terms.f1[0]),
                    "f2": float(terms.f2[0]),
                    "feasible": bool(report.feasible[0]),
                    "g": {k: float(getattr(report, k)[0]) for k in ("g1", "g2", "g3", "g4", "g5")},
                    "optimizer": self.optimizer,
                    "iterations": int(res.iterations),
                    "evaluations": int(res.evaluations),
                    "skipped_waypoints": skipped,
                },
            )
        return None


AVOIDERS["pso-ca"] = PsoCaAvoider
