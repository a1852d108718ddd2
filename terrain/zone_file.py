"""Danger-zone files: YAML and GeoJSON, read into the zones of :mod:`terrain.zones` (and
written from them), validated at the edge.

Files (DESIGN §5):

- YAML: ``terrapath: 1`` and a ``danger_zones:`` list (optional ``name:``); each entry is
  a cylinder ``{x, y, diameter, floor?, top?, id?}`` in map metres or ``{lon, lat, diameter,
  floor?, top?, id?}`` in WGS84 degrees (``radius`` instead of ``diameter`` if preferred), or a polygon ``{vertices: [[x, y], ...], holes?: [[[x,
  y], ...], ...], floor?, top?, id?}`` in map metres or ``{vertices_lonlat: [[lon, lat], ...],
  holes_lonlat?: [...], ...}`` in degrees, or a polygon of several parts ``{parts: [{vertices,
  holes?}, ...], floor?, top?, id?}`` (``vertices_lonlat`` / ``holes_lonlat`` in the parts for
  degrees).  Rings are open lists of at least 3 distinct vertices in either orientation; a
  repeated closing vertex is allowed.  Lon/lat is converted with ``grid.from_lonlat``, so it needs
  a georeferenced grid;
- GeoJSON: a FeatureCollection (coordinates lon/lat, WGS84, RFC 7946; a third coordinate is
  ignored) of Point features, each a cylinder with a ``diameter`` (or ``radius``) property in
  metres, and Polygon / MultiPolygon features (holes allowed), each a polygon zone; properties:
  optional ``floor`` and ``top`` and an optional ``id`` (else ``name``, else the feature's own
  ``id``).  Every zone, YAML or GeoJSON, may carry a ``margin`` (metres >= 0): it is read as the
  zone grown by that much all round (:func:`terrain.zones.inflated`: wider, its top higher, its
  floor lower), which is what is stored and written back.  Other properties are ignored, since GIS tools add their own (``fid`` ...).  A GeoJSON
  ring must be closed (its last position repeats its first): a ring that is not is refused,
  naming the feature.

Polygons are checked with shapely (:func:`terrain.zones.polygon_problem`): a ring that crosses
itself, a hole outside its exterior, overlapping parts and every other invalidity is refused with
shapely's reason (``Self-intersection[x y]``, in the coordinates of the file) and the field of the
feature.  Lon/lat vertices are converted one by one: edges are straight lines in map metres.  A
polygon zone is stored normalised (see :mod:`terrain.zones`), so the records written by
:func:`zones_to_records` read back to an equal zone.

Choices: the parser follows the extension (``.json``/``.geojson`` parse as JSON, anything else as
YAML, always ``yaml.safe_load``); the schema follows the content (a mapping with ``type`` and no
``terrapath`` key is GeoJSON, and a ``.json``/``.geojson`` file must be GeoJSON unless it has a
``terrapath`` key).  Ids are kept as text (``id: 3`` becomes ``"3"``) and must be unique.  When a
grid is given, every cylinder centre must lie inside its bounds and every polygon must overlap
them.  A missing, unreadable or structurally wrong file raises :class:`DataFileError`; a bad field
raises :class:`InputError`; each message is one line naming the file and the field
(``danger_zones[2].diameter``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from os import PathLike
from pathlib import Path
from typing import Any, Literal, NamedTuple

import numpy as np

from terrain.docfile import (
    check_header,
    feature_id,
    geojson_features,
    read_document,
)
from terrain.docfile import found as _found
from terrain.errors import InputError, where
from terrain.grid import HeightGrid
from terrain.zones import (
    DangerZone,
    FloatArray,
    PolygonZone,
    Ring,
    Zone,
    inflated,
    open_ring,
    orient,
    polygon_problem,
    shapely_geometry,
)

ZONE_KEYS = (
    *("x", "y", "lon", "lat", "diameter", "radius", "margin", "floor", "top"),
    *("floor_agl", "top_agl", "id"),
)
POLYGON_KEYS = (
    "vertices",
    "vertices_lonlat",
    "holes",
    "holes_lonlat",
    "parts",
    "margin",
    "floor",
    "top",
    "floor_agl",
    "top_agl",
    "id",
)
PART_KEYS = ("vertices", "vertices_lonlat", "holes", "holes_lonlat")
DOCUMENT_KEYS = ("terrapath", "name", "danger_zones")
GEOJSON_SUFFIXES = (".json", ".geojson")
GEOJSON_GEOMETRIES = ("Point", "Polygon", "MultiPolygon")

Source = str | PathLike[str] | None


# -- parsing -----------------------------------------------------------------------------------------


class _Entry(NamedTuple):
    field: str
    lonlat: bool  # True: (a, b) = (lon, lat); False: (a, b) = (x, y)
    a: float
    b: float
    diameter: float
    top: float | None
    id: str | None
    floor: float | None = None
    margin: float = 0.0  # the zone is grown by this much all round (inflated)
    agl: tuple[float | None, float | None] = (None, None)  # floor_agl, top_agl


class _PolyEntry(NamedTuple):
    field: str  # the entry (danger_zones[2], features[1])
    lonlat: bool
    parts: list[list[FloatArray]]  # as given (open rings), lon/lat or map metres
    floor: float | None
    top: float | None
    id: str | None
    margin: float = 0.0
    agl: tuple[float | None, float | None] = (None, None)  # floor_agl, top_agl


_AnyEntry = _Entry | _PolyEntry


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


def _floor(value: Any, top: float | None, path: Source, field: str) -> float | None:
    if value is None:
        return None
    floor = _number(value, path, field, "a floor altitude in metres AMSL (or null for no floor)")
    if top is not None and not floor < top:
        raise InputError(
            f"{where(path, field)}expected a floor below the top ({top:g} m), found {_found(value)}"
        )
    return floor


def _agl(props: dict[str, Any], path: Source, field: str) -> tuple[float | None, float | None]:
    """``floor_agl`` and ``top_agl`` (metres above the ground; each or its AMSL twin)."""
    out: list[float | None] = []
    for name in ("floor_agl", "top_agl"):
        value = props.get(name)
        if value is not None and props.get(name.removesuffix("_agl")) is not None:
            raise InputError(
                f"{where(path, field)}give {name.removesuffix('_agl')} (m AMSL) or {name} "
                "(m above the ground), not both"
            )
        out.append(
            None
            if value is None
            else _number(value, path, f"{field}.{name}", "metres above the ground")
        )
    lo, hi = out
    if lo is not None and hi is not None and not lo < hi:
        raise InputError(
            f"{where(path, field)}floor_agl ({lo:g} m) must be below top_agl ({hi:g} m)"
        )
    return lo, hi


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


def _vertex(
    value: Any, path: Source, field: str, lonlat: bool, geojson: bool
) -> tuple[float, float]:
    sizes = (2, 3) if geojson else (2,)
    pair = "[lon, lat]" if lonlat else "[x, y]"
    if not isinstance(value, list | tuple) or len(value) not in sizes:
        raise InputError(f"{where(path, field)}expected a vertex {pair}, found {_found(value)}")
    if lonlat:
        lon = _number(value[0], path, f"{field}[0]", "a longitude in degrees")
        lat = _number(value[1], path, f"{field}[1]", "a latitude in degrees")
        if not -180.0 <= lon <= 180.0:
            raise InputError(
                f"{where(path, f'{field}[0]')}expected a longitude in [-180, 180], found {lon}"
            )
        if not -90.0 <= lat <= 90.0:
            raise InputError(
                f"{where(path, f'{field}[1]')}expected a latitude in [-90, 90], found {lat}"
            )
        return (lon, lat)
    return (
        _number(value[0], path, f"{field}[0]", "x in map metres"),
        _number(value[1], path, f"{field}[1]", "y in map metres"),
    )


def _ring(
    value: Any, path: Source, field: str, lonlat: bool, geojson: bool, label: str
) -> FloatArray:
    """One ring: YAML rings are open (a repeated closing vertex allowed), GeoJSON rings closed."""
    pair = "[lon, lat]" if lonlat else "[x, y]"
    if not isinstance(value, list | tuple):
        raise InputError(
            f"{where(path, field)}{label}expected a ring, a list of {pair} vertices, "
            f"found {_found(value)}"
        )
    ring = np.array(
        [_vertex(v, path, f"{field}[{i}]", lonlat, geojson) for i, v in enumerate(value)],
        dtype=np.float64,
    ).reshape(-1, 2)
    if geojson and ring.shape[0] >= 2 and not np.array_equal(ring[0], ring[-1]):
        first, last = ring[0].tolist(), ring[-1].tolist()
        raise InputError(
            f"{where(path, field)}{label}ring is not closed: its first position {first} and its "
            f"last {last} differ (a GeoJSON ring repeats its first position at the end)"
        )
    distinct = open_ring(ring)
    if distinct.shape[0] < 3:
        raise InputError(
            f"{where(path, field)}{label}expected a ring of at least 3 distinct vertices, "
            f"found {distinct.shape[0]}"
        )
    return distinct


def _check_polygon(parts: list[list[FloatArray]], path: Source, field: str, label: str) -> None:
    problem = polygon_problem(parts)
    if problem is not None:
        raise InputError(f"{where(path, field)}{label}not a valid polygon: {problem}")


def _yaml_part(part: dict[str, Any], path: Source, field: str) -> tuple[bool, list[FloatArray]]:
    """(lonlat, rings) of one YAML polygon part (an entry, or one item of its ``parts``)."""
    if "vertices" in part and "vertices_lonlat" in part:
        raise InputError(
            f"{where(path, field)}give vertices (map metres) or vertices_lonlat (degrees), not both"
        )
    if "vertices" not in part and "vertices_lonlat" not in part:
        raise InputError(
            f"{where(path, field)}missing 'vertices' (map metres) or 'vertices_lonlat' (degrees)"
        )
    lonlat = "vertices_lonlat" in part
    vkey, hkey, other = (
        ("vertices_lonlat", "holes_lonlat", "holes")
        if lonlat
        else ("vertices", "holes", "holes_lonlat")
    )
    if other in part:
        raise InputError(
            f"{where(path, f'{field}.{other}')}the holes of a polygon given by {vkey} are '{hkey}'"
        )
    rings = [_ring(part[vkey], path, f"{field}.{vkey}", lonlat, False, "")]
    holes = part.get(hkey, [])
    if holes is None:
        holes = []
    if not isinstance(holes, list | tuple):
        raise InputError(
            f"{where(path, f'{field}.{hkey}')}expected a list of rings, found {_found(holes)}"
        )
    for i, hole in enumerate(holes):
        rings.append(_ring(hole, path, f"{field}.{hkey}[{i}]", lonlat, False, ""))
    return lonlat, rings


def _yaml_polygon(entry: dict[str, Any], path: Source, field: str) -> _PolyEntry:
    unknown = [str(k) for k in entry if k not in POLYGON_KEYS]
    if unknown:
        raise InputError(
            f"{where(path, field)}unknown key(s) {', '.join(map(repr, unknown))}; "
            f"allowed for a polygon zone: {', '.join(POLYGON_KEYS)}"
        )
    if "parts" in entry:
        given = [k for k in PART_KEYS if k in entry]
        if given:
            raise InputError(
                f"{where(path, field)}give the rings in 'parts' or at the top of the zone, not "
                f"both; found parts and {', '.join(given)}"
            )
        items = entry["parts"]
        if not isinstance(items, list) or not items:
            raise InputError(
                f"{where(path, field + '.parts')}expected a non-empty list of "
                f"{{vertices, holes?}} mappings, found {_found(items)}"
            )
        kinds: list[bool] = []
        parts: list[list[FloatArray]] = []
        for i, item in enumerate(items):
            pfield = f"{field}.parts[{i}]"
            if not isinstance(item, dict):
                raise InputError(
                    f"{where(path, pfield)}expected a mapping {{vertices, holes?}}, "
                    f"found {_found(item)}"
                )
            bad = [str(k) for k in item if k not in PART_KEYS]
            if bad:
                raise InputError(
                    f"{where(path, pfield)}unknown key(s) {', '.join(map(repr, bad))}; "
                    f"allowed: {', '.join(PART_KEYS)}"
                )
            lonlat, rings = _yaml_part(item, path, pfield)
            kinds.append(lonlat)
            parts.append(rings)
        if len(set(kinds)) > 1:
            raise InputError(
                f"{where(path, field + '.parts')}give every part in map metres (vertices) or "
                "every part in degrees (vertices_lonlat), not a mix"
            )
        lonlat, check_field = kinds[0], field
    else:
        lonlat, rings = _yaml_part(entry, path, field)
        parts = [rings]
        simple = len(rings) == 1
        check_field = f"{field}.{'vertices_lonlat' if lonlat else 'vertices'}" if simple else field
    ident = _ident(entry.get("id"), path, f"{field}.id")
    _check_polygon(parts, path, check_field, f"zone {ident!r}: " if ident is not None else "")
    top = _top(entry.get("top"), path, f"{field}.top")
    floor = _floor(entry.get("floor"), top, path, f"{field}.floor")
    margin = _margin(entry.get("margin"), path, f"{field}.margin")
    return _PolyEntry(field, lonlat, parts, floor, top, ident, margin, _agl(entry, path, field))


def _yaml_entry(entry: Any, path: Source, field: str) -> _AnyEntry:
    if not isinstance(entry, dict):
        raise InputError(
            f"{where(path, field)}expected a mapping like {{x, y, diameter, top}}, "
            f"found {_found(entry)}"
        )
    polygon_keys = [k for k in ("vertices", "vertices_lonlat", "parts") if k in entry]
    if polygon_keys:
        centre_keys = [k for k in ("x", "y", "lon", "lat", "diameter") if k in entry]
        if centre_keys:
            raise InputError(
                f"{where(path, field)}a zone is a cylinder (centre and diameter) or a polygon "
                f"(vertices), not both; found {', '.join(centre_keys + polygon_keys)}"
            )
        return _yaml_polygon(entry, path, field)
    unknown = [str(k) for k in entry if k not in ZONE_KEYS]
    if unknown:
        raise InputError(
            f"{where(path, field)}unknown key(s) {', '.join(map(repr, unknown))}; "
            f"allowed: {', '.join(ZONE_KEYS)} (a polygon zone has vertices instead of a centre)"
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
    diameter = _size(entry, path, field)
    top = _top(entry.get("top"), path, f"{field}.top")
    floor = _floor(entry.get("floor"), top, path, f"{field}.floor")
    ident = _ident(entry.get("id"), path, f"{field}.id")
    margin = _margin(entry.get("margin"), path, f"{field}.margin")
    agl = _agl(entry, path, field)
    return _Entry(field, bool(has_ll), a, b, diameter, top, ident, floor, margin, agl)


def _size(entry: dict[str, Any], path: Source, field: str) -> float:
    """A cylinder's diameter from its ``diameter`` or its ``radius`` (one of them)."""
    if "diameter" in entry and "radius" in entry:
        raise InputError(f"{where(path, field)}give 'diameter' or 'radius', not both")
    if "diameter" in entry:
        return _diameter(entry["diameter"], path, f"{field}.diameter", "a diameter in metres > 0")
    if "radius" in entry:
        return 2.0 * _diameter(entry["radius"], path, f"{field}.radius", "a radius in metres > 0")
    raise InputError(f"{where(path, field)}missing 'diameter' (metres, > 0) or 'radius'")


def _margin(value: Any, path: Source, field: str) -> float:
    """An optional margin (metres >= 0; absent: 0)."""
    if value is None:
        return 0.0
    out = _number(value, path, field, "a margin in metres >= 0")
    if out < 0:
        raise InputError(f"{where(path, field)}expected a margin in metres >= 0, found {value!r}")
    return out


def _feature_ident(
    feature: dict[str, Any], props: dict[str, Any], path: Source, field: str
) -> str | None:
    given = feature_id(feature, props, field)
    return None if given is None else _ident(given[0], path, given[1])


def _geojson_polygon(
    feature: dict[str, Any],
    gtype: str,
    coords: Any,
    props: dict[str, Any],
    path: Source,
    field: str,
) -> _PolyEntry:
    ident = _feature_ident(feature, props, path, field)
    label = f"feature {ident!r}: " if ident is not None else ""
    cfield = f"{field}.geometry.coordinates"
    polygons = [coords] if gtype == "Polygon" else coords
    what = "a list of rings" if gtype == "Polygon" else "a list of polygons (lists of rings)"
    if not isinstance(polygons, list) or not polygons:
        raise InputError(f"{where(path, cfield)}{label}expected {what}, found {_found(coords)}")
    parts: list[list[FloatArray]] = []
    for i, poly in enumerate(polygons):
        pf = cfield if gtype == "Polygon" else f"{cfield}[{i}]"
        if not isinstance(poly, list) or not poly:
            raise InputError(
                f"{where(path, pf)}{label}expected a list of rings (exterior, then holes), "
                f"found {_found(poly)}"
            )
        parts.append([_ring(r, path, f"{pf}[{j}]", True, True, label) for j, r in enumerate(poly)])
    _check_polygon(parts, path, f"{field}.geometry", label)
    pfield = f"{field}.properties"
    top = _top(props.get("top"), path, f"{pfield}.top")
    floor = _floor(props.get("floor"), top, path, f"{pfield}.floor")
    margin = _margin(props.get("margin"), path, f"{pfield}.margin")
    return _PolyEntry(field, True, parts, floor, top, ident, margin, _agl(props, path, pfield))


def _geojson_entry(feature: Any, path: Source, field: str) -> _AnyEntry:
    if not isinstance(feature, dict) or feature.get("type") != "Feature":
        raise InputError(f"{where(path, field)}expected a GeoJSON Feature, found {_found(feature)}")
    geometry = feature.get("geometry")
    gtype = geometry.get("type") if isinstance(geometry, dict) else None
    if gtype not in GEOJSON_GEOMETRIES or not isinstance(geometry, dict):
        raise InputError(
            f"{where(path, field + '.geometry')}expected a Point, Polygon or MultiPolygon "
            f"geometry, found {_found(gtype if gtype is not None else geometry)}"
        )
    coords = geometry.get("coordinates")
    props = feature.get("properties")
    pfield = f"{field}.properties"
    if props is None:
        props = {}
    if not isinstance(props, dict):
        raise InputError(f"{where(path, pfield)}expected a mapping, found {_found(props)}")
    if gtype != "Point":
        return _geojson_polygon(feature, str(gtype), coords, props, path, field)
    cfield = f"{field}.geometry.coordinates"
    if not isinstance(coords, list) or len(coords) not in (2, 3):
        raise InputError(f"{where(path, cfield)}expected [lon, lat], found {_found(coords)}")
    lon = _number(coords[0], path, f"{cfield}[0]", "a longitude in degrees")
    lat = _number(coords[1], path, f"{cfield}[1]", "a latitude in degrees")
    _check_lonlat(lon, lat, path, cfield)
    diameter = _size(props, path, pfield)
    top = _top(props.get("top"), path, f"{pfield}.top")
    floor = _floor(props.get("floor"), top, path, f"{pfield}.floor")
    ident = _feature_ident(feature, props, path, field)
    margin = _margin(props.get("margin"), path, f"{pfield}.margin")
    agl = _agl(props, path, pfield)
    return _Entry(field, True, lon, lat, diameter, top, ident, floor, margin, agl)


def _to_map(
    entries: list[_AnyEntry], grid: HeightGrid | None, path: Source
) -> tuple[FloatArray, FloatArray, list[list[list[FloatArray]]]]:
    """Cylinder centres (xs, ys) and polygon rings of every entry in map metres (lon/lat
    converted with the grid); rings of cylinder entries are empty lists."""
    cyl = [e for e in entries if isinstance(e, _Entry)]
    xs = np.array([e.a if isinstance(e, _Entry) else np.nan for e in entries], dtype=np.float64)
    ys = np.array([e.b if isinstance(e, _Entry) else np.nan for e in entries], dtype=np.float64)
    rings: list[list[list[FloatArray]]] = [
        [list(p) for p in e.parts] if isinstance(e, _PolyEntry) else [] for e in entries
    ]
    lonlat = [e.lonlat for e in entries]
    if not any(lonlat):
        return xs, ys, rings
    first = entries[lonlat.index(True)]
    if grid is None or grid.crs is None:
        found = "no map grid" if grid is None else "a local grid without CRS"
        what = "centres" if isinstance(first, _Entry) else "vertices"
        raise InputError(
            f"{where(path, first.field)}lon/lat {what} need a georeferenced map, found "
            f"{found}; give {'x/y' if what == 'centres' else 'vertices'} in map metres instead"
        )
    # one conversion for everything: cylinder centres first, then every polygon vertex
    cyl_ll = np.array([e.lonlat for e in cyl], dtype=np.bool_)
    lon = [np.array([e.a for e in cyl])[cyl_ll]]
    lat = [np.array([e.b for e in cyl])[cyl_ll]]
    for e, r in zip(entries, rings, strict=True):
        if isinstance(e, _PolyEntry) and e.lonlat:
            for part in r:
                for ring in part:
                    lon.append(ring[:, 0])
                    lat.append(ring[:, 1])
    try:
        mx, my = grid.from_lonlat(np.concatenate(lon), np.concatenate(lat))
    except InputError as exc:
        raise InputError(f"{where(path, first.field)}{exc}") from exc
    cyl_rows = np.array(
        [i for i, e in enumerate(entries) if isinstance(e, _Entry) and e.lonlat], dtype=np.int64
    )
    n = cyl_rows.shape[0]
    xs[cyl_rows], ys[cyl_rows] = mx[:n], my[:n]
    at = n
    for e, r in zip(entries, rings, strict=True):
        if isinstance(e, _PolyEntry) and e.lonlat:
            for part in r:
                for j, ring in enumerate(part):
                    v = ring.shape[0]
                    part[j] = np.stack([mx[at : at + v], my[at : at + v]], axis=1)
                    at += v
    return xs, ys, rings


def _finish(entries: list[_AnyEntry], grid: HeightGrid | None, path: Source) -> tuple[Zone, ...]:
    """Convert lon/lat, check bounds and unique ids, build the zones."""
    xs, ys, rings = _to_map(entries, grid, path)
    if grid is not None and entries:
        bounds = ", ".join(f"{v:.3f}" for v in grid.bounds)
        xmin, ymin, xmax, ymax = grid.bounds
        for i, e in enumerate(entries):
            if isinstance(e, _Entry):
                if not bool(grid.contains(xs[i], ys[i])):
                    given = f"lon/lat ({e.a}, {e.b}) = map " if e.lonlat else ""
                    raise InputError(
                        f"{where(path, e.field)}centre {given}({xs[i]:.3f}, {ys[i]:.3f}) lies "
                        f"outside the map bounds (xmin, ymin, xmax, ymax) = ({bounds})"
                    )
                continue
            from shapely.geometry import box

            if not shapely_geometry(rings[i]).intersects(box(xmin, ymin, xmax, ymax)):
                raise InputError(
                    f"{where(path, e.field)}the polygon lies entirely outside the map bounds "
                    f"(xmin, ymin, xmax, ymax) = ({bounds})"
                )
    seen: dict[str, str] = {}
    for e in entries:
        if e.id is not None:
            if e.id in seen:
                raise InputError(
                    f"{where(path, e.field + '.id')}duplicate id {e.id!r} (also {seen[e.id]})"
                )
            seen[e.id] = e.field
    zones: list[Zone] = []
    # a limit above the ground follows the DEM's surface (bilinear) on a map
    ground = grid.height_at if grid is not None else None
    for i, e in enumerate(entries):
        zone: Zone
        fa, ta = e.agl
        if isinstance(e, _Entry):
            zone = DangerZone(
                float(xs[i]), float(ys[i]), e.diameter, e.top, e.id, e.floor, fa, ta, ground
            )
        else:
            try:
                zone = PolygonZone(
                    tuple(tuple(p) for p in rings[i]),  # type: ignore[arg-type]
                    e.floor,
                    e.top,
                    e.id,
                    fa,
                    ta,
                    ground,
                )
            except InputError as exc:  # valid in lon/lat, not once converted (a sliver): say so
                raise InputError(f"{where(path, e.field)}in map metres: {exc}") from exc
        zones.append(inflated(zone, e.margin))
    return tuple(zones)


def zones_from_records(
    records: Any,
    grid: HeightGrid | None = None,
    *,
    source: Source = None,
    field: str = "danger_zones",
) -> tuple[Zone, ...]:
    """Validate a list of zone mappings (as in a mission file's ``danger_zones:``).

    ``source`` and ``field`` only label error messages (``'mission.yaml', field
    'danger_zones[1].top': ...``).  With a ``grid``, lon/lat entries are converted, every centre
    must lie inside the map and every polygon must overlap it.
    """
    if not isinstance(records, list | tuple):
        raise InputError(
            f"{where(source, field)}expected a list of zones (use [] for none), "
            f"found {_found(records)}"
        )
    entries = [_yaml_entry(r, source, f"{field}[{i}]") for i, r in enumerate(records)]
    return _finish(entries, grid, source)


def zones_from_fields(
    records: Iterable[tuple[str, Any]], grid: HeightGrid | None = None, *, source: Source = None
) -> tuple[Zone, ...]:
    """Zones from records each labelled by the field it stands at in ``source``: a YAML-style
    mapping (as in ``danger_zones:``) or a GeoJSON Feature, as a mission file of another tool
    holds them (a ``.plan``'s geofence, a GeoJSON path's polygons)."""
    entries = [
        _geojson_entry(rec, source, fld)
        if isinstance(rec, dict) and rec.get("type") == "Feature"
        else _yaml_entry(rec, source, fld)
        for fld, rec in records
    ]
    return _finish(entries, grid, source) if entries else ()


def _ring_record(ring: Ring) -> list[list[float]]:
    return [[x, y] for x, y in ring]


def zones_to_records(zones: Iterable[Zone]) -> list[dict[str, Any]]:
    """Plain mappings (map metres) that read back to equal zones: ``{x, y, diameter, floor?,
    top?, id?}`` for a cylinder, ``{vertices, holes?, floor?, top?, id?}`` for a one-part polygon
    and ``{parts: [{vertices, holes?}, ...], floor?, top?, id?}`` for several parts."""
    out: list[dict[str, Any]] = []
    for z in zones:
        rec: dict[str, Any]
        if isinstance(z, DangerZone):
            rec = {"x": z.x, "y": z.y, "diameter": z.diameter}
        else:
            parts = []
            for part in z.parts:
                p: dict[str, Any] = {"vertices": _ring_record(part[0])}
                if len(part) > 1:
                    p["holes"] = [_ring_record(h) for h in part[1:]]
                parts.append(p)
            rec = parts[0] if len(parts) == 1 else {"parts": parts}
        for name in ("floor", "top", "floor_agl", "top_agl"):
            if getattr(z, name) is not None:
                rec[name] = getattr(z, name)
        if z.id is not None:
            rec["id"] = z.id
        out.append(rec)
    return out


def _lonlat_ring(
    ring: FloatArray, grid: HeightGrid, ccw: bool, digits: int | None
) -> list[list[float]]:
    """An open map-metre ring as a closed GeoJSON lon/lat ring in the asked orientation."""
    lon, lat = grid.to_lonlat(ring[:, 0], ring[:, 1])
    ll = np.stack([np.asarray(lon, dtype=np.float64), np.asarray(lat, dtype=np.float64)], axis=1)
    if digits is not None:
        ll = np.round(ll, digits)
    ll = orient(open_ring(ll), ccw)
    closed = np.concatenate([ll, ll[:1]], axis=0)
    return [[float(a), float(b)] for a, b in closed]


def zone_feature(
    zone: Zone,
    grid: HeightGrid,
    circles: Literal["points", "polygons"] = "points",
    n: int = 72,
    digits: int | None = None,
) -> dict[str, Any]:
    """One zone as a GeoJSON Feature (lon/lat, WGS84) with properties ``id``, ``kind``,
    ``floor``, ``top`` (null when unset) and, for a cylinder, ``diameter``.

    A polygon is a Polygon (or MultiPolygon) with closed rings, exteriors counter-clockwise and
    holes clockwise (RFC 7946).  A cylinder is a Point (``circles="points"``, which reads back as
    the same cylinder) or its circumscribed ``n``-gon (``"polygons"``, for tools that draw
    shapes).  ``digits`` rounds the degrees (8 digits is about a millimetre).
    """
    props: dict[str, Any] = {"id": zone.id, "kind": zone.kind, "floor": zone.floor, "top": zone.top}
    for name in ("floor_agl", "top_agl"):
        if getattr(zone, name) is not None:
            props[name] = getattr(zone, name)
    geometry: dict[str, Any]
    if isinstance(zone, DangerZone):
        props["diameter"] = zone.diameter
        if circles == "points":
            lon, lat = grid.to_lonlat(zone.x, zone.y)
            coords = [float(lon), float(lat)]
            if digits is not None:
                coords = [round(c, digits) for c in coords]
            geometry = {"type": "Point", "coordinates": coords}
        else:
            ring = _lonlat_ring(zone.outline(n)[0], grid, True, digits)
            geometry = {"type": "Polygon", "coordinates": [ring]}
    else:
        polys = [
            [
                _lonlat_ring(np.asarray(r, dtype=np.float64), grid, j == 0, digits)
                for j, r in enumerate(part)
            ]
            for part in zone.parts
        ]
        if len(polys) == 1:
            geometry = {"type": "Polygon", "coordinates": polys[0]}
        else:
            geometry = {"type": "MultiPolygon", "coordinates": polys}
    return {"type": "Feature", "geometry": geometry, "properties": props}


def zones_to_geojson(
    zones: Iterable[Zone],
    grid: HeightGrid,
    *,
    circles: Literal["points", "polygons"] = "points",
    n: int = 72,
) -> dict[str, Any]:
    """A GeoJSON FeatureCollection of the zones (WGS84 lon/lat; see :func:`zone_feature`).  With
    the default ``circles="points"`` it reads back with :func:`load_zones` to the same zones."""
    features = [zone_feature(z, grid, circles, n) for z in zones]
    return {"type": "FeatureCollection", "features": features}


def _read(path: Path) -> Any:
    return read_document(path, "a danger-zone file", GEOJSON_SUFFIXES)


def _load_geojson(data: Any, path: Path, grid: HeightGrid | None) -> tuple[Zone, ...]:
    features = geojson_features(data, path)
    entries = [_geojson_entry(f, path, f"features[{i}]") for i, f in enumerate(features)]
    return _finish(entries, grid, path)


def _load_document(data: Any, path: Path, grid: HeightGrid | None) -> tuple[Zone, ...]:
    data = check_header(data, path, "danger_zones", DOCUMENT_KEYS, "zones")
    return zones_from_records(data["danger_zones"], grid, source=path)


def load_zones(path: str | PathLike[str], grid: HeightGrid | None = None) -> tuple[Zone, ...]:
    """Read danger zones from a YAML or GeoJSON file (see the module docstring for the formats)."""
    p = Path(path)
    data = _read(p)
    is_doc = isinstance(data, dict) and "terrapath" in data
    if p.suffix.lower() in GEOJSON_SUFFIXES and not is_doc:
        return _load_geojson(data, p, grid)
    if isinstance(data, dict) and "type" in data and not is_doc:
        return _load_geojson(data, p, grid)
    return _load_document(data, p, grid)
