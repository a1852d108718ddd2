"""What the simulation loop needs of a vehicle and its controller: the :class:`FlightStack`
protocol. The loop (:func:`replay.sim.simulate`) asks a stack for the initial state over the first
waypoint, hands it every avoider's command (:mod:`replay.guidance`), and lets it fly for a period
in compiled steps; the distances that scale with the vehicle (when a waypoint counts as reached,
when to turn for the next leg) belong to the stack. The stacks:
:class:`replay.flight.fixedwing.stack.FixedWingStack` and
:class:`replay.flight.multirotor.stack.MultirotorStack`.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from replay.flight.log import FlightLog
from replay.guidance import GuidanceCommand

FloatArray = npt.NDArray[np.float64]


class FlightStack(Protocol):
    """What the simulation loop needs of a vehicle and its controller."""

    name: str
    params: Any
    hover_capable: bool
    arrival_distance: float
    switch_distance: float  # 0 when corners are flown as fillets
    corner_distance: float  # how far before a waypoint the flown path leaves the leg

    @property
    def dt(self) -> float: ...

    @property
    def waypoints(self) -> FloatArray: ...

    @property
    def next_index(self) -> int: ...

    @property
    def done(self) -> bool: ...

    def initial_state(self) -> FloatArray: ...

    def apply(self, command: GuidanceCommand) -> None: ...

    def fly(
        self, state: FloatArray, t: float, duration: float, *, record_every: int
    ) -> FlightLog: ...


__all__ = ["FlightStack"]
