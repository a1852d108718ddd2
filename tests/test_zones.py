"""Danger-zone files: YAML and GeoJSON, map metres and lon/lat, and every validation message."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from terrain.errors import DataFileError, InputError, TerrapathError
from terrain.zone_file import (
    load_zones,
    zones_from_records,
    zones_to_geojson,
    zones_to_records,
)
from terrain.zones import DangerZone
from tests.conftest import X0, Y0  # the Big Tujunga corner of the utm_grid fixture


def write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def write_yaml(tmp_path: Path, zones: object, name: str = "zones.yaml") -> Path:
    return write(tmp_path, name, yaml.safe_dump({"terrapath": 1, "danger_zones": zones}))


def error_of(exc_type: type[Exception], *args: object) -> str:
    with pytest.raises(exc_type) as info:
        load_zones(*args)  # type: ignore[arg-type]
    msg = str(info.value)
    assert "\n" not in msg
    return msg


# -- the dataclass -----------------------------------------------------------------------------------


def test_dangerzone_fields_and_radius():
    z = DangerZone(1, 2, 500, 800, "sam")
    assert (z.x, z.y, z.diameter, z.top, z.id, z.radius) == (1.0, 2.0, 500.0, 800.0, "sam", 250.0)
    assert isinstance(z.x, float) and isinstance(z.top, float)
    assert DangerZone(0, 0, 1).top is None
    with pytest.raises(AttributeError):
        z.x = 5  # type: ignore[misc]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((0, 0, 0), "diameter must be > 0 metres; got 0.0"),
        ((0, 0, -5), "diameter must be > 0 metres; got -5.0"),
        ((math.nan, 0, 5), "x must be a finite number; got nan"),
        ((0, "a", 5), "y must be a finite number; got 'a'"),
        ((0, 0, 5, math.inf), "top must be a finite altitude or None; got inf"),
        ((0, 0, 5, None, 3), "id must be text or None; got 3"),
    ],
)
def test_dangerzone_validation(args, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        DangerZone(*args)


# -- YAML, map metres ------------------------------------------------------------------------------


def test_yaml_map_metres(tmp_path, local_grid):
    path = write(
        tmp_path,
        "zones.yaml",
        "terrapath: 1\nname: test\ndanger_zones:\n"
        "  - {x: 1000, y: 500, diameter: 500, top: 800}\n"
        "  - {x: 10.5, y: 20.25, diameter: 40, id: b}\n"
        "  - {x: 0, y: 1000, diameter: 1, top: null, id: 7}\n",
    )
    zones = load_zones(path, local_grid)
    assert zones == (
        DangerZone(1000.0, 500.0, 500.0, 800.0, None),
        DangerZone(10.5, 20.25, 40.0, None, "b"),
        DangerZone(0.0, 1000.0, 1.0, None, "7"),
    )
    assert load_zones(path) == zones  # no grid: no bounds check, same values


def test_empty_zone_list(tmp_path):
    assert load_zones(write_yaml(tmp_path, [])) == ()


def test_records_round_trip(tmp_path, local_grid):
    zones = (DangerZone(1.25, 2.5, 3.75, 4.125, "a"), DangerZone(100.1, 200.2, 0.3))
    records = zones_to_records(zones)
    assert records == [
        {"x": 1.25, "y": 2.5, "diameter": 3.75, "top": 4.125, "id": "a"},
        {"x": 100.1, "y": 200.2, "diameter": 0.3},
    ]
    assert zones_from_records(records, local_grid) == zones
    assert load_zones(write_yaml(tmp_path, records), local_grid) == zones


def test_zones_from_records_messages_name_source_and_field():
    with pytest.raises(InputError) as info:
        zones_from_records([{"x": 0, "y": 0, "diameter": -1}], source="mission.yaml")
    assert str(info.value) == (
        "'mission.yaml', field 'danger_zones[0].diameter': expected a diameter in metres > 0, "
        "found -1"
    )
    with pytest.raises(InputError, match=r"expected a list of zones \(use \[\] for none\), found"):
        zones_from_records({"x": 0}, source="mission.yaml")
    with pytest.raises(InputError, match=r"^field 'zones\[0\]': missing 'diameter'"):
        zones_from_records([{"x": 0, "y": 0}], field="zones")


# -- YAML, lon/lat ---------------------------------------------------------------------------------


def test_yaml_lonlat_converted_with_grid(tmp_path, utm_grid):
    cx, cy = X0 + 4500.0, Y0 - 4500.0
    lon, lat = utm_grid.to_lonlat(cx, cy)
    path = write_yaml(
        tmp_path,
        [{"lon": float(lon), "lat": float(lat), "diameter": 300, "top": 1500, "id": "sam"}],
    )
    (zone,) = load_zones(path, utm_grid)
    assert zone.x == pytest.approx(cx, abs=1e-6) and zone.y == pytest.approx(cy, abs=1e-6)
    assert (zone.diameter, zone.top, zone.id) == (300.0, 1500.0, "sam")
    assert -118.4 < lon < -118.2 and 34.2 < lat < 34.4


def test_lonlat_without_georeferenced_grid(tmp_path, local_grid):
    path = write_yaml(
        tmp_path, [{"x": 5, "y": 5, "diameter": 1}, {"lon": -118, "lat": 34, "diameter": 1}]
    )
    msg = error_of(InputError, path)
    assert msg.startswith(f"{str(path)!r}, field 'danger_zones[1]': ")
    assert "lon/lat centres need a georeferenced map, found no map grid" in msg
    msg = error_of(InputError, path, local_grid)
    assert "found a local grid without CRS; give x/y in map metres instead" in msg


# -- GeoJSON ---------------------------------------------------------------------------------------


def feature(lon, lat, **props):
    return {
        "type": "Feature",
        "geometry": {"type": "Point", "coordinates": [lon, lat]},
        "properties": props,
    }


def test_geojson_points(tmp_path, utm_grid):
    pts = [(X0 + 1000.0, Y0 - 1000.0), (X0 + 8000.0, Y0 - 7000.0)]
    lons, lats = utm_grid.to_lonlat([p[0] for p in pts], [p[1] for p in pts])
    doc = {
        "type": "FeatureCollection",
        "features": [
            feature(lons[0], lats[0], diameter=400, top=1200, name="north", fid=3),
            feature(lons[1], lats[1], radius=150),
        ],
    }
    doc["features"][1]["id"] = "f2"
    path = write(tmp_path, "zones.geojson", json.dumps(doc))
    zones = load_zones(path, utm_grid)
    assert [z.id for z in zones] == ["north", "f2"]
    assert [(z.diameter, z.top) for z in zones] == [(400.0, 1200.0), (300.0, None)]
    for z, (x, y) in zip(zones, pts, strict=True):
        assert z.x == pytest.approx(x, abs=1e-6) and z.y == pytest.approx(y, abs=1e-6)


def test_geojson_round_trip_and_sniffing(tmp_path, utm_grid):
    zones = (DangerZone(X0 + 100, Y0 - 200, 50, 900, "a"), DangerZone(X0 + 5000, Y0 - 5000, 800))
    doc = zones_to_geojson(zones, utm_grid)
    for name in ("z.geojson", "z.json", "z.yaml", "z.txt"):  # any extension: content decides
        back = load_zones(write(tmp_path, name, json.dumps(doc)), utm_grid)
        assert [(z.diameter, z.top, z.id) for z in back] == [
            (50.0, 900.0, "a"),
            (800.0, None, None),
        ]
        np.testing.assert_allclose(
            [[z.x, z.y] for z in back], [[z.x, z.y] for z in zones], atol=1e-6
        )


def test_terrapath_document_in_json_file(tmp_path):
    doc = {"terrapath": 1, "danger_zones": [{"x": 1, "y": 2, "diameter": 3}]}
    assert load_zones(write(tmp_path, "z.json", json.dumps(doc))) == (DangerZone(1, 2, 3),)


@pytest.mark.parametrize(
    ("mutate", "exc", "field", "expected"),
    [
        (
            lambda d: d.update(type="Feature"),
            DataFileError,
            "type",
            "expected a GeoJSON FeatureCollection, found 'Feature' (text)",
        ),
        (
            lambda d: d.update(features={}),
            DataFileError,
            "features",
            "expected a list, found {} (a mapping)",
        ),
        (
            lambda d: d["features"].append(5),
            InputError,
            "features[1]",
            "expected a GeoJSON Feature, found 5",
        ),
        (
            lambda d: d["features"][0]["geometry"].update(type="LineString"),
            InputError,
            "features[0].geometry",
            "expected a Point, Polygon or MultiPolygon geometry, found 'LineString' (text)",
        ),
        (
            lambda d: d["features"][0]["geometry"].update(coordinates=[1]),
            InputError,
            "features[0].geometry.coordinates",
            "expected [lon, lat], found [1] (a list)",
        ),
        (
            lambda d: d["features"][0]["geometry"].update(coordinates=["a", 3]),
            InputError,
            "features[0].geometry.coordinates[0]",
            "expected a longitude in degrees, found 'a' (text)",
        ),
        (
            lambda d: d["features"][0]["geometry"].update(coordinates=[10, 95]),
            InputError,
            "features[0].geometry.coordinates.lat",
            "expected degrees in [-90, 90], found 95.0",
        ),
        (
            lambda d: d["features"][0].update(properties={}),
            InputError,
            "features[0].properties",
            "missing 'diameter' (metres, > 0) or 'radius'",
        ),
        (
            lambda d: d["features"][0].update(properties={"diameter": 1, "radius": 1}),
            InputError,
            "features[0].properties",
            "give 'diameter' or 'radius', not both",
        ),
        (
            lambda d: d["features"][0].update(properties={"radius": -4}),
            InputError,
            "features[0].properties.radius",
            "expected a radius in metres > 0, found -4",
        ),
        (
            lambda d: d["features"][0].update(properties={"diameter": 5, "top": "high"}),
            InputError,
            "features[0].properties.top",
            "expected a top altitude in metres AMSL (or null for no top), found 'high' (text)",
        ),
    ],
)
def test_geojson_errors(tmp_path, utm_grid, mutate, exc, field, expected):
    lon, lat = utm_grid.to_lonlat(X0 + 100, Y0 - 100)
    doc = {"type": "FeatureCollection", "features": [feature(float(lon), float(lat), diameter=10)]}
    mutate(doc)
    path = write(tmp_path, "bad.geojson", json.dumps(doc))
    msg = error_of(exc, path, utm_grid)
    assert msg == f"{str(path)!r}, field {field!r}: {expected}"


def test_geojson_needs_georeferenced_grid(tmp_path, local_grid):
    doc = {"type": "FeatureCollection", "features": [feature(-118.2, 34.3, diameter=10)]}
    path = write(tmp_path, "z.geojson", json.dumps(doc))
    msg = error_of(InputError, path, local_grid)
    assert msg.startswith(
        f"{str(path)!r}, field 'features[0]': lon/lat centres need a georeferenced"
    )


def test_geojson_syntax_error_has_line(tmp_path):
    path = write(tmp_path, "z.geojson", '{"type": "FeatureCollection",\n "features": [,]}')
    msg = error_of(DataFileError, path)
    assert msg.startswith(f"{str(path)!r}: not valid JSON at line 2, column 15: ")


# -- file-level errors ----------------------------------------------------------------------------


def test_missing_file_and_folder(tmp_path):
    missing = tmp_path / "nope.yaml"
    assert (
        error_of(DataFileError, missing)
        == f"{str(missing)!r}: no such file (expected a danger-zone file)"
    )
    assert (
        error_of(DataFileError, tmp_path)
        == f"{str(tmp_path)!r}: is a folder, expected a danger-zone file"
    )
    with pytest.raises(OSError):  # DataFileError is an OSError for callers who do not know it
        load_zones(missing)


def test_not_utf8(tmp_path):
    path = tmp_path / "z.yaml"
    path.write_bytes(b"terrapath: 1\ndanger_zones: [\xff]\n")
    assert error_of(DataFileError, path).startswith(f"{str(path)!r}: not UTF-8 text")


def test_yaml_syntax_error_has_line_number(tmp_path):
    path = write(tmp_path, "z.yaml", "terrapath: 1\ndanger_zones:\n  - {x: 1, y: 2\n  - {x: 3}\n")
    msg = error_of(DataFileError, path)
    assert msg.startswith(f"{str(path)!r}: not valid YAML at line 4, column 5: ")


def test_yaml_uses_safe_loader(tmp_path):
    path = write(
        tmp_path, "z.yaml", "terrapath: 1\ndanger_zones: !!python/object/apply:os.getcwd []\n"
    )
    msg = error_of(DataFileError, path)
    assert msg.startswith(f"{str(path)!r}: not valid YAML at line 2, column 15: ")


@pytest.mark.parametrize(
    ("text", "field", "expected"),
    [
        (
            "",
            None,
            "expected a mapping with 'terrapath: 1' and 'danger_zones', found an empty file",
        ),
        (
            "- 1\n",
            None,
            "expected a mapping with 'terrapath: 1' and 'danger_zones', found a list",
        ),
        ("danger_zones: []\n", "terrapath", "missing format version key; expected 'terrapath: 1'"),
        ("terrapath: 2\ndanger_zones: []\n", "terrapath", "expected format version 1, found 2"),
        (
            "terrapath: true\ndanger_zones: []\n",
            "terrapath",
            "expected format version 1, found True (a boolean)",
        ),
        (
            "terrapath: '1'\ndanger_zones: []\n",
            "terrapath",
            "expected format version 1, found '1' (text)",
        ),
        ("terrapath: 1\n", "danger_zones", "missing; expected a list of zones"),
    ],
)
def test_document_errors(tmp_path, text, field, expected):
    path = write(tmp_path, "z.yaml", text)
    prefix = f"{str(path)!r}, field {field!r}: " if field else f"{str(path)!r}: "
    assert error_of(DataFileError, path) == prefix + expected


def test_unknown_top_level_key(tmp_path):
    path = write(tmp_path, "z.yaml", "terrapath: 1\ndanger_zones: []\nzones: []\n")
    assert error_of(InputError, path) == (
        f"{str(path)!r}: unknown key(s) 'zones'; allowed: terrapath, name, danger_zones"
    )


# -- entry-level errors ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("entry", "field", "expected"),
    [
        ({"x": 1, "y": 2, "diameter": 3, "colour": "red"}, "danger_zones[1]",
         "unknown key(s) 'colour'; allowed: x, y, lon, lat, diameter, radius, margin, floor, "
         "top, floor_agl, top_agl, id (a polygon zone has vertices instead of a centre)"),
        ({"x": 1, "y": 2, "diameter": 3, "radius": 1}, "danger_zones[1]",
         "give 'diameter' or 'radius', not both"),
        ({"x": 1, "diameter": 3}, "danger_zones[1]",
         "missing 'y'; a zone centre needs x and y (map metres) or lon and lat (degrees)"),
        ({"diameter": 3}, "danger_zones[1]",
         "missing 'x'; a zone centre needs x and y (map metres) or lon and lat (degrees)"),
        ({"lat": 34, "diameter": 3}, "danger_zones[1]",
         "missing 'lon'; a zone centre needs x and y (map metres) or lon and lat (degrees)"),
        ({"x": 1, "y": 2, "lon": -118, "diameter": 3}, "danger_zones[1]",
         "give the centre as x/y (map metres) or lon/lat (degrees), not both; found x, y, lon"),
        ({"x": "1", "y": 2, "diameter": 3}, "danger_zones[1].x", "expected a number, found '1' (text)"),
        ({"x": 1, "y": float("nan"), "diameter": 3}, "danger_zones[1].y", "expected a number, found nan"),
        ({"x": float("inf"), "y": 2, "diameter": 3}, "danger_zones[1].x", "expected a number, found inf"),
        ({"x": 1, "y": True, "diameter": 3}, "danger_zones[1].y", "expected a number, found True (a boolean)"),
        ({"x": 1, "y": 2}, "danger_zones[1]", "missing 'diameter' (metres, > 0) or 'radius'"),
        ({"x": 1, "y": 2, "diameter": -3}, "danger_zones[1].diameter", "expected a diameter in metres > 0, found -3"),
        ({"x": 1, "y": 2, "diameter": 0}, "danger_zones[1].diameter", "expected a diameter in metres > 0, found 0"),
        ({"x": 1, "y": 2, "diameter": None}, "danger_zones[1].diameter",
         "expected a diameter in metres > 0, found nothing (null)"),
        ({"x": 1, "y": 2, "diameter": 3, "top": "high"}, "danger_zones[1].top",
         "expected a top altitude in metres AMSL (or null for no top), found 'high' (text)"),
        ({"x": 1, "y": 2, "diameter": 3, "top": [1]}, "danger_zones[1].top",
         "expected a top altitude in metres AMSL (or null for no top), found [1] (a list)"),
        ({"x": 1, "y": 2, "diameter": 3, "id": [1]}, "danger_zones[1].id",
         "expected text or an integer, found [1] (a list)"),
        ({"lon": -200, "lat": 34, "diameter": 3}, "danger_zones[1].lon", "expected degrees in [-180, 180], found -200.0"),
        ({"x": 1, "y": 2, "diameter": 3, "id": "a"}, "danger_zones[1].id", "duplicate id 'a' (also danger_zones[0])"),
        ([1, 2, 3], "danger_zones[1]", "expected a mapping like {x, y, diameter, top}, found [1, 2, 3] (a list)"),
    ],
)  # fmt: skip
def test_entry_errors(tmp_path, entry, field, expected):
    path = write_yaml(tmp_path, [{"x": 0, "y": 0, "diameter": 1, "id": "a"}, entry])
    msg = error_of(InputError, path)
    assert msg == f"{str(path)!r}, field {field!r}: {expected}"


def test_yaml_nan_literal_refused(tmp_path):
    path = write(
        tmp_path, "z.yaml", "terrapath: 1\ndanger_zones:\n  - {x: .nan, y: 0, diameter: 1}\n"
    )
    assert error_of(InputError, path).endswith(
        "field 'danger_zones[0].x': expected a number, found nan"
    )


def test_centre_outside_map(tmp_path, local_grid, utm_grid):
    path = write_yaml(
        tmp_path, [{"x": 2000, "y": 0, "diameter": 1}, {"x": 2000.5, "y": 10, "diameter": 1}]
    )
    assert error_of(InputError, path, local_grid) == (
        f"{str(path)!r}, field 'danger_zones[1]': centre (2000.500, 10.000) lies outside the map "
        "bounds (xmin, ymin, xmax, ymax) = (0.000, 0.000, 2000.000, 1000.000)"
    )
    far = write_yaml(tmp_path, [{"lon": -100.0, "lat": 34.0, "diameter": 1}], "far.yaml")
    msg = error_of(InputError, far, utm_grid)
    assert msg.startswith(
        f"{str(far)!r}, field 'danger_zones[0]': centre lon/lat (-100.0, 34.0) = map ("
    )
    assert "lies outside the map bounds" in msg


def test_top_below_terrain_is_allowed(tmp_path, utm_grid):
    path = write_yaml(tmp_path, [{"x": X0 + 50, "y": Y0 - 50, "diameter": 10, "top": 100}])
    assert load_zones(path, utm_grid)[0].top == 100.0  # terrain is 800 m there


def test_all_errors_share_the_root(tmp_path):
    with pytest.raises(TerrapathError):
        load_zones(tmp_path / "missing.yaml")
    with pytest.raises(ValueError):
        load_zones(write_yaml(tmp_path, [{"x": 1, "y": 2, "diameter": -1}]))


def test_a_radius_instead_of_a_diameter_and_a_margin_that_grows_the_zone(tmp_path, local_grid):
    """Issue 20: YAML takes ``radius`` as GeoJSON does, and any zone a ``margin``: the zone is
    read grown by it (a cylinder's radius, its top up and its floor down; a polygon buffered)."""
    path = write_yaml(
        tmp_path,
        [
            {"x": 1000, "y": 500, "radius": 250, "id": "r"},
            {"x": 500, "y": 500, "radius": 100, "margin": 25, "top": 300, "floor": 100, "id": "m"},
            {"vertices": [[0, 0], [100, 0], [100, 100]], "margin": 10, "id": "p"},
        ],
    )
    r, m, p = load_zones(path, local_grid)
    assert r == DangerZone(1000.0, 500.0, 500.0, None, "r")
    assert m == DangerZone(500.0, 500.0, 250.0, 325.0, "m", 75.0)
    assert p.geometry.area == pytest.approx(5000.0 + 10.0 * (100 + 100 + 100 * math.sqrt(2))
                                            + math.pi * 100.0, rel=2e-3)  # fmt: skip
    # written back as the grown zone, and read back equal
    assert zones_from_records(zones_to_records((r, m, p)), local_grid) == (r, m, p)
    for entry, message in (
        ({"x": 0, "y": 0, "radius": 5, "diameter": 10}, "give 'diameter' or 'radius', not both"),
        ({"x": 0, "y": 0, "radius": -5}, r"radius': expected a radius in metres > 0, found -5"),
        ({"x": 0, "y": 0, "diameter": 5, "margin": -1}, r"margin': expected a margin in metres"),
        ({"x": 0, "y": 0, "diameter": 5, "margin": "wide"}, r"margin': expected a margin in"),
        ({"x": 0, "y": 0}, "missing 'diameter' \\(metres, > 0\\) or 'radius'"),
    ):
        with pytest.raises(InputError, match=message):
            zones_from_records([entry], source="zones.yaml")
