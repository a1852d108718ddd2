"""The avoiders terrapath knows: its own in an explicit table, name -> (module, class), and those
of installed packages (entry points of the group ``terrapath.avoiders``, :mod:`terrain.plugins`),
every one imported on use.

No module registers itself as a side effect of being imported, so there is no import cycle:
:func:`make_avoider` imports the one module it needs. Options are checked against the class's
keyword arguments (the names it accepts are listed when one is wrong); ranges are checked by the
avoider itself. A built-in avoider joins by adding its row here (and its entry point to
``pyproject.toml``: a test checks both agree); any other joins by its package's entry point
(docs/plugins.md). A plugin's class says what the table says of a built-in with class
attributes: ``summary`` (else its docstring's first line) and ``sensors`` (default: every one).
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from replay.avoidance.base import Avoider
from replay.guidance import AvoidanceDecision
from terrain.errors import ContractError, InputError, PluginError, TerrapathError
from terrain.plugins import Plugin, Registry

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


# every hook the replay calls (replay.avoidance.base.Avoider); AvoiderBase gives all but decide
# and reset
HOOKS = (
    *("name", "period", "passive", "check_vehicle", "check_setup", "rangefinder_spread_deg"),
    *("reset", "decide"),
)


def _check_plugin(obj: Any, plugin: Plugin) -> None:
    """A plugin's avoider is a class with every hook of the protocol."""
    if not isinstance(obj, type):
        raise PluginError(f"{plugin.describe()}: expected an avoider class, found {obj!r}")
    missing = [h for h in HOOKS if not hasattr(obj, h)]
    if missing:
        raise PluginError(
            f"{plugin.describe()}: the class lacks {', '.join(missing)}; an avoider subclasses "
            "replay.avoidance.AvoiderBase and defines reset() and decide()"
        )


REGISTRY = Registry(
    "terrapath.avoiders", {n: f"{e.module}:{e.cls}" for n, e in AVOIDERS.items()}, _check_plugin
)


def avoider_names() -> list[str]:
    """Every avoider's name, built-in or installed (nothing imported)."""
    return REGISTRY.names()


def avoider_plugin(name: str) -> Plugin:
    """The registry's entry of ``name`` (who gives it; unknown names refused)."""
    plugin = REGISTRY.find(name) if isinstance(name, str) else None
    if plugin is None:
        raise InputError(f"unknown avoider {name!r}; available: {', '.join(avoider_names())}")
    return plugin


def avoider_entry(name: str) -> AvoiderEntry:
    """The table's row of ``name``; an installed avoider's made from its class (imported now)."""
    if name in AVOIDERS:
        return AVOIDERS[name]
    plugin = avoider_plugin(name)
    cls = REGISTRY.load(name)
    doc = (cls.__doc__ or "").strip().splitlines()
    summary = getattr(cls, "summary", None) or (doc[0] if doc else "")
    sensors = tuple(getattr(cls, "sensors", SENSORS))
    odd = [s for s in sensors if s not in SENSORS]
    if odd or not sensors:
        raise PluginError(
            f"{plugin.describe()}: sensors must name some of {', '.join(SENSORS)}; found {sensors!r}"
        )
    module, _, attr = plugin.value.partition(":")
    return AvoiderEntry(module.strip(), attr.strip(), str(summary), sensors)


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
    return avoider_entry(name)


def avoider_class(name: str) -> type:
    """The class registered under ``name`` (imported now)."""
    avoider_plugin(name)  # unknown names refused, a name given twice named
    if name not in AVOIDERS:
        cls = REGISTRY.load(name)
        assert isinstance(cls, type)  # _check_plugin
        return cls
    entry = AVOIDERS[name]
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


OWN_PACKAGES = ("terrain", "planner", "replay", "terrapath")


def hook_checked(avoider: Any, hook: str, *args: Any) -> Any:
    """``avoider.<hook>(*args)`` (``decide``, ``reset``, ``check_vehicle``...). An exception an
    installed package's avoider raises (not an error terrapath defines) ends the run with a
    one-line :class:`~terrain.errors.ContractError` naming its class and the hook, the
    exception chained for a debugger; terrapath's own avoiders' bugs keep their traceback."""
    try:
        return getattr(avoider, hook)(*args)
    except Exception as exc:
        cls = type(avoider)
        if isinstance(exc, TerrapathError) or cls.__module__.split(".")[0] in OWN_PACKAGES:
            raise
        first = str(exc).splitlines()[0] if str(exc) else ""
        raise ContractError(
            f"avoider {getattr(avoider, 'name', cls.__name__)!r} "
            f"({cls.__module__}.{cls.__qualname__}) raised {type(exc).__name__} in {hook}(): "
            f"{first}"
        ) from exc


def decide_checked(avoider: Any, ctx: Any) -> AvoidanceDecision | None:
    """``avoider.decide(ctx)`` through :func:`hook_checked`, its answer checked
    (:func:`checked_decision`)."""
    return checked_decision(avoider, hook_checked(avoider, "decide", ctx))


def checked_decision(avoider: Any, decision: object) -> AvoidanceDecision | None:
    """``decision`` when it is what ``decide`` may return (an AvoidanceDecision or None), else
    the :class:`~terrain.errors.ContractError` that ends the run, naming the avoider and its
    class (a plugin's package is in its module's name)."""
    if decision is None or isinstance(decision, AvoidanceDecision):
        return decision
    cls = type(avoider)
    raise ContractError(
        f"avoider {getattr(avoider, 'name', cls.__name__)!r} ({cls.__module__}.{cls.__qualname__}) "
        f"returned {type(decision).__name__} from decide(); expected a "
        "replay.guidance.AvoidanceDecision or None"
    )


__all__ = [
    "AVOIDERS",
    "DEFAULT_SENSOR",
    "HOOKS",
    "REGISTRY",
    "SENSORS",
    "AvoiderEntry",
    "avoider_class",
    "avoider_entry",
    "avoider_names",
    "avoider_options",
    "avoider_plugin",
    "checked_decision",
    "decide_checked",
    "hook_checked",
    "make_avoider",
    "sensor_for",
]
