"""The mission file (DESIGN.md §5): the source of truth between `plan` and `replay`.

```yaml
terrapath: 1
name: demo
crs: EPSG:32611              # "local" for plain metres
terrain: {dem: [../data/maps/x.tif], cell_size: 30}   # optional; paths relative to this file
vehicle: solar-uav
cruise: {speed: 15.0, altitude: 200.0, turn_radius: 143.0}   # altitude used for waypoints given as
                             # [x, y]; turn_radius: corners are flown as fillets of this radius
                             # (absent: the autopilot turns 1 km before each waypoint, seed 000)
waypoints: [[x, y, z], ...]  # map metres, z metres AMSL (where a spiral is: the altitude it ends at)
spirals: [{waypoint, entry_altitude, turns, radius, direction}, ...]   # climb / descent spirals
                             # (planner.spiral): at waypoint i the aircraft arrives at
                             # entry_altitude and circles `turns` times to the waypoint's altitude
speeds: [{waypoint, speed}, ...]   # speed changes (an imported mission's DO_CHANGE_SPEED): from
                             # waypoint i on, the true airspeed is speed (m/s)
terrain_heights: [{waypoint, height}, ...]   # terrain-frame legs (an imported mission's
                             # MAV_FRAME_GLOBAL_TERRAIN_ALT items): the leg into waypoint i is
                             # flown `height` metres above the ground all along (its z is the
                             # ground under it plus height)
danger_zones: [{x, y, diameter, floor?, top?, id?} or {vertices: [[x, y], ...], floor?, top?, id?}, ...]
plan: {...}                  # provenance written by `terrapath plan`
waypoints_geo: [{lon, lat, alt_amsl, alt_agl}, ...]   # written for people and other tools; ignored on read
```

Read with ``yaml.safe_load`` only; unknown keys are refused with the allowed names; every error
names the file and the field.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml

from planner.spiral import Spiral
from terrain.atomic import atomic_output
from terrain.docfile import (
    FORMAT_VERSION,
    absolute_as_written,
    find_reference,
    found,
    kind_of,
    parse_yaml,
    reference_places,
)
from terrain.errors import DataFileError, InputError, where
from terrain.grid import HeightGrid, crs_label
from terrain.zone_file import zones_from_records, zones_to_records
from terrain.zones import Zone

# The coordinates a mission may hold: map metres (UTM northings reach 10,000 km) and altitudes
# (metres AMSL, from below the Dead Sea to above any aircraft's ceiling); beyond them the numbers
# only overflow the flight model (a waypoint at 1e308 m, an altitude of 1e9 m).
MAX_XY = 1e8
ALTITUDES = (-1_000.0, 50_000.0)

MISSION_KEYS = (
    "terrapath",
    "name",
    "crs",
    "terrain",
    "vehicle",
    "cruise",
    "waypoints",
    "spirals",
    "terrain_heights",
    "speeds",
    "danger_zones",
    "plan",
    "waypoints_geo",
)
DEFAULT_VEHICLE = "aerosonde"
DEFAULT_CRUISE = {"speed": 25.0, "altitude": 200.0}


@dataclass(frozen=True)
class TerrainRef:
    """DEM tiles and an optional cell size.

    ``dem`` holds, for each tile, the first place it is looked for.  A reference read from a file
    also keeps the entries as that file wrote them (``written``), every place each one is looked
    for, in order (``candidates``: relative to the folder of the file that names it, then as
    given, i.e. absolute or relative to the working directory) and that file (``source``, and
    ``attachment`` when the reference sits in an attachment of it, as in an MCAP run).
    :meth:`paths` takes the first place that exists for each tile; its error names the file, the
    field and every place looked.
    """

    dem: tuple[str, ...]
    cell_size: float | None = None
    written: tuple[str, ...] = ()
    candidates: tuple[tuple[str, ...], ...] = ()
    source: str | None = None
    attachment: str | None = None
    local_cell_size: float | None = None  # metres a cell of a DEM without a CRS measures

    @classmethod
    def from_entries(
        cls,
        entries: Sequence[str],
        cell_size: float | None = None,
        *,
        source: str | None = None,
        attachment: str | None = None,
    ) -> TerrainRef:
        """DEM entries as the file ``source`` wrote them."""
        looked = tuple(reference_places(d, source) for d in entries)
        return cls(
            tuple(c[0] for c in looked),
            cell_size,
            written=tuple(entries),
            candidates=looked,
            source=source,
            attachment=attachment,
        )

    def also_look_in(self, places: Sequence[str]) -> TerrainRef:
        """The same reference with one more place to look for each tile, last (e.g. the absolute
        path a recorded run flew); unchanged unless ``places`` has one entry per tile."""
        if len(places) != len(self.dem):
            return self
        looked = tuple(
            tuple(dict.fromkeys((*self._looked(i), str(absolute_as_written(q)))))
            for i, q in enumerate(places)
        )
        return replace(self, candidates=looked)

    def _looked(self, i: int) -> tuple[str, ...]:
        return self.candidates[i] if self.candidates else (self.dem[i],)

    def _written(self, i: int) -> str:
        return self.written[i] if self.written else self.dem[i]

    def paths(self) -> tuple[str, ...]:
        """The tile files to open (absolute): the first place that exists for each; else a
        DataFileError naming the file holding the reference, the field and the places looked."""
        return tuple(
            find_reference(
                self._looked(i),
                self._written(i),
                holder=self.source,
                attachment=self.attachment,
                field=f"terrain.dem[{i}]",
                what="DEM",
                hint="; give it with --dem",
            )
            for i in range(len(self.dem))
        )

    def load(self) -> HeightGrid:
        from terrain.load import load_dem

        return load_dem(
            list(self.paths()), cell_size=self.cell_size, local_cell_size=self.local_cell_size
        )


@dataclass(frozen=True, eq=False)
class Mission:
    """A validated mission. ``waypoints`` is (W, 3): x east, y north (map metres), z AMSL."""

    name: str
    waypoints: npt.NDArray[np.float64]
    crs: str = "local"
    terrain: TerrainRef | None = None
    vehicle: str = DEFAULT_VEHICLE
    cruise_speed: float = DEFAULT_CRUISE["speed"]
    cruise_altitude: float = DEFAULT_CRUISE["altitude"]
    turn_radius: float | None = None
    danger_zones: tuple[Zone, ...] = ()
    plan: dict[str, Any] = field(default_factory=dict)
    source: str | None = None
    spirals: tuple[Spiral, ...] = ()
    # waypoint index -> metres above the ground the leg into it is flown at (terrain frame)
    terrain_heights: dict[int, float] = field(default_factory=dict)
    # waypoint index -> the true airspeed (m/s) flown from it on (a speed change)
    speeds: dict[int, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        w = np.array(self.waypoints, dtype=np.float64, copy=True)
        if w.ndim != 2 or w.shape[1] != 3 or len(w) < 2 or not np.isfinite(w).all():
            raise InputError(
                f"mission waypoints must be at least two finite [x, y, z]; got {w.shape}"
            )
        w.flags.writeable = False
        object.__setattr__(self, "waypoints", w)
        at = [s.at for s in self.spirals]
        if len(set(at)) != len(at) or any(a >= len(w) for a in at):
            raise InputError(
                f"mission spirals must be at distinct waypoints 0..{len(w) - 1}; got {at}"
            )
        if any(not 0 <= k < len(w) for k in self.speeds) or any(
            not (math.isfinite(v) and v > 0) for v in self.speeds.values()
        ):
            raise InputError(
                f"mission speeds must be > 0 m/s at waypoints 0..{len(w) - 1}; got {self.speeds}"
            )
        if any(not 0 <= k < len(w) for k in self.terrain_heights):
            raise InputError(
                f"mission terrain heights must be at waypoints 0..{len(w) - 1}; "
                f"got {sorted(self.terrain_heights)}"
            )


def _fail(path: str | None, fld: str, msg: str) -> InputError:
    return InputError(f"{where(path, fld)}{msg}")


def _num(value: Any, path: str | None, fld: str, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise _fail(path, fld, f"expected a number, found {value!r}")
    v = float(value)
    if not math.isfinite(v) or (positive and v <= 0):
        raise _fail(
            path, fld, f"expected a {'positive ' if positive else ''}finite number, found {value!r}"
        )
    return v


def _mapping(value: Any, path: str | None, fld: str, keys: tuple[str, ...]) -> dict[str, Any]:
    if not isinstance(value, dict):
        # the whole document (fld ""): say what it is, not what it holds (it may not be a mission)
        what = kind_of(value) if not fld else found(value)
        raise _fail(path, fld, f"expected a mapping with keys {', '.join(keys)}; found {what}")
    unknown = sorted(set(map(str, value)) - set(keys))
    if unknown:
        raise _fail(path, fld, f"unknown key(s) {', '.join(unknown)}; allowed: {', '.join(keys)}")
    return value


def mission_from_dict(
    data: Any, path: str | None = None, *, attachment: str | None = None
) -> Mission:
    """Validate a parsed mission document read from ``path`` (or from its attachment
    ``attachment``, as in an MCAP run): entries in ``terrain.dem`` are looked for relative to
    ``path``'s folder, then as given (see :class:`TerrainRef`)."""
    doc = _mapping(data, path, "", MISSION_KEYS) if data is not None else None
    if doc is None:
        raise DataFileError(
            f"{where(path)}empty file, expected a mission (terrapath: 1, waypoints: ...)"
        )
    if doc.get("terrapath") != FORMAT_VERSION:
        raise _fail(
            path,
            "terrapath",
            f"expected format version {FORMAT_VERSION}, found {doc.get('terrapath')!r}",
        )
    cruise = _mapping(doc.get("cruise", {}), path, "cruise", ("speed", "altitude", "turn_radius"))
    speed = _num(cruise.get("speed", DEFAULT_CRUISE["speed"]), path, "cruise.speed", positive=True)
    alt = _num(cruise.get("altitude", DEFAULT_CRUISE["altitude"]), path, "cruise.altitude")
    if not ALTITUDES[0] <= alt <= ALTITUDES[1]:
        lo, hi = ALTITUDES
        raise _fail(
            path, "cruise.altitude", f"expected metres AMSL in {lo:,.0f}..{hi:,.0f}, found {alt:g}"
        )
    turn = cruise.get("turn_radius")
    turn_radius = None if turn is None else _num(turn, path, "cruise.turn_radius", positive=True)
    raw = doc.get("waypoints")
    if not isinstance(raw, list) or len(raw) < 2:
        raise _fail(
            path,
            "waypoints",
            f"expected a list of at least two [x, y] or [x, y, z]; found {found(raw)}",
        )
    pts = []
    for i, w in enumerate(raw):
        if not isinstance(w, list | tuple) or len(w) not in (2, 3):
            raise _fail(path, f"waypoints[{i}]", f"expected [x, y] or [x, y, z], found {found(w)}")
        xyz = [_num(v, path, f"waypoints[{i}][{j}]") for j, v in enumerate(w)]
        for j, v in enumerate(xyz):
            lo, hi = (-MAX_XY, MAX_XY) if j < 2 else ALTITUDES
            if not lo <= v <= hi:
                what = "an altitude in metres AMSL" if j == 2 else "map metres"
                raise _fail(
                    path,
                    f"waypoints[{i}][{j}]",
                    f"expected {what} in {lo:,.0f}..{hi:,.0f}, found {v:g}",
                )
        pts.append(xyz if len(xyz) == 3 else [*xyz, alt])
    terrain = None
    if doc.get("terrain") is not None:
        t = _mapping(doc["terrain"], path, "terrain", ("dem", "cell_size", "local_cell_size"))
        dem = t.get("dem")
        if isinstance(dem, str):
            dem = [dem]
        if not isinstance(dem, list) or not dem or not all(isinstance(d, str) for d in dem):
            raise _fail(path, "terrain.dem", f"expected a list of DEM file paths, found {dem!r}")
        cell = t.get("cell_size")
        local = t.get("local_cell_size")
        terrain = TerrainRef.from_entries(
            dem,
            None if cell is None else _num(cell, path, "terrain.cell_size", positive=True),
            source=path,
            attachment=attachment,
        )
        if local is not None:
            size = _num(local, path, "terrain.local_cell_size", positive=True)
            terrain = replace(terrain, local_cell_size=size)
    name = doc.get("name", Path(path).stem if path else "mission")
    vehicle = doc.get("vehicle", DEFAULT_VEHICLE)
    if not isinstance(vehicle, str) or not vehicle:
        raise _fail(
            path, "vehicle", f"expected a preset name or a vehicle file path, found {vehicle!r}"
        )
    crs = doc.get("crs", "local")
    if not isinstance(crs, str):
        raise _fail(
            path, "crs", f"expected a CRS string such as 'EPSG:32611' or 'local', found {crs!r}"
        )
    plan = doc.get("plan") or {}
    if not isinstance(plan, dict):
        raise _fail(path, "plan", f"expected a mapping, found {plan!r}")
    zones = zones_from_records(doc.get("danger_zones") or [], None, source=path)
    raw_spirals = doc.get("spirals") or []
    if not isinstance(raw_spirals, list):
        raise _fail(path, "spirals", f"expected a list of spirals, found {found(raw_spirals)}")
    spirals = tuple(
        Spiral.from_dict(d, where(path, f"spirals[{i}]").rstrip(": ") or f"spirals[{i}]")
        for i, d in enumerate(raw_spirals)
    )
    for i, sp in enumerate(spirals):
        if sp.at >= len(pts):
            raise _fail(
                path,
                f"spirals[{i}].waypoint",
                f"expected a waypoint index 0..{len(pts) - 1}, found {sp.at}",
            )
        if not ALTITUDES[0] <= sp.entry <= ALTITUDES[1]:
            lo, hi = ALTITUDES
            raise _fail(
                path,
                f"spirals[{i}].entry_altitude",
                f"expected metres AMSL in {lo:,.0f}..{hi:,.0f}, found {sp.entry:g}",
            )
    if len({sp.at for sp in spirals}) != len(spirals):
        raise _fail(path, "spirals", "expected at most one spiral per waypoint")
    heights = _terrain_heights(doc.get("terrain_heights") or [], len(pts), path)
    speeds = _terrain_heights(
        doc.get("speeds") or [], len(pts), path, key="speeds", value="speed", positive=True
    )
    return Mission(
        name=str(name),
        waypoints=np.array(pts),
        crs=crs,
        terrain=terrain,
        vehicle=vehicle,
        cruise_speed=speed,
        cruise_altitude=alt,
        turn_radius=turn_radius,
        danger_zones=zones,
        plan=plan,
        source=path,
        spirals=spirals,
        terrain_heights=heights,
        speeds=speeds,
    )


def _terrain_heights(
    raw: Any,
    n: int,
    path: str | None,
    *,
    key: str = "terrain_heights",
    value: str = "height",
    positive: bool = False,
) -> dict[int, float]:
    """``terrain_heights: [{waypoint, height}, ...]`` (or ``speeds: [{waypoint, speed}, ...]``,
    module docstring) as {index: value}."""
    if not isinstance(raw, list):
        raise _fail(path, key, f"expected a list, found {found(raw)}")
    out: dict[int, float] = {}
    for i, rec in enumerate(raw):
        fld = f"{key}[{i}]"
        rec = _mapping(rec, path, fld, ("waypoint", value))
        k = rec.get("waypoint")
        if isinstance(k, bool) or not isinstance(k, int) or not 0 <= k < n or k in out:
            raise _fail(
                path,
                f"{fld}.waypoint",
                f"expected a waypoint index 0..{n - 1} named once, found {k!r}",
            )
        out[k] = _num(rec.get(value), path, f"{fld}.{value}", positive=positive)
    return out


def load_mission(path: str | os.PathLike[str]) -> Mission:
    """Read and validate a mission YAML file."""
    p = Path(path)
    if not p.is_file():
        raise DataFileError(f"{str(p)!r}: no such file")
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise DataFileError(f"{str(p)!r}: not a text file, expected a mission YAML") from None
    data = parse_yaml(text, repr(str(p)))
    return mission_from_dict(data, str(p))


def _r(v: float, nd: int = 3) -> float:
    return round(float(v), nd)


def mission_to_dict(
    mission: Mission, path: str | os.PathLike[str] | None = None, grid: HeightGrid | None = None
) -> dict[str, Any]:
    """The YAML document of a mission; DEM paths relative to ``path``'s folder; with a
    georeferenced ``grid`` also ``waypoints_geo`` (lon/lat, AMSL and above-ground altitudes)."""
    base = Path(path).resolve().parent if path else None
    doc: dict[str, Any] = {"terrapath": FORMAT_VERSION, "name": mission.name, "crs": mission.crs}
    if mission.terrain is not None:
        try:  # where the tiles were found, else where they were first looked for
            tiles = mission.terrain.paths()
        except DataFileError:
            tiles = mission.terrain.dem
        dem = [os.path.relpath(Path(d).resolve(), base) if base else d for d in tiles]
        doc["terrain"] = {"dem": dem}
        if mission.terrain.cell_size is not None:
            doc["terrain"]["cell_size"] = mission.terrain.cell_size
        if mission.terrain.local_cell_size is not None:
            doc["terrain"]["local_cell_size"] = mission.terrain.local_cell_size
    doc["vehicle"] = mission.vehicle
    doc["cruise"] = {"speed": mission.cruise_speed, "altitude": mission.cruise_altitude}
    if mission.turn_radius is not None:
        doc["cruise"]["turn_radius"] = round(float(mission.turn_radius), 2)
    doc["waypoints"] = [[_r(v) for v in w] for w in mission.waypoints]
    if mission.spirals:
        doc["spirals"] = [s.as_dict() for s in mission.spirals]
    if mission.terrain_heights:
        doc["terrain_heights"] = [
            {"waypoint": k, "height": _r(h)} for k, h in sorted(mission.terrain_heights.items())
        ]
    if mission.speeds:
        doc["speeds"] = [{"waypoint": k, "speed": _r(v)} for k, v in sorted(mission.speeds.items())]
    doc["danger_zones"] = zones_to_records(mission.danger_zones)
    doc["plan"] = mission.plan
    if grid is not None:
        w = mission.waypoints
        ground = grid.height_at(w[:, 0], w[:, 1])
        geo = []
        if grid.is_georeferenced:
            lon, lat = grid.to_lonlat(w[:, 0], w[:, 1])
            for lo, la, z, g in zip(lon, lat, w[:, 2], ground, strict=True):
                geo.append(
                    {"lon": _r(lo, 7), "lat": _r(la, 7), "alt_amsl": _r(z), "alt_agl": _r(z - g)}
                )
        else:
            geo = [
                {"alt_amsl": _r(z), "alt_agl": _r(z - g)}
                for z, g in zip(w[:, 2], ground, strict=True)
            ]
        doc["waypoints_geo"] = geo
    return doc


def save_mission(
    mission: Mission, path: str | os.PathLike[str], grid: HeightGrid | None = None
) -> Path:
    """Write a mission YAML (temporary name, then rename)."""
    out = Path(path)
    doc = mission_to_dict(mission, out, grid)
    with atomic_output(out) as tmp:
        tmp.write_text(
            "# terrapath mission: map metres (x east, y north), altitudes metres AMSL\n"
            + yaml.safe_dump(_plain(doc), sort_keys=False, default_flow_style=None, width=100),
            encoding="utf-8",
        )
    return out


def _plain(value: Any) -> Any:
    """Turn numpy scalars/arrays and tuples into plain YAML-safe Python values."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def on_terrain(mission: Mission, grid: HeightGrid | None) -> Mission:
    """``mission`` whose danger zones limited above the ground (``floor_agl``, ``top_agl``)
    follow ``grid``'s surface (:func:`terrain.zones.with_ground`); unchanged without a grid."""
    if grid is None or not any(
        z.floor_agl is not None or z.top_agl is not None for z in mission.danger_zones
    ):
        return mission
    from terrain.zones import with_ground

    zones = tuple(with_ground(z, grid.height_at) for z in mission.danger_zones)
    return replace(mission, danger_zones=zones)


def grid_crs_label(grid: HeightGrid) -> str:
    """What a mission records as its CRS for a grid."""
    return crs_label(grid.crs) if grid.crs is not None else "local"
