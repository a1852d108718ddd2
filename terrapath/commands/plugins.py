"""`terrapath plugins`: the avoiders, optimisers, vehicles and generators terrapath can use --
its own and those installed packages give by entry point (:mod:`terrain.plugins`) -- with who
gives each, its version and a one-line summary.

Listing imports every plugin (its summary is in its code): a plugin that cannot be imported, is
not what its group expects, or shares its name with another is listed with its one-line error,
and the command then exits with status 1, so a script (or CI) sees it.
"""

from __future__ import annotations

import inspect
import json
from collections.abc import Iterator
from typing import Any

import click

EXIT_BROKEN = 1  # some plugin cannot be used


def _first_line(obj: Any) -> str:
    """An object's ``summary`` attribute, else the first line of its docstring (a class's or a
    function's: an instance's would be its class's, which says nothing of it)."""
    text = getattr(obj, "summary", None)
    if not isinstance(text, str) or not text:
        text = (obj.__doc__ or "") if isinstance(obj, type) or inspect.isroutine(obj) else ""
    lines = text.strip().splitlines()
    return lines[0].strip() if lines else ""


def _summary(group: str, name: str, obj: Any) -> str:
    if group == "terrapath.avoiders":
        from replay.avoidance.registry import avoider_entry

        return avoider_entry(name).summary
    if group == "terrapath.vehicles":
        kind = "multirotor" if type(obj).__name__ == "MultirotorParams" else "fixed wing"
        source = " ".join(str(getattr(obj, "source", "") or "").split())
        if len(source) > 80:
            source = source[:77].rsplit(" ", 1)[0] + " ..."
        speed = getattr(obj, "cruise_speed", None)
        head = f"{kind}, cruise {speed:g} m/s" if isinstance(speed, int | float) else kind
        return f"{head}: {source}" if source else head
    return _first_line(obj)


def _registries() -> Iterator[tuple[str, Any]]:
    from planner.optim import REGISTRY as optimizers
    from replay.avoidance.registry import REGISTRY as avoiders
    from replay.campaign.generators import REGISTRY as generators
    from replay.flight.fixedwing.presets import VEHICLES

    yield "avoiders", avoiders
    yield "optimizers", optimizers
    yield "vehicles", VEHICLES
    yield "generators", generators


def listing(include_builtins: bool = True) -> list[dict[str, Any]]:
    """One record per entry (a clash's sides each): group, name, package, version, summary and
    error (None when it can be used)."""
    from terrain.errors import TerrapathError
    from terrapath import __version__

    out = []
    for label, registry in _registries():
        for p in registry.entries():
            if p.builtin and not include_builtins:
                continue
            record: dict[str, Any] = {
                "group": label,
                "name": p.name,
                "package": p.package or "terrapath",
                "version": p.version if not p.builtin else __version__,
                "builtin": p.builtin,
                "entry_point": p.value,
                "summary": "",
                "error": None,
            }
            try:
                registry.find(p.name)  # a clash is refused here
                obj = p.load()
                if registry.check is not None and not p.builtin:
                    registry.check(obj, p)
                record["summary"] = _summary(registry.group, p.name, obj)
            except TerrapathError as exc:
                record["error"] = str(exc)
            out.append(record)
    return out


@click.command("plugins")
@click.option("--json", "as_json", is_flag=True, help="Machine-readable output.")
@click.option(
    "--installed",
    "only_installed",
    is_flag=True,
    help="Only what installed packages give (not terrapath's built-ins).",
)
def plugins_cmd(as_json: bool, only_installed: bool) -> int:
    """List the avoiders, optimisers, vehicles and campaign generators terrapath can use: its
    built-ins and those installed packages add (entry points terrapath.avoiders,
    terrapath.optimizers, terrapath.vehicles, terrapath.generators), with each one's package,
    version and summary.  Exit status 1 when one of them cannot be used (its error is listed)."""
    records = listing(include_builtins=not only_installed)
    broken = [r for r in records if r["error"]]
    if as_json:
        click.echo(json.dumps(records, indent=2))
    else:
        group = None
        name_w = max((len(r["name"]) for r in records), default=0)
        who_w = max((len(f"{r['package']} {r['version']}") for r in records), default=0)
        for r in records:
            if r["group"] != group:
                group = r["group"]
                click.echo(f"{group}:")
            who = f"{r['package']} {r['version']}"
            text = f"error: {r['error']}" if r["error"] else r["summary"]
            click.echo(f"  {r['name']:<{name_w}}  {who:<{who_w}}  {text}".rstrip())
        if not records:
            click.echo("no plugins installed")
    if broken:
        click.echo(
            f"terrapath: error: {len(broken)} plugin(s) cannot be used, e.g. {broken[0]['error']}",
            err=True,
        )
        return EXIT_BROKEN
    return 0


__all__ = ["listing", "plugins_cmd"]
