"""Named parts found by entry point: terrapath's own and those of installed packages (issue 39).

A package installed with pip adds an avoider, an optimiser, a vehicle or a campaign generator by
declaring an entry point in one of the groups of :data:`GROUPS` (its ``pyproject.toml``)::

    [project.entry-points."terrapath.avoiders"]
    sidestep = "terrapath_sidestep:SidestepAvoider"

Each registry (:class:`Registry`: the avoiders' in :mod:`replay.avoidance.registry`, the
optimisers' in :mod:`planner.optim`, the vehicles' in :mod:`replay.flight.fixedwing.presets`, the
generators' in :mod:`replay.campaign.generators`) holds its built-ins as the same
``"module:attribute"`` texts and adds the entry points of every other installed distribution.

Built-ins come from the in-code table, not from terrapath's own entry points.  terrapath's
``pyproject.toml`` declares them too (``tests/test_plugins.py`` checks that both say the same),
but the metadata of the installed distribution can belong to another checkout or another commit
(an editable install of one worktree imported with another's sources on ``PYTHONPATH``, or a
tree run without any install): the table is always the code being run.  Entry points of the
``terrapath`` distribution itself are therefore skipped.

Loading is lazy: finding the entry points reads the installed packages' metadata (once per
process and group) and imports nothing; a plugin's module is imported when its name is used, or
when ``terrapath plugins`` lists it.  A name given by two packages (or by a package and
terrapath) is a :class:`~terrain.errors.PluginError` naming both whenever that name is used; a
plugin that fails to import is one naming the package and the entry point.  Neither stops the
other names of the group from working.

This module lives in ``terrain`` (the bottom of the import chain) so that every layer's registry
can use it; it knows nothing of what the parts are.
"""

from __future__ import annotations

import functools
import importlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from importlib import metadata
from typing import Any

from terrain.errors import PluginError

OWN_DISTRIBUTION = "terrapath"
GROUPS = {
    "terrapath.avoiders": "avoider",
    "terrapath.optimizers": "optimiser",
    "terrapath.vehicles": "vehicle",
    "terrapath.generators": "generator",
}


def _canonical(name: str) -> str:
    """A distribution's name as pip compares them (PEP 503: case and ``-_.`` runs ignored)."""
    return "-".join(name.lower().replace("_", "-").replace(".", "-").split("-"))


@dataclass(frozen=True)
class Plugin:
    """One named part: where it is (``value``, ``"module:attribute"``) and who gives it
    (``package`` and ``version``; ``None`` for terrapath's built-ins)."""

    group: str
    name: str
    value: str
    package: str | None = None
    version: str | None = None

    @property
    def builtin(self) -> bool:
        return self.package is None

    @property
    def origin(self) -> str:
        """How messages name it: ``package sidestep 0.1.0`` or ``terrapath (built-in)``."""
        if self.package is None:
            return "terrapath (built-in)"
        return f"package {self.package} {self.version or ''}".rstrip()

    @property
    def kind(self) -> str:
        return GROUPS.get(self.group, "plugin")

    def describe(self) -> str:
        """``the avoider 'sidestep' of package terrapath-sidestep 0.1.0
        (terrapath.avoiders = terrapath_sidestep:SidestepAvoider)``."""
        return f"the {self.kind} {self.name!r} of {self.origin} ({self.group} = {self.value})"

    def load(self) -> Any:
        """The object the entry point names, imported now (once a process)."""
        return _load(self)


@functools.cache
def _load(plugin: Plugin) -> Any:
    module_name, sep, attr = plugin.value.partition(":")
    module_name, attr = module_name.strip(), attr.strip()
    if not module_name or (sep and not attr):
        raise PluginError(
            f"{plugin.describe()}: expected 'module:attribute', found {plugin.value!r}"
        )
    try:
        obj: Any = importlib.import_module(module_name)
    except Exception as exc:  # a plugin's import can fail any way: say which and go on
        raise PluginError(
            f"{plugin.describe()}: cannot import {module_name!r} "
            f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})"
        ) from None
    for part in attr.split(".") if attr else ():
        try:
            obj = getattr(obj, part)
        except AttributeError:
            raise PluginError(
                f"{plugin.describe()}: module {module_name!r} has no {attr!r}; the entry point "
                "names something that is not there"
            ) from None
    return obj


@functools.cache
def installed(group: str) -> tuple[Plugin, ...]:
    """The entry points of ``group`` of every installed distribution but terrapath's own, in a
    stable order (name, package): reading metadata, importing nothing."""
    found = []
    for ep in metadata.entry_points(group=group):
        dist = getattr(ep, "dist", None)
        package = str(dist.name) if dist is not None and dist.name else "?"
        if _canonical(package) == OWN_DISTRIBUTION:
            continue  # the built-ins: the in-code table is the code being run (module docstring)
        version = str(dist.version) if dist is not None else None
        found.append(Plugin(group, ep.name, ep.value, package, version))
    # the same distribution seen twice on sys.path (an install and a source tree): once
    unique = {(p.name, _canonical(p.package or ""), p.value): p for p in found}
    return tuple(sorted(unique.values(), key=lambda p: (p.name, p.package or "")))


class Registry:
    """The named parts of one group: ``builtins`` (name -> ``"module:attribute"``) and the
    installed packages' entry points; ``check(obj, plugin)`` (optional) refuses an object that is
    not what the group expects with a :class:`PluginError`."""

    def __init__(
        self,
        group: str,
        builtins: Mapping[str, str],
        check: Callable[[Any, Plugin], None] | None = None,
    ) -> None:
        self.group = group
        self.builtins = dict(builtins)
        self.check = check
        self._cache: tuple[int, dict[str, list[Plugin]]] | None = None

    def _by_name(self) -> dict[str, list[Plugin]]:
        """Every name's entries (built once per :func:`refresh`: a lookup is a dict's)."""
        if self._cache is not None and self._cache[0] == _generation[0]:
            return self._cache[1]
        out: dict[str, list[Plugin]] = {
            n: [Plugin(self.group, n, v)] for n, v in self.builtins.items()
        }
        for p in installed(self.group):
            out.setdefault(p.name, []).append(p)
        self._cache = (_generation[0], out)
        return out

    def names(self) -> list[str]:
        """Every name, built-in or installed (sorted; nothing is imported)."""
        return sorted(self._by_name())

    def plugin_names(self) -> list[str]:
        """The names only installed packages give."""
        return sorted(n for n in self._by_name() if n not in self.builtins)

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name in self._by_name()

    def entries(self) -> Iterator[Plugin]:
        """Every entry, a clash's sides each (for listing)."""
        for name in self.names():
            yield from self._by_name()[name]

    def find(self, name: str) -> Plugin | None:
        """The entry of ``name`` (None: no such name); a name given twice is a PluginError."""
        given = self._by_name().get(name)
        if not given:
            return None
        if len(given) > 1:
            who = " and ".join(p.origin for p in given)
            raise PluginError(
                f"the {given[0].kind} name {name!r} is given by {who}; uninstall one of them "
                f"(pip uninstall PACKAGE) or ask its author to rename it"
            )
        return given[0]

    def load(self, name: str) -> Any | None:
        """The object registered as ``name``, imported now and checked (None: no such name)."""
        plugin = self.find(name)
        if plugin is None:
            return None
        obj = plugin.load()
        if self.check is not None and not plugin.builtin:
            self.check(obj, plugin)
        return obj


_generation = [0]  # bumped by refresh(): the registries' name tables are rebuilt


def refresh() -> None:
    """Forget the entry points read so far (tests that install a package mid-process)."""
    installed.cache_clear()
    _load.cache_clear()
    _generation[0] += 1


__all__ = ["GROUPS", "OWN_DISTRIBUTION", "Plugin", "Registry", "installed", "refresh"]
