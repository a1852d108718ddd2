"""Was the mission flown? The judgements of a replay beyond the threats (DESIGN.md §4, issue 32),
each a named :class:`Failure` in the run's metrics.

- **Spans** (:class:`Spans`): the intervals where a per-sample condition holds, fed chunk by
  chunk, each with its start and end, the worst value and where it was.
- **Stall** (:class:`StallJudge`): the equivalent airspeed below the fixed-wing aircraft's 1-g
  stall speed (``sqrt(2 W / (rho0 S CL_max))``, EAS: the same at every altitude) for more than
  ``STALL_MIN_S`` seconds.  Multirotors have no stall.
- **Conformance** (:class:`Conformance`): the track within ``lateral`` metres of the path the
  autopilot was asked to fly (its own cross-track error to the current leg or turn fillet: an
  avoider's new waypoints are the plan) and within ``vertical`` metres of a band round the
  altitude command it was asked to hold (the command, widened after a step by how fast the
  vehicle can climb or descend to it).  While an avoider steers with commands rather than a path
  (a course, an orbit, a climb rate, a held position) the track is not judged; after every
  command, and after every leg change that is not a turn fillet (seed 000's switch 1 km before a
  waypoint turns the aircraft onto a leg it is not yet on), the aircraft has ``return_time``
  seconds to converge.  An excursion already under way when the time after an avoider's command
  runs out is ``not_back_on_plan``; any other is a ``lateral_excursion`` or
  ``vertical_excursion``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

STALL_MIN_S = 2.0  # below the stall speed for longer than this is a stall (a gust is not)
RETURN_TIME_S = 60.0  # default: back within the tolerances this long after a manoeuvre
VERTICAL_TOLERANCE_M = 30.0  # default: at least this, or half the planned clearance
LATERAL_TOLERANCE_M = 50.0  # default: at least this, or a quarter of the turn radius
# the share of its climb and descent rates a vehicle is expected to make good on a step of the
# altitude command (an autopilot closes on its limits, it does not fly them exactly)
RATE_SHARE = 0.8

# every failure a run can have, in the order they are listed
FAILURE_NAMES = (
    "terrain_contact",
    "off_map",
    "unknown_terrain",
    "violation",
    "stall",
    "lateral_excursion",
    "vertical_excursion",
    "not_back_on_plan",
    "missed_goal",
    "avoider_end",
    "time_limit",
)


@dataclass(frozen=True)
class Failure:
    """One reason a run is not a success: its ``name`` (one of ``FAILURE_NAMES``), when (``t_end``
    None: until the end of the run), where (map x, y of the worst moment), the worst ``value``
    (metres, or m/s for a stall; NaN when it has none) and one line for people."""

    name: str
    t_start: float
    t_end: float | None
    where: tuple[float, float] | None
    value: float
    text: str


@dataclass
class Span:
    """An interval of samples (``t_end`` is the first sample after it; None: still open)."""

    t_start: float
    t_end: float | None
    worst: float
    x: float
    y: float
    tag: bool = False  # e.g. opened as a manoeuvre's grace ran out

    def duration(self, t_end: float) -> float:
        return (t_end if self.t_end is None else self.t_end) - self.t_start


class Spans:
    """The intervals where a per-sample condition holds, fed chunk by chunk (the result does not
    depend on how the samples are chunked)."""

    def __init__(self) -> None:
        self.spans: list[Span] = []
        self.open: Span | None = None

    def update(
        self,
        times: FloatArray,
        mask: npt.ArrayLike,
        values: FloatArray,
        positions: FloatArray,
        tags: BoolArray | None = None,
    ) -> None:
        """``mask`` (k,) where the condition holds at ``times`` (k,), its ``values`` (k,; the
        worst is the largest) at ``positions`` (k, >= 2); ``tags`` (k,) what a span opening at a
        sample is tagged with."""
        m = np.asarray(mask, dtype=bool)
        if not len(m):
            return
        if self.open is not None and not m[0]:
            self._close(float(times[0]))
        cuts = [0, *(np.flatnonzero(np.diff(m.astype(np.int8))) + 1).tolist(), len(m)]
        for a, b in itertools.pairwise(cuts):
            if not m[a]:
                continue
            k = a + int(np.argmax(values[a:b]))
            worst = float(values[k])
            span = self.open
            if span is None:
                tag = bool(tags[a]) if tags is not None else False
                span = Span(float(times[a]), None, -math.inf, math.nan, math.nan, tag)
                self.open = span
            if worst > span.worst:
                span.worst, span.x, span.y = worst, float(positions[k, 0]), float(positions[k, 1])
            if b < len(m):
                self._close(float(times[b]))

    def _close(self, t: float) -> None:
        assert self.open is not None
        self.open.t_end = t
        self.spans.append(self.open)
        self.open = None

    def finish(self) -> list[Span]:
        """Every span, the one still open last (``t_end`` None)."""
        if self.open is not None:
            self.spans.append(self.open)
            self.open = None
        return self.spans


def span_text(span: Span, t_end: float) -> str:
    """``t = 12.0-15.5 s (3.5 s) at (x, y)``."""
    end = "the end" if span.t_end is None else f"{span.t_end:.1f}"
    return (
        f"t = {span.t_start:.1f} s to {end}{'' if span.t_end is None else ' s'} ({span.duration(t_end):.1f} s) "
        f"at ({_metre(span.x)}, {_metre(span.y)})"
    )


def _metre(v: float) -> str:
    return "?" if math.isnan(v) else str(int(round(v)))


def _where(span: Span) -> tuple[float, float] | None:
    return None if math.isnan(span.x) else (span.x, span.y)


# ---- stall -----------------------------------------------------------------------------------
def stall_eas(params: Any) -> float | None:
    """The 1-g stall speed (m/s, equivalent airspeed) of a fixed-wing vehicle: the speed at which
    level flight needs the largest lift coefficient of its lift curve; None for a vehicle without
    a wing (a multirotor)."""
    if not hasattr(params, "CLalpha"):
        return None
    from replay.flight.atmosphere import RHO0
    from replay.flight.fixedwing.dynamics import lift_coefficient
    from replay.flight.fixedwing.trim import alpha_max_lift

    cl_max = lift_coefficient(alpha_max_lift(params), params)
    return math.sqrt(2.0 * params.weight / (RHO0 * params.S * cl_max))


class StallJudge:
    """Spans with the equivalent airspeed below the stall's ``eas`` (m/s); those longer than
    ``min_s`` are stalls."""

    def __init__(self, eas: float, temperature_offset: float = 0.0, min_s: float = STALL_MIN_S):
        self.eas = float(eas)
        self.dtemp = float(temperature_offset)
        self.min_s = float(min_s)
        self.spans = Spans()

    def update(self, times: FloatArray, positions: FloatArray, airspeed: FloatArray) -> None:
        from replay.flight.atmosphere import equivalent_airspeed

        eas = np.asarray(equivalent_airspeed(airspeed, positions[:, 2], self.dtemp))
        self.spans.update(times, eas < self.eas, self.eas - eas, positions)

    def failures(self, t_end: float) -> list[Failure]:
        out = []
        for s in self.spans.finish():
            if s.duration(t_end) <= self.min_s:
                continue
            low = self.eas - s.worst
            out.append(
                Failure(
                    "stall",
                    s.t_start,
                    s.t_end,
                    _where(s),
                    low,
                    f"airspeed {low:.1f} m/s EAS, below the stall's {self.eas:.1f} m/s, "
                    + span_text(s, t_end),
                )
            )
        return out


# ---- conformance -----------------------------------------------------------------------------
@dataclass(frozen=True)
class Tolerances:
    """How far the track may stray from the plan (m) and how long a return may take (s)."""

    vertical: float
    lateral: float
    return_time: float

    def __post_init__(self) -> None:
        for name in ("vertical", "lateral", "return_time"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise InputError(f"conformance {name} must be a positive number; got {v!r}")

    @classmethod
    def of(
        cls,
        vertical: float | None,
        lateral: float | None,
        return_time: float | None,
        *,
        planned_clearance: float | None,
        turn_radius: float | None,
    ) -> Tolerances:
        """The given tolerances, else the defaults: vertical the larger of 30 m and half the
        planned clearance, lateral the larger of 50 m and a quarter of the turn radius, the
        return 60 s."""
        if vertical is None:
            vertical = max(VERTICAL_TOLERANCE_M, 0.5 * float(planned_clearance or 0.0))
        if lateral is None:
            lateral = max(LATERAL_TOLERANCE_M, 0.25 * float(turn_radius or 0.0))
        return cls(float(vertical), float(lateral), float(return_time or RETURN_TIME_S))


class Conformance:
    """The track against the autopilot's own guidance, sample by sample (module docstring).

    Vertically the altitude must lie in a band round the altitude command: after the command
    steps up, its lower edge climbs to it at ``RATE_SHARE`` of the vehicle's ``climb_rate``
    (m/s); after it steps down, its upper edge descends at that share of its ``descent_rate``
    (from where the aircraft was when it last took up its legs).  The error is the distance
    outside the band -- a terrain-following floor that steps up (or falls away) is judged by
    whether the aircraft climbs (or descends) about as fast as it can, not by the step."""

    def __init__(
        self,
        tolerances: Tolerances,
        climb_rate: float = math.inf,
        descent_rate: float = math.inf,
    ) -> None:
        self.tol = tolerances
        self.climb_rate = RATE_SHARE * float(climb_rate)
        self.descent_rate = RATE_SHARE * float(descent_rate)
        # the band of altitudes the vehicle can be in on its way to the command (None: none yet)
        self.band: tuple[float, float] | None = None
        self.lateral = Spans()
        self.vertical = Spans()
        self.settle_until = -math.inf
        self.after_command = False  # the latest grace follows an avoider's command
        self.judged_before = True
        self.off_plan_s = 0.0
        self.t_last: float | None = None
        self.at_waypoints: list[Failure] = []
        self.command_until = -math.inf  # converging after an avoider's command until then
        # the band's upper edge over the last chunk (times, high): Conformance.waypoint
        self.highs: tuple[FloatArray, FloatArray] = (np.zeros(0), np.zeros(0))

    def settle(self, t: float) -> None:
        """A new plan or command at ``t``: the aircraft has the return time to converge."""
        self.settle_until = max(self.settle_until, float(t) + self.tol.return_time)
        self.command_until = max(self.command_until, float(t) + self.tol.return_time)
        self.after_command = True

    def update(
        self,
        times: FloatArray,
        positions: FloatArray,
        cross_track: FloatArray,
        altitude_cmd: FloatArray,
        following: bool,
        converge_from: Sequence[float] = (),
    ) -> None:
        """One chunk: map ``positions`` (k, 3) at ``times``, the autopilot's ``cross_track`` and
        ``altitude_cmd`` there; ``following`` whether it followed its legs (else it flew an
        avoider's commands); ``converge_from``: times in the chunk after which it has to converge
        anew (leg changes that are not fillets)."""
        if not len(times):
            return
        rt = self.tol.return_time
        settled = times >= self.settle_until
        for te in converge_from:
            settled &= ~((times >= te) & (times < te + rt))
            if te + rt >= self.settle_until:
                self.settle_until, self.after_command = te + rt, False
        judged = settled & bool(following)
        lat = np.abs(cross_track)
        z = positions[:, 2]
        low, high = self._reachable(times, z, altitude_cmd, following)
        self.highs = (np.asarray(times, dtype=np.float64), high)
        vert = np.maximum(np.maximum(low - z, z - high), 0.0)  # outside the band
        # the first judged samples after an avoider's manoeuvre or new plan
        fresh = judged & ~np.concatenate([[self.judged_before], judged[:-1]]) & self.after_command
        self.judged_before = bool(judged[-1])
        self.lateral.update(times, judged & (lat > self.tol.lateral), lat, positions, fresh)
        # how far: from the altitude commanded (the band decides whether it is off at all)
        off_cmd = np.abs(z - altitude_cmd)
        self.vertical.update(times, judged & (vert > self.tol.vertical), off_cmd, positions, fresh)
        prev = self.t_last if self.t_last is not None else float(times[0])
        step = np.diff(np.concatenate([[prev], times]))
        self.t_last = float(times[-1])
        # off the plan: flying an avoider's commands, or beyond a tolerance (settling or not)
        off = (lat > self.tol.lateral) | (vert > self.tol.vertical) | (not following)
        self.off_plan_s += float(step[off].sum())

    def _reachable(
        self, times: FloatArray, z: FloatArray, command: FloatArray, following: bool
    ) -> tuple[FloatArray, FloatArray]:
        """The band (low, high) of altitudes on the plan: the command, widened after a step by
        where the vehicle can be by now -- ``low`` follows the command up at the climb rate (and
        down at once), ``high`` follows it down at the descent rate (and up at once). While the
        vehicle flies an avoider's commands the band is its own altitude."""
        if not following:
            self.band = (float(z[-1]), float(z[-1]))
            return np.asarray(z, dtype=np.float64), np.asarray(z, dtype=np.float64)
        low, high = np.empty(len(times)), np.empty(len(times))
        if self.band is None:
            self.band = (min(float(z[0]), float(command[0])), max(float(z[0]), float(command[0])))
        lo, hi = self.band
        prev = float(times[0]) if self.t_last is None else self.t_last
        up, down = self.climb_rate, self.descent_rate
        for k, (t, c) in enumerate(zip(times.tolist(), command.tolist(), strict=True)):
            dt = max(0.0, t - prev)
            lo = min(c, lo + up * dt)
            hi = max(c, hi - down * dt)
            low[k], high[k], prev = lo, hi, t
        self.band = (lo, hi)
        return low, high

    def waypoint(
        self,
        index: int,
        t: float,
        position: FloatArray,
        leg: FloatArray,
        altitude_cmd: float,
        terrain_following: bool = False,
    ) -> None:
        """Waypoint ``index`` reached at ``t`` at map ``position`` on the leg ``leg`` (2, 3: its
        start and end): the altitude must be within the vertical tolerance of the leg's profile
        there (linear along the leg, as the autopilot commands it). The band of :meth:`update`
        lets the aircraft lag a command at the rate it climbs, which a terrain-following floor
        needs -- but it would also excuse a mission's own climb the aircraft cannot make (a
        Cessna passing its 4,000 m waypoint at 3,513 m, climbing as well as it can): where a
        leg ends, the plan's altitude is what was asked. Above the profile is on the plan when
        the command there was higher, and -- with ``terrain_following``, the one thing that
        lifts the aircraft above its plan on purpose -- while it descends from a floor that fell
        away about as fast as it can (the band's upper edge: :meth:`update` of the chunk
        first). Not judged while the
        aircraft still converges after an avoider's command (a leg change's lateral
        convergence does not excuse the altitude)."""
        if t < self.command_until:
            return
        a, b = np.asarray(leg[0], dtype=np.float64), np.asarray(leg[1], dtype=np.float64)
        run = b[:2] - a[:2]
        length2 = float(run @ run)
        f = 1.0 if length2 < 1e-9 else float(np.clip((position[:2] - a[:2]) @ run / length2, 0, 1))
        profile = float(a[2] + f * (b[2] - a[2]))
        z = float(position[2])
        below = profile - z
        ceiling = max(profile, float(altitude_cmd))
        times, high = self.highs
        if terrain_following and len(times):
            ceiling = max(ceiling, float(high[min(int(np.searchsorted(times, t)), len(times) - 1)]))
        above = z - ceiling
        if below <= self.tol.vertical and above <= self.tol.vertical:
            return
        off = below if below > 0 else above
        way = "below" if below > 0 else "above"
        where = (float(position[0]), float(position[1]))
        self.at_waypoints.append(
            Failure(
                "vertical_excursion",
                float(t),
                float(t),
                where,
                float(off),
                f"passed waypoint {index} at {z:,.0f} m, {off:.0f} m {way} the plan's "
                f"{profile:,.0f} m there (tolerance {self.tol.vertical:g} m), t = {t:.1f} s "
                f"at ({where[0]:.0f}, {where[1]:.0f})",
            )
        )

    def failures(self, t_end: float) -> list[Failure]:
        out = list(self.at_waypoints)
        for what, spans, tol in (
            ("lateral", self.lateral, self.tol.lateral),
            ("vertical", self.vertical, self.tol.vertical),
        ):
            for s in spans.finish():
                if s.tag:
                    name = "not_back_on_plan"
                    text = (
                        f"still {s.worst:.0f} m off the plan {what}ly {self.tol.return_time:g} s "
                        f"after the avoider's last command (tolerance {tol:g} m), "
                    )
                else:
                    name = f"{what}_excursion"
                    text = f"{s.worst:.0f} m off the plan {what}ly (tolerance {tol:g} m), "
                out.append(
                    Failure(
                        name, s.t_start, s.t_end, _where(s), s.worst, text + span_text(s, t_end)
                    )
                )
        return out
