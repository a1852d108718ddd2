"""The avoider interface the simulation loop calls, and the baseline that never avoids.

An avoider receives an :class:`AvoidanceContext` (time, vehicle state, the latest sensor picture,
the waypoint list being flown and the index of the waypoint flown to, the flight stack's limits)
at its own period (``period`` attribute, default: the radar's) and returns an
:class:`~replay.guidance.AvoidanceDecision` -- one typed guidance command
(:mod:`replay.guidance`), or none to keep going, and optionally an end outcome -- or ``None``
(nothing to decide). The loop records every decision with its compute time.  Avoiders read the
sensor's pictures through :mod:`replay.avoidance.perception` (obstacle memory, tracks, clusters, fitted
circles), each with the settings it needs, updated once per scan.  ``none``
(:class:`NoAvoidance`) keeps the mission: the baseline of seed 000 Fig. 17.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import numpy.typing as npt

from replay.guidance import AvoidanceDecision

if TYPE_CHECKING:
    from planner.mission import Mission
    from replay.flight.base import Vehicle
    from replay.sim import ReplayConfig
    from replay.threats.kinds import ThreatSet
    from terrain.grid import HeightGrid
    from terrain.validity import ValidityChecker
    from terrain.zones import Zone

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
    # the latest scan: a RadarPicture (the rangefinders' subclass) or a CooperativePicture, read
    # through replay.avoidance.perception; each avoider reads the attributes of its sensor
    picture: Any
    waypoints: FloatArray  # (W, 3) current list, map metres
    next_index: int  # index in ``waypoints`` of the waypoint being flown to
    # the vehicle's parameters (a Vehicle: fixed wing or multirotor; limits: bank, pitch, climb)
    vehicle: Any = None
    terrain: Any = None  # terrain.model.TerrainModel, or None: flat ground
    terrain_clearance: float = 0.0  # the autopilot's terrain following clearance (0: off)
    switch_distance: float = 0.0  # the stack turns to the next leg this far from a waypoint
    fillets: bool = False  # the stack flies its corners as turn fillets (else it cuts them)
    zones: tuple[Zone, ...] = ()  # the mission's danger zones: no-fly volumes
    # what a new waypoint or leg must pass: the map, its measured terrain and the danger zones
    validity: ValidityChecker | None = None  # None: nothing to check
    # the air's velocity where the aircraft is (3,) map m/s (x east, y north, z up); still air 0
    wind: FloatArray = field(default_factory=lambda: np.zeros(3))


class Avoider(Protocol):
    """Every hook the replay calls on an avoider (:class:`AvoiderBase` gives the defaults).

    - ``name``: how runs and decisions name it; ``period``: seconds between its decisions (None:
      the sensor's scan period); ``passive``: True for an avoider that never acts (the loop then
      builds no context for it);
    - :meth:`check_vehicle` and :meth:`check_setup`, before anything is flown: refuse (with a
      one-line :class:`terrain.errors.InputError`) an aircraft or a set-up the method cannot
      work with;
    - :meth:`rangefinder_spread_deg`: the half-angle (deg) of the rangefinder beams it wants
      when the user sets none (0: a line);
    - :meth:`reset` at the start of a flight (the run's random generator, shared with the
      sensor) and :meth:`decide` at its period."""

    name: str
    period: float | None
    passive: bool

    def check_vehicle(self, params: Vehicle, speed: float) -> None: ...

    def check_setup(
        self,
        config: ReplayConfig,
        mission: Mission,
        threats: ThreatSet,
        grid: HeightGrid | None,
        speed: float,
    ) -> None: ...

    def rangefinder_spread_deg(self, range_m: float) -> float: ...

    def reset(self, waypoints: FloatArray, rng: np.random.Generator) -> None: ...

    def decide(self, ctx: AvoidanceContext) -> AvoidanceDecision | None: ...


class AvoiderBase:
    """The defaults of the optional hooks of :class:`Avoider`: the sensor's period, every
    vehicle and set-up accepted, rangefinder beams as lines."""

    name = "avoider"
    period: float | None = None
    passive = False

    def check_vehicle(self, params: Vehicle, speed: float) -> None:
        return None

    def check_setup(
        self,
        config: ReplayConfig,
        mission: Mission,
        threats: ThreatSet,
        grid: HeightGrid | None,
        speed: float,
    ) -> None:
        return None

    def point_keep_m(self) -> tuple[float, float] | None:
        """How far (m) the avoider keeps from the centre of a threat the radar sees as a point
        -- a static sphere, an intruder -- whose size it cannot measure: (static, moving);
        None when it does not say (``replay.run``'s start-up warning)."""
        return None

    def rangefinder_spread_deg(self, range_m: float) -> float:
        return 0.0


class NoAvoidance(AvoiderBase):
    """Keep the mission whatever the sensors see."""

    name = "none"
    passive = True

    def reset(self, waypoints: FloatArray, rng: np.random.Generator) -> None:
        return None

    def decide(self, ctx: AvoidanceContext) -> AvoidanceDecision | None:
        return None


__all__ = ["AvoidanceContext", "AvoidanceDecision", "Avoider", "AvoiderBase", "NoAvoidance"]
