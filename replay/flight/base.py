"""What the simulation loop needs of a vehicle and its controller: the :class:`FlightStack`
protocol. The loop (:func:`replay.sim.simulate`) asks a stack for the initial state over the first
waypoint, hands it every avoider's command (:mod:`replay.guidance`), and lets it fly for a period
in compiled steps; the distances that scale with the vehicle (when a waypoint counts as reached,
when to turn for the next leg) belong to the stack. The stacks:
:class:`replay.flight.fixedwing.stack.FixedWingStack` and
:class:`replay.flight.multirotor.stack.MultirotorStack`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import fields
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from replay.flight.log import FlightLog
from replay.guidance import Commanded, GuidanceCommand
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
G = 9.81  # m/s^2, the value seed 000 uses (eq. 13)


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

    def set_wind(self, wind: npt.ArrayLike) -> None:
        """The air's velocity (NED, m/s) from now on (:mod:`replay.flight.wind`)."""
        ...

    def set_gusts(self, gusts: npt.ArrayLike) -> None:
        """The turbulence of the next ``fly`` call, step by step ((G, 6): velocity NED and
        rotational gusts; :class:`replay.flight.wind.Dryden`)."""
        ...

    def apply(self, command: GuidanceCommand) -> None: ...

    def commanded(self, t: float) -> Commanded: ...

    def fly(
        self, state: FloatArray, t: float, duration: float, *, record_every: int
    ) -> FlightLog: ...


TerrainHeight = Callable[[FloatArray, FloatArray], npt.ArrayLike]


class Vehicle(Protocol):
    """What a replay needs of a vehicle's parameters (fixed wing:
    :class:`replay.flight.fixedwing.params.VehicleParams`; multirotor:
    :class:`replay.flight.multirotor.model.MultirotorParams`): its name and cruise speed, whether
    its stack follows the terrain, the speeds it accepts, and the flight stack that flies it."""

    @property
    def name(self) -> str: ...

    @property
    def cruise_speed(self) -> float: ...

    @property
    def follows_terrain(self) -> bool: ...

    def check_speed(self, speed: float, what: str = "speed") -> float: ...

    def flight_stack(
        self,
        waypoints: npt.ArrayLike,
        *,
        speed: float,
        turn_radius: float | None = None,
        switch_distance: float = 1000.0,
        terrain_height: TerrainHeight | None = None,
        terrain_clearance: float = 0.0,
        temperature_offset: float = 0.0,
        spirals: Sequence[Any] = (),
        land: bool = False,
        leg_heights: Mapping[int, float] | None = None,
        leg_speeds: Mapping[int, float] | None = None,
    ) -> FlightStack: ...


def file_overrides(data: dict[Any, Any], path: str | None, text: tuple[str, ...]) -> dict[str, Any]:
    """The fields a vehicle document changes on its base (every key but ``terrapath`` and
    ``base``): the ``text`` ones non-empty strings, the others numbers (as floats); a ``name``
    is required.  One-line errors naming ``path`` and the field."""
    from terrain.errors import where

    if "name" not in data:
        raise InputError(f"{where(path, 'name')}missing: a vehicle file needs a name")
    overrides: dict[str, Any] = {}
    for k, v in data.items():
        if k in ("terrapath", "base"):
            continue
        if k in text:
            if not isinstance(v, str) or not v:
                raise InputError(f"{where(path, k)}expected a non-empty string, found {v!r}")
            overrides[k] = v
        elif isinstance(v, bool) or not isinstance(v, int | float):
            raise InputError(f"{where(path, k)}expected a number, found {v!r}")
        else:
            overrides[k] = float(v)
    return overrides


def check_numbers(
    p: Any,
    skip: tuple[str, ...],
    positive: tuple[str, ...],
    non_negative: tuple[str, ...],
    bad: Callable[[str, str, Any], InputError],
) -> None:
    """The number checks of a vehicle's ``validate`` (fixed-wing and multirotor): every field of
    the dataclass ``p`` but those in ``skip`` a finite number, those in ``positive`` > 0 and in
    ``non_negative`` >= 0; the first that is not raises ``bad(field, expected, found)``."""
    for f in fields(p):
        if f.name in skip:
            continue
        v = getattr(p, f.name)
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise bad(f.name, "a finite number", v)
    for k in positive:
        if getattr(p, k) <= 0:
            raise bad(k, "a number > 0", getattr(p, k))
    for k in non_negative:
        if getattr(p, k) < 0:
            raise bad(k, "a number >= 0", getattr(p, k))


__all__ = ["FlightStack", "G", "TerrainHeight", "Vehicle", "check_numbers"]
