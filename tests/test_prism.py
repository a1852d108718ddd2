"""The ``prism`` threat kind (a building): exact separation and nearest point, the threat file's
footprint rules (closed ring, >= 3 vertices, simple, no holes), the ground as default bottom,
GeoJSON buildings, and every consumer of a threat's shape (recorder, cooperative sensor, view,
picture, a replay's separation metric)."""

from __future__ import annotations

import json
import math
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from rasterio.crs import CRS

from replay.record.messages import normalize_threat
from replay.record.scene import prism_mesh
from replay.run import ReplayRequest, run_replay
from replay.sensors.cooperative import CooperativeSensor
from replay.source import recorded_threats
from replay.threats.file import load_threats, recorded_text, threats_from_records
from replay.threats.kinds import CylinderThreat, PrismThreat, footprint_ring
from terrain.errors import InputError
from terrain.zones import PolygonZone
from tests.conftest import make_grid

ROOT = Path(__file__).resolve().parents[1]
MISSION = ROOT / "data" / "scenarios" / "seed004-mission.yaml"

SQUARE = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]
# an L: the notch is the square (10..20, 10..20), its reflex corner at (10, 10)
ELL = [(0.0, 0.0), (20.0, 0.0), (20.0, 10.0), (10.0, 10.0), (10.0, 20.0), (0.0, 20.0)]

X0, Y0 = 400_000.0, 3_800_000.0  # top-left corner of a 10 km UTM 11N test grid, 100 m cells
XC, YC = X0 + 5000.0, Y0 - 5000.0
CENTRE = np.array([XC, YC])


def closed(ring: list[tuple[float, float]], dx: float = 0.0, dy: float = 0.0) -> list[list[float]]:
    pts = [[x + dx, y + dy] for x, y in ring]
    return [*pts, pts[0]]


def write(tmp_path: Path, text: str, name: str = "threats.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    return path


def sloped_grid() -> Any:
    """Heights rising 1 m per 100 m cell eastwards and 0.5 m per cell southwards, from 50 m."""
    r, c = np.mgrid[0:100, 0:100]
    return make_grid(50.0 + c + 0.5 * r, cell=100.0, x0=X0, y0=Y0, crs=CRS.from_epsg(32611))


# -- geometry -------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("point", "expected"),
    [
        ((15.0, 5.0, 10.0), 5.0),  # outside an edge
        ((13.0, 14.0, 10.0), 5.0),  # outside a corner: hypot(3, 4)
        ((5.0, 5.0, 10.0), -5.0),  # inside, at the centre: minus the distance to every wall
        ((2.0, 5.0, 10.0), -2.0),  # inside, nearer one wall
        ((5.0, 5.0, 19.0), -1.0),  # inside, nearer the top than any wall
        ((5.0, 5.0, 25.0), 5.0),  # above the top
        ((5.0, 5.0, 0.0), 5.0),  # below the bottom
        ((13.0, 14.0, 24.0), math.hypot(5.0, 4.0)),  # beyond a corner and above the top
        ((10.0, 5.0, 12.0), 0.0),  # on a wall
    ],
)
def test_square_separation_is_exact(point: tuple[float, float, float], expected: float) -> None:
    th = PrismThreat(id="b", footprint=SQUARE, top=20.0, bottom=5.0)
    assert float(th.separation(point)) == pytest.approx(expected, abs=1e-12)


def test_concave_corner_of_an_l_shape() -> None:
    th = PrismThreat(id="l", footprint=ELL, top=30.0, bottom=0.0)
    pts = np.array(
        [
            [25.0, -5.0, 10.0],  # beyond an outer corner
            [16.0, 14.0, 10.0],  # in the notch: the inner wall y = 10 is nearest
            [12.0, 15.0, 10.0],  # in the notch, beside the inner wall x = 10
            [9.0, 9.0, 10.0],  # inside, by the reflex corner: sqrt(2) from it
            [5.0, 15.0, 10.0],  # inside the upright
            [15.0, 5.0, 10.0],  # inside the foot
        ]
    )
    np.testing.assert_allclose(
        th.separation(pts), [math.sqrt(50.0), 4.0, 2.0, -math.sqrt(2.0), -5.0, -5.0], atol=1e-12
    )
    np.testing.assert_allclose(
        th.nearest_point(pts),
        [[20.0, 0.0, 10.0], [16.0, 10.0, 10.0], [10.0, 15.0, 10.0], *pts[3:].tolist()],
        atol=1e-12,
    )
    # the centroid of the L (area 300): (100 * 5 + 100 * 15 + 100 * 5, ...) / 300 on each axis
    assert th.centroid == pytest.approx((25.0 / 3.0, 25.0 / 3.0))
    np.testing.assert_allclose(th.position(), [25.0 / 3.0, 25.0 / 3.0, 30.0])


def test_a_fine_regular_polygon_separates_like_the_cylinder() -> None:
    n, r = 720, 100.0
    a = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    ring = np.c_[XC + r * np.cos(a), YC + r * np.sin(a)]
    prism = PrismThreat(id="p", footprint=ring, top=300.0, bottom=100.0)
    cylinder = CylinderThreat(id="c", center=(XC, YC), radius=r, top=300.0, bottom=100.0)
    rng = np.random.default_rng(3)
    q = np.c_[rng.uniform(-250, 250, (5000, 2)) + CENTRE, rng.uniform(0, 400, 5000)]
    sagitta = r * (1.0 - math.cos(math.pi / n))  # the most the polygon lies inside the circle
    diff = prism.separation(q) - cylinder.separation(q)
    assert diff.min() >= -1e-9 and diff.max() <= sagitta + 1e-9
    # a nearest point may slide along an edge (chord) up to half its length from the circle's
    half_chord = r * math.sin(math.pi / n)
    assert np.abs(prism.nearest_point(q) - cylinder.nearest_point(q)).max() < half_chord + sagitta


footprints = st.lists(
    st.tuples(st.floats(-50, 50), st.floats(-50, 50)), min_size=3, max_size=8, unique=True
).map(lambda pts: np.array(pts) + CENTRE)


@settings(max_examples=60, deadline=None)
@given(
    footprints,
    st.lists(st.tuples(st.floats(-80, 80), st.floats(-80, 80), st.floats(-20, 60)), min_size=1),
)
def test_separation_equals_the_danger_zone_prism(pts: np.ndarray, qs: list[Any]) -> None:
    """Against an independent implementation (shapely's distance, :class:`PolygonZone`) on the
    convex hull of random points: the same signed distance."""
    import shapely

    hull = shapely.MultiPoint(pts).convex_hull
    if hull.geom_type != "Polygon" or hull.area < 1.0:
        return
    ring = np.asarray(hull.exterior.coords)
    th = PrismThreat(id="h", footprint=ring, top=40.0, bottom=0.0)
    zone = PolygonZone(((tuple(map(tuple, ring[:-1])),),), floor=0.0, top=40.0)
    q = np.asarray(qs) + np.array([XC, YC, 0.0])
    np.testing.assert_allclose(th.separation(q), zone.separation(q), atol=1e-9)
    assert np.all(th.separation(th.nearest_point(q)) <= 1e-9)


def test_the_footprint_is_normalised_and_shapes_for_the_recorder() -> None:
    clockwise = [(0.0, 0.0), (0.0, 10.0), (0.0, 10.0), (10.0, 10.0), (10.0, 0.0), (0.0, 0.0)]
    th = PrismThreat(id="b", footprint=clockwise, top=20.0, appears_at=5.0)
    assert th.footprint == ((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0))
    assert th.enclosing_radius == pytest.approx(math.sqrt(50.0))
    assert th.shape(5.0) == {
        "id": "b",
        "kind": "prism",
        "center": [5.0, 5.0, 20.0],
        "footprint": [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]],
        "top": 20.0,
        "bottom": None,
    }
    assert th.extended and not th.active(4.0) and th.active(5.0)
    assert np.array_equal(th.velocity(), np.zeros(3))


def test_radar_sees_the_nearest_point_and_the_outline_edges() -> None:
    th = PrismThreat(id="b", footprint=SQUARE, top=20.0, bottom=5.0)
    ids, pts = th.radar_points(0.0, (30.0, 5.0, 50.0))
    assert ids == ["b", "b#left", "b#right"]
    # looking west from x = 30: the nearest point on the wall x = 10, clipped to the top; the
    # outline's left edge is the south-east corner, its right edge the north-east corner
    np.testing.assert_allclose(pts, [[10.0, 5.0, 20.0], [10.0, 0.0, 20.0], [10.0, 10.0, 20.0]])
    ids, pts = th.radar_points(0.0, (4.0, 6.0, 50.0))  # over the roof: the outline surrounds it
    assert ids == ["b"]
    np.testing.assert_allclose(pts, [[4.0, 6.0, 20.0]])


# -- the threat file ------------------------------------------------------------------------------
def test_records_round_trip_through_the_loader(tmp_path: Path) -> None:
    th = PrismThreat(
        id="b", footprint=ELL, top=30.0, bottom=2.5, appears_at=1.0, disappears_at=90.0
    )
    rec = th.to_record()
    assert rec["footprint"][0] == rec["footprint"][-1]  # written closed, as the file asks
    (again,) = threats_from_records([rec]).threats
    assert again == th and again.to_record() == rec
    doc = {
        "terrapath": 1,
        "threats": [rec, PrismThreat(id="c", footprint=SQUARE, top=9).to_record()],
    }
    path = write(tmp_path, yaml.safe_dump(doc))
    ts = load_threats(path)
    assert [t.to_record() for t in ts] == doc["threats"]
    assert ts.get("c").bottom == -math.inf  # type: ignore[attr-defined]


def test_the_default_bottom_is_the_ground_under_the_footprint(tmp_path: Path) -> None:
    grid = sloped_grid()
    ring = closed(ELL, XC + 3.0, YC - 7.0)
    text = f"""\
    terrapath: 1
    threats:
      - {{id: b, kind: prism, footprint: {ring}, top: 200}}
      - {{id: c, kind: prism, footprint: {ring}, top: 200, bottom: 10}}
    """
    ts = load_threats(write(tmp_path, text), grid)
    b = ts.get("b")
    assert isinstance(b, PrismThreat)
    c = ts.get("c")
    assert isinstance(c, PrismThreat) and c.bottom == 10.0
    assert b.bottom == grid.lowest_under(ring)
    # never above the ground anywhere under the footprint, and within one cell's relief of it
    xs, ys = np.meshgrid(np.linspace(XC + 3, XC + 23, 81), np.linspace(YC - 7, YC + 13, 81))
    inside = b.separation(np.c_[xs.ravel(), ys.ravel(), np.full(xs.size, 190.0)]) <= 0
    ground = grid.height_at(xs.ravel()[inside], ys.ravel()[inside])
    assert b.bottom <= ground.min() <= b.bottom + 1.5
    assert ground.max() <= grid.highest_under(ring) <= ground.max() + 1.5
    # the record carries the bottom: it reads back equal without the grid
    assert threats_from_records([b.to_record()]).threats == (b,)


def test_lowest_under_is_the_exact_minimum_at_a_cell_centre() -> None:
    heights = np.full((10, 10), 100.0)
    heights[4, 5] = 80.0  # one low cell centre, inside the footprint below
    grid = make_grid(heights, cell=10.0, x0=0.0, y0=100.0)
    x, y = grid.index_to_xy(4, 5)
    ring = [(x - 3, y - 3), (x + 3, y - 3), (x + 3, y + 3), (x - 3, y + 3)]
    assert grid.lowest_under(ring) == 80.0 and grid.highest_under(ring) == 100.0
    far = [(5.0, 5.0), (12.0, 5.0), (12.0, 12.0)]  # the south-west corner, far from it
    assert grid.lowest_under(far) == 100.0


def test_an_open_footprint_is_closed_as_a_zones_file_ring(tmp_path: Path) -> None:
    # the rule of terrain.zone_file's YAML rings: open, a repeated closing vertex allowed
    square = [[0, 0], [10, 0], [10, 10], [0, 10]]
    open_ = load_threats(
        write(
            tmp_path,
            f"terrapath: 1\nthreats:\n  - {{id: b, kind: prism, footprint: {square}, top: 5}}\n",
        )
    )
    closed = load_threats(
        write(
            tmp_path,
            f"terrapath: 1\nthreats:\n  - {{id: b, kind: prism, footprint: {[*square, square[0]]}, top: 5}}\n",
            "c.yaml",
        )
    )
    (a,), (b,) = open_.threats, closed.threats
    assert a == b and len(a.footprint) == 4  # type: ignore[attr-defined]


BAD = [
    (
        "footprint: [[0, 0], [10, 0], [0, 0]], top: 5",
        ".footprint",
        "at least 3 distinct vertices, found 2",
    ),
    (
        "footprint: [[0, 0], [10, 10], [10, 0], [0, 10], [0, 0]], top: 5",
        ".footprint",
        "expected a simple polygon, found Self-intersection[5 5]",
    ),
    (
        "footprint: [[[0, 0], [10, 0], [10, 10], [0, 0]], [[6, 2], [8, 2], [8, 4], [6, 2]]], "
        "top: 5",
        ".footprint",
        "has no holes",
    ),
    ("footprint: [[0, 0], [10, 0], [10, 10], [0, 0]], top: 5, bottom: 5", ".bottom", "below top"),
    ("footprint: [[0, 0], [10, 0], [10, 10], [0, 0]], top: 5, bottom: 9", ".bottom", "below top"),
    ("footprint: [[0, 0], [10, 0], [10, 10], [0, 0]]", "", "missing 'top'"),
    ("footprint: [[0, 0], [10, 0], [10, 10], [0, 0]], top: .nan", ".top", "expected a top"),
    ("footprint: [[0, 0], [10, 0], [x, 10], [0, 0]], top: 5", ".footprint[2][0]", "a number"),
    ("footprint: [[0, 0], [10, 0, 3], [10, 10], [0, 0]], top: 5", ".footprint[1]", "[x, y]"),
    ("top: 5", "", "found neither"),
    (
        "footprint: [[0, 0], [1, 0], [1, 1], [0, 0]], "
        "footprint_lonlat: [[0, 0], [1, 0], [1, 1], [0, 0]], top: 5",
        "",
        "not both",
    ),
    (
        "footprint: [[0, 0], [1, 0], [1, 1], [0, 0]], top: 5, radius: 3",
        "",
        "unknown key(s) 'radius'",
    ),
]


@pytest.mark.parametrize(("keys", "field", "phrase"), BAD)
def test_every_bad_footprint_names_the_file_and_field(
    tmp_path: Path, keys: str, field: str, phrase: str
) -> None:
    path = write(
        tmp_path, f"terrapath: 1\nthreats:\n  - {{id: b, kind: prism, {keys}}}\n", "bad.yaml"
    )
    with pytest.raises(InputError) as info:
        load_threats(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{str(path)!r}, field 'threats[0]{field}': "), message
    assert phrase in message, message


def test_with_a_grid_the_footprint_must_lie_on_the_map_and_top_above_the_ground(
    tmp_path: Path,
) -> None:
    grid = sloped_grid()
    off = closed(SQUARE, X0 - 5.0, YC)
    path = write(
        tmp_path,
        f"terrapath: 1\nthreats:\n  - {{id: b, kind: prism, footprint: {off}, top: 500}}\n",
    )
    with pytest.raises(
        InputError, match=r"field 'threats\[0\]\.footprint\[0\]': position .* outside"
    ):
        load_threats(path, grid)
    low = closed(SQUARE, XC, YC)  # the ground there is about 124 m: a top of 120 m is under it
    path = write(
        tmp_path,
        f"terrapath: 1\nthreats:\n  - {{id: b, kind: prism, footprint: {low}, top: 120}}\n",
    )
    with pytest.raises(InputError, match=r"field 'threats\[0\]\.top': expected above the ground"):
        load_threats(path, grid)


def test_constructor_checks_too() -> None:
    with pytest.raises(InputError, match="at least 3 distinct vertices"):
        PrismThreat(id="b", footprint=[(0, 0), (1, 1)], top=1)
    with pytest.raises(InputError, match="Self-intersection"):
        PrismThreat(id="b", footprint=[(0, 0), (10, 10), (10, 0), (0, 10)], top=1)
    with pytest.raises(InputError, match="must be below top"):
        PrismThreat(id="b", footprint=SQUARE, top=1, bottom=1)
    with pytest.raises(InputError, match="expected a list of finite"):
        footprint_ring([(0, 0), (1, math.nan), (1, 1)], "f")


# -- GeoJSON buildings ----------------------------------------------------------------------------
def geojson_feature(grid: Any, ring: list[tuple[float, float]], **props: Any) -> dict[str, Any]:
    lon, lat = grid.to_lonlat([x for x, _ in ring], [y for _, y in ring])
    coords = [[float(a), float(b)] for a, b in zip(lon, lat, strict=True)]
    return {
        "type": "Feature",
        "properties": props,
        "geometry": {"type": "Polygon", "coordinates": [[*coords, coords[0]]]},
    }


def test_geojson_polygons_are_prisms(tmp_path: Path) -> None:
    grid = sloped_grid()
    ring = [(x + XC, y + YC) for x, y in ELL]
    fc = {
        "type": "FeatureCollection",
        "features": [
            geojson_feature(grid, ring, id="town-hall", top=300, fid=7),
            geojson_feature(
                grid, [(x + 100, y) for x, y in ring], name="annex", top=280, bottom=140
            ),
        ],
    }
    path = write(tmp_path, json.dumps(fc), "buildings.geojson")
    ts = load_threats(path, grid)
    assert ts.ids == ("town-hall", "annex")
    hall, annex = ts.threats
    assert isinstance(hall, PrismThreat) and isinstance(annex, PrismThreat)
    np.testing.assert_allclose(hall.footprint, ring, atol=1e-6)
    assert hall.bottom == grid.lowest_under(hall.ring) and annex.bottom == 140.0
    # a run records it as a YAML threat file that reads back to equal threats
    again = recorded_threats(recorded_text(path, ts), "run.mcap", grid)
    assert again.threats == ts.threats


@pytest.mark.parametrize(
    ("change", "field", "phrase"),
    [
        (
            lambda f: f["geometry"]["coordinates"].append([[0, 0], [0.1, 0], [0, 0.1], [0, 0]]),
            "features[0].geometry.coordinates",
            "feature 'b': a prism's footprint has no holes; found 1 interior ring",
        ),
        (
            lambda f: f["geometry"].update(type="MultiPolygon"),
            "features[0].geometry",
            "split a MultiPolygon",
        ),
        (
            lambda f: f["geometry"]["coordinates"][0].pop(),
            "features[0].geometry.coordinates[0]",
            "closed ring",
        ),
        (lambda f: f["properties"].pop("top"), "features[0]", "missing 'properties.top'"),
        (
            lambda f: f["properties"].update(bottom=400),
            "features[0].properties.bottom",
            "below top",
        ),
        (lambda f: f["properties"].pop("id"), "features[0].properties", "missing 'id'"),
    ],
)
def test_bad_geojson_features_name_the_feature(
    tmp_path: Path, change: Any, field: str, phrase: str
) -> None:
    grid = sloped_grid()
    feature = geojson_feature(grid, [(x + XC, y + YC) for x, y in SQUARE], id="b", top=300)
    change(feature)
    path = write(
        tmp_path, json.dumps({"type": "FeatureCollection", "features": [feature]}), "b.json"
    )
    with pytest.raises(InputError) as info:
        load_threats(path, grid)
    assert str(info.value).startswith(f"{str(path)!r}, field {field!r}: "), str(info.value)
    assert phrase in str(info.value)


# -- consumers of the shape -----------------------------------------------------------------------
def test_prism_mesh_is_a_closed_solid_of_area_times_height() -> None:
    for ring in (ELL, SQUARE[::-1]):
        v, f = prism_mesh(np.asarray(ring) + CENTRE, 10.0, 40.0)
        edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
        # closed and consistently oriented: every directed edge once, its reverse once
        assert len({tuple(e) for e in edges.tolist()}) == len(edges)
        assert {tuple(e) for e in edges.tolist()} == {tuple(e) for e in edges[:, ::-1].tolist()}
        a, b, c = (v[f[:, k]] - np.array([XC, YC, 0.0]) for k in range(3))
        volume = float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)
        area = 300.0 if ring is ELL else 100.0
        assert volume == pytest.approx(area * 30.0)


def test_the_recorder_checks_a_prism_shape() -> None:
    shape = PrismThreat(id="b", footprint=SQUARE, top=20.0, bottom=5.0).shape()
    assert normalize_threat(shape) == shape
    with pytest.raises(InputError, match="footprint: expected at least 3"):
        normalize_threat({**shape, "footprint": [[0, 0], [1, 1]]})
    with pytest.raises(InputError, match="missing 'top'"):
        normalize_threat({**shape, "top": None, "bottom": None})
    with pytest.raises(InputError, match=r"top 20\.0 must be above bottom 30\.0"):
        normalize_threat({**shape, "bottom": 30.0})


def test_the_cooperative_sensor_reports_the_enclosing_cylinder() -> None:
    th = PrismThreat(id="l", footprint=np.asarray(ELL) + CENTRE, top=30.0, bottom=0.0)
    sensor = CooperativeSensor(range_m=50.0)
    # 40 m east of the foot's wall (x = XC + 20): heard, though the reported point is 55 m away
    pic = sensor.scan(0.0, (XC + 60.0, YC + 5.0, 10.0), (th,))
    assert pic.threat_ids == ("l",)
    np.testing.assert_allclose(pic.positions[0], [XC + 25 / 3, YC + 25 / 3, 30.0])
    assert pic.radii[0] == pytest.approx(th.enclosing_radius) and pic.tops[0] == 30.0
    far = CooperativeSensor(range_m=39.0).scan(0.0, (XC + 60.0, YC + 5.0, 10.0), (th,))
    assert far.threat_ids == ()
    # the circle holds the footprint: no vertex is outside it
    c = np.array(th.centroid)
    assert np.hypot(*(th.ring - c).T).max() == pytest.approx(th.enclosing_radius)


def test_view_and_picture_draw_the_footprint() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon

    from replay.record.picture import _draw_threat
    from terrapath.view.figures import _footprints, _threat_mesh

    th = PrismThreat(id="l", footprint=ELL, top=30.0, bottom=10.0)
    v, _ = _threat_mesh(th.shape(), 0.0)
    assert v[:, 2].min() == 10.0 and v[:, 2].max() == 30.0
    ((x, y),) = _footprints(th, 0.0)
    np.testing.assert_allclose(np.c_[x, y], [*ELL, ELL[0]])
    fig, ax = plt.subplots()
    _draw_threat(ax, th, np.zeros((2, 3)), np.zeros(2), np.zeros(2))
    (patch,) = [p for p in ax.patches if isinstance(p, Polygon)]
    np.testing.assert_allclose(patch.get_xy()[:-1], ELL)
    plt.close(fig)


# -- a replay with a building ---------------------------------------------------------------------
def test_a_replay_measures_the_separation_from_buildings(tmp_path: Path) -> None:
    """seed 004's leg (due north along x = 0 at 120 m) through one building and past another; the
    separation metric is the hand formula at every recorded sample, and the run records both."""
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
    from mcap.reader import make_reader

    from replay.record import topics as T
    from replay.record.reader import load_run

    across = [(-20.0, 600.0), (20.0, 600.0), (20.0, 640.0), (-20.0, 640.0)]
    beside = [(30.0, 300.0), (60.0, 300.0), (60.0, 330.0), (45.0, 345.0), (30.0, 330.0)]
    doc = {
        "terrapath": 1,
        "threats": [
            {"id": "across", "kind": "prism", "footprint": closed(across), "top": 150, "bottom": 0},
            {"id": "beside", "kind": "prism", "footprint": closed(beside), "top": 150},
        ],
    }
    path = write(tmp_path, yaml.safe_dump(doc))
    res = run_replay(ReplayRequest.of(str(MISSION), threats=str(path)), tmp_path / "run.mcap")
    m = res.metrics.as_dict()
    x, y, z = res.positions.T
    inside = (np.abs(x) <= 20.0) & (np.abs(y - 620.0) <= 20.0)
    depth = np.minimum(
        np.minimum(20.0 - np.abs(x), 20.0 - np.abs(y - 620.0)), np.minimum(150.0 - z, z)
    )
    assert inside.any() and m["min_separation"]["across"]["value"] == pytest.approx(
        -depth[inside].max(), abs=1e-9
    )
    # beside, open below and above the flight: the horizontal distance (shapely's)
    import shapely

    flat = shapely.distance(shapely.points(res.positions[:, :2]), shapely.Polygon(beside))
    assert m["min_separation"]["beside"]["value"] == pytest.approx(flat.min(), abs=1e-9)
    assert 29.99 < flat.min() < 30.01
    assert [v["threat"] for v in m["violations"]] == ["across"] and not m["success"]

    rec = load_run(tmp_path / "run.mcap")
    again = recorded_threats(rec.attachments["threats.yaml"].decode(), "run.mcap", None)
    assert [t.to_record() for t in again] == doc["threats"]
    with open(tmp_path / "run.mcap", "rb") as f:
        first = next(
            SceneUpdate.FromString(msg.data)
            for _, _, msg in make_reader(f).iter_messages(topics=[T.THREATS])
        )
    ents = {e.id: e for e in first.entities}
    (tri,) = ents["threat/across"].triangles
    assert len(tri.points) == 8 and len(tri.indices) == 3 * 12  # 4 walls x 2 + 2 caps x 2
    pts = np.array([(p.x, p.y, p.z) for p in tri.points])
    assert pts[:, 2].min() == 0.0 and pts[:, 2].max() == 150.0  # from the pose at the bottom
