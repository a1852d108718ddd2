"""`PlanResult`: what a global planning run produced, typed and frozen (never a bare tuple)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from planner.flown import TOLERANCE, fillets
from planner.performance import Performance
from planner.problem import PlanningProblem, lead_turn_excess
from planner.profile import PathSamples, sample_path
from planner.spiral import Spiral
from terrain.validity import SegmentValidity

FloatArray = npt.NDArray[np.float64]
Status = Literal["feasible", "infeasible"]


@dataclass(frozen=True)
class Violation:
    """One broken constraint: what, which segment, where (map metres), how much."""

    kind: Literal[
        "terrain",
        "danger_zone",
        "climb",
        "turn",
        "unknown_terrain",
        "above_band",
        "spiral",
        "energy",
    ]
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
    flown: FloatArray = field(default_factory=lambda: np.zeros((0, 3)), repr=False)
    spirals: tuple[Spiral, ...] = ()  # climb and descent spirals (planner.spiral)

    @property
    def path(self) -> FloatArray:
        """The path the aircraft flies (the filleted polyline; the waypoints without a vehicle)."""
        return self.flown if len(self.flown) else self.waypoints

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


def spiral_violation(reason: str, prefix: str = "spirals cannot help: ") -> Violation:
    """Why the climb and descent spirals that would have made a too-steep plan flyable could not
    be placed (:func:`planner.spiral.spiral_repair`), or (``prefix``) why the take-off does not
    join the plan; no place (NaN)."""
    return Violation("spiral", -1, math.nan, math.nan, math.nan, 0.0, prefix + reason)


def _at(kind: Any, leg: int, point: FloatArray, amount: float, detail: str) -> Violation:
    """A violation of ``kind`` on waypoint-list segment ``leg`` at a map ``point`` (x, y, z)."""
    return Violation(
        kind, leg, float(point[0]), float(point[1]), float(point[2]), float(amount), detail
    )


def pieces(n_points: int, chords: int | None) -> tuple[list[str], list[int]]:
    """What each piece of a flown path is, for messages, and the waypoint-list segment it
    belongs to (a turn: the leg into it): ``n_points`` waypoints (S, W_1..W_N, G), ``chords`` per
    turn fillet, or None when the flown path is the polyline itself."""
    if chords is None:
        legs = list(range(n_points - 1))
        return [f"segment {i} (waypoint {i} -> {i + 1})" for i in legs], legs
    labels: list[str] = []
    legs = []
    for k in range(1, n_points - 1):
        labels += [f"leg {k - 1} (waypoint {k - 1} -> {k})"] + [
            f"the turn at waypoint {k}"
        ] * chords
        legs += [k - 1] * (chords + 1)
    labels.append(f"leg {n_points - 2} (waypoint {n_points - 2} -> {n_points - 1})")
    legs.append(n_points - 2)
    return labels, legs


def find_violations(
    problem: PlanningProblem, path: FloatArray, check: SegmentValidity | None = None
) -> tuple[Violation, ...]:
    """Where a waypoint path breaks its constraints, on the path the aircraft flies: the deepest
    point below terrain + clearance of each colliding piece (a leg or a turn), each zone entered
    (with ``avoid_zones``), each piece climbing or descending beyond the aircraft's gradients and
    each leg too short for the turn fillets at its ends.  ``check``: the validity layer's verdict
    on the flown path's pieces (computed when None); a piece it refuses that none of the above
    explains is reported as such, so an infeasible result always says where."""
    flown = problem.flown(path)
    perf = problem.performance
    chords = problem.chords if perf is not None else None
    labels, legs = pieces(len(path), chords)
    samples = sample_path(problem.safety_grid, flown)
    out: list[Violation] = []
    what = "terrain + clearance" if problem.clearance else "terrain"
    depths = problem.clearance - samples.clearance
    for i, at, below, deepest in _worst_per_piece(flown, samples, depths, labels):
        out.append(
            _at(
                "terrain",
                legs[i],
                at,
                below,
                f"{labels[i]} runs about {below:.0f} m below {what}, "
                f"{deepest:.0f} m deep at x={at[0]:.0f}, y={at[1]:.0f}",
            )
        )
    if problem.avoid_zones and problem.zones:
        inside = problem.validity.segments(flown[:-1], flown[1:], clearance=False).zone_lengths
        per_label: dict[tuple[str, int], float] = {}
        for i, k in zip(*np.nonzero(inside > 0), strict=True):
            key = (labels[int(i)], int(k))
            per_label[key] = per_label.get(key, 0.0) + float(inside[i, k])
        for (label, k), amount in per_label.items():
            zone = problem.zones[k]
            name = zone.id or f"#{k}"
            cx, cy = zone.centroid
            out.append(
                Violation(
                    "danger_zone",
                    legs[labels.index(label)],
                    float(cx),
                    float(cy),
                    float("nan") if zone.top is None else zone.top,
                    amount,
                    f"{label} enters danger zone {name}"
                    + (f" (or its {problem.zone_margin:g} m margin)" if problem.zone_margin else "")
                    + f" for {amount:.0f} m",
                )
            )
    out.extend(_unknown_violations(problem, samples, labels, legs))
    if perf is not None:
        out.extend(_climb_violations(perf, path, flown, labels, legs))
        out.extend(_turn_violations(perf, path))
        out.extend(_end_turn_violations(problem, path))
    out.extend(_band_violations(problem, flown, labels, legs))
    if check is None:
        check = problem.validity.path(flown)
    named = {v.segment for v in out}
    for i in np.flatnonzero(~check.valid).tolist():
        if legs[i] in named:
            continue
        named.add(legs[i])
        mid = 0.5 * (flown[i] + flown[i + 1])
        out.append(
            _at(
                "terrain",
                legs[i],
                mid,
                float(-check.clearance[i]),
                f"{labels[i]} fails the validity check (terrain + clearance, unknown terrain or "
                f"zones): {check.clearance[i]:.0f} m clearance on the densely sampled flown path",
            )
        )
    return tuple(out)


def above_ground(problem: PlanningProblem, flown: FloatArray) -> PathSamples:
    """The flown path sampled every half cell, heights above the DEM's surface (bilinear)."""
    return sample_path(problem.grid, flown)


def flown_checks(
    problem: PlanningProblem, flown: FloatArray
) -> tuple[bool, SegmentValidity, float | None]:
    """What a plan's flown path must pass beyond its cost's hard terms: whether it does, the
    validity layer's check of it (sampled every half cell) and, with an above-ground band, the
    highest it flies above the ground (its densely sampled maximum; None without a band)."""
    check = problem.validity.path(flown)
    ok = bool(check.valid.all())
    top = None
    if problem.agl_max is not None:
        top = float(above_ground(problem, flown).clearance.max())
        ok = ok and top <= problem.agl_max
    return ok, check, top


def _band_violations(
    problem: PlanningProblem, flown: FloatArray, labels: list[str], legs: list[int]
) -> list[Violation]:
    """One violation per leg or turn that flies more than ``agl_max`` above the ground."""
    top = problem.agl_max
    if top is None:
        return []
    s = above_ground(problem, flown)
    return [
        _at(
            "above_band",
            legs[i],
            at,
            over,
            f"{labels[i]} flies about {over:.0f} m more than --agl-max {top:g} m above the "
            f"ground, {most:.0f} m over it at x={at[0]:.0f}, y={at[1]:.0f}",
        )
        for i, at, over, most in _worst_per_piece(flown, s, s.clearance - top, labels)
    ]


def _worst_per_piece(
    flown: FloatArray, samples: PathSamples, excess: FloatArray, labels: list[str]
) -> list[tuple[int, FloatArray, float, float]]:
    """For each leg or turn (by label, at its first segment with any) whose samples exceed a
    limit by ``excess`` > 0: (segment, the worst sample's point, the metres of the segment over
    the limit, the worst excess)."""
    out = []
    seen: set[str] = set()
    for i in range(len(flown) - 1):
        on = samples.segment == i
        over = excess[on]
        k = int(np.argmax(over))
        if over[k] > 0 and labels[i] not in seen:
            seen.add(labels[i])
            seg_len = float(np.linalg.norm(flown[i + 1] - flown[i]))
            out.append(
                (i, samples.points[on][k], float((over > 0).mean() * seg_len), float(over[k]))
            )
    return out


def _unknown_violations(
    problem: PlanningProblem, samples: PathSamples, labels: list[str], legs: list[int]
) -> list[Violation]:
    """One violation per leg or turn that crosses terrain the DEM did not measure (or a cell next
    to it), unless the problem allows unknown terrain."""
    mask = problem.unknown_grid
    if mask is None:
        return []
    pts = samples.points
    over = mask.heights[mask.cell_of(pts[:, 0], pts[:, 1])] > 0
    out: list[Violation] = []
    done: set[str] = set()
    for k in np.flatnonzero(over):
        i = int(samples.segment[k])
        if labels[i] in done:
            continue
        done.add(labels[i])
        on = samples.segment == i
        dist = samples.distance[on]
        part = float(over[on].mean() * (dist[-1] - dist[0]))
        out.append(
            _at(
                "unknown_terrain",
                legs[i],
                pts[k],
                part,
                f"{labels[i]} crosses about {part:.0f} m of terrain the DEM did not measure "
                f"from x={pts[k, 0]:.0f}, y={pts[k, 1]:.0f} (--allow-unknown-terrain accepts it)",
            )
        )
    return out


def _climb_violations(
    perf: Performance, path: FloatArray, flown: FloatArray, labels: list[str], legs: list[int]
) -> list[Violation]:
    """One violation per leg or turn whose gradient exceeds the aircraft's (the steepest piece).

    A leg's figures are those of the line between its waypoints (the straight piece the aircraft
    flies is part of it, with the same gradient, but may be only metres long between two turn
    fillets); a leg with no horizontal length climbs straight up, which no gradient describes.
    A turn's are those of its arc."""
    d = np.diff(flown, axis=0)
    h = np.hypot(d[:, 0], d[:, 1])
    dz = d[:, 2]
    up = dz - perf.climb_gradient * h
    down = -dz - perf.descent_gradient * h
    out: list[Violation] = []
    done: set[str] = set()
    for i in np.flatnonzero((up > TOLERANCE) | (down > TOLERANCE)):
        label = labels[int(i)]
        if label in done:
            continue
        done.add(label)
        members = [j for j, lab in enumerate(labels) if lab == label]
        if label.startswith("leg "):  # the waypoints' line
            k = legs[int(i)]
            rise = float(path[k + 1, 2] - path[k, 2])
            run = float(np.hypot(*(path[k + 1, :2] - path[k, :2])))
        else:
            rise = float(dz[members].sum())
            run = float(h[members].sum())
        climbing = rise > 0
        limit = perf.climb_gradient if climbing else perf.descent_gradient
        rate = perf.climb_rate if climbing else perf.descent_rate
        excess = float(np.maximum(up[members], down[members]).clip(min=0).sum())
        mid = 0.5 * (flown[members[0]] + flown[members[-1] + 1])
        verb = "climbs" if climbing else "descends"
        where = (
            f"in {run / 1000:.2f} km ({100 * abs(rise) / run:.1f} %)"
            if run > TOLERANCE
            else "with no horizontal length (straight " + ("up)" if climbing else "down)")
        )
        out.append(
            _at(
                "climb",
                legs[int(i)],
                mid,
                excess,
                f"{label} {verb} {abs(rise):.0f} m {where}; "
                f"the {perf.name} at {perf.speed:g} m/s can {verb[:-1]} at most "
                f"{100 * limit:.1f} % ({perf.climb_fraction:g} x {rate:g} m/s)",
            )
        )
    return out


def _end_turn_violations(problem: PlanningProblem, path: FloatArray) -> list[Violation]:
    """The turn from the take-off's climb-out onto the first leg, or from the last leg onto the
    landing's approach, where its fillet does not fit (:func:`planner.problem.lead_turn_excess`)."""
    perf = problem.performance
    out: list[Violation] = []
    if perf is None:
        return out
    for lead, k, what in ((problem.lead_in, 0, "take-off's climb-out onto the first leg"),
                          (problem.lead_out, len(path) - 1, "last leg onto the landing approach")):  # fmt: skip
        if lead is None:
            continue
        ends = (lead, None) if k == 0 else (None, lead)
        excess = lead_turn_excess(path, perf.turn_radius, *ends)
        if float(excess[0]) <= 0.0:
            continue
        out.append(
            _at(
                "turn",
                max(0, k - 1),
                path[k],
                float(excess[0]),
                f"the turn from the {what} at waypoint {k} needs {float(excess[0]):.0f} m more "
                f"leg than there is: the {perf.name} turns with a radius of "
                f"{perf.turn_radius:.0f} m at {perf.speed:g} m/s",
            )
        )
    return out


def _turn_violations(perf: Performance, path: FloatArray) -> list[Violation]:
    """One violation per leg too short for the turn fillets at its two ends."""
    f = fillets(path, perf.turn_radius)
    d = np.zeros(len(path))
    d[1:-1] = f.wanted[0]
    out: list[Violation] = []
    for j in np.flatnonzero(f.leg_excess[0] > 0):
        a, b = path[j], path[j + 1]
        length = float(np.hypot(*(b[:2] - a[:2])))
        ends = [k for k in (j, j + 1) if 0 < k < len(path) - 1 and d[k] > 0]
        turns = " and ".join(
            f"{np.degrees(f.angle[0, k - 1]):.0f} deg at waypoint {k}" for k in ends
        )
        mid = 0.5 * (a + b)
        out.append(
            _at(
                "turn",
                int(j),
                mid,
                float(f.leg_excess[0, j]),
                f"leg {j} (waypoint {j} -> {j + 1}) is {length:.0f} m long but its turns "
                f"({turns}) need {d[j] + d[j + 1]:.0f} m of it: the {perf.name} turns with a "
                f"radius of {perf.turn_radius:.0f} m at {perf.speed:g} m/s "
                f"({perf.turn_bank_deg:.0f} deg bank)",
            )
        )
    return out
