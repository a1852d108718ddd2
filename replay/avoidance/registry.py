"""The avoiders terrapath knows: an explicit table, name -> (module, class), imported on use.

No module registers itself as a side effect of being imported, so there is no import cycle:
:func:`make_avoider` imports the one module it needs. Options are checked against the class's
keyword arguments (the names it accepts are listed when one is wrong); ranges are checked by the
avoider itself. A new avoider joins by adding its row here.
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from replay.avoidance.base import Avoider
from terrain.errors import InputError

SENSORS = ("radar", "cooperative", "rangefinder")  # what an avoider may see through
DEFAULT_SENSOR = "radar"


@dataclass(frozen=True)
class AvoiderEntry:
    module: str
    cls: str
    summary: str
    sensors: tuple[str, ...] = SENSORS  # the sensors it can work with


AVOIDERS: dict[str, AvoiderEntry] = {
    "none": AvoiderEntry(
        "replay.avoidance.base", "NoAvoidance", "keep the mission whatever the sensors see"
    ),
    "pso-ca": AvoiderEntry(
        "replay.avoidance.pso_ca",
        "PsoCaAvoider",
        "seed 000: radar-driven waypoint re-planning with PSO (or GA, SA, MAFOA, GCPSO, MPSO)",
    ),
    "ctga": AvoiderEntry(
        "replay.avoidance.ctga",
        "CtgaAvoider",
        "seed 001: circular arcs round convex obstacles, flown in the aircraft's orbit mode",
    ),
    "fga": AvoiderEntry(
        "replay.avoidance.fga",
        "FgaAvoider",
        "seed 004: collision cones and a critical start time, heading or pitch manoeuvre",
    ),
    "priority": AvoiderEntry(
        "replay.avoidance.priority",
        "PriorityAvoider",
        "seed 003: stop, scan 32 directions with rangefinders, choose a set-point by steps "
        "4a-4d (hover-capable vehicles; the rangefinders are its sensor)",
        sensors=("rangefinder",),
    ),
}


def sensor_for(avoiders: Iterable[str], sensor: str | None = None, *, where: str = "") -> str:
    """The sensor the ``avoiders`` fly with: ``sensor`` when given, else the only one every
    one of them can work with (``--avoid priority``: the rangefinders), else the default
    (radar).  A ``sensor`` one of them cannot work with is refused, ``where`` (e.g.
    ``"--sensor"``) naming what gave it."""
    names = tuple(avoiders)
    fits = [s for s in SENSORS if all(s in _entry(n).sensors for n in names)]
    if sensor is None:
        return fits[0] if len(fits) == 1 else DEFAULT_SENSOR
    for n in names:
        ok = _entry(n).sensors
        if sensor not in ok:
            raise InputError(
                f"{where + ' ' if where else ''}{sensor}: the {n} avoider works with "
                f"{' or '.join(ok)} only; give that sensor or leave the sensor out (it is implied)"
            )
    return sensor


def _entry(name: str) -> AvoiderEntry:
    try:
        return AVOIDERS[name]
    except KeyError:
        raise InputError(
            f"unknown avoider {name!r}; available: {', '.join(sorted(AVOIDERS))}"
        ) from None


def avoider_class(name: str) -> type:
    """The class registered under ``name`` (imported now)."""
    entry = _entry(name)
    cls = getattr(importlib.import_module(entry.module), entry.cls)
    assert isinstance(cls, type)
    return cls


def avoider_options(name: str) -> dict[str, Any]:
    """The options an avoider accepts, with their defaults (``inspect.Parameter.empty`` when
    there is none)."""
    sig = inspect.signature(avoider_class(name))
    return {
        p.name: p.default
        for p in sig.parameters.values()
        if p.name != "self" and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
    }


def make_avoider(name: str, **options: Any) -> Avoider:
    """The avoider registered under ``name``, built with ``options`` (unknown ones refused with
    the allowed names)."""
    cls = avoider_class(name)
    allowed = avoider_options(name)
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        listed = ", ".join(sorted(allowed)) if allowed else "none"
        raise InputError(
            f"avoider {name!r} has no option {', '.join(map(repr, unknown))}; its options: {listed}"
        )
    avoider: Avoider = cls(**options)
    return avoider


__all__ = [
    "AVOIDERS",
    "DEFAULT_SENSOR",
    "SENSORS",
    "AvoiderEntry",
    "avoider_class",
    "avoider_options",
    "make_avoider",
    "sensor_for",
]
