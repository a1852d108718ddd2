"""Airspace and UAS geozones from the files that publish them (issue 35), read into danger zones
(:mod:`terrain.zones`) on a map, with floors and tops referenced to sea level or to the ground.

- **OpenAir** (``.txt``/``.air``/``.openair``), read with ``aerofiles`` (a kept library, pure
  Python, that parses the standard and the extended format -- AC, AN, AL, AH, V X=/D=, DP, DA,
  DB, DC, AA -- and reports a bad record with its line, e.g. an arc with no centre). A record
  of one circle (DC) is a cylinder; any other outline (points, arcs) is a polygon, its arcs
  drawn every :data:`ARC_STEP_DEG` degrees round their centre (distances in nautical miles, on
  the local sphere: within a metre over the few miles of a control zone). Limits: ``SFC`` /
  ``GND`` (the ground: no floor), ``UNL`` (no top), ``FL95`` (pressure altitude, read on the
  standard atmosphere as 9,500 ft AMSL), ``1500ft`` / ``1500 ft AMSL`` / ``MSL`` (above sea
  level; feet unless ``m``), ``AGL`` / ``ASFC`` / ``AGND`` / ``SFC`` after a number (above the
  ground). Airways (DY) are refused with their line.
- **ED-269 JSON** (EUROCAE ED-269 "UAS geographical zones", the form in which states publish
  their geozones; the document itself is paid -- the fields followed are those of the published
  files and of the InterUSS geo-awareness test data, the same as ED-318's successor schema):
  ``features[]`` each with ``identifier``, ``name``, ``restriction``, ``applicability[]``
  (``permanent``, ``startDateTime``, ``endDateTime``) and ``geometry[]`` of ``uomDimensions``
  (``M`` / ``FT``), ``lowerLimit`` / ``upperLimit`` with ``lowerVerticalReference`` /
  ``upperVerticalReference`` (``AGL``, ``AMSL``, ``WGS84`` -- ellipsoid heights read as AMSL:
  the geoid's offset, within about 100 m, is not applied, and the report says so) and a
  ``horizontalProjection``: a GeoJSON ``Polygon`` (lon/lat) or a ``Circle`` (``center`` [lon,
  lat], ``radius`` in the unit of ``uomDimensions``). ``NO_RESTRICTION`` zones are skipped (they
  restrict nothing); the others (``PROHIBITED``, ``REQ_AUTHORISATION``, ``CONDITIONAL``) are kept
  out of. A feature may hold several geometries (zones ``ID``, ``ID#2``...).

**Time**: with a mission start (``start``, timezone-aware) and its duration, a zone applies
when one of its activations (OpenAir AA, ED-269 applicability) overlaps the flight; a permanent
zone always does; without a start every zone applies (the conservative reading). An ED-269
applicability's ``schedule`` (daily periods, as ED-318's ``DailyPeriod``: ``day`` a list of
``MON``..``SUN`` or ``ANY``, ``startTime`` / ``endTime`` times of day in UTC unless they carry an
offset, a period ending before it starts running past midnight) narrows its window to those
hours; a period bounded by a daylight event (``startEvent`` / ``endEvent``: sunrise, sunset,
civil twilight) is read as the whole of its day -- no solar ephemeris here -- and the report
says so.

Every problem is one line naming the file and the record (OpenAir: its line; ED-269: the feature
and field).
"""

from __future__ import annotations

import datetime as dt
import io
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from terrain.docfile import parse_json, read_text
from terrain.errors import DataFileError, InputError, where
from terrain.grid import HeightGrid
from terrain.zones import Zone

FT = 0.3048
NM = 1852.0
ARC_STEP_DEG = 2.0  # an OpenAir arc is drawn with a vertex every this many degrees
DEFAULT_FLIGHT_S = 6 * 3600.0  # the flight a start time covers when its duration is not known


@dataclass(frozen=True)
class Airspace:
    """The zones read from airspace files, and what the user should know about them (skipped
    records, references read approximately)."""

    zones: tuple[Zone, ...]
    notes: tuple[str, ...] = ()


# -- limits ------------------------------------------------------------------------------------


_LIMIT = re.compile(
    r"^\s*(?P<num>[-+]?\d+(?:\.\d+)?)\s*(?P<unit>ft|f|feet|m)?\s*"
    r"(?P<ref>amsl|msl|agl|asfc|agnd|gnd|sfc|aal)?\s*$",
    re.IGNORECASE,
)


def openair_limit(text: str) -> tuple[float | None, bool]:
    """(metres, above the ground?) of an OpenAir limit; (None, ...) for the ground or unlimited
    (module docstring). Raises ValueError with what was expected."""
    t = " ".join(str(text).split()).upper()
    if t in ("SFC", "GND", "SURFACE", "GROUND"):
        return None, True
    if t in ("UNL", "UNLIM", "UNLIMITED", "UNLTD"):
        return None, False
    fl = re.fullmatch(r"FL\s*(\d+(?:\.\d+)?)", t)
    if fl:
        return float(fl.group(1)) * 100.0 * FT, False
    m = _LIMIT.match(t)
    if not m:
        raise ValueError(
            f"altitude {text!r}: expected SFC/GND, UNL, FL95, or a height such as '1500ft AMSL' "
            "or '400ft AGL'"
        )
    value = float(m.group("num"))
    unit = (m.group("unit") or "FT").upper()
    metres = value if unit == "M" else value * FT
    ref = (m.group("ref") or "MSL").upper()
    return metres, ref in ("AGL", "ASFC", "AGND", "GND", "SFC")


def _record(floor: tuple[float | None, bool], top: tuple[float | None, bool]) -> dict[str, Any]:
    """The floor/top keys of a zone record from two (metres, above the ground?) limits."""
    rec: dict[str, Any] = {}
    (lo, lo_agl), (hi, hi_agl) = floor, top
    if lo is not None and not (lo_agl and lo <= 0.0):
        rec["floor_agl" if lo_agl else "floor"] = lo
    if hi is not None:
        rec["top_agl" if hi_agl else "top"] = hi
    return rec


# -- time ----------------------------------------------------------------------------------------


def _time(text: Any, label: str) -> dt.datetime | None:
    if text is None or text == "":
        return None
    try:
        t = dt.datetime.fromisoformat(str(text).replace("Z", "+00:00"))
    except ValueError:
        raise ValueError(f"{label} {text!r}: expected an ISO 8601 time") from None
    return t if t.tzinfo is not None else t.replace(tzinfo=dt.UTC)


def _applies(
    windows: Sequence[tuple[dt.datetime | None, dt.datetime | None]],
    start: dt.datetime | None,
    duration_s: float,
) -> bool:
    """Whether a zone active in ``windows`` (None ends: open) applies to a flight from
    ``start`` for ``duration_s``; no windows or no start: it applies."""
    if start is None or not windows:
        return True
    end = start + dt.timedelta(seconds=duration_s)
    for a, b in windows:
        if (a is None or a < end) and (b is None or b > start):
            return True
    return False


WEEKDAYS = ("MON", "TUE", "WED", "THU", "FRI", "SAT", "SUN")


def _time_of_day(text: Any, label: str) -> dt.timedelta:
    """A schedule's time of day as the offset from midnight UTC (``08:00``, ``08:00:00Z``,
    ``08:00:00.00+02:00``; ``24:00`` is the end of the day)."""
    raw = str(text).strip()
    if raw.startswith("24:00"):
        return dt.timedelta(hours=24)
    try:
        t = dt.time.fromisoformat(raw.replace("Z", "+00:00"))
    except ValueError:
        raise ValueError(f"{label} {text!r}: expected a time of day (HH:MM[:SS][Z])") from None
    off = t.utcoffset() or dt.timedelta(0)
    return dt.timedelta(hours=t.hour, minutes=t.minute, seconds=t.second) - off


def _scheduled(
    window: tuple[dt.datetime | None, dt.datetime | None],
    schedule: Any,
    start: dt.datetime,
    end: dt.datetime,
    notes: list[str],
    label: str,
) -> list[tuple[dt.datetime | None, dt.datetime | None]]:
    """The activations of one applicability with a daily ``schedule`` that fall in its window,
    over the days the flight ``start`` -> ``end`` spans (the day before too: a period past
    midnight)."""
    if not isinstance(schedule, list) or not schedule:
        raise ValueError(f"schedule: expected a list of daily periods, found {schedule!r:.60}")
    out: list[tuple[dt.datetime | None, dt.datetime | None]] = []
    first = start.astimezone(dt.UTC).date() - dt.timedelta(days=1)
    n_days = (end.astimezone(dt.UTC).date() - first).days + 1
    for k, period in enumerate(schedule):
        where_ = f"schedule[{k}]"
        if not isinstance(period, dict):
            raise ValueError(f"{where_}: expected a daily period (a mapping)")
        days = period.get("day", "ANY")
        days = [days] if isinstance(days, str) else days
        if not isinstance(days, list) or not all(
            str(d).upper() in (*WEEKDAYS, "ANY") for d in days
        ):
            raise ValueError(f"{where_}.day {days!r}: expected MON..SUN or ANY")
        wanted = {str(d).upper() for d in days}
        event = period.get("startEvent") or period.get("endEvent")
        if event:
            if not any("daylight event" in n for n in notes):
                notes.append(
                    f"{label}: a schedule bounded by a daylight event ({event}) is read as the "
                    "whole day (no sunrise/sunset computed)"
                )
            t0, t1 = dt.timedelta(0), dt.timedelta(hours=24)
        else:
            t0 = _time_of_day(period.get("startTime", "00:00"), f"{where_}.startTime")
            t1 = _time_of_day(period.get("endTime", "24:00"), f"{where_}.endTime")
            if t1 <= t0:
                t1 += dt.timedelta(hours=24)  # past midnight
        for d in range(n_days):
            day = first + dt.timedelta(days=d)
            if "ANY" not in wanted and WEEKDAYS[day.weekday()] not in wanted:
                continue
            midnight = dt.datetime.combine(day, dt.time(0), tzinfo=dt.UTC)
            a, b = midnight + t0, midnight + t1
            if window[0] is not None:
                a = max(a, window[0])
            if window[1] is not None:
                b = min(b, window[1])
            if a < b:
                out.append((a, b))
    return out


# -- OpenAir -------------------------------------------------------------------------------------


def _arc_points(
    center: Sequence[float], radius_nm: float, a0: float, a1: float, clockwise: bool
) -> list[list[float]]:
    """[lon, lat] points of an arc round ``center`` [lat, lon] from bearing ``a0`` to ``a1``
    (degrees from north, clockwise or not), every :data:`ARC_STEP_DEG`."""
    lat0, lon0 = float(center[0]), float(center[1])
    sweep = (a1 - a0) % 360.0 if clockwise else -((a0 - a1) % 360.0)
    if abs(sweep) < 1e-9:
        sweep = 360.0 if clockwise else -360.0
    n = max(2, int(math.ceil(abs(sweep) / ARC_STEP_DEG)) + 1)
    out = []
    for k in range(n):
        b = math.radians(a0 + sweep * k / (n - 1))
        dlat = radius_nm * math.cos(b) / 60.0
        dlon = radius_nm * math.sin(b) / (60.0 * math.cos(math.radians(lat0)))
        out.append([lon0 + dlon, lat0 + dlat])
    return out


def _bearing_nm(center: Sequence[float], point: Sequence[float]) -> tuple[float, float]:
    """(bearing in degrees, distance in nautical miles) from ``center`` to ``point`` ([lat, lon])."""
    lat0 = math.radians(float(center[0]))
    dn = (float(point[0]) - float(center[0])) * 60.0
    de = (float(point[1]) - float(center[1])) * 60.0 * math.cos(lat0)
    return math.degrees(math.atan2(de, dn)) % 360.0, math.hypot(dn, de)


def _openair_zone(rec: dict[str, Any]) -> dict[str, Any]:
    elements = rec.get("elements") or []
    if not elements:
        raise ValueError("no outline (DP, DA, DB or DC)")
    ring: list[list[float]] = []
    for e in elements:
        kind = e.get("type")
        if kind == "point":
            lat, lon = e["location"]
            ring.append([float(lon), float(lat)])
        elif kind == "circle":
            if len(elements) == 1:
                lat, lon = e["center"]
                return {"lon": float(lon), "lat": float(lat), "radius": float(e["radius"]) * NM}
            ring += _arc_points(e["center"], float(e["radius"]), 0.0, 360.0, True)
        elif kind == "arc":
            if "radius" in e:
                a0, a1, r = float(e["start"]), float(e["end"]), float(e["radius"])
                ring += _arc_points(e["center"], r, a0, a1, bool(e["clockwise"]))
            else:
                a0, r = _bearing_nm(e["center"], e["start"])
                a1, _ = _bearing_nm(e["center"], e["end"])
                ring += _arc_points(e["center"], r, a0, a1, bool(e["clockwise"]))
        else:
            raise ValueError(
                f"line {e.get('lineno', '?')}: {kind or 'an element'} is not read (airways are "
                "not zones here)"
            )
    out: list[list[float]] = []
    for p in ring:  # no repeated consecutive vertices (an arc starting where a point was)
        if not out or abs(out[-1][0] - p[0]) + abs(out[-1][1] - p[1]) > 1e-10:
            out.append(p)
    if len(out) > 3 and abs(out[0][0] - out[-1][0]) + abs(out[0][1] - out[-1][1]) < 1e-10:
        out.pop()
    return {"vertices_lonlat": out}


def _read_openair(path: Path, text: str, start: dt.datetime | None, duration_s: float) -> list[Any]:
    from aerofiles.openair import Reader

    records: list[tuple[str, dict[str, Any]]] = []
    for n, (rec, err) in enumerate(Reader(io.StringIO(text))):
        if err is not None:
            line = getattr(err, "lineno", "?")
            what = str(err)
            if "center" in what:
                what = f"{what}: an arc or circle with no centre (no 'V X=' before it)"
            raise InputError(f"{where(path)}line {line}: {what}")
        if rec.get("type") != "airspace":
            continue
        name = rec.get("name") or f"#{n}"
        label = f"airspace {name!r} (class {rec.get('class')})"
        try:
            zone = _openair_zone(rec)
            floor = openair_limit(rec.get("floor") or "SFC")
            top = openair_limit(rec.get("ceiling") or "UNL")
        except (ValueError, KeyError, TypeError) as exc:
            raise InputError(f"{where(path)}{label}: {exc}") from None
        windows = []
        for act in rec.get("activation") or rec.get("activations") or []:
            if isinstance(act, dict) and ("start" in act or "end" in act):
                try:
                    windows.append((_time(act.get("start"), "start"), _time(act.get("end"), "end")))
                except ValueError as exc:
                    raise InputError(f"{where(path)}{label}: {exc}") from None
        if not _applies(windows, start, duration_s):
            continue
        zone.update(_record(floor, top))
        zone["id"] = str(name)
        records.append((label, zone))
    return records


# -- ED-269 --------------------------------------------------------------------------------------


def _ed269_limit(
    geo: dict[str, Any], side: str, scale: float, fld: str, src: Path, notes: list[str]
) -> tuple[float | None, bool]:
    value = geo.get(f"{side}Limit")
    ref = str(geo.get(f"{side}VerticalReference") or "AMSL").upper()
    if value is None:
        return None, side == "lower"
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError(f"{where(src, f'{fld}.{side}Limit')}expected a number, found {value!r}")
    if ref not in ("AGL", "AMSL", "WGS84", "SFC"):
        raise InputError(
            f"{where(src, f'{fld}.{side}VerticalReference')}expected AGL, AMSL or WGS84, "
            f"found {ref!r}"
        )
    if ref == "WGS84" and not any("WGS84" in n for n in notes):
        notes.append(
            "WGS84 (ellipsoid) limits read as AMSL: the geoid's offset (within about 100 m) "
            "is not applied"
        )
    return float(value) * scale, ref in ("AGL", "SFC")


def _read_ed269(
    path: Path, data: Any, start: dt.datetime | None, duration_s: float, notes: list[str]
) -> list[Any]:
    features = data.get("features") if isinstance(data, dict) else data
    if not isinstance(features, list):
        raise DataFileError(f"{where(path, 'features')}expected a list of UAS geozones")
    records: list[tuple[str, dict[str, Any]]] = []
    for i, f in enumerate(features):
        fld = f"features[{i}]"
        if not isinstance(f, dict):
            raise InputError(f"{where(path, fld)}expected a geozone (a mapping)")
        if str(f.get("restriction", "")).upper() == "NO_RESTRICTION":
            continue
        ident = str(f.get("identifier") or f.get("name") or f"zone-{i}")
        windows: list[tuple[dt.datetime | None, dt.datetime | None]] = []
        for j, app in enumerate(f.get("applicability") or []):
            if not isinstance(app, dict) or str(app.get("permanent", "")).upper() == "YES":
                windows = []
                break
            try:
                window = (
                    _time(app.get("startDateTime"), "startDateTime"),
                    _time(app.get("endDateTime"), "endDateTime"),
                )
                if app.get("schedule") is None:
                    windows.append(window)
                elif start is not None:
                    end = start + dt.timedelta(seconds=duration_s)
                    active = _scheduled(window, app["schedule"], start, end, notes, ident)
                    # no activation in the flight's days: a window that cannot overlap
                    windows.extend(active or [(start - dt.timedelta(days=2), start)])
            except ValueError as exc:
                raise InputError(f"{where(path, f'{fld}.applicability[{j}]')}{exc}") from None
        if not _applies(windows, start, duration_s):
            continue
        geometries = f.get("geometry")
        if not isinstance(geometries, list) or not geometries:
            raise InputError(f"{where(path, fld + '.geometry')}expected a list of geometries")
        for k, geo in enumerate(geometries):
            gfld = f"{fld}.geometry[{k}]"
            if not isinstance(geo, dict):
                raise InputError(f"{where(path, gfld)}expected a mapping")
            uom = str(geo.get("uomDimensions") or "M").upper()
            if uom not in ("M", "FT"):
                raise InputError(
                    f"{where(path, gfld + '.uomDimensions')}expected M or FT, found {uom!r}"
                )
            scale = FT if uom == "FT" else 1.0
            floor = _ed269_limit(geo, "lower", scale, gfld, path, notes)
            top = _ed269_limit(geo, "upper", scale, gfld, path, notes)
            hp = geo.get("horizontalProjection")
            hfld = f"{gfld}.horizontalProjection"
            if not isinstance(hp, dict):
                raise InputError(f"{where(path, hfld)}expected a Polygon or a Circle")
            kind = hp.get("type")
            rec: dict[str, Any]
            if kind == "Circle":
                c, r = hp.get("center"), hp.get("radius")
                if not (isinstance(c, list) and len(c) >= 2) or not isinstance(r, int | float):
                    raise InputError(f"{where(path, hfld)}a Circle needs center [lon, lat], radius")
                rec = {"lon": float(c[0]), "lat": float(c[1]), "radius": float(r) * scale}
            elif kind == "Polygon":
                coords = hp.get("coordinates")
                if not isinstance(coords, list) or not coords or not isinstance(coords[0], list):
                    raise InputError(f"{where(path, hfld + '.coordinates')}expected rings")
                rec = {"vertices_lonlat": [list(map(float, p[:2])) for p in coords[0]]}
                if len(coords) > 1:
                    rec["holes_lonlat"] = [[list(map(float, p[:2])) for p in h] for h in coords[1:]]
            else:
                raise InputError(
                    f"{where(path, hfld + '.type')}expected Polygon or Circle, found {kind!r}"
                )
            rec.update(_record(floor, top))
            rec["id"] = ident if k == 0 else f"{ident}#{k + 1}"
            records.append((gfld, rec))
    return records


# -- files ---------------------------------------------------------------------------------------


def load_airspace(
    paths: Sequence[str | Path],
    grid: HeightGrid,
    *,
    start: dt.datetime | None = None,
    duration_s: float = DEFAULT_FLIGHT_S,
) -> Airspace:
    """The zones of every airspace file (OpenAir or ED-269 JSON, by content) that apply to a
    flight from ``start`` (module docstring), on ``grid`` (lon/lat converted; limits above the
    ground following its surface). Zones entirely off the map are left out and counted."""
    from shapely.geometry import box

    from terrain.zone_file import zones_from_fields

    zones: list[Zone] = []
    notes: list[str] = []
    seen: set[str] = set()
    for raw in paths:
        path = Path(raw)
        text = read_text(path, "an airspace file", encoding="utf-8-sig")
        if text.lstrip().startswith(("{", "[")):
            data = parse_json(text, path)
            records = _read_ed269(path, data, start, duration_s, notes)
        else:
            records = _read_openair(path, text, start, duration_s)
        near = []
        lon0, lat0, lon1, lat1 = grid.lonlat_bounds() or (-180.0, -90.0, 180.0, 90.0)
        area = box(lon0, lat0, lon1, lat1)
        for fld, rec in records:
            shape = _lonlat_shape(rec)
            if not shape.intersects(area):
                continue
            if "radius" in rec and not area.contains(shape.centroid):
                # a circle reaching onto the map from a centre off it: its outline instead
                ring = [list(c) for c in shape.exterior.coords[:-1]]
                rec = {k: v for k, v in rec.items() if k not in ("lon", "lat", "radius")}
                rec["vertices_lonlat"] = ring
            near.append((fld, rec))
        if len(near) < len(records):
            notes.append(f"{path.name}: {len(records) - len(near)} zone(s) off the map left out")
        for _fld, rec in near:  # ids unique (the judge names zones by them)
            ident, n = str(rec.get("id") or "airspace"), 2
            while ident in seen:
                ident, n = f"{rec.get('id') or 'airspace'}#{n}", n + 1
            seen.add(ident)
            rec["id"] = ident
        zones.extend(zones_from_fields(near, grid, source=str(path)))
    return Airspace(tuple(zones), tuple(notes))


def _lonlat_shape(rec: dict[str, Any]) -> Any:
    from shapely.geometry import Polygon

    if "vertices_lonlat" in rec:
        return Polygon(rec["vertices_lonlat"]).buffer(0)
    # the circle on the local sphere, circumscribed (72 sides, as a zone's outline)
    r = float(rec["radius"]) / 111_320.0 / math.cos(math.pi / 72)
    lat0 = float(rec["lat"])
    scale = max(math.cos(math.radians(lat0)), 0.05)
    ring = [
        (
            float(rec["lon"]) + r * math.sin(2 * math.pi * k / 72) / scale,
            lat0 + r * math.cos(2 * math.pi * k / 72),
        )
        for k in range(72)
    ]

    return Polygon(ring)


def parse_start(text: str) -> dt.datetime:
    """A mission start time: ISO 8601, UTC unless it names its offset."""
    try:
        t = _time(text, "start time")
    except ValueError as exc:
        raise InputError(str(exc)) from None
    if t is None:
        raise InputError("start time: expected an ISO 8601 time such as 2026-06-01T09:30Z")
    return t
