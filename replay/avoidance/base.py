"""The avoider interface the simulation loop calls after every radar scan.

An avoider receives an :class:`AvoidanceContext` (time, vehicle state, radar picture, the current
waypoint list and the index of the waypoint being flown to) and returns an
:class:`AvoidanceDecision` — a new waypoint list (and the index to fly to next) and/or a guidance
override — or ``None`` to keep flying the mission. The loop records every decision with its
compute time. ``none`` (:class:`NoAvoidance`) keeps the mission: the baseline of seed 000 Fig. 17.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class AvoidanceContext:
    """What an avoider may look at. Positions and velocities in map metres (x east, y north, z up)."""

    t: float
    state: FloatArray  # 12-state NED vector (replay.frames)
    position: FloatArray  # (3,) map
    velocity: FloatArray  # (3,) map, m/s
    airspeed: float
    course: float  # rad, clockwise from north
    picture: Any  # replay.radar.RadarPicture
    waypoints: FloatArray  # (W, 3) current list, map metres
    next_index: int  # index in ``waypoints`` of the waypoint being flown to
    vehicle: Any = None  # replay.vehicle.VehicleParams (limits: bank, pitch, climb rate)
    terrain: Any = None  # terrain.model.TerrainModel or None (flat ground)
    terrain_clearance: float = 0.0  # the autopilot's terrain following clearance (0: off)
    switch_distance: float = 0.0  # the autopilot turns to the next leg this far from a waypoint


@dataclass(frozen=True)
class AvoidanceDecision:
    """An avoider's answer: a replacement waypoint list and/or a guidance override.

    ``guidance`` keys (all optional): ``course`` (rad, clockwise from north), ``altitude`` (m AMSL),
    ``airspeed`` (m/s); ``None`` returns control to waypoint following.
    """

    waypoints: FloatArray | None = None
    next_index: int | None = None
    guidance: dict[str, float] | None = None
    direct: bool = False  # fly from the aircraft's position to waypoints[next_index]
    reason: str = ""
    info: dict[str, Any] = field(default_factory=dict)


class Avoider(Protocol):
    name: str

    def reset(self, waypoints: FloatArray, rng: np.random.Generator) -> None: ...

    def decide(self, ctx: AvoidanceContext) -> AvoidanceDecision | None: ...


class NoAvoidance:
    """Keep the mission whatever the radar sees."""

    name = "none"

    def reset(self, waypoints: FloatArray, rng: np.random.Generator) -> None:
        return None

    def decide(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        return None


AVOIDERS: dict[str, Callable[..., Avoider]] = {"none": NoAvoidance}


def _register_builtin() -> None:
    """Import the avoider modules so they add themselves to :data:`AVOIDERS`."""
    import replay.avoidance.pso_ca  # noqa: F401


def make_avoider(name: str, **options: Any) -> Avoider:
    """The avoider registered under ``name`` (later issues add pso-ca, ctga, fga, priority)."""
    _register_builtin()
    try:
        factory = AVOIDERS[name]
    except KeyError:
        raise InputError(
            f"unknown avoider {name!r}; available: {', '.join(sorted(AVOIDERS))}"
        ) from None
    return factory(**options)
