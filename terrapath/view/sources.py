"""What ``terrapath view`` shows: its SOURCEs read (a mission YAML from ``plan``, or a replay
MCAP), checked to lie on one map, and each run's trajectory sampled for display.

A replay MCAP is recognised by its magic bytes, whatever its name; anything else must be a
mission.  A run's display samples (:class:`Track`) are a regular stride of its recorded states,
at most :data:`MAX_TRACK` of them; separations and the height above the terrain are computed on
those samples (from the threats' own geometry, as the run's metrics are).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from terrain.docfile import parse_yaml
from terrain.errors import DataFileError, InputError, TerrapathError

FloatArray = npt.NDArray[np.float64]
MCAP_MAGIC = b"\x89MCAP0\r\n"
MAX_TRACK = 20_000  # display samples of one run (the time plots; the 3D line takes fewer)


@dataclass(frozen=True, eq=False)
class Track:
    """A run's display samples: time (s), map xyz, height above the terrain (altitude on flat
    ground), airspeed, bank, the separation from each threat's surface (NaN while inactive) and
    the nearest active threat (its separation, its id; NaN / "" when none is active)."""

    step: int  # every step-th recorded state
    n_states: int
    t: FloatArray
    xyz: FloatArray
    agl: FloatArray
    airspeed: FloatArray
    bank: FloatArray
    separations: dict[str, FloatArray]
    nearest: FloatArray
    nearest_id: tuple[str, ...]
    wind: FloatArray | None = None  # (K, 3) the air's velocity NED, gusts included (None: still)


@dataclass(frozen=True, eq=False)
class Source:
    """One SOURCE: its mission, its map (None: flat ground, or a DEM no longer found) and, for a
    run, what the run's picture draws (:class:`replay.record.picture.RunView`) and its track."""

    path: Path
    mission: Any
    grid: Any
    note: str
    run: Any = None
    track: Track | None = None
    beams: tuple[Any, ...] = ()  # the rangefinder beams drawn (terrapath.view.beams.Mark s)

    @property
    def label(self) -> str:
        if self.run is None:
            return f"{self.path.name} (plan)"
        outcome = "success" if self.run.success else "FAILED"
        return f"{self.path.name} ({self.run.avoid or 'no avoidance'}, {outcome})"


def read_source(path: str | Path, dem: tuple[str, ...] = ()) -> Source:
    """A SOURCE: a replay MCAP (by its magic bytes), a mission YAML, or a mission of another
    tool (QGroundControl .plan, .waypoints, GeoJSON, KML) on the DEM ``dem``; a one-line error
    for anything else, a missing file, or a run without a trajectory."""
    from planner.imports import is_foreign
    from planner.mission import load_mission
    from replay.record.picture import load_grid, recorded_view

    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: no such file")
    if is_foreign(p):
        from replay.source import import_mission

        mission, grid, _, _ = import_mission(str(p), dem, None, None)
        return Source(p, mission, grid, "")
    with p.open("rb") as f:
        head = f.read(len(MCAP_MAGIC))
    if head == MCAP_MAGIC:
        from terrapath.view.beams import beam_marks

        run = recorded_view(p, MAX_TRACK)
        return Source(p, run.mission, run.grid, run.note, run, track_of(run), tuple(beam_marks(p)))
    try:
        mission = load_mission(p)
    except TerrapathError as exc:
        if _looks_like_a_mission(p):
            raise  # a mission with a bad field: its own error names the field
        raise InputError(
            f"{p}: neither a replay MCAP nor a mission YAML from terrapath plan ({exc})"
        ) from None
    grid, note = load_grid(mission)
    return Source(p, mission, grid, note)


def _looks_like_a_mission(p: Path) -> bool:
    """A YAML mapping with waypoints (what every mission has)."""
    try:
        doc = parse_yaml(p.read_text(encoding="utf-8"), repr(str(p)))
    except (OSError, UnicodeDecodeError, DataFileError):
        return False
    return isinstance(doc, dict) and "waypoints" in doc


def read_sources(paths: list[str], dem: tuple[str, ...] = ()) -> list[Source]:
    """Every SOURCE, checked to lie on one map (same DEM tiles, or all on flat ground); ``dem``
    for the missions of other tools."""
    if not paths:
        raise InputError("give at least one SOURCE: a mission YAML or a replay MCAP")
    sources = [read_source(p, dem) for p in paths]
    first = sources[0]
    for s in sources[1:]:
        if _map_key(s) != _map_key(first):
            raise InputError(
                f"{s.path}: on another map than {first.path} "
                f"({_map_name(s)} against {_map_name(first)}); view the runs of one map together"
            )
    return sources


def _map_key(s: Source) -> Any:
    g = s.grid
    if g is None:
        return None
    return (tuple(g.bounds), g.rows, g.cols)


def _map_name(s: Source) -> str:
    if s.grid is None:
        return "flat ground"
    return ", ".join(Path(t).name for t in s.grid.sources) or "a height grid"


def track_of(run: Any, max_points: int = MAX_TRACK) -> Track:
    """The display samples of a run (module docstring)."""
    from replay.record.picture import separation_of

    n = len(run.times)
    step = max(1, math.ceil(n / max_points))
    stride = run.stride
    t = np.asarray(run.times[::step], dtype=np.float64)
    xyz = np.asarray(run.positions[::step], dtype=np.float64)
    if run.grid is not None:
        agl = xyz[:, 2] - np.asarray(run.grid.height_at(xyz[:, 0], xyz[:, 1]), dtype=np.float64)
    else:
        agl = xyz[:, 2].copy()
    seps = {th.id: separation_of(th, xyz, t) for th in run.threats}
    if seps:
        ids = list(seps)
        table = np.column_stack([seps[i] for i in ids])
        filled = np.where(np.isnan(table), np.inf, table)
        k = np.argmin(filled, axis=1)
        best = filled[np.arange(len(t)), k]
        nearest = np.where(np.isfinite(best), best, np.nan)
        nearest_id = tuple(ids[j] if math.isfinite(b) else "" for j, b in zip(k, best, strict=True))
    else:
        nearest = np.full(len(t), np.nan)
        nearest_id = ("",) * len(t)
    return Track(
        step * stride,
        run.n_states or n,
        t,
        xyz,
        agl,
        np.asarray(run.airspeed[::step], dtype=np.float64),
        np.asarray(run.bank[::step], dtype=np.float64),
        seps,
        nearest,
        nearest_id,
        None if run.wind is None else np.asarray(run.wind[::step], dtype=np.float64),
    )


__all__ = ["MAX_TRACK", "Source", "Track", "read_source", "read_sources", "track_of"]
