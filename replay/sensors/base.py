"""What the simulation loop needs of a sensor (:class:`Sensor`), and the helpers the sensors share:
checked numbers and seeds, the scan schedule, the own position.

A sensor scans when it is :meth:`Sensor.due`; :meth:`Sensor.scan` takes the time, the own
position (map metres), the threats, the terrain (for terrain returns and ray casting) and the
vehicle's 12-state vector (the rangefinders tilt with the body; the radar and the cooperative
sensor do not read it), and returns its picture: :class:`replay.sensors.radar.RadarPicture`
(and the rangefinders' subclass) or :class:`replay.sensors.cooperative.CooperativePicture`, which
the avoiders read through :mod:`replay.avoidance.perception`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import numpy.typing as npt

from terrain.errors import InputError

if TYPE_CHECKING:
    from replay.threats.kinds import Threat
    from terrain.model import TerrainModel

FloatArray = npt.NDArray[np.float64]
_DUE_SLACK_S = 1e-6  # scans fall due this much early, so sums of 0.01 s steps do not skip one


class Sensor(Protocol):
    """A sensor the loop scans with (``radar``, ``cooperative``, ``rangefinder``)."""

    name: str
    period_s: float

    def due(self, t: float) -> bool: ...

    def scan(
        self,
        t: float,
        own_position: npt.ArrayLike,
        threats: Iterable[Threat],
        terrain_model: TerrainModel | None = None,
        min_clearance: float | None = None,
        state: npt.ArrayLike | None = None,
    ) -> Any: ...


def sensor_number(sensor: str, name: str, value: Any, minimum: float, strict: bool) -> float:
    """A sensor parameter as a finite float above (``strict``) or at least ``minimum``; else a
    one-line error naming the sensor and the parameter."""
    try:
        out = float(value)
    except (TypeError, ValueError):
        out = math.nan
    ok = math.isfinite(out) and (out > minimum if strict else out >= minimum)
    if isinstance(value, bool) or not ok:
        rel = ">" if strict else ">="
        raise InputError(
            f"{sensor} {name} must be a finite number {rel} {minimum:g}; got {value!r}"
        )
    return out


def sensor_rng(sensor: str, seed: Any) -> tuple[np.random.Generator, int | None]:
    """(the sensor's random generator, its integer seed or None when a Generator was given)."""
    if isinstance(seed, np.random.Generator):
        return seed, None
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer):
        raise InputError(f"{sensor} seed must be an integer or a numpy Generator; got {seed!r}")
    return np.random.default_rng(int(seed)), int(seed)


def scan_due(last_scan_t: float | None, period_s: float, t: float) -> bool:
    """A sensor's ``due``: True when no scan happened yet or ``period_s`` has passed since the
    last one (less ``_DUE_SLACK_S``)."""
    return last_scan_t is None or t >= last_scan_t + period_s - _DUE_SLACK_S


def check_own_position(value: npt.ArrayLike) -> FloatArray:
    """A sensor's own position: 3 finite map coordinates, else a one-line error."""
    own = np.asarray(value, dtype=np.float64)
    if own.shape != (3,) or not np.all(np.isfinite(own)):
        raise InputError(f"own position must be 3 finite map coordinates; got {value!r}")
    return own


__all__ = ["Sensor", "check_own_position", "scan_due", "sensor_number", "sensor_rng"]
