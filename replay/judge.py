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
  (a course, an orbit, a climb rate, a held position) the track is judged against what it
  commanded (:class:`replay.guidance.Commanded`, the flight stack's own command): laterally the
  distance from the commanded orbit's circle (its centre moving as commanded), from the line of a
  held course (through where the aircraft was once the turn onto it should be done), from a held
  point, or the leg's cross-track when only the vertical axis is overridden; vertically the band
  round the altitude command as on the legs, and for a climb-rate command the altitude where the
  climb began (told to climb it must not end up lower; told to descend, not higher).  Each new
  command has the time it takes to fly onto it (:meth:`Conformance.grace`); a command re-issued
  unchanged keeps its time.  Failing it is ``off_command``.  After every command that hands
  back the legs, and after every leg change that is not a turn fillet (seed 000's switch 1 km
  before a waypoint turns the aircraft onto a leg it is not yet on), the aircraft has
  ``return_time`` seconds to converge.  An excursion already under way when the time after an
  avoider's command runs out is ``not_back_on_plan``; any other is a ``lateral_excursion`` or
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

from planner.performance import ground_speed
from replay.guidance import Commanded
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
# the time an avoider's command is given beyond the turn (or the distance) it takes to fly onto
# it: the course loop's settling after the turn, the orbit's vector field converging
SETTLE_S = 10.0
ORBIT_GAIN = 4.0  # the orbit vector field's gain k the grace assumes (the autopilot's default)

# every failure a run can have, in the order they are listed
FAILURE_NAMES = (
    "terrain_contact",
    "off_map",
    "unknown_terrain",
    "violation",
    "stall",
    "energy_exhausted",
    "lateral_excursion",
    "vertical_excursion",
    "not_back_on_plan",
    "off_command",
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
        if not len(m) or (self.open is None and not m.any()):
            return  # nothing opens, nothing to close (most chunks)
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
def gust_altitude_error(sigma_w: float, scale_w: float, speed: float, gain: float) -> float:
    """The standard deviation (m) of the altitude error an altitude hold of bandwidth ``gain``
    (1/s: the climb rate asked per metre off) keeps in vertical gusts of intensity ``sigma_w``
    (m/s) and scale ``scale_w`` (m) flown through at ``speed`` (m/s): the gust as a first-order
    Markov process of time constant ``T = L_w / V`` (the Dryden vertical spectrum's correlation
    time) driving ``e' = -k e + w_g`` has the variance ``sigma_w^2 T / (k (1 + k T))``.  The
    climb-rate loop is taken as perfect (the aircraft climbs at what it is asked): the bound
    of a loop with its authority to spare."""
    t = scale_w / max(speed, 1e-9)
    return float(sigma_w * math.sqrt(t / (gain * (1.0 + gain * t))))


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
        speed: float = math.inf,
        turn_rate: float = math.inf,
        orbit_gain: float = ORBIT_GAIN,
    ) -> None:
        self.tol = tolerances
        self.speed = float(speed)
        self.turn_rate = float(turn_rate)
        self.orbit_gain = float(orbit_gain)
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
        # an avoider's command: the one flown, judged from when, a held course's line, where a
        # climb or descent began; the spans off it, by axis and kind
        self.command: Commanded | None = None
        self.command_from = math.inf
        self.anchor: tuple[float, float] | None = None
        self.climb_key: tuple[str, float] | None = None
        self.climb_from = 0.0
        self.off_command: dict[tuple[str, str], Spans] = {}
        # the horizontal wind (north, east) m/s where the aircraft is (the loop sets it each
        # tick): the way onto an orbit is flown over the ground
        self.wind: tuple[float, float] = (0.0, 0.0)

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
        commanded: Commanded | None = None,
    ) -> None:
        """One chunk: map ``positions`` (k, 3) at ``times``, the autopilot's ``cross_track`` and
        ``altitude_cmd`` there; ``following`` whether it followed its legs (else it flew an
        avoider's command, ``commanded``: judged against it, see the module docstring);
        ``converge_from``: times in the chunk after which it has to converge anew (leg changes
        that are not fillets)."""
        if not len(times):
            return
        if following or commanded is None:
            self.command, self.climb_key = None, None
            self._close_commanded(float(times[0]))
        else:
            self._commanded(times, positions, cross_track, altitude_cmd, commanded)
        rt = self.tol.return_time
        settled = times >= self.settle_until
        for te in converge_from:
            settled &= ~((times >= te) & (times < te + rt))
            if te + rt >= self.settle_until:
                self.settle_until, self.after_command = te + rt, False
        judged = settled & bool(following)
        lat = np.abs(cross_track)
        z = positions[:, 2]
        low, high = self._reachable(
            times,
            z,
            altitude_cmd,
            following or (commanded is not None and commanded.vertical == "altitude"),
        )
        self.highs = (np.asarray(times, dtype=np.float64), high)
        vert = np.maximum(np.maximum(low - z, z - high), 0.0)  # outside the band
        lat_off, vert_off = lat > self.tol.lateral, vert > self.tol.vertical
        lat_judged, vert_judged = judged & lat_off, judged & vert_off
        on_altitude = not following and commanded is not None and commanded.vertical == "altitude"
        # (most chunks open and close nothing: the spans' work is skipped then)
        lateral, vertical = self.lateral, self.vertical
        if (
            lateral.open is not None
            or vertical.open is not None
            or on_altitude
            or lat_judged.any()
            or vert_judged.any()
        ):
            # the first judged samples after an avoider's manoeuvre or new plan
            before = np.concatenate([[self.judged_before], judged[:-1]])
            fresh = judged & ~before & self.after_command
            lateral.update(times, lat_judged, lat, positions, fresh)
            # how far: from the altitude commanded (the band decides whether it is off at all)
            off_cmd = np.abs(z - altitude_cmd)
            vertical.update(times, vert_judged, off_cmd, positions, fresh)
            if on_altitude:
                spans = self._spans("vertical", "altitude", float(times[0]))
                spans.update(times, vert_off, off_cmd, positions)
        self.judged_before = bool(judged[-1])
        prev = self.t_last if self.t_last is not None else float(times[0])
        self.t_last = float(times[-1])
        # off the plan: flying an avoider's commands, or beyond a tolerance (settling or not)
        off = lat_off | vert_off | (not following)
        if off.any():  # (else the sum is 0.0)
            step = np.diff(np.concatenate([[prev], times]))
            self.off_plan_s += float(step[off].sum())

    def grace(self, command: Commanded, position: FloatArray, course: float | None) -> float:
        """The time (s) an aircraft at ``position`` (map) on ``course`` (rad; None: unknown) has
        to fly onto ``command``: the turn onto a held course at the vehicle's turn rate; half a
        turn and the way onto an orbit's circle as its vector field closes it (Beard & McLain
        eq 10.9: the course ``pi/2 + atan(k e / rho)`` off the radial, so the distance ``e`` to
        the circle shrinks as ``de/dt = -V a e / sqrt(1 + a^2 e^2)``, ``a = k / rho``, ``V`` the
        speed it closes on a moving centre with over the ground -- in a wind (:attr:`wind`)
        its ground speed towards the centre, crabbed into the cross wind
        (``planner.performance.ground_speed``: 5 m/s for a 15 m/s aircraft into 10 m/s), less
        the centre's speed away -- at least a fifth of its own airspeed; integrated from
        ``e0`` to half the tolerance: ``(F(e0) - F(e1)) / (V a)``, ``F(e) = u - atanh(1 / u)``,
        ``u = sqrt(1 + a^2 e^2)``); the way to a held point at the speed -- each plus
        ``SETTLE_S``."""
        v, w = self.speed, self.turn_rate
        p = np.asarray(position[:2], dtype=np.float64)
        if command.lateral == "course":
            turn = (
                math.pi
                if course is None
                else abs(math.remainder(command.course - course, math.tau))
            )
            return turn / w + SETTLE_S
        if command.lateral == "orbit":
            to = command.center_at(np.array([command.t]))[0] - p
            d = float(np.hypot(*to))
            u = to / d if d > 1e-9 else np.array([0.0, 1.0])
            closing = max(
                ground_speed(v, self.wind, u) - float(np.dot(command.center_velocity, u)),
                0.2 * v,
            )
            a = self.orbit_gain / max(command.radius, 1e-6)
            e0, e1 = abs(d - command.radius), 0.5 * self.tol.lateral

            def f(e: float) -> float:
                u = math.sqrt(1.0 + (a * e) ** 2)
                return u - math.atanh(1.0 / u)

            join = (f(e0) - f(e1)) / (closing * a) if e0 > e1 else 0.0
            return join + math.pi / w + SETTLE_S
        if command.lateral == "point":
            return float(np.hypot(*(p - np.asarray(command.point)))) / v + SETTLE_S
        return SETTLE_S

    def _commanded(
        self,
        times: FloatArray,
        positions: FloatArray,
        cross_track: FloatArray,
        altitude_cmd: FloatArray,
        command: Commanded,
    ) -> None:
        """Judge one chunk flown on an avoider's ``command`` (module docstring)."""
        z = positions[:, 2]
        if not command.same_as(self.command):
            course = None
            if len(positions) > 1:
                d = positions[1, :2] - positions[0, :2]
                course = (
                    math.atan2(float(d[0]), float(d[1])) if float(np.hypot(*d)) > 1e-6 else None
                )
            self.command_from = float(times[0]) + self.grace(command, positions[0], course)
            self.anchor = None
        self.command = command
        key = (command.vertical, command.climb_rate if command.vertical == "climb" else 0.0)
        if key != self.climb_key:
            self.climb_key, self.climb_from = key, float(z[0])
        judged = times >= self.command_from
        xy = positions[:, :2]
        kind = command.lateral
        if kind == "course":
            if self.anchor is None and judged.any():
                k = int(np.argmax(judged))
                self.anchor = (float(xy[k, 0]), float(xy[k, 1]))
            u = np.array([math.sin(command.course), math.cos(command.course)])
            rel = xy - np.asarray(self.anchor if self.anchor is not None else xy[0])
            lat = np.abs(rel[:, 0] * u[1] - rel[:, 1] * u[0])
        elif kind == "orbit":
            lat = np.abs(np.hypot(*(xy - command.center_at(times)).T) - command.radius)
        elif kind == "point":
            lat = np.hypot(*(xy - np.asarray(command.point)).T)
        elif kind == "path":
            lat = np.abs(np.asarray(cross_track, dtype=np.float64))
        else:  # a held bank: no track to judge
            lat = np.zeros(len(times))
        lateral = self._spans("lateral", kind, float(times[0]))
        lateral.update(times, judged & (lat > self.tol.lateral), lat, positions)
        if command.vertical == "climb":
            z0, rate = self.climb_from, command.climb_rate
            off = np.where(rate > 0.0, z0 - z, np.where(rate < 0.0, z - z0, np.abs(z - z0)))
            vertical = self._spans("vertical", "climb", float(times[0]))
            vertical.update(times, off > self.tol.vertical, off, positions)

    def _spans(self, axis: str, kind: str, t: float) -> Spans:
        """The spans off the command on ``axis`` for commands of ``kind`` (the same axis's
        others closed at ``t``)."""
        for (a, k), spans in self.off_command.items():
            if a == axis and k != kind and spans.open is not None:
                spans._close(t)
        return self.off_command.setdefault((axis, kind), Spans())

    def _close_commanded(self, t: float) -> None:
        """Close at ``t`` every open span off an avoider's command (the legs are flown again)."""
        for spans in self.off_command.values():
            if spans.open is not None:
                spans._close(t)

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
        names = {
            "course": "held course's line",
            "orbit": "orbit's circle",
            "point": "held position",
            "path": "leg (its vertical axis overridden)",
            "climb": "climb's start altitude",
            "altitude": "altitude commanded",
        }
        for (axis, kind), spans in sorted(self.off_command.items()):
            tol = self.tol.lateral if axis == "lateral" else self.tol.vertical
            for s in spans.finish():
                out.append(
                    Failure(
                        "off_command",
                        s.t_start,
                        s.t_end,
                        _where(s),
                        s.worst,
                        f"{s.worst:.0f} m {axis}ly off the avoider's command (the "
                        f"{names.get(kind, kind)}, tolerance {tol:g} m), " + span_text(s, t_end),
                    )
                )
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
