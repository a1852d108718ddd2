"""Metrics of a replay run (DESIGN.md §4), accumulated chunk by chunk by the simulation loop.

- success: the goal reached *and the mission flown*: no failure (:class:`replay.judge.Failure`,
  each named): ``terrain_contact`` (judged on the conservative heights), ``off_map``,
  ``unknown_terrain`` (unless accepted), ``violation`` (a threat's or zone's safety volume,
  ids ``zone:<id>``), ``stall``, ``lateral_excursion``, ``vertical_excursion``,
  ``not_back_on_plan``, ``off_command`` (:mod:`replay.judge`), ``missed_goal``, ``avoider_end`` (an avoider ended
  the run, e.g. "target unreachable") or ``time_limit``;
- minimum separation to each threat (distance to its safety surface; negative = inside) and when;
- violations: every interval spent inside a threat's safety volume -- or closer to its surface
  than the success margin asked (FGA's d_m, CTGA's R_safe; 0 by default) -- with entry/exit times;
- minimum terrain clearance (height above the terrain under the aircraft) and when;
- time spent off the map (where the terrain is unknown) and over terrain the DEM did not measure;
- flown length (3D), path-length ratio PLR = flown length / straight source-destination distance
  (seed 000 §6), flight time, waypoints added by the avoider, time spent in the avoider per decision;
- every avoider decision that gave up (its reason starts with "failed", it ended the run, or the
  flight stack refused its command), counted per reason with the first time.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from replay.judge import FAILURE_NAMES, Failure, Spans, span_text

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Violation:
    threat: str
    t_enter: float
    t_exit: float | None  # None: still inside when the run ended
    min_separation: float


# the metrics measured in wall-clock time (never the same twice; everything else is)
WALL_CLOCK_METRICS = (
    *("decision_time_mean_s", "decision_time_max_s"),
    *("avoider_time_s", "avoider_time_max_s"),
    "decision_times_ms",  # a campaign row's list of every decision's time
)


@dataclass(frozen=True)
class RunMetrics:
    success: bool
    end_reason: str
    reached_goal: bool
    terrain_contact: bool
    flight_time_s: float
    flown_length_m: float
    straight_distance_m: float
    plr: float
    min_terrain_clearance_m: float
    min_terrain_clearance_t: float
    min_separation: dict[str, dict[str, float]]
    violations: tuple[Violation, ...]
    waypoints_added: int
    decisions: int
    decision_time_mean_s: float
    decision_time_max_s: float
    off_map_s: float = 0.0
    unknown_terrain_s: float = 0.0
    margin_m: float = 0.0  # separations below this count as violations (0: the surface)
    # every call of the avoider, including those that decide nothing (FGA waiting at 10 Hz)
    avoider_calls: int = 0
    avoider_time_s: float = 0.0
    avoider_time_max_s: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict)
    # why the run is not a success, in FAILURE_NAMES order then by time (empty: success)
    failures: tuple[Failure, ...] = ()
    off_plan_s: float = 0.0  # flying an avoider's commands, or beyond a conformance tolerance
    # the avoider's decisions that gave up, per reason: reason, count, t_first, first (its text)
    gave_up: tuple[dict[str, Any], ...] = ()
    # what the run was judged by: vertical_m, lateral_m, return_time_s, stall_eas_mps ...
    judged_by: dict[str, Any] = field(default_factory=dict)
    # each climb or descent spiral flown: waypoint, t (s), the altitude it was left at and the
    # plan's (m AMSL)
    spirals: tuple[dict[str, Any], ...] = ()
    # what the source gave (replay.flight.energy.Source.as_dict): kind, unit, used, capacity
    # and the share left where the vehicle gives a capacity
    energy: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["spirals"] = [dict(s) for s in self.spirals]
        d["violations"] = [asdict(v) for v in self.violations]
        d["failures"] = [asdict(f) for f in self.failures]
        d["gave_up"] = [dict(g) for g in self.gave_up]
        return _finite(d)


def _finite(value: Any) -> Any:
    """JSON-safe: inf/nan become None."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


class MetricsTracker:
    """Feed it the trajectory chunk by chunk; :meth:`finish` gives the :class:`RunMetrics`."""

    def __init__(
        self,
        threat_ids: list[str],
        start: FloatArray,
        goal: FloatArray,
        margin: float = 0.0,
        allow_unknown: bool = False,
    ) -> None:
        if not (math.isfinite(margin) and margin >= 0.0):
            raise ValueError(f"success margin must be a number of metres >= 0; got {margin!r}")
        self.margin = float(margin)
        self.start = np.asarray(start, dtype=np.float64)
        self.goal = np.asarray(goal, dtype=np.float64)
        self.length = 0.0
        self.last: FloatArray | None = None
        self.min_sep = {tid: (math.inf, math.nan) for tid in threat_ids}
        self.inside: dict[str, tuple[float, float]] = {}  # id -> (t_enter, min sep so far)
        self.violations: list[Violation] = []
        self.min_clear = (math.inf, math.nan)
        self.decision_times: list[float] = []
        self.calls = 0
        self.call_time = 0.0
        self.call_max = 0.0
        self.added = 0
        self.off_map_s = 0.0
        self.unknown_s = 0.0
        self.allow_unknown = bool(allow_unknown)
        self.off_map_spans = Spans()
        self.unknown_spans = Spans()
        self.gave_up: dict[str, dict[str, Any]] = {}
        self.t_last: float | None = None

    def update(
        self,
        times: FloatArray,
        positions: FloatArray,
        separations: dict[str, FloatArray],
        clearance: FloatArray,
        off_map: npt.NDArray[np.bool_] | None = None,
        unknown: npt.NDArray[np.bool_] | None = None,
    ) -> None:
        """One chunk: sample times (k,), map positions (k, 3), separation per active threat or
        zone (k,), terrain clearance (k,), and where the aircraft was off the map or over unknown
        terrain (k,) (each sample counts for the time since the previous one)."""
        ids = list(separations)
        seps = np.zeros((len(times), 0)) if not ids else np.column_stack(list(separations.values()))
        self.update_columns(times, positions, ids, seps, clearance, off_map, unknown)

    def update_columns(
        self,
        times: FloatArray,
        positions: FloatArray,
        ids: Sequence[str],
        separations: FloatArray,
        clearance: FloatArray,
        off_map: npt.NDArray[np.bool_] | None = None,
        unknown: npt.NDArray[np.bool_] | None = None,
    ) -> None:
        """:meth:`update` with the separations as one array (k, m), a column per id in ``ids``."""
        prev = self.t_last if self.t_last is not None else float(times[0])
        step = np.diff(np.concatenate([[prev], times]))
        self.t_last = float(times[-1])
        zero = np.zeros(len(times))
        if off_map is not None:
            self.off_map_s += float(step[off_map].sum())
            self.off_map_spans.update(times, off_map, zero, positions)
        if unknown is not None:
            self.unknown_s += float(step[unknown].sum())
            self.unknown_spans.update(times, unknown, zero, positions)
        pts = positions if self.last is None else np.vstack([self.last[None, :], positions])
        self.length += float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
        self.last = positions[-1].copy()
        k = int(np.argmin(clearance))
        if clearance[k] < self.min_clear[0]:
            self.min_clear = (float(clearance[k]), float(times[k]))
        if not len(ids):
            return
        rows = np.argmin(separations, axis=0)
        lows = separations[rows, np.arange(len(ids))].tolist()
        when = times[rows].tolist()
        none = (math.inf, math.nan)
        for c, tid in enumerate(ids):
            if lows[c] < self.min_sep.get(tid, none)[0]:
                self.min_sep[tid] = (float(lows[c]), float(when[c]))
        # a threat never inside in this chunk, and not inside before it, opens no interval
        entered = np.flatnonzero((separations < self.margin).any(axis=0)).tolist()
        for c in sorted({*entered, *(c for c, tid in enumerate(ids) if tid in self.inside)}):
            self._track_violation(ids[c], times, separations[:, c])

    def lowest(self, tid: str, value: float, t: float) -> None:
        """A smallest separation from ``tid`` (at time ``t``) measured apart from the chunks
        (``replay.threats.book``): kept when lower than the one so far, or as low and earlier."""
        low, when = self.min_sep.get(tid, (math.inf, math.nan))
        if value < low or (value == low and t < when):
            self.min_sep[tid] = (float(value), float(t))

    def _track_violation(self, tid: str, times: FloatArray, sep: FloatArray) -> None:
        """Open/close violation intervals at the samples where the separation crosses the margin
        (0: the threat's surface)."""
        inside = sep < self.margin
        was_inside = tid in self.inside
        t0, low = self.inside.get(tid, (math.nan, math.inf))
        before = np.concatenate([[was_inside], inside[:-1]])
        start = 0
        for e in np.flatnonzero(inside != before).tolist():
            if inside[e]:  # enters at sample e
                t0, low, start = float(times[e]), math.inf, e
            else:  # leaves at sample e
                low = min(low, float(sep[start:e].min())) if e > start else low
                self.violations.append(Violation(tid, t0, float(times[e]), low))
        if inside[-1]:
            self.inside[tid] = (t0, min(low, float(sep[start:].min())))
        else:
            self.inside.pop(tid, None)

    def call(self, compute_s: float) -> None:
        """One call of the avoider, whether it decided anything or not."""
        self.calls += 1
        self.call_time += float(compute_s)
        self.call_max = max(self.call_max, float(compute_s))

    def decision(
        self,
        compute_s: float,
        waypoints_added: int = 0,
        *,
        t: float = math.nan,
        gave_up: str | None = None,
    ) -> None:
        """One decision of the avoider; ``gave_up``: the reason when it gave up (at ``t``)."""
        self.decision_times.append(float(compute_s))
        self.added += int(waypoints_added)
        if gave_up is not None:
            key = reason_key(gave_up)
            entry = self.gave_up.setdefault(
                key, {"reason": key, "count": 0, "t_first": float(t), "first": gave_up}
            )
            entry["count"] += 1

    def finish(
        self,
        t_end: float,
        reached_goal: bool,
        terrain_contact: bool,
        end_reason: str,
        *,
        contact_at: tuple[float, float, float] | None = None,
        failures: Sequence[Failure] = (),
        off_plan_s: float = 0.0,
        judged_by: dict[str, Any] | None = None,
        position_at: Callable[[float], tuple[float, float]] | None = None,
        spirals: Sequence[dict[str, Any]] = (),
        energy: dict[str, Any] | None = None,
    ) -> RunMetrics:
        """The run's metrics; ``contact_at`` (x, y, clearance) where the terrain was touched,
        ``failures`` the loop's other judges found (stall, conformance), ``position_at(t)`` the
        map (x, y) of the aircraft at time t (where a violation began)."""
        for tid, (t0, m) in list(self.inside.items()):
            self.violations.append(Violation(tid, t0, None, m))
        self.inside.clear()
        self.violations.sort(key=lambda v: v.t_enter)
        straight = float(np.linalg.norm(self.goal - self.start))
        dt = self.decision_times
        found = [
            *self._failures(
                t_end, reached_goal, terrain_contact, end_reason, contact_at, position_at
            ),
            *failures,
        ]
        order = {n: k for k, n in enumerate(FAILURE_NAMES)}
        found.sort(key=lambda f: (order.get(f.name, len(order)), f.t_start))
        gave_up = sorted(self.gave_up.values(), key=lambda g: g["t_first"])
        return RunMetrics(
            success=not found,
            end_reason=end_reason,
            reached_goal=reached_goal,
            terrain_contact=terrain_contact,
            flight_time_s=float(t_end),
            flown_length_m=self.length,
            straight_distance_m=straight,
            plr=self.length / straight if straight > 0 else math.nan,
            min_terrain_clearance_m=self.min_clear[0],
            min_terrain_clearance_t=self.min_clear[1],
            min_separation={k: {"value": v[0], "t": v[1]} for k, v in self.min_sep.items()},
            violations=tuple(self.violations),
            waypoints_added=self.added,
            decisions=len(dt),
            decision_time_mean_s=float(np.mean(dt)) if dt else 0.0,
            decision_time_max_s=float(np.max(dt)) if dt else 0.0,
            off_map_s=self.off_map_s,
            margin_m=self.margin,
            unknown_terrain_s=self.unknown_s,
            avoider_calls=self.calls,
            avoider_time_s=self.call_time,
            avoider_time_max_s=self.call_max,
            failures=tuple(found),
            off_plan_s=float(off_plan_s),
            gave_up=tuple(gave_up),
            judged_by=dict(judged_by or {}),
            spirals=tuple(dict(s) for s in spirals),
            energy=dict(energy or {}),
        )

    def _failures(
        self,
        t_end: float,
        reached_goal: bool,
        terrain_contact: bool,
        end_reason: str,
        contact_at: tuple[float, float, float] | None,
        position_at: Callable[[float], tuple[float, float]] | None = None,
    ) -> list[Failure]:
        """The failures this tracker judges: terrain contact, the map, unknown terrain, safety
        volumes and how the run ended."""
        out: list[Failure] = []
        if terrain_contact:
            x, y, c = contact_at if contact_at is not None else (math.nan, math.nan, math.nan)
            out.append(
                Failure(
                    "terrain_contact",
                    t_end,
                    t_end,
                    None if contact_at is None else (x, y),
                    c,
                    f"below the highest measured ground of its cell at t = {t_end:.1f} s"
                    + ("" if contact_at is None else f" at ({x:.0f}, {y:.0f})"),
                )
            )
        for name, spans, what in (
            ("off_map", self.off_map_spans, "off the map (terrain unknown there)"),
            ("unknown_terrain", self.unknown_spans, "over terrain the DEM did not measure"),
        ):
            found = spans.finish()
            if name == "unknown_terrain" and self.allow_unknown:
                continue
            for s in found:
                out.append(
                    Failure(
                        name,
                        s.t_start,
                        s.t_end,
                        (s.x, s.y),
                        s.duration(t_end),
                        f"{what}: " + span_text(s, t_end).replace(" at (", ", from (", 1),
                    )
                )
        for v in self.violations:
            where = None if position_at is None else position_at(v.t_enter)
            end = "the end" if v.t_exit is None else f"{v.t_exit:.1f} s"
            inside = f"closer than {self.margin:g} m to" if self.margin else "inside"
            out.append(
                Failure(
                    "violation",
                    v.t_enter,
                    v.t_exit,
                    where,
                    v.min_separation,
                    f"{inside} {v.threat} from t = {v.t_enter:.1f} s to {end} "
                    f"(deepest {v.min_separation:.1f} m)"
                    + ("" if where is None else f", entered at ({where[0]:.0f}, {where[1]:.0f})"),
                )
            )
        if not reached_goal and end_reason != "terrain contact":
            name = (
                "missed_goal"
                if end_reason.startswith("missed the goal")
                else "time_limit"
                if end_reason == "time limit"
                else "energy_exhausted"
                if end_reason.startswith("energy exhausted")
                else "avoider_end"
            )
            pos = None if self.last is None else (float(self.last[0]), float(self.last[1]))
            out.append(Failure(name, t_end, t_end, pos, math.nan, f"the run ended: {end_reason}"))
        return out


def reason_key(reason: str) -> str:
    """What decisions that gave up for the same reason share: the reason's first clause, without
    the obstacles it names (``failed: no waypoint meets g1-g7 for s1, s2; keeping ...`` ->
    ``failed: no waypoint meets g1-g7``)."""
    head = reason.split(";")[0].strip()
    return re.sub(r"\s+for\s+.*$", "", head) or reason
