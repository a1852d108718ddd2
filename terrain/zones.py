"""Danger zones: vertical cylinders read from YAML or GeoJSON, validated at the edge.

A :class:`DangerZone` is a vertical cylinder in map coordinates: centre (x, y) in metres of the
grid's projected CRS, a diameter in metres and an optional ``top`` altitude (metres AMSL; ``None``
means unbounded).  The cylinder reaches down without limit; a top at or below the terrain is allowed.

Files (DESIGN §5):

- YAML: ``terrapath: 1`` and a ``danger_zones:`` list (optional ``name:``); each entry is
  ``{x, y, diameter, top?, id?}`` in map metres or ``{lon, lat, diameter, top?, id?}`` in WGS84
  degrees (converted with ``grid.from_lonlat``, so lon/lat needs a georeferenced grid);
- GeoJSON: a FeatureCollection of Point features, coordinates lon/lat (WGS84, RFC 7946; a third
  coordinate is ignored), each with a ``diameter`` (or ``radius``) property in metres, optional
  ``top`` and an optional ``id`` (else ``name``, else the feature's own ``id``).  Other properties
  are ignored, since GIS tools add their own (``fid`` ...).

Choices: the parser follows the extension (``.json``/``.geojson`` parse as JSON, anything else as
YAML, always ``yaml.safe_load``); the schema follows the content (a mapping with ``type`` and no
``terrapath`` key is GeoJSON, and a ``.json``/``.geojson`` file must be GeoJSON unless it has a
``terrapath`` key).  Ids are kept as text (``id: 3`` becomes ``"3"``) and must be unique.  When a
grid is given, every centre must lie inside its bounds.  A missing, unreadable or structurally wrong
file raises :class:`DataFileError`; a bad field raises :class:`InputError`; each message is one line
naming the file and the field (``danger_zones[2].diameter``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from terrain.docfile import (
    check_header,
    read_document,
)
from terrain.docfile import found as _found
from terrain.errors import DataFileError, InputError, where
from terrain.grid import HeightGrid

ZONE_KEYS = ("x", "y", "lon", "lat", "diameter", "top", "id")
DOCUMENT_KEYS = ("terrapath", "name", "danger_zones")
GEOJSON_SUFFIXES = (".json", ".geojson")

Source = str | PathLike[str] | None


@dataclass(frozen=True)
class DangerZone:
    """A vertical cylinder: centre (x, y) map metres, diameter m, top m AMSL or None (unbounded)."""

    x: float
    y: float
    diameter: float
    top: float | None = None
    id: str | None = None

    def __post_init__(self) -> None:
        for name in ("x", "y", "diameter"):
            given = getattr(self, name)
            try:
                value = float(given)
            except (TypeError, ValueError, OverflowError):
                value = math.nan
            if isinstance(given, bool) or not math.isfinite(value):
                raise InputError(f"danger zone {name} must be a finite number; got {given!r}")
            object.__setattr__(self, name, value)
        if self.diameter <= 0:
            raise InputError(f"danger zone diameter must be > 0 metres; got {self.diameter}")
        if self.top is not None:
            try:
                top = float(self.top)
            except (TypeError, ValueError, OverflowError):
                top = math.nan
            if isinstance(self.top, bool) or not math.isfinite(top):
                raise InputError(
                    f"danger zone top must be a finite altitude or None; got {self.top!r}"
                )
            object.__setattr__(self, "top", top)
        if self.id is not None and not isinstance(self.id, str):
            raise InputError(f"danger zone id must be text or None; got {self.id!r}")

    @property
    def radius(self) -> float:
        return self.diameter / 2.0


class _Entry(NamedTuple):
    field: str
    lonlat: bool  # True: (a, b) = (lon, lat); False: (a, b) = (x, y)
    a: float
    b: float
    diameter: float
    top: float | None
    id: str | None


def _number(value: Any, path: Source, field: str, expected: str = "a number") -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"{where(path, field)}expected {expected}, found {_found(value)}")
    try:
        out = float(value)
    except OverflowError:
        out = math.inf
    if not math.isfinite(out):
        raise InputError(f"{where(path, field)}expected {expected}, found {_found(value)}")
    return out


def _ident(value: Any, path: Source, field: str) -> str | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, str | int):
        raise InputError(f"{where(path, field)}expected text or an integer, found {_found(value)}")
    return str(value)


def _top(value: Any, path: Source, field: str) -> float | None:
    if value is None:
        return None
    return _number(value, path, field, "a top altitude in metres AMSL (or null for no top)")


def _diameter(value: Any, path: Source, field: str, expected: str) -> float:
    d = _number(value, path, field, expected)
    if d <= 0:
        raise InputError(f"{where(path, field)}expected {expected}, found {_found(value)}")
    return d


def _check_lonlat(lon: float, lat: float, path: Source, field: str) -> None:
    if not -180.0 <= lon <= 180.0:
        raise InputError(
            f"{where(path, field + '.lon')}expected degrees in [-180, 180], found {lon}"
        )
    if not -90.0 <= lat <= 90.0:
        raise InputError(f"{where(path, field + '.lat')}expected degrees in [-90, 90], found {lat}")


def _yaml_entry(entry: Any, path: Source, field: str) -> _Entry:
    if not isinstance(entry, dict):
        raise InputError(
            f"{where(path, field)}expected a mapping like {{x, y, diameter, top}}, "
            f"found {_found(entry)}"
        )
    unknown = [str(k) for k in entry if k not in ZONE_KEYS]
    if unknown:
        raise InputError(
            f"{where(path, field)}unknown key(s) {', '.join(map(repr, unknown))}; "
            f"allowed: {', '.join(ZONE_KEYS)}"
        )
    has_xy = [k for k in ("x", "y") if k in entry]
    has_ll = [k for k in ("lon", "lat") if k in entry]
    if has_xy and has_ll:
        raise InputError(
            f"{where(path, field)}give the centre as x/y (map metres) or lon/lat (degrees), "
            f"not both; found {', '.join(has_xy + has_ll)}"
        )
    keys = ("lon", "lat") if has_ll else ("x", "y")
    for k in keys:
        if k not in entry:
            raise InputError(
                f"{where(path, field)}missing '{k}'; a zone centre needs x and y (map metres) "
                "or lon and lat (degrees)"
            )
    a = _number(entry[keys[0]], path, f"{field}.{keys[0]}")
    b = _number(entry[keys[1]], path, f"{field}.{keys[1]}")
    if has_ll:
        _check_lonlat(a, b, path, field)
    if "diameter" not in entry:
        raise InputError(f"{where(path, field)}missing 'diameter' (metres, > 0)")
    diameter = _diameter(entry["diameter"], path, f"{field}.diameter", "a diameter in metres > 0")
    top = _top(entry.get("top"), path, f"{field}.top")
    ident = _ident(entry.get("id"), path, f"{field}.id")
    return _Entry(field, bool(has_ll), a, b, diameter, top, ident)


def _geojson_entry(feature: Any, path: Source, field: str) -> _Entry:
    if not isinstance(feature, dict) or feature.get("type") != "Feature":
        raise InputError(f"{where(path, field)}expected a GeoJSON Feature, found {_found(feature)}")
    geometry = feature.get("geometry")
    gtype = geometry.get("type") if isinstance(geometry, dict) else None
    if gtype != "Point" or not isinstance(geometry, dict):
        raise InputError(
            f"{where(path, field + '.geometry')}expected a Point geometry, "
            f"found {_found(gtype if gtype is not None else geometry)}"
        )
    coords = geometry.get("coordinates")
    cfield = f"{field}.geometry.coordinates"
    if not isinstance(coords, list) or len(coords) not in (2, 3):
        raise InputError(f"{where(path, cfield)}expected [lon, lat], found {_found(coords)}")
    lon = _number(coords[0], path, f"{cfield}[0]", "a longitude in degrees")
    lat = _number(coords[1], path, f"{cfield}[1]", "a latitude in degrees")
    _check_lonlat(lon, lat, path, cfield)
    props = feature.get("properties")
    pfield = f"{field}.properties"
    if props is None:
        props = {}
    if not isinstance(props, dict):
        raise InputError(f"{where(path, pfield)}expected a mapping, found {_found(props)}")
    if "diameter" in props and "radius" in props:
        raise InputError(f"{where(path, pfield)}give 'diameter' or 'radius', not both")
    if "diameter" in props:
        diameter = _diameter(
            props["diameter"], path, f"{pfield}.diameter", "a diameter in metres > 0"
        )
    elif "radius" in props:
        radius = _diameter(props["radius"], path, f"{pfield}.radius", "a radius in metres > 0")
        diameter = 2.0 * radius
    else:
        raise InputError(f"{where(path, pfield)}missing 'diameter' (metres, > 0) or 'radius'")
    top = _top(props.get("top"), path, f"{pfield}.top")
    for value, at in (
        (props.get("id"), f"{pfield}.id"),
        (props.get("name"), f"{pfield}.name"),
        (feature.get("id"), f"{field}.id"),
    ):
        if value is not None:
            ident = _ident(value, path, at)
            break
    else:
        ident = None
    return _Entry(field, True, lon, lat, diameter, top, ident)


def _finish(entries: list[_Entry], grid: HeightGrid | None, path: Source) -> tuple[DangerZone, ...]:
    """Convert lon/lat, check bounds and unique ids, build the zones."""
    xs = np.array([e.a for e in entries], dtype=np.float64)
    ys = np.array([e.b for e in entries], dtype=np.float64)
    lonlat = np.array([e.lonlat for e in entries], dtype=np.bool_)
    if lonlat.any():
        first = entries[int(np.argmax(lonlat))]
        if grid is None or grid.crs is None:
            found = "no map grid" if grid is None else "a local grid without CRS"
            raise InputError(
                f"{where(path, first.field)}lon/lat centres need a georeferenced map, found "
                f"{found}; give x/y in map metres instead"
            )
        try:
            mx, my = grid.from_lonlat(xs[lonlat], ys[lonlat])
        except InputError as exc:
            raise InputError(f"{where(path, first.field)}{exc}") from exc
        xs[lonlat], ys[lonlat] = mx, my
    if grid is not None and entries:
        inside = grid.contains(xs, ys)
        if not inside.all():
            i = int(np.argmin(inside))
            e = entries[i]
            given = f"lon/lat ({e.a}, {e.b}) = map " if e.lonlat else ""
            bounds = ", ".join(f"{v:.3f}" for v in grid.bounds)
            raise InputError(
                f"{where(path, e.field)}centre {given}({xs[i]:.3f}, {ys[i]:.3f}) lies outside "
                f"the map bounds (xmin, ymin, xmax, ymax) = ({bounds})"
            )
    seen: dict[str, str] = {}
    for e in entries:
        if e.id is not None:
            if e.id in seen:
                raise InputError(
                    f"{where(path, e.field + '.id')}duplicate id {e.id!r} (also {seen[e.id]})"
                )
            seen[e.id] = e.field
    return tuple(
        DangerZone(float(x), float(y), e.diameter, e.top, e.id)
        for e, x, y in zip(entries, xs, ys, strict=True)
    )


def zones_from_records(
    records: Any,
    grid: HeightGrid | None = None,
    *,
    source: Source = None,
    field: str = "danger_zones",
) -> tuple[DangerZone, ...]:
    """Validate a list of zone mappings (as in a mission file's ``danger_zones:``).

    ``source`` and ``field`` only label error messages (``'mission.yaml', field
    'danger_zones[1].top': ...``).  With a ``grid``, lon/lat entries are converted and every centre
    must lie inside the map.
    """
    if not isinstance(records, list | tuple):
        raise InputError(
            f"{where(source, field)}expected a list of zones (use [] for none), "
            f"found {_found(records)}"
        )
    entries = [_yaml_entry(r, source, f"{field}[{i}]") for i, r in enumerate(records)]
    return _finish(entries, grid, source)


def zones_to_records(zones: Iterable[DangerZone]) -> list[dict[str, Any]]:
    """Plain mappings ``{x, y, diameter, top?, id?}`` (map metres) that read back to equal zones."""
    out: list[dict[str, Any]] = []
    for z in zones:
        rec: dict[str, Any] = {"x": z.x, "y": z.y, "diameter": z.diameter}
        if z.top is not None:
            rec["top"] = z.top
        if z.id is not None:
            rec["id"] = z.id
        out.append(rec)
    return out


def zones_to_geojson(zones: Iterable[DangerZone], grid: HeightGrid) -> dict[str, Any]:
    """A GeoJSON FeatureCollection of the zone centres (WGS84 lon/lat) with their properties."""
    zs = list(zones)
    lon, lat = grid.to_lonlat([z.x for z in zs], [z.y for z in zs])
    features = []
    for z, lo, la in zip(zs, np.atleast_1d(lon), np.atleast_1d(lat), strict=True):
        props: dict[str, Any] = {"diameter": z.diameter}
        if z.top is not None:
            props["top"] = z.top
        if z.id is not None:
            props["id"] = z.id
        geometry = {"type": "Point", "coordinates": [float(lo), float(la)]}
        features.append({"type": "Feature", "geometry": geometry, "properties": props})
    return {"type": "FeatureCollection", "features": features}


def _read(path: Path) -> Any:
    return read_document(path, "a danger-zone file", GEOJSON_SUFFIXES)


def _load_geojson(data: Any, path: Path, grid: HeightGrid | None) -> tuple[DangerZone, ...]:
    if not isinstance(data, dict) or data.get("type") != "FeatureCollection":
        found = _found(data.get("type")) if isinstance(data, dict) else _found(data)
        raise DataFileError(
            f"{where(path, 'type')}expected a GeoJSON FeatureCollection, found {found}"
        )
    features = data.get("features")
    if not isinstance(features, list):
        raise DataFileError(f"{where(path, 'features')}expected a list, found {_found(features)}")
    entries = [_geojson_entry(f, path, f"features[{i}]") for i, f in enumerate(features)]
    return _finish(entries, grid, path)


def _load_document(data: Any, path: Path, grid: HeightGrid | None) -> tuple[DangerZone, ...]:
    data = check_header(data, path, "danger_zones", DOCUMENT_KEYS, "zones")
    return zones_from_records(data["danger_zones"], grid, source=path)


def load_zones(path: str | PathLike[str], grid: HeightGrid | None = None) -> tuple[DangerZone, ...]:
    """Read danger zones from a YAML or GeoJSON file (see the module docstring for the formats)."""
    p = Path(path)
    data = _read(p)
    is_doc = isinstance(data, dict) and "terrapath" in data
    if p.suffix.lower() in GEOJSON_SUFFIXES and not is_doc:
        return _load_geojson(data, p, grid)
    if isinstance(data, dict) and "type" in data and not is_doc:
        return _load_geojson(data, p, grid)
    return _load_document(data, p, grid)
