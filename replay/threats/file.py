"""The threat file (DESIGN §5): YAML or GeoJSON, validated at the edge into a :class:`~replay.threats.kinds.ThreatSet`.

A threat file is YAML (``yaml.safe_load`` only) with ``terrapath: 1``, an optional ``name`` and a
``threats:`` list (``DOCUMENT_KEYS``).  Every entry has a unique ``id`` (text, or an integer kept as
text), a ``kind`` (``KINDS``), ``appears_at`` (seconds after the start, default 0, >= 0) and an
optional ``disappears_at`` (> ``appears_at``) (``COMMON_KEYS``), and the keys of its kind
(``KIND_KEYS``; what each kind means: :mod:`replay.threats.kinds`, :mod:`replay.threats.body`).
Positions are map metres (x east, y north, z metres AMSL, :mod:`replay.frames`):

``static`` -- ``position: [x, y, z]`` and a safety ``radius`` R > 0 (or its ``diameter``, as for
    every size below: one of the two, as in a zones file); optional ``solid: true`` (a
    body the radar sees whole, centre and radius, instead of seed 000's point; default false).
``hill`` -- ``points: [[x, y, z], ...]`` and ``radius`` or ``diameter`` (one number for all
    points, or one per point).
``body`` -- ``center: [x0, y0, z0]``, ``axes: [a, b, c]``, ``exponents: [p, q, r]`` (seed 001 eq 3,
    each in ``EXPONENT_RANGE``).
``cylinder`` -- ``center: [x, y]``, ``radius``, ``top`` and optional ``bottom`` (default -inf).
``prism`` -- a building: ``footprint: [[x, y], ...]`` (map metres) or ``footprint_lonlat: [[lon,
    lat], ...]`` (degrees, converted vertex by vertex: edges are straight in map metres), ``top``
    and optional ``bottom``.  The footprint is one ring, open (a repeated closing vertex allowed),
    as a zones file's rings (:mod:`terrain.zone_file`), with at least 3 distinct vertices, no
    self-intersection (shapely's reason is given) and no holes (a list of rings is refused).
    ``bottom`` defaults to the ground: with a map grid, the lowest terrain under the footprint
    (:meth:`~terrain.grid.HeightGrid.lowest_under`; ``top`` must then be above it), without one
    -inf, as for a cylinder.
``intruder`` -- a safety ``radius`` and either ``position: [x, y, z]`` and ``velocity: [east, north,
    up]`` (m/s), optional ``stops_at``; or ``waypoints: [[x, y, z], ...]`` (>= 2) flown at ``speed``
    (m/s, > 0), optional ``loop: true``; optional ``solid`` as for ``static``.

``static``, ``body`` and ``intruder`` may give ``lon``, ``lat`` (WGS84 degrees) and ``alt`` (metres
AMSL) instead of ``position`` / ``center``, ``cylinder`` ``lon``, ``lat`` instead of ``center``, and
``prism`` ``footprint_lonlat`` instead of ``footprint``; they are converted with the map grid
(``HeightGrid.from_lonlat``), so lon/lat needs a georeferenced grid.  Hill points and intruder
waypoints are map metres only.

**GeoJSON** (a ``.json``/``.geojson`` file, or any file whose content is a mapping with ``type``
and no ``terrapath`` key, as for danger zones, :mod:`terrain.zone_file`): a FeatureCollection of
Polygon features (RFC 7946: lon/lat WGS84, closed rings, a third coordinate ignored), each a
``prism`` threat whose footprint is the polygon's exterior ring; properties ``id`` (else
``name``, else the feature's own ``id``; required), ``top`` (required), ``bottom``,
``appears_at`` and ``disappears_at`` with the meanings above, other properties ignored (GIS
tools add their own).  A polygon with holes, a MultiPolygon or any other geometry is refused
naming the feature.  Errors name the feature's fields (``features[3].properties.top``,
``features[3].geometry.coordinates[0]``).

Validation (:func:`load_threats`): unknown keys are refused listing the keys allowed for the kind;
missing fields, wrong types, NaN or infinite numbers, radii/axes/speeds <= 0, duplicate ids, an
intruder with neither or both of ``velocity`` and ``waypoints``, a bad footprint (above), and (with
a grid) positions or footprint vertices outside the map each raise a one-line error naming the
file and the field (``threats[2].radius``).  A missing, unreadable or structurally wrong file
raises :class:`DataFileError`, a bad field :class:`InputError`.

:func:`threats_from_records` validates the ``threats:`` list alone (a mission or a recorded run
carries one); :func:`threats_to_records` writes threats back as such a list.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from os import PathLike
from pathlib import Path
from typing import Any

from replay.threats.body import EXPONENT_RANGE, BodyThreat
from replay.threats.kinds import (
    CylinderThreat,
    HillThreat,
    IntruderThreat,
    PrismThreat,
    StaticThreat,
    Threat,
    ThreatSet,
    Vec3,
    footprint_ring,
)
from terrain.docfile import (
    check_header,
    feature_id,
    geojson_features,
    parse_yaml,
    read_document,
)
from terrain.docfile import found as _found
from terrain.errors import DataFileError, InputError, where
from terrain.grid import HeightGrid

DOCUMENT_KEYS = ("terrapath", "name", "threats")
KINDS = ("static", "hill", "body", "cylinder", "prism", "intruder")
COMMON_KEYS = ("id", "kind", "appears_at", "disappears_at")
KIND_KEYS: dict[str, tuple[str, ...]] = {
    "static": ("position", "lon", "lat", "alt", "radius", "diameter", "solid"),
    "hill": ("points", "radius", "diameter"),
    "body": ("center", "lon", "lat", "alt", "axes", "exponents"),
    "cylinder": ("center", "lon", "lat", "radius", "diameter", "top", "bottom"),
    "prism": ("footprint", "footprint_lonlat", "top", "bottom"),
    "intruder": (
        *("position", "lon", "lat", "alt", "velocity", "stops_at"),
        *("waypoints", "speed", "loop", "radius", "diameter", "solid"),
    ),
}

GEOJSON_SUFFIXES = (".json", ".geojson")
GEOJSON_PROPERTIES = ("id", "name", "top", "bottom", "appears_at", "disappears_at")

Source = str | PathLike[str] | None


def threats_to_records(threats: Iterable[Threat]) -> list[dict[str, Any]]:
    """Plain mappings (map metres) that :func:`threats_from_records` reads back to equal threats."""
    return [t.to_record() for t in threats]


# -- parsing ------------------------------------------------------------------------------------


class _FieldError(InputError):
    """An error the parser raised itself, already naming the file and the field."""


class _Parser:
    """Field-by-field validation of one file's threat records, with file/field messages."""

    def __init__(self, source: Source, grid: HeightGrid | None):
        self.source = source
        self.grid = grid

    def fail(self, field: str, message: str) -> InputError:
        return _FieldError(f"{where(self.source, field)}{message}")

    def number(self, value: Any, field: str, expected: str = "a number") -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(field, f"expected {expected}, found {_found(value)}")
        try:
            out = float(value)
        except OverflowError:
            out = math.inf
        if not math.isfinite(out):
            raise self.fail(field, f"expected {expected}, found {_found(value)}")
        return out

    def positive(self, value: Any, field: str, expected: str) -> float:
        out = self.number(value, field, expected)
        if out <= 0:
            raise self.fail(field, f"expected {expected}, found {_found(value)}")
        return out

    def vector(self, value: Any, field: str, n: int, expected: str) -> tuple[float, ...]:
        if not isinstance(value, list | tuple) or len(value) != n:
            raise self.fail(field, f"expected {expected}, found {_found(value)}")
        return tuple(self.number(v, f"{field}[{i}]") for i, v in enumerate(value))

    def point3(self, value: Any, field: str) -> Vec3:
        x, y, z = self.vector(value, field, 3, "[x, y, z] in map metres")
        self.inside(x, y, field)
        return (x, y, z)

    def point_list(self, value: Any, field: str, minimum: int) -> tuple[Vec3, ...]:
        if not isinstance(value, list | tuple) or len(value) < minimum:
            raise self.fail(
                field, f"expected a list of at least {minimum} [x, y, z], found {_found(value)}"
            )
        return tuple(self.point3(v, f"{field}[{i}]") for i, v in enumerate(value))

    def inside(self, x: float, y: float, field: str, given: str = "") -> None:
        if self.grid is not None and not bool(self.grid.contains(x, y)):
            bounds = ", ".join(f"{v:.3f}" for v in self.grid.bounds)
            raise self.fail(
                field,
                f"position {given}({x:.3f}, {y:.3f}) lies outside the map bounds "
                f"(xmin, ymin, xmax, ymax) = ({bounds})",
            )

    def located(self, entry: dict[str, Any], field: str, key: str, dims: int) -> tuple[float, ...]:
        """``key: [x, y(, z)]`` or ``lon, lat(, alt)`` converted with the grid."""
        ll_keys = ("lon", "lat", "alt") if dims == 3 else ("lon", "lat")
        ll = [k for k in ll_keys if k in entry]
        if key in entry and ll:
            raise self.fail(field, f"give '{key}' (map metres) or {'/'.join(ll_keys)}, not both")
        if not ll:
            if key not in entry:
                raise self.fail(
                    field, f"missing '{key}' (map metres) or {', '.join(ll_keys)} (degrees)"
                )
            if dims == 3:
                return self.point3(entry[key], f"{field}.{key}")
            xy = self.vector(entry[key], f"{field}.{key}", 2, "[x, y] in map metres")
            self.inside(xy[0], xy[1], f"{field}.{key}")
            return xy
        for k in ll_keys:
            if k not in entry:
                raise self.fail(
                    field, f"missing '{k}'; lon/lat positions need {', '.join(ll_keys)}"
                )
        x, y = self.lonlat(entry["lon"], entry["lat"], field, f"{field}.lon", f"{field}.lat")
        if dims == 3:
            return (x, y, self.number(entry["alt"], f"{field}.alt", "an altitude in metres AMSL"))
        return (x, y)

    def lonlat(
        self, lon_value: Any, lat_value: Any, field: str, lon_field: str, lat_field: str
    ) -> tuple[float, float]:
        """A WGS84 (lon, lat) in degrees as map (x, y), converted with the grid (which must be
        georeferenced) and inside the map."""
        lon = self.number(lon_value, lon_field, "a longitude in degrees")
        lat = self.number(lat_value, lat_field, "a latitude in degrees")
        if not -180.0 <= lon <= 180.0:
            raise self.fail(lon_field, f"expected degrees in [-180, 180], found {lon}")
        if not -90.0 <= lat <= 90.0:
            raise self.fail(lat_field, f"expected degrees in [-90, 90], found {lat}")
        if self.grid is None or self.grid.crs is None:
            found = "no map grid" if self.grid is None else "a local grid without CRS"
            raise self.fail(
                field, f"lon/lat positions need a georeferenced map, found {found}; use map metres"
            )
        mx, my = self.grid.from_lonlat(lon, lat)
        x, y = float(mx), float(my)
        self.inside(x, y, field, f"lon/lat ({lon}, {lat}) = map ")
        return (x, y)

    def entry(self, entry: Any, field: str) -> Threat:
        if not isinstance(entry, dict):
            raise self.fail(
                field, f"expected a mapping like {{id, kind, ...}}, found {_found(entry)}"
            )
        kind = entry.get("kind")
        if "kind" not in entry:
            raise self.fail(field, f"missing 'kind'; expected one of {', '.join(KINDS)}")
        if kind not in KINDS:
            raise self.fail(
                f"{field}.kind", f"expected one of {', '.join(KINDS)}, found {_found(kind)}"
            )
        allowed = COMMON_KEYS + KIND_KEYS[kind]
        unknown = [str(k) for k in entry if k not in allowed]
        if unknown:
            raise self.fail(
                field,
                f"unknown key(s) {', '.join(map(repr, unknown))} for kind {kind!r}; "
                f"allowed: {', '.join(allowed)}",
            )
        if "id" not in entry:
            raise self.fail(field, "missing 'id' (text, unique in the file)")
        common = self.common(entry["id"], f"{field}.id", entry, field)
        try:
            return getattr(self, f"_{kind}")(entry, field, common)
        except _FieldError:
            raise
        except InputError as exc:  # a constructor's own check: label it with the entry
            raise self.fail(field, str(exc)) from exc

    def common(self, ident: Any, id_field: str, times: dict[str, Any], at: str) -> dict[str, Any]:
        """The keys every threat has: the id and the activity window (``times``, its fields
        under ``at``)."""
        if isinstance(ident, bool) or not isinstance(ident, str | int) or ident == "":
            raise self.fail(id_field, f"expected text or an integer, found {_found(ident)}")
        common: dict[str, Any] = {"id": str(ident)}
        if times.get("appears_at") is not None:
            t0 = self.number(times["appears_at"], f"{at}.appears_at", "seconds >= 0")
            if t0 < 0:
                raise self.fail(f"{at}.appears_at", f"expected seconds >= 0, found {t0}")
            common["appears_at"] = t0
        if times.get("disappears_at") is not None:
            t1 = self.number(times["disappears_at"], f"{at}.disappears_at", "seconds")
            if t1 <= common.get("appears_at", 0.0):
                raise self.fail(
                    f"{at}.disappears_at",
                    f"expected a time after appears_at ({common.get('appears_at', 0.0):g} s), "
                    f"found {t1}",
                )
            common["disappears_at"] = t1
        return common

    def feature(self, feature: Any, field: str) -> Threat:
        """A GeoJSON Polygon feature as a prism (module docstring)."""
        if not isinstance(feature, dict) or feature.get("type") != "Feature":
            raise self.fail(field, f"expected a GeoJSON Feature, found {_found(feature)}")
        geometry = feature.get("geometry")
        gtype = geometry.get("type") if isinstance(geometry, dict) else None
        if gtype != "Polygon" or not isinstance(geometry, dict):
            hint = " (split a MultiPolygon into one feature per polygon)" * (
                gtype == "MultiPolygon"
            )
            raise self.fail(
                f"{field}.geometry",
                f"expected a Polygon geometry (a prism){hint}, "
                f"found {_found(gtype if gtype is not None else geometry)}",
            )
        props = feature.get("properties")
        if props is None:
            props = {}
        if not isinstance(props, dict):
            raise self.fail(f"{field}.properties", f"expected a mapping, found {_found(props)}")
        pfield = f"{field}.properties"
        given = feature_id(feature, props, field)
        if given is None:
            raise self.fail(pfield, "missing 'id' (or 'name', or the feature's own 'id')")
        common = self.common(given[0], given[1], props, pfield)
        cfield = f"{field}.geometry.coordinates"
        coords = geometry.get("coordinates")
        if not isinstance(coords, list) or not coords:
            raise self.fail(cfield, f"expected a list of rings, found {_found(coords)}")
        if len(coords) > 1:
            raise self.fail(
                cfield,
                f"feature {common['id']!r}: a prism's footprint has no holes; found "
                f"{len(coords) - 1} interior ring(s)",
            )
        ring = self.ring(coords[0], f"{cfield}[0]", True, (2, 3), closed=True)
        return self.prism(
            common,
            ring,
            f"{cfield}[0]",
            props.get("top"),
            props.get("bottom"),
            field,
            "properties.top",
        )

    def _require(self, entry: dict[str, Any], field: str, key: str, expected: str) -> Any:
        if key not in entry:
            raise self.fail(field, f"missing '{key}' ({expected})")
        return entry[key]

    def _size_key(self, entry: dict[str, Any], field: str) -> str:
        """Which of ``radius`` and ``diameter`` the entry gives (one of them, as for zones)."""
        if "radius" in entry and "diameter" in entry:
            raise self.fail(field, "give 'radius' or 'diameter', not both")
        if "diameter" in entry:
            return "diameter"
        if "radius" not in entry:
            raise self.fail(field, "missing 'radius' (metres, > 0) or 'diameter'")
        return "radius"

    def _radius(self, entry: dict[str, Any], field: str) -> float:
        """The safety radius, from ``radius`` or half the ``diameter``."""
        key = self._size_key(entry, field)
        r = self.positive(entry[key], f"{field}.{key}", f"a {key} in metres > 0")
        return r if key == "radius" else 0.5 * r

    def _flag(self, entry: dict[str, Any], field: str, key: str) -> bool:
        """An optional true/false key (default false)."""
        value = entry.get(key, False)
        if not isinstance(value, bool):
            raise self.fail(f"{field}.{key}", f"expected true or false, found {_found(value)}")
        return value

    def _static(self, entry: dict[str, Any], field: str, common: dict[str, Any]) -> Threat:
        c = self.located(entry, field, "position", 3)
        return StaticThreat(
            **common,
            center=(c[0], c[1], c[2]),
            radius=self._radius(entry, field),
            solid=self._flag(entry, field, "solid"),
        )

    def _hill(self, entry: dict[str, Any], field: str, common: dict[str, Any]) -> Threat:
        pts = self.point_list(
            self._require(entry, field, "points", "a list of [x, y, z]"), f"{field}.points", 1
        )
        key = self._size_key(entry, field)
        r = entry[key]
        if isinstance(r, list):
            if len(r) != len(pts):
                raise self.fail(
                    f"{field}.{key}",
                    f"expected one {key} or {len(pts)} (one per point), found {len(r)}",
                )
            sizes = tuple(
                self.positive(v, f"{field}.{key}[{i}]", f"a {key} in metres > 0")
                for i, v in enumerate(r)
            )
        else:
            sizes = (self.positive(r, f"{field}.{key}", f"a {key} in metres > 0"),)
        radii = sizes if key == "radius" else tuple(0.5 * d for d in sizes)
        return HillThreat(**common, points=pts, radii=radii)

    def _body(self, entry: dict[str, Any], field: str, common: dict[str, Any]) -> Threat:
        c = self.located(entry, field, "center", 3)
        raw = self._require(entry, field, "axes", "[a, b, c] semi-axes in metres")
        ax = self.vector(raw, f"{field}.axes", 3, "[a, b, c] semi-axes in metres > 0")
        for i, v in enumerate(ax):
            if v <= 0:
                raise self.fail(
                    f"{field}.axes[{i}]", f"expected a semi-axis in metres > 0, found {v}"
                )
        raw = self._require(entry, field, "exponents", "[p, q, r] of seed 001 eq 3")
        ex = self.vector(raw, f"{field}.exponents", 3, "[p, q, r] (seed 001 eq 3)")
        lo, hi = EXPONENT_RANGE
        for i, v in enumerate(ex):
            if not lo <= v <= hi:
                raise self.fail(
                    f"{field}.exponents[{i}]",
                    f"expected an exponent in [{lo}, {hi}] (convex body), found {v}",
                )
        return BodyThreat(
            **common,
            center=(c[0], c[1], c[2]),
            axes=(ax[0], ax[1], ax[2]),
            exponents=(ex[0], ex[1], ex[2]),
        )

    def _cylinder(self, entry: dict[str, Any], field: str, common: dict[str, Any]) -> Threat:
        c = self.located(entry, field, "center", 2)
        radius = self._radius(entry, field)
        top = self.number(
            self._require(entry, field, "top", "top altitude in metres AMSL"),
            f"{field}.top",
            "a top altitude in metres AMSL",
        )
        bottom = -math.inf
        if entry.get("bottom") is not None:
            bottom = self.number(entry["bottom"], f"{field}.bottom", "an altitude in metres AMSL")
            if bottom >= top:
                raise self.fail(f"{field}.bottom", f"expected below top ({top}), found {bottom}")
        return CylinderThreat(**common, center=(c[0], c[1]), radius=radius, top=top, bottom=bottom)

    def _prism(self, entry: dict[str, Any], field: str, common: dict[str, Any]) -> Threat:
        given = [k for k in ("footprint", "footprint_lonlat") if k in entry]
        if len(given) != 1:
            raise self.fail(
                field,
                "give 'footprint' (a ring [[x, y], ...] in map metres) or "
                "'footprint_lonlat' ([[lon, lat], ...] in degrees), "
                + ("not both" if given else "found neither"),
            )
        key = given[0]
        ring = self.ring(entry[key], f"{field}.{key}", key == "footprint_lonlat")
        return self.prism(
            common, ring, f"{field}.{key}", entry.get("top"), entry.get("bottom"), field, "top"
        )

    def ring(
        self,
        value: Any,
        field: str,
        lonlat: bool,
        dims: tuple[int, ...] = (2,),
        *,
        closed: bool = False,
    ) -> Any:
        """A prism footprint: a ring of [x, y] (``lonlat``: [lon, lat]; ``dims``: the sizes a
        position may have, a third coordinate being ignored) as map (x, y) tuples.  Open (a
        repeated closing vertex allowed) as in a zones file, or with ``closed`` (GeoJSON,
        RFC 7946) closed: its last position repeats its first."""
        pair = "[lon, lat]" if lonlat else "[x, y]"
        if (
            isinstance(value, list | tuple)
            and value
            and isinstance(value[0], list | tuple)
            and value[0]
            and isinstance(value[0][0], list | tuple)
        ):
            raise self.fail(
                field,
                f"expected one ring [{pair}, ...], found {len(value)} rings; a footprint has no "
                "holes (give the outer ring only, or one prism per part)",
            )
        if not isinstance(value, list | tuple) or len(value) < 2:
            what = (
                f"a closed ring [{pair}, ...] (last = first)" if closed else f"a ring [{pair}, ...]"
            )
            raise self.fail(field, f"expected {what}, found {_found(value)}")
        points: list[tuple[float, float]] = []
        for i, v in enumerate(value):
            at = f"{field}[{i}]"
            if not isinstance(v, list | tuple) or len(v) not in dims:
                raise self.fail(at, f"expected {pair}, found {_found(v)}")
            if lonlat:
                self.number(v[0], f"{at}[0]", "a longitude in degrees")
                self.number(v[1], f"{at}[1]", "a latitude in degrees")
            else:
                self.number(v[0], f"{at}[0]")
                self.number(v[1], f"{at}[1]")
        repeated = list(value[0][:2]) == list(value[-1][:2])
        if closed and not repeated:
            raise self.fail(
                field,
                f"expected a closed ring (the last position repeats the first, as GeoJSON "
                f"requires), found first {list(value[0][:2])} and last {list(value[-1][:2])}",
            )
        for i, v in enumerate(value[:-1] if repeated else value):
            at = f"{field}[{i}]"
            if lonlat:
                points.append(self.lonlat(v[0], v[1], at, f"{at}[0]", f"{at}[1]"))
            else:
                x, y = float(v[0]), float(v[1])
                self.inside(x, y, at)
                points.append((x, y))
        try:
            ring = footprint_ring(points, "the footprint")
        except InputError as exc:
            raise self.fail(field, str(exc).removeprefix("the footprint: ")) from None
        return ring

    def prism(
        self,
        common: dict[str, Any],
        ring: Any,
        ring_field: str,
        top_value: Any,
        bottom_value: Any,
        field: str,
        top_key: str,
    ) -> Threat:
        """A prism from a checked ring; ``top_key`` is the field that holds top and bottom
        (``top``, or ``properties.top`` in GeoJSON)."""
        at = top_key.removesuffix("top")
        if top_value is None:
            raise self.fail(field, f"missing '{top_key}' (top altitude in metres AMSL)")
        top = self.number(top_value, f"{field}.{top_key}", "a top altitude in metres AMSL")
        if bottom_value is not None:
            bottom = self.number(
                bottom_value, f"{field}.{at}bottom", "a bottom altitude in metres AMSL"
            )
            if bottom >= top:
                raise self.fail(
                    f"{field}.{at}bottom", f"expected below top ({top}), found {bottom}"
                )
        elif self.grid is not None:  # default: the ground under the footprint
            bottom = self.grid.lowest_under(ring)
            if bottom >= top:
                raise self.fail(
                    f"{field}.{top_key}",
                    f"expected above the ground under the footprint ({bottom:g} m, the default "
                    f"bottom), found {top}",
                )
        else:
            bottom = -math.inf
        try:
            return PrismThreat(**common, footprint=ring, top=top, bottom=bottom)
        except InputError as exc:
            raise self.fail(ring_field, str(exc)) from None

    def _intruder(self, entry: dict[str, Any], field: str, common: dict[str, Any]) -> Threat:
        has_v, has_w = "velocity" in entry, "waypoints" in entry
        if has_v == has_w:
            found = "both" if has_v else "neither"
            raise self.fail(
                field,
                f"an intruder needs 'velocity' (with 'position') or 'waypoints' (with 'speed'), "
                f"exactly one; found {found}",
            )
        radius = self._radius(entry, field)
        common = {**common, "solid": self._flag(entry, field, "solid")}
        if has_v:
            for key in ("speed", "loop"):
                if key in entry:
                    raise self.fail(f"{field}.{key}", "goes with 'waypoints', not 'velocity'")
            start = self.located(entry, field, "position", 3)
            v = self.vector(entry["velocity"], f"{field}.velocity", 3, "[east, north, up] m/s")
            stop = None
            if entry.get("stops_at") is not None:
                stop = self.number(entry["stops_at"], f"{field}.stops_at", "seconds")
                if stop < common.get("appears_at", 0.0):
                    raise self.fail(
                        f"{field}.stops_at", f"expected a time >= appears_at, found {stop}"
                    )
            return IntruderThreat(
                **common,
                radius=radius,
                start=(start[0], start[1], start[2]),
                velocity_mps=(v[0], v[1], v[2]),
                stops_at=stop,
            )
        for key in ("position", "lon", "lat", "alt", "stops_at"):
            if key in entry:
                raise self.fail(
                    f"{field}.{key}",
                    "goes with 'velocity'; a waypoint intruder starts at its first waypoint",
                )
        wps = self.point_list(entry["waypoints"], f"{field}.waypoints", 2)
        speed = self.positive(
            self._require(entry, field, "speed", "m/s along the waypoints, > 0"),
            f"{field}.speed",
            "a speed in m/s > 0",
        )
        loop = self._flag(entry, field, "loop")
        return IntruderThreat(**common, radius=radius, waypoints=wps, speed=speed, loop=loop)


def threats_from_records(
    records: Any,
    grid: HeightGrid | None = None,
    *,
    source: Source = None,
    field: str = "threats",
    name: str | None = None,
) -> ThreatSet:
    """Validate a list of threat mappings (a threat file's ``threats:``).  ``source`` and ``field``
    label error messages; with a ``grid``, lon/lat is converted and positions must lie on the map."""
    if not isinstance(records, list | tuple):
        raise InputError(
            f"{where(source, field)}expected a list of threats (use [] for none), "
            f"found {_found(records)}"
        )
    parser = _Parser(source, grid)
    return _collect(parser, [(f"{field}[{i}]", rec) for i, rec in enumerate(records)], name, False)


def _collect(
    parser: _Parser, items: list[tuple[str, Any]], name: str | None, geojson: bool
) -> ThreatSet:
    """Parse (field, entry) pairs (GeoJSON features with ``geojson``); ids must be unique."""
    threats: list[Threat] = []
    seen: dict[str, str] = {}
    for at, item in items:
        th = parser.feature(item, at) if geojson else parser.entry(item, at)
        if th.id in seen:
            raise parser.fail(f"{at}.id", f"duplicate id {th.id!r} (also {seen[th.id]})")
        seen[th.id] = at
        threats.append(th)
    source = parser.source
    return ThreatSet(tuple(threats), None if source is None else str(source), name)


def load_threats(path: str | PathLike[str], grid: HeightGrid | None = None) -> ThreatSet:
    """Read and validate a threat file, YAML or GeoJSON (see the module docstring)."""
    p = Path(path)
    data = read_document(p, "a threat file", GEOJSON_SUFFIXES)
    is_doc = isinstance(data, dict) and "terrapath" in data
    if not is_doc and (
        p.suffix.lower() in GEOJSON_SUFFIXES or (isinstance(data, dict) and "type" in data)
    ):
        return _load_geojson(data, p, grid)
    data = check_header(data, p, "threats", DOCUMENT_KEYS, "threats")
    name = data.get("name")
    if name is not None and not isinstance(name, str):
        raise InputError(f"{where(p, 'name')}expected text, found {_found(name)}")
    return threats_from_records(data["threats"], grid, source=p, name=name)


def recorded_text(path: str | PathLike[str], threats: ThreatSet) -> str:
    """The text a run records for the threat file ``path`` that gave ``threats``: the file itself
    when it is a terrapath YAML document (comments kept), else -- GeoJSON -- the YAML document of
    the threats (map metres, bottoms explicit), which reads back to equal threats."""
    import yaml

    text = Path(path).read_text(encoding="utf-8")
    try:
        data = parse_yaml(text, repr(str(path)))
    except DataFileError:
        data = None
    if isinstance(data, dict) and "terrapath" in data:
        return text
    doc = {"terrapath": 1, "name": threats.name, "threats": threats_to_records(threats)}
    return str(yaml.safe_dump(doc, sort_keys=False))


def _load_geojson(data: Any, path: Path, grid: HeightGrid | None) -> ThreatSet:
    features = geojson_features(data, path)
    name = data.get("name")
    parser = _Parser(path, grid)
    items = [(f"features[{i}]", f) for i, f in enumerate(features)]
    return _collect(parser, items, name if isinstance(name, str) else None, True)
