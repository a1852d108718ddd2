"""Guidance commands: what an avoider (or a test) tells a flight stack to do, typed and frozen.

One command at a time; a flight stack (:mod:`replay.flight.fixedwing.stack`) either flies it or refuses it
with a reason (:class:`GuidanceRefused`: an orbit tighter than the aircraft can turn, a hover
command to a fixed-wing aircraft). Positions are map metres (x east, y north, z AMSL), courses
and yaws radians clockwise from north, rates m/s (+ up).

- :class:`FollowWaypoints` -- a waypoint list and the index to fly to next; ``direct`` starts the
  leg at the aircraft's position ("direct to") instead of the previous waypoint;
- :class:`HoldCourse` -- a course, with an altitude or a climb rate (or neither: keep the altitude
  mode as it is);
- :class:`Orbit` -- circle a centre at a radius, clockwise (seen from above) or not, at an altitude
  (default: the altitude flown when the orbit starts); a moving centre has a velocity;
- :class:`ClimbRate` / :class:`FlightPathAngle` / :class:`HoldAltitude` -- the vertical axis only
  (the lateral guidance is kept);
- for hover-capable vehicles: :class:`GoTo` (a point, optionally a yaw), :class:`HoldPosition`
  (here, or a given point) and :class:`YawTo`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]


class GuidanceRefused(InputError):
    """A command the flight stack cannot fly; the message says why (it is recorded)."""


def _finite(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating):
        raise InputError(f"{what} must be a number; got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise InputError(f"{what} must be a finite number; got {value!r}")
    return v


def _optional(value: Any, what: str) -> float | None:
    return None if value is None else _finite(value, what)


def _vector(value: Any, n: int, what: str) -> tuple[float, ...]:
    try:
        items = list(value)
    except TypeError:
        items = []
    if len(items) != n:
        raise InputError(f"{what} must be {n} numbers; got {value!r}")
    return tuple(_finite(v, what) for v in items)


@dataclass(frozen=True, eq=False)
class FollowWaypoints:
    waypoints: FloatArray
    next_index: int = 1
    direct: bool = False

    def __post_init__(self) -> None:
        w = np.array(self.waypoints, dtype=np.float64, copy=True)
        if w.ndim != 2 or w.shape[1] != 3 or len(w) < 1 or not np.isfinite(w).all():
            raise InputError(
                f"FollowWaypoints needs a list of finite [x, y, z]; got shape {w.shape}"
            )
        if isinstance(self.next_index, bool) or not 0 <= int(self.next_index) < len(w):
            raise InputError(
                f"FollowWaypoints next_index must be in [0, {len(w) - 1}]; got {self.next_index!r}"
            )
        w.flags.writeable = False
        object.__setattr__(self, "waypoints", w)
        object.__setattr__(self, "next_index", int(self.next_index))


@dataclass(frozen=True)
class HoldCourse:
    course: float
    altitude: float | None = None
    climb_rate: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "course", _finite(self.course, "HoldCourse course"))
        object.__setattr__(self, "altitude", _optional(self.altitude, "HoldCourse altitude"))
        object.__setattr__(self, "climb_rate", _optional(self.climb_rate, "HoldCourse climb_rate"))
        if self.altitude is not None and self.climb_rate is not None:
            raise InputError("HoldCourse takes an altitude or a climb rate, not both")


@dataclass(frozen=True)
class Orbit:
    center: tuple[float, float]
    radius: float
    clockwise: bool = True
    altitude: float | None = None
    center_velocity: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _vector(self.center, 2, "Orbit center"))
        r = _finite(self.radius, "Orbit radius")
        if r <= 0:
            raise InputError(f"Orbit radius must be > 0 metres; got {self.radius!r}")
        object.__setattr__(self, "radius", r)
        object.__setattr__(self, "altitude", _optional(self.altitude, "Orbit altitude"))
        object.__setattr__(
            self, "center_velocity", _vector(self.center_velocity, 2, "Orbit center_velocity")
        )
        if not isinstance(self.clockwise, bool):
            raise InputError(f"Orbit clockwise must be true or false; got {self.clockwise!r}")


@dataclass(frozen=True)
class ClimbRate:
    rate: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "rate", _finite(self.rate, "ClimbRate rate"))


@dataclass(frozen=True)
class FlightPathAngle:
    gamma: float  # rad, + up

    def __post_init__(self) -> None:
        g = _finite(self.gamma, "FlightPathAngle gamma")
        if not -0.5 * math.pi < g < 0.5 * math.pi:
            raise InputError(f"FlightPathAngle gamma must lie in (-pi/2, pi/2); got {g!r}")
        object.__setattr__(self, "gamma", g)


@dataclass(frozen=True)
class HoldAltitude:
    altitude: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "altitude", _finite(self.altitude, "HoldAltitude altitude"))


@dataclass(frozen=True)
class GoTo:
    point: tuple[float, float, float]
    yaw: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "point", _vector(self.point, 3, "GoTo point"))
        object.__setattr__(self, "yaw", _optional(self.yaw, "GoTo yaw"))


@dataclass(frozen=True)
class HoldPosition:
    point: tuple[float, float, float] | None = None  # None: where the vehicle is

    def __post_init__(self) -> None:
        if self.point is not None:
            object.__setattr__(self, "point", _vector(self.point, 3, "HoldPosition point"))


@dataclass(frozen=True)
class YawTo:
    yaw: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "yaw", _finite(self.yaw, "YawTo yaw"))


GuidanceCommand = (
    FollowWaypoints
    | HoldCourse
    | Orbit
    | ClimbRate
    | FlightPathAngle
    | HoldAltitude
    | GoTo
    | HoldPosition
    | YawTo
)
COMMANDS: tuple[type, ...] = (
    FollowWaypoints,
    HoldCourse,
    Orbit,
    ClimbRate,
    FlightPathAngle,
    HoldAltitude,
    GoTo,
    HoldPosition,
    YawTo,
)
HOVER_COMMANDS: tuple[type, ...] = (GoTo, HoldPosition, YawTo)


def check_command(command: Any) -> GuidanceCommand:
    """``command`` if it is a guidance command, else a one-line error naming the valid ones."""
    if not isinstance(command, COMMANDS):
        raise InputError(
            f"unknown guidance command {type(command).__name__}; expected one of "
            + ", ".join(c.__name__ for c in COMMANDS)
        )
    return command  # type: ignore[return-value]


def command_record(command: GuidanceCommand) -> dict[str, Any]:
    """Plain data of a command for the recorder (``{"command": name, ...fields}``)."""
    out: dict[str, Any] = {"command": type(command).__name__}
    for name in command.__dataclass_fields__:
        value = getattr(command, name)
        if isinstance(value, np.ndarray):
            value = value.tolist()
        elif isinstance(value, tuple):
            value = list(value)
        out[name] = value
    return out


@dataclass(frozen=True)
class Commanded:
    """What a flight stack flies while an avoider steers it with commands rather than legs: the
    reference its track is judged against (``replay.judge.Conformance``), read from the stack's
    own command at the start of each tick.

    ``lateral``: ``"course"`` (hold ``course``), ``"orbit"`` (``center`` at time ``t``, moving at
    ``center_velocity``, ``radius``, ``clockwise``), ``"point"`` (hold ``point``'s x, y) or
    ``"bank"`` (a held bank angle: no track to judge). ``vertical``: ``"altitude"`` (the logged
    altitude command is the reference), ``"climb"`` (climb at ``climb_rate``: never below where
    the climb began, or above where a descent began) or ``"none"``."""

    t: float
    lateral: str
    vertical: str
    course: float = 0.0
    center: tuple[float, float] = (0.0, 0.0)
    center_velocity: tuple[float, float] = (0.0, 0.0)
    radius: float = 0.0
    clockwise: bool = True
    point: tuple[float, float] = (0.0, 0.0)
    climb_rate: float = 0.0

    def center_at(self, times: FloatArray) -> FloatArray:
        """The orbit's centre (k, 2) at ``times`` (a moving centre advances from ``t``)."""
        dt = np.asarray(times, dtype=np.float64) - self.t
        return np.column_stack(
            [
                self.center[0] + self.center_velocity[0] * dt,
                self.center[1] + self.center_velocity[1] * dt,
            ]
        )

    def same_as(self, other: Commanded | None) -> bool:
        """Whether ``other`` asks for the same track (an avoider re-issuing its command, or the
        same orbit with its centre moved on): the time it has to get there is not restarted."""
        if other is None or other.lateral != self.lateral:
            return False
        if self.lateral == "course":
            return abs(math.remainder(self.course - other.course, math.tau)) < 1e-3
        if self.lateral == "orbit":
            here = other.center_at(np.array([self.t]))[0]
            return (
                float(np.hypot(*(here - np.asarray(self.center)))) < 1.0
                and abs(self.radius - other.radius) < 1.0
                and self.clockwise == other.clockwise
            )
        if self.lateral == "point":
            return float(np.hypot(*np.subtract(self.point, other.point))) < 1.0
        return True


@dataclass(frozen=True)
class AvoidanceDecision:
    """An avoider's answer: one guidance command (None: keep going as before) and why.

    ``end`` ends the run with that outcome (e.g. "target unreachable"), recorded as the run's end
    reason. ``info`` is what the recorder stores of the decision (inputs, cost terms ...), never
    read by the flight stack.
    """

    command: GuidanceCommand | None = None
    reason: str = ""
    end: str | None = None
    info: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.command is not None:
            check_command(self.command)
        if self.end is not None and (not isinstance(self.end, str) or not self.end):
            raise InputError(f"an avoider's end outcome must be non-empty text; got {self.end!r}")


__all__: Sequence[str] = [
    "COMMANDS",
    "HOVER_COMMANDS",
    "AvoidanceDecision",
    "ClimbRate",
    "Commanded",
    "FlightPathAngle",
    "FollowWaypoints",
    "GoTo",
    "GuidanceCommand",
    "GuidanceRefused",
    "HoldAltitude",
    "HoldCourse",
    "HoldPosition",
    "Orbit",
    "YawTo",
    "check_command",
    "command_record",
]
