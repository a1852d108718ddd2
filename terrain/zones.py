"""Danger zones: vertical cylinders and polygon prisms read from YAML or GeoJSON, validated at the edge.

Two kinds of zone (``Zone = DangerZone | PolygonZone``), both in map coordinates (metres of the
grid's projected CRS) and both with an optional ``floor`` and ``top`` altitude (metres AMSL; ``None``
means unbounded below / above; a floor or top at or below the terrain is allowed):

- :class:`DangerZone`, a vertical cylinder: centre (x, y) and diameter in metres;
- :class:`PolygonZone`, a vertical prism over a polygon: one or several parts (a GeoJSON
  MultiPolygon), each an exterior ring and optional holes.

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
  zone grown by that much all round (:func:`inflated`: wider, its top higher, its floor lower),
  which is what is stored and written back.  Other properties are ignored, since GIS tools add their own (``fid`` ...).  A GeoJSON
  ring must be closed (its last position repeats its first): a ring that is not is refused,
  naming the feature.

Polygons are checked with shapely: a ring that crosses itself, a hole outside its exterior,
overlapping parts and every other invalidity is refused with shapely's reason (``Self-intersection
[x y]``, in the coordinates of the file) and the field of the feature.  Lon/lat vertices are
converted one by one: edges are straight lines in map metres.  A polygon zone is stored
normalised: rings open, without repeated consecutive vertices, exteriors counter-clockwise and
holes clockwise, each starting at its first vertex as given; so the records written by
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
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import cached_property
from os import PathLike
from pathlib import Path
from typing import Any, ClassVar, Literal, NamedTuple, TypeAlias

import numpy as np
import numpy.typing as npt

from terrain.docfile import (
    check_header,
    feature_id,
    geojson_features,
    read_document,
)
from terrain.docfile import finite_number as _finite
from terrain.docfile import found as _found
from terrain.errors import InputError, where
from terrain.grid import HeightGrid

ZONE_KEYS = ("x", "y", "lon", "lat", "diameter", "radius", "margin", "floor", "top", "id")
POLYGON_KEYS = (
    "vertices",
    "vertices_lonlat",
    "holes",
    "holes_lonlat",
    "parts",
    "margin",
    "floor",
    "top",
    "id",
)
PART_KEYS = ("vertices", "vertices_lonlat", "holes", "holes_lonlat")
DOCUMENT_KEYS = ("terrapath", "name", "danger_zones")
GEOJSON_SUFFIXES = (".json", ".geojson")
GEOJSON_GEOMETRIES = ("Point", "Polygon", "MultiPolygon")

Source = str | PathLike[str] | None
FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
Vertex = tuple[float, float]
Ring = tuple[Vertex, ...]
Part = tuple[Ring, ...]  # exterior ring, then holes


def _altitudes(zone: Any, what: str) -> None:
    """Validate and convert ``floor`` and ``top`` (finite or None, floor below top) in place."""
    for name in ("floor", "top"):
        given = getattr(zone, name)
        if given is not None:
            try:
                value = float(given)
            except (TypeError, ValueError, OverflowError):
                value = math.nan
            if isinstance(given, bool) or not math.isfinite(value):
                raise InputError(f"{what} {name} must be a finite altitude or None; got {given!r}")
            object.__setattr__(zone, name, value)
    if zone.floor is not None and zone.top is not None and not zone.floor < zone.top:
        raise InputError(f"{what} floor ({zone.floor:g} m) must be below its top ({zone.top:g} m)")
    if zone.id is not None and not isinstance(zone.id, str):
        raise InputError(f"{what} id must be text or None; got {zone.id!r}")


def _prism_separation(
    horizontal: FloatArray, z: FloatArray, floor: float | None, top: float | None
) -> FloatArray:
    """Signed distance to a vertical prism from the signed horizontal distance to its outline
    (negative inside) and the altitude: outside both ways the Euclidean combination, otherwise
    the larger of the two (negative inside: minus the depth)."""
    lo = -math.inf if floor is None else floor
    hi = math.inf if top is None else top
    dz = np.maximum(lo - z, z - hi)  # > 0 below the floor or above the top
    both = (horizontal > 0) & (dz > 0)
    return np.asarray(np.where(both, np.hypot(horizontal, dz), np.maximum(horizontal, dz)))


def _vertical(z: npt.ArrayLike, floor: float | None, top: float | None) -> BoolArray:
    za = np.asarray(z, dtype=np.float64)
    ok = np.ones(za.shape, dtype=np.bool_)
    if top is not None:
        ok &= za <= top
    if floor is not None:
        ok &= za >= floor
    return ok


@dataclass(frozen=True)
class DangerZone:
    """A vertical cylinder: centre (x, y) map metres, diameter m, top and floor m AMSL or None
    (unbounded).  ``floor`` is the last field so that ``DangerZone(x, y, diameter, top, id)``
    keeps its meaning."""

    x: float
    y: float
    diameter: float
    top: float | None = None
    id: str | None = None
    floor: float | None = None

    kind: ClassVar[Literal["cylinder"]] = "cylinder"

    def __post_init__(self) -> None:
        for name in ("x", "y", "diameter"):
            given = getattr(self, name)
            object.__setattr__(self, name, _finite(given, f"danger zone {name}"))
        if self.diameter <= 0:
            raise InputError(f"danger zone diameter must be > 0 metres; got {self.diameter}")
        _altitudes(self, "danger zone")

    @property
    def radius(self) -> float:
        return self.diameter / 2.0

    @property
    def size(self) -> float:
        """The zone's size in metres, the normaliser d of F_dangerzones = min(1, L_inside / d):
        the diameter (seed 002)."""
        return self.diameter

    @property
    def centroid(self) -> tuple[float, float]:
        """The centre (x, y), map metres."""
        return (self.x, self.y)

    def outline(self, n: int = 72) -> list[FloatArray]:
        """The circle as one open (n, 2) ring, counter-clockwise, map metres: the regular n-gon
        circumscribed about it (its edges touch the circle), so the outline contains the zone."""
        if n < 3:
            raise InputError(f"an outline needs n >= 3 vertices; got {n}")
        r = self.radius / math.cos(math.pi / n)
        a = 2.0 * math.pi * np.arange(n) / n
        return [np.stack([self.x + r * np.cos(a), self.y + r * np.sin(a)], axis=1)]

    def contains(self, x: npt.ArrayLike, y: npt.ArrayLike, z: npt.ArrayLike) -> BoolArray:
        """Whether points (x, y, z) (broadcast together) lie in the closed cylinder."""
        xa, ya, za = np.broadcast_arrays(
            np.asarray(x, dtype=np.float64),
            np.asarray(y, dtype=np.float64),
            np.asarray(z, dtype=np.float64),
        )
        wx, wy = xa - self.x, ya - self.y
        r = self.radius
        return np.asarray((wx * wx + wy * wy <= r * r) & _vertical(za, self.floor, self.top))

    def separation(self, points: npt.ArrayLike) -> FloatArray:
        """Signed distance (m) from map points (..., 3) to the zone's surface: negative inside."""
        q = np.asarray(points, dtype=np.float64)
        horizontal = np.hypot(q[..., 0] - self.x, q[..., 1] - self.y) - self.radius
        return _prism_separation(horizontal, q[..., 2], self.floor, self.top)


def _ring_area(ring: FloatArray) -> float:
    """Signed area (shoelace; > 0 counter-clockwise) of an open ring, relative to its first
    vertex for precision in projected coordinates."""
    r = ring - ring[0]
    x, y = r[:, 0], r[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _open_ring(ring: FloatArray) -> FloatArray:
    """Drop repeated consecutive vertices and a repeated closing vertex."""
    keep = np.ones(ring.shape[0], dtype=np.bool_)
    keep[1:] = np.any(ring[1:] != ring[:-1], axis=1)
    r = ring[keep]
    while r.shape[0] > 1 and np.array_equal(r[0], r[-1]):
        r = r[:-1]
    return r


def _orient(ring: FloatArray, ccw: bool) -> FloatArray:
    """The ring in the asked orientation, starting at the same vertex."""
    if (_ring_area(ring) > 0) != ccw:
        return np.concatenate([ring[:1], ring[:0:-1]], axis=0)
    return ring


def _shapely(parts: Sequence[Sequence[npt.ArrayLike]]) -> Any:
    from shapely.geometry import MultiPolygon, Polygon

    polys = [Polygon(part[0], list(part[1:])) for part in parts]
    return polys[0] if len(polys) == 1 else MultiPolygon(polys)


def polygon_problem(parts: Sequence[Sequence[npt.ArrayLike]]) -> str | None:
    """Why rings ((V, 2), open or closed; each part an exterior then holes) do not make a valid
    polygon (shapely's reason, e.g. ``Self-intersection[1 2]``), or None when they do."""
    from shapely.validation import explain_validity

    geometry = _shapely(parts)
    if geometry.is_valid:
        return None
    return str(explain_validity(geometry))


def _normalise_parts(parts: Any) -> tuple[Part, ...]:
    if isinstance(parts, str | bytes) or not isinstance(parts, Sequence) or len(parts) == 0:
        raise InputError(
            "polygon zone parts must be a non-empty list of parts, each a list of rings "
            f"(exterior, then holes); got {parts!r:.60}"
        )
    arrays: list[list[FloatArray]] = []
    for i, part in enumerate(parts):
        if isinstance(part, str | bytes) or not isinstance(part, Sequence) or len(part) == 0:
            raise InputError(
                f"polygon zone part {i} must be a non-empty list of rings; got {part!r:.60}"
            )
        rings: list[FloatArray] = []
        for j, ring in enumerate(part):
            try:
                arr = np.asarray(ring, dtype=np.float64)
            except (TypeError, ValueError):
                arr = np.zeros((0,))
            if arr.ndim != 2 or arr.shape[1] != 2 or not np.isfinite(arr).all():
                raise InputError(
                    f"polygon zone ring {j} of part {i} must be a list of finite (x, y) "
                    f"vertices; got {ring!r:.60}"
                )
            arr = _open_ring(arr)
            if arr.shape[0] < 3:
                raise InputError(
                    f"polygon zone ring {j} of part {i} needs at least 3 distinct vertices; "
                    f"got {arr.shape[0]}"
                )
            rings.append(_orient(arr, ccw=(j == 0)))
        arrays.append(rings)
    problem = polygon_problem(arrays)
    if problem is not None:
        raise InputError(f"polygon zone is not a valid polygon: {problem}")
    return tuple(
        tuple(tuple((float(v[0]), float(v[1])) for v in ring) for ring in rings) for rings in arrays
    )


@dataclass(frozen=True)
class PolygonZone:
    """A vertical prism over a polygon: ``parts`` in map metres, each an exterior ring then its
    holes (rings are sequences of (x, y) vertices); ``floor`` and ``top`` m AMSL or None
    (unbounded).  Stored normalised (see the module docstring), so equal shapes compare equal.

    Build one from a ring with :meth:`from_vertices`.
    """

    parts: tuple[Part, ...]
    floor: float | None = None
    top: float | None = None
    id: str | None = None

    kind: ClassVar[Literal["polygon"]] = "polygon"

    def __post_init__(self) -> None:
        object.__setattr__(self, "parts", _normalise_parts(self.parts))
        _altitudes(self, "polygon zone")

    @classmethod
    def from_vertices(
        cls,
        vertices: npt.ArrayLike,
        holes: Iterable[npt.ArrayLike] = (),
        *,
        floor: float | None = None,
        top: float | None = None,
        id: str | None = None,
    ) -> PolygonZone:
        """A one-part polygon zone from its exterior ring (and holes), map metres."""
        parts: Any = ((vertices, *holes),)  # normalised (and checked) by __post_init__
        return cls(parts, floor, top, id)

    @cached_property
    def rings(self) -> list[FloatArray]:
        """Every ring of every part as an open (V, 2) array, map metres."""
        return [np.array(ring, dtype=np.float64) for part in self.parts for ring in part]

    @cached_property
    def edges(self) -> FloatArray:
        """(E, 4) x0, y0, x1, y1 of every edge of every ring."""
        from terrain.prisms import ring_edges

        return np.concatenate([ring_edges(r) for r in self.rings], axis=0)

    @cached_property
    def geometry(self) -> Any:
        """The shapely Polygon (or MultiPolygon) in map metres."""
        return _shapely(self.parts)

    @property
    def area(self) -> float:
        """Horizontal area, m² (holes excluded)."""
        return float(self.geometry.area)

    @property
    def size(self) -> float:
        """The zone's size in metres, the normaliser d of F_dangerzones = min(1, L_inside / d):
        the diameter of the circle of equal area, 2 sqrt(A / pi).  Chosen so that a polygon
        approximating a circle costs what the circle costs, and so that the size depends on the
        zone alone (not on the direction it is crossed in)."""
        return 2.0 * math.sqrt(self.area / math.pi)

    @property
    def centroid(self) -> tuple[float, float]:
        """The area centroid (x, y), map metres (it may lie outside a concave zone)."""
        c = self.geometry.centroid
        return (float(c.x), float(c.y))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax), map metres."""
        xmin, ymin, xmax, ymax = self.geometry.bounds
        return (float(xmin), float(ymin), float(xmax), float(ymax))

    def outline(self, n: int = 72) -> list[FloatArray]:
        """The exterior ring of each part, open (V, 2) arrays, counter-clockwise, map metres
        (``n`` is for circles and ignored here)."""
        return [np.array(part[0], dtype=np.float64) for part in self.parts]

    def contains(self, x: npt.ArrayLike, y: npt.ArrayLike, z: npt.ArrayLike) -> BoolArray:
        """Whether points (x, y, z) (broadcast together) lie in the closed prism (the even-odd
        rule of :mod:`terrain.prisms`, so this agrees with the segment lengths)."""
        from terrain.prisms import points_in_edges

        xa, ya, za = np.broadcast_arrays(
            np.asarray(x, dtype=np.float64),
            np.asarray(y, dtype=np.float64),
            np.asarray(z, dtype=np.float64),
        )
        vertical = _vertical(za, self.floor, self.top)
        out = np.zeros(xa.shape, dtype=np.bool_)
        if vertical.any():
            out[vertical] = points_in_edges(xa[vertical], ya[vertical], self.edges)
        return out

    def separation(self, points: npt.ArrayLike) -> FloatArray:
        """Signed distance (m) from map points (..., 3) to the prism's surface: negative inside
        (the horizontal distance to the outline from shapely, its sign from :meth:`contains`)."""
        import shapely

        q = np.asarray(points, dtype=np.float64)
        flat = q.reshape(-1, 3)
        boundary = self.geometry.boundary
        d = shapely.distance(shapely.points(flat[:, 0], flat[:, 1]), boundary)
        inside = points_in_polygon_xy(self, flat[:, 0], flat[:, 1])
        horizontal = np.where(inside, -d, d).reshape(q.shape[:-1])
        return _prism_separation(horizontal, q[..., 2], self.floor, self.top)


def inflated(zone: Zone, margin: float) -> Zone:
    """``zone`` grown by ``margin`` metres all round: wider, its top higher and its floor lower
    (a polygon is buffered with round joins, 16 segments a quarter circle). The planner keeps its
    paths out of the inflated zones, so the aircraft flying them keeps that margin."""
    if margin <= 0:
        return zone
    top = None if zone.top is None else zone.top + margin
    floor = None if zone.floor is None else zone.floor - margin
    if isinstance(zone, DangerZone):
        return DangerZone(zone.x, zone.y, zone.diameter + 2 * margin, top, zone.id, floor)
    grown = zone.geometry.buffer(margin, quad_segs=16)
    polys = list(getattr(grown, "geoms", [grown]))
    parts = tuple(
        (
            tuple(poly.exterior.coords)[:-1],
            *(tuple(h.coords)[:-1] for h in poly.interiors),
        )
        for poly in polys
    )
    return PolygonZone(parts, floor, top, zone.id)


def points_in_polygon_xy(zone: PolygonZone, x: npt.ArrayLike, y: npt.ArrayLike) -> BoolArray:
    """Whether map points lie inside a polygon zone's outline, whatever the altitude."""
    from terrain.prisms import points_in_edges

    xa = np.asarray(x, dtype=np.float64)
    ya = np.asarray(y, dtype=np.float64)
    return np.asarray(points_in_edges(xa, ya, zone.edges), dtype=np.bool_)


Zone: TypeAlias = DangerZone | PolygonZone


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


class _PolyEntry(NamedTuple):
    field: str  # the entry (danger_zones[2], features[1])
    lonlat: bool
    parts: list[list[FloatArray]]  # as given (open rings), lon/lat or map metres
    floor: float | None
    top: float | None
    id: str | None
    margin: float = 0.0


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
    distinct = _open_ring(ring)
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
    return _PolyEntry(field, lonlat, parts, floor, top, ident, margin)


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
    return _Entry(field, bool(has_ll), a, b, diameter, top, ident, floor, margin)


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
    return _PolyEntry(field, True, parts, floor, top, ident, margin)


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
    return _Entry(field, True, lon, lat, diameter, top, ident, floor, margin)


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

            if not _shapely(rings[i]).intersects(box(xmin, ymin, xmax, ymax)):
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
    for i, e in enumerate(entries):
        zone: Zone
        if isinstance(e, _Entry):
            zone = DangerZone(float(xs[i]), float(ys[i]), e.diameter, e.top, e.id, e.floor)
        else:
            try:
                zone = PolygonZone(tuple(tuple(p) for p in rings[i]), e.floor, e.top, e.id)  # type: ignore[arg-type]
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
        if z.floor is not None:
            rec["floor"] = z.floor
        if z.top is not None:
            rec["top"] = z.top
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
    ll = _orient(_open_ring(ll), ccw)
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
