"""Options shared by several subcommands (like rasterio's ``rio/options.py``)."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any, TypeVar

import click

from terrain.errors import InputError

F = TypeVar("F", bound=Callable[..., Any])


def _parse_box(
    ctx: click.Context, param: click.Parameter, value: str | None
) -> tuple[float, ...] | None:
    if value is None:
        return None
    try:
        parts = tuple(float(v) for v in value.split(","))
    except ValueError:
        parts = ()
    if len(parts) != 4:
        raise click.BadParameter(f"expected XMIN,YMIN,XMAX,YMAX (4 numbers); got {value!r}")
    return parts


def dem_options(f: F) -> F:
    """DEM arguments and the options of :func:`terrain.load_dem`."""
    decorators = [
        click.argument("dem", nargs=-1, required=True, type=click.Path(dir_okay=False)),
        click.option(
            "--crs",
            default=None,
            help="Target CRS (e.g. EPSG:32611); default: the DEM's own if metric, else the UTM zone of its centre.",
        ),
        click.option(
            "--cell-size",
            type=float,
            default=None,
            help="Resample to this cell size in metres (default: native).",
        ),
        click.option(
            "--crop",
            callback=_parse_box,
            default=None,
            metavar="XMIN,YMIN,XMAX,YMAX",
            help="Crop box in map metres (or lon/lat with --crop-lonlat).",
        ),
        click.option(
            "--crop-lonlat", is_flag=True, help="The crop box is WEST,SOUTH,EAST,NORTH in degrees."
        ),
        click.option(
            "--band", type=int, default=None, help="Band holding elevation, for multi-band rasters."
        ),
        click.option(
            "--local-cell-size",
            type=float,
            default=None,
            help="For a DEM without a CRS whose cells are not metres (pixels, simulation units): "
            "the metres one cell measures (lengths are then reported in metres).",
        ),
    ]
    return decorate(f, decorators)


def decorate(f: F, decorators: Sequence[Callable[[Any], Any]]) -> F:
    """``f`` under ``decorators``, the first outermost (as they would be written above it)."""
    for d in reversed(decorators):
        f = d(f)
    return f


def load_grid(
    dem: tuple[str, ...],
    crs: str | None,
    cell_size: float | None,
    crop: Any,
    crop_lonlat: bool,
    band: int | None,
    local_cell_size: float | None = None,
) -> Any:
    """Load the grid the DEM options describe (errors surface as TerrapathError)."""
    from terrain.load import load_dem

    return load_dem(
        list(dem),
        crs=crs,
        cell_size=cell_size,
        crop=crop,
        crop_lonlat=crop_lonlat,
        band=band,
        local_cell_size=local_cell_size,
    )


json_option = click.option("--json", "as_json", is_flag=True, help="Machine-readable JSON output.")


def _check_seed(ctx: click.Context, param: click.Parameter, value: int) -> int:
    if value < 0:  # numpy's generators take no negative seeds (a traceback deep in the run)
        raise click.BadParameter(f"must be an integer >= 0; got {value}")
    return value


def seed_option(help: str) -> Callable[[F], F]:
    """``--seed``: the run's random seed (an integer >= 0, 0 by default); ``help`` says what it
    seeds and where it is recorded."""
    return click.option(
        "--seed",
        type=int,
        default=0,
        show_default=True,
        callback=_check_seed,
        metavar="INTEGER>=0",
        help=help,
    )


def output_option(
    help: str, *, default: str | None = None, required: bool = True, directory: bool = False
) -> Callable[[F], F]:
    """``-o/--output``: the file (or with ``directory`` the folder) a command writes; required
    unless it has a ``default`` or ``required`` is False."""
    # no default at all rather than ``default=None``: click 8.2+ takes an explicit None as a
    # value given, and a required option then reaches the command as None
    extra: dict[str, Any] = {} if default is None else {"default": default, "show_default": True}
    return click.option(
        "-o",
        "--output",
        required=required and default is None,
        type=click.Path(file_okay=not directory, dir_okay=directory),
        help=help,
        **extra,
    )


def _same_file(a: str | Path, b: str | Path) -> bool:
    try:
        return os.path.samefile(a, b)  # hard links and symlinks too
    except OSError:  # one of them does not exist (yet)
        return Path(a).resolve() == Path(b).resolve()


def refuse_overwriting(outputs: Iterable[str | Path], inputs: dict[str, Iterable[str]]) -> None:
    """Refuse to write any of ``outputs`` over one of the ``inputs`` (what names them, e.g.
    ``"--zones"``, to the files it names), before anything is read or written."""
    for out in outputs:
        for what, paths in inputs.items():
            for p in paths:
                if _same_file(out, p):
                    raise click.BadParameter(
                        f"{str(out)!r} would overwrite the {what} file {p!r}; write to another "
                        "file",
                        param_hint="-o/--output",
                    )


def vehicle_option(help: str, default: str | None = None) -> Callable[[F], F]:
    """``--vehicle``: a preset name or a vehicle file."""
    return click.option("--vehicle", default=default, show_default=default is not None, help=help)


def airspace_options(f: F) -> F:
    """``--airspace FILE`` (repeatable: OpenAir or ED-269 JSON, :mod:`terrain.airspace`) and
    ``--start-time`` (ISO 8601: the zones active during the flight)."""
    decorators = [
        click.option(
            "--airspace",
            "airspace",
            multiple=True,
            type=click.Path(exists=True, dir_okay=False),
            help="Airspace or UAS geozones to keep out of: an OpenAir file or ED-269 JSON "
            "(repeat for several). Limits above the ground follow the terrain.",
        ),
        click.option(
            "--start-time",
            default=None,
            metavar="ISO-8601",
            help="When the mission starts (e.g. 2026-06-01T09:30Z): time-limited zones apply "
            "when active during the flight. Default: every zone applies.",
        ),
    ]
    return decorate(f, decorators)


def wind_options(f: F) -> F:
    """``--wind SPEED,FROM_DEG[,UP]``, ``--wind-profile``, ``--turbulence`` and ``--wind-file``
    (winds aloft): the air mass of :mod:`replay.flight.wind`, read by
    :func:`wind_from_options`."""
    return _wind_decorators(f, turbulence=True)


def steady_wind_options(f: F) -> F:
    """:func:`wind_options` without ``--turbulence`` (what ``plan`` plans for)."""
    return _wind_decorators(f, turbulence=False)


def _wind_decorators(f: F, turbulence: bool) -> F:
    decorators = [
        click.option(
            "--wind",
            "wind_text",
            default=None,
            metavar="SPEED,FROM_DEG[,UP]",
            help="A steady wind: its speed (m/s) and the direction it blows from (degrees "
            "clockwise from north, as pilots say it), optionally a vertical air speed (m/s, up > "
            "0), e.g. --wind 10,270. Default: still air.",
        ),
        click.option(
            "--wind-profile",
            type=click.Choice(["uniform", "power", "log"]),
            default="uniform",
            show_default=True,
            help="How --wind changes with the height over the ground: uniform (the same at "
            "every height), or --wind is the surface wind at 10 m growing to 300 m by a power "
            "law (exponent 1/7) or a logarithmic profile (roughness 0.03 m).",
        ),
    ]
    if turbulence:
        decorators.append(
            click.option(
                "--turbulence",
                type=click.Choice(["light", "moderate", "severe"]),
                default=None,
                help="Dryden turbulence (MIL-F-8785C) on top of the wind: gusts in the 6-DOF "
                "equations, seeded by --seed. Default: none.",
            )
        )
    decorators.append(
        click.option(
            "--wind-file",
            type=click.Path(exists=True, dir_okay=False),
            default=None,
            help="Winds aloft: a wind file of layers by altitude (speed and direction each, "
            "as forecasts give them; docs/formats.md), instead of --wind.",
        )
    )
    return decorate(f, decorators)


def wind_from_options(
    text: str | None, profile: str, path: str | None, turbulence: str | None = None
) -> Any:
    """The :class:`replay.flight.wind.Wind` of the wind options, or None (still air)."""
    from dataclasses import replace

    from replay.flight.wind import Wind, load_wind_file, parse_wind

    if text is not None and path is not None:
        raise InputError("give --wind or --wind-file, not both")
    if path is not None:
        wind = load_wind_file(path)
        return replace(wind, turbulence=turbulence) if turbulence else wind
    if text is None:
        if profile != "uniform":
            raise InputError("--wind-profile shapes --wind: give --wind too")
        return Wind(turbulence=turbulence) if turbulence else None
    return parse_wind(text, profile, turbulence)


def dem_tiles_option(help: str) -> Callable[[F], F]:
    """``--dem TILE`` (repeatable, existing files): the DEM a mission flies over."""
    return click.option(
        "--dem",
        "dem_tiles",
        multiple=True,
        type=click.Path(exists=True, dir_okay=False),
        help=help,
    )


def speed_option(help: str, dest: str = "speed") -> Callable[[F], F]:
    """``--speed`` (m/s, > 0): the true airspeed a mission is flown at."""
    return click.option(
        "--speed",
        dest,
        type=click.FloatRange(min=0.0, min_open=True),
        default=None,
        help=help,
    )
