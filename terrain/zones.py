"""Danger zones: vertical cylinders and polygon prisms, validated when built.

Two kinds of zone (``Zone = DangerZone | PolygonZone``), both in map coordinates (metres of the
grid's projected CRS) and both with an optional ``floor`` and ``top`` altitude (metres AMSL; ``None``
means unbounded below / above; a floor or top at or below the terrain is allowed):

- :class:`DangerZone`, a vertical cylinder: centre (x, y) and diameter in metres;
- :class:`PolygonZone`, a vertical prism over a polygon: one or several parts (a GeoJSON
  MultiPolygon), each an exterior ring and optional holes.

A floor or a top may instead be given **above the ground** (``floor_agl``, ``top_agl``, metres;
issue 35: the UAS geozones of ED-269 and the OpenAir airspace limited "AGL"): a surface that
follows the terrain, evaluated under each point (a 120 m AGL ceiling over 2-4 km mountains is not
a 4,120 m flat top). Such a zone needs the terrain's surface, ``ground(x, y)`` (map metres ->
metres AMSL: the DEM's bilinear surface, :func:`with_ground`; the zone files bind it when they
are read on a map): :meth:`contains` and :meth:`separation` evaluate its limits under each point,
and :class:`terrain.zoneset.ZoneSet` measures the length inside it on segments sampled every
:data:`AGL_STEP_M`. Code that reads only ``floor`` and ``top`` (AMSL) sees such a zone unbounded
on that side -- the conservative reading (a ceiling above the ground read as no ceiling).

The files that hold them (YAML and GeoJSON, DESIGN §5) are read and written by
:mod:`terrain.zone_file`.

Polygons are checked with shapely (:func:`polygon_problem`): a ring that crosses itself, a hole
outside its exterior, overlapping parts and every other invalidity is refused with shapely's reason
(``Self-intersection[x y]``).  A polygon zone is stored normalised: rings open, without repeated
consecutive vertices, exteriors counter-clockwise and holes clockwise, each starting at its first
vertex as given; so the records written by :func:`terrain.zone_file.zones_to_records` read back to
an equal zone.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any, ClassVar, Literal, TypeAlias

import numpy as np
import numpy.typing as npt

from terrain.docfile import finite_number as _finite
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
Vertex = tuple[float, float]
Ring = tuple[Vertex, ...]
Part = tuple[Ring, ...]  # exterior ring, then holes
Ground = Callable[[npt.ArrayLike, npt.ArrayLike], FloatArray]
AGL_STEP_M = 25.0  # segments are sampled this often against a zone limited above the ground


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
    for name in ("floor_agl", "top_agl"):
        given = getattr(zone, name)
        if given is not None:
            value = _finite(given, f"{what} {name}")
            object.__setattr__(zone, name, value)
            if getattr(zone, name.removesuffix("_agl")) is not None:
                raise InputError(
                    f"{what}: give {name.removesuffix('_agl')} (m AMSL) or {name} (m above the "
                    "ground), not both"
                )
    fa, ta = zone.floor_agl, zone.top_agl
    if fa is not None and ta is not None and not fa < ta:
        raise InputError(f"{what} floor_agl ({fa:g} m) must be below its top_agl ({ta:g} m)")
    if zone.id is not None and not isinstance(zone.id, str):
        raise InputError(f"{what} id must be text or None; got {zone.id!r}")


def _prism_separation(horizontal: FloatArray, z: FloatArray, floor: Any, top: Any) -> FloatArray:
    """Signed distance to a vertical prism from the signed horizontal distance to its outline
    (negative inside) and the altitude: outside both ways the Euclidean combination, otherwise
    the larger of the two (negative inside: minus the depth)."""
    lo = -math.inf if floor is None else floor
    hi = math.inf if top is None else top
    dz = np.maximum(lo - z, z - hi)  # > 0 below the floor or above the top
    both = (horizontal > 0) & (dz > 0)
    return np.asarray(np.where(both, np.hypot(horizontal, dz), np.maximum(horizontal, dz)))


def limits(zone: Any, x: npt.ArrayLike, y: npt.ArrayLike) -> tuple[Any, Any]:
    """(floor, top) of ``zone`` under map points (x, y), metres AMSL: its own altitudes, or its
    heights above the ground on its ``ground`` surface; None where unbounded."""
    lo, hi = zone.floor, zone.top
    if zone.floor_agl is None and zone.top_agl is None:
        return lo, hi
    if zone.ground is None:
        raise InputError(
            f"zone {zone.id or '(no id)'} has a limit above the ground: it needs the terrain "
            "(read it on a map, or terrain.zones.with_ground)"
        )
    g = np.asarray(zone.ground(x, y), dtype=np.float64)
    if zone.floor_agl is not None:
        lo = g + zone.floor_agl
    if zone.top_agl is not None:
        hi = g + zone.top_agl
    return lo, hi


def with_ground(zone: Zone, ground: Ground | None) -> Zone:
    """``zone`` whose limits above the ground are evaluated on ``ground`` (unchanged if it has
    none)."""
    if zone.floor_agl is None and zone.top_agl is None:
        return zone
    return replace(zone, ground=ground)


def _vertical(z: npt.ArrayLike, floor: Any, top: Any) -> BoolArray:
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
    floor_agl: float | None = None
    top_agl: float | None = None
    ground: Ground | None = field(default=None, compare=False, repr=False)

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
        lo, hi = limits(self, xa, ya)
        return np.asarray((wx * wx + wy * wy <= r * r) & _vertical(za, lo, hi))

    def separation(self, points: npt.ArrayLike) -> FloatArray:
        """Signed distance (m) from map points (..., 3) to the zone's surface: negative inside
        (a limit above the ground: the vertical distance to it under the point)."""
        q = np.asarray(points, dtype=np.float64)
        horizontal = np.hypot(q[..., 0] - self.x, q[..., 1] - self.y) - self.radius
        lo, hi = limits(self, q[..., 0], q[..., 1])
        return _prism_separation(horizontal, q[..., 2], lo, hi)


def _ring_area(ring: FloatArray) -> float:
    """Signed area (shoelace; > 0 counter-clockwise) of an open ring, relative to its first
    vertex for precision in projected coordinates."""
    r = ring - ring[0]
    x, y = r[:, 0], r[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def open_ring(ring: FloatArray) -> FloatArray:
    """Drop repeated consecutive vertices and a repeated closing vertex."""
    keep = np.ones(ring.shape[0], dtype=np.bool_)
    keep[1:] = np.any(ring[1:] != ring[:-1], axis=1)
    r = ring[keep]
    while r.shape[0] > 1 and np.array_equal(r[0], r[-1]):
        r = r[:-1]
    return r


def orient(ring: FloatArray, ccw: bool) -> FloatArray:
    """The ring in the asked orientation, starting at the same vertex."""
    if (_ring_area(ring) > 0) != ccw:
        return np.concatenate([ring[:1], ring[:0:-1]], axis=0)
    return ring


def shapely_geometry(parts: Sequence[Sequence[npt.ArrayLike]]) -> Any:
    """The shapely Polygon (one part) or MultiPolygon of rings (each part an exterior then holes)."""
    from shapely.geometry import MultiPolygon, Polygon

    polys = [Polygon(part[0], list(part[1:])) for part in parts]
    return polys[0] if len(polys) == 1 else MultiPolygon(polys)


def polygon_problem(parts: Sequence[Sequence[npt.ArrayLike]]) -> str | None:
    """Why rings ((V, 2), open or closed; each part an exterior then holes) do not make a valid
    polygon (shapely's reason, e.g. ``Self-intersection[1 2]``), or None when they do."""
    from shapely.validation import explain_validity

    geometry = shapely_geometry(parts)
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
            arr = open_ring(arr)
            if arr.shape[0] < 3:
                raise InputError(
                    f"polygon zone ring {j} of part {i} needs at least 3 distinct vertices; "
                    f"got {arr.shape[0]}"
                )
            rings.append(orient(arr, ccw=(j == 0)))
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
    floor_agl: float | None = None
    top_agl: float | None = None
    ground: Ground | None = field(default=None, compare=False, repr=False)

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
        return shapely_geometry(self.parts)

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
        lo, hi = limits(self, xa, ya)
        vertical = _vertical(za, lo, hi)
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
        lo, hi = limits(self, q[..., 0], q[..., 1])
        return _prism_separation(horizontal, q[..., 2], lo, hi)


def keep_in_separation(fences: Sequence[Zone], points: npt.ArrayLike) -> FloatArray:
    """Signed distance (m) from map points (..., 3) to the boundary of the union of ``fences``
    (inclusion geofences): positive inside one of them, negative outside all -- the opposite
    sign of a danger zone's :meth:`separation`, so that leaving the fence reads as entering a
    no-fly volume."""
    q = np.asarray(points, dtype=np.float64)
    if not fences:
        return np.full(q.shape[:-1], np.inf)
    return np.asarray(np.max([-f.separation(q) for f in fences], axis=0))


OUTSIDE_FENCE_ID = "outside-geofence"  # the zone a mission's inclusion geofences leave open


def outside_of(
    fences: Sequence[Zone],
    bounds: tuple[float, float, float, float],
    *,
    id: str = OUTSIDE_FENCE_ID,
    n: int = 72,
) -> PolygonZone:
    """The no-fly zone that keeps a flight inside the union of the inclusion geofences
    ``fences`` (2-D, as a ``.plan`` gives them): the rectangle ``bounds`` (xmin, ymin, xmax,
    ymax; the map's, widened so that its edges lie off it) with the fences as holes.  Every
    consumer of danger zones -- the plan's cost, ``check``, the replay's judge and the avoiders'
    candidate legs -- then keeps inside the fences, and a message reads "enters zone
    outside-geofence".  A circular fence is the regular ``n``-gon inscribed in it (the allowed
    area never larger than the fence's)."""
    from shapely.geometry import Polygon, box
    from shapely.ops import unary_union

    if not fences:
        raise InputError("outside_of needs at least one inclusion geofence")
    shapes = []
    for f in fences:
        if isinstance(f, DangerZone):
            a = 2.0 * math.pi * np.arange(n) / n
            shapes.append(
                Polygon(np.stack([f.x + f.radius * np.cos(a), f.y + f.radius * np.sin(a)], 1))
            )
        else:
            shapes.append(f.geometry)
    allowed = unary_union(shapes)
    xmin, ymin, xmax, ymax = bounds
    fx0, fy0, fx1, fy1 = allowed.bounds
    pad = 0.05 * max(xmax - xmin, ymax - ymin, fx1 - fx0, fy1 - fy0, 1.0)
    outer = box(
        min(xmin, fx0) - pad, min(ymin, fy0) - pad, max(xmax, fx1) + pad, max(ymax, fy1) + pad
    )
    rest = outer.difference(allowed)
    polys = list(getattr(rest, "geoms", [rest]))
    parts = [
        [np.asarray(q.exterior.coords), *(np.asarray(h.coords) for h in q.interiors)]
        for q in polys
        if not q.is_empty
    ]
    return PolygonZone(tuple(parts), id=id)  # type: ignore[arg-type]


def inflated(zone: Zone, margin: float) -> Zone:
    """``zone`` grown by ``margin`` metres all round: wider, its top higher and its floor lower
    (a polygon is buffered with round joins, 16 segments a quarter circle). The planner keeps its
    paths out of the inflated zones, so the aircraft flying them keeps that margin."""
    if margin <= 0:
        return zone
    top = None if zone.top is None else zone.top + margin
    floor = None if zone.floor is None else zone.floor - margin
    floor_agl = None if zone.floor_agl is None else zone.floor_agl - margin
    top_agl = None if zone.top_agl is None else zone.top_agl + margin
    if isinstance(zone, DangerZone):
        return DangerZone(
            zone.x,
            zone.y,
            zone.diameter + 2 * margin,
            top,
            zone.id,
            floor,
            floor_agl,
            top_agl,
            zone.ground,
        )
    grown = zone.geometry.buffer(margin, quad_segs=16)
    polys = list(getattr(grown, "geoms", [grown]))
    parts = tuple(
        (
            tuple(poly.exterior.coords)[:-1],
            *(tuple(h.coords)[:-1] for h in poly.interiors),
        )
        for poly in polys
    )
    return PolygonZone(parts, floor, top, zone.id, floor_agl, top_agl, zone.ground)


def points_in_polygon_xy(zone: PolygonZone, x: npt.ArrayLike, y: npt.ArrayLike) -> BoolArray:
    """Whether map points lie inside a polygon zone's outline, whatever the altitude."""
    from terrain.prisms import points_in_edges

    xa = np.asarray(x, dtype=np.float64)
    ya = np.asarray(y, dtype=np.float64)
    return np.asarray(points_in_edges(xa, ya, zone.edges), dtype=np.bool_)


Zone: TypeAlias = DangerZone | PolygonZone
