"""Multirotor plans (issue 33): `terrapath plan --vehicle quadrotor` plans with the multirotor's
own limits (it climbs on the spot, stops to turn), exports a quadrotor mission, and the replay
flies it with the multirotor stack -- between the buildings of a real city block."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from planner.mission import load_mission
from planner.performance import Performance
from terrapath.cli import main
from tests.conftest import ROOT

BUBENEC = ROOT / "data" / "maps" / "momepy_bubenec" / "bubenec_dtm.tif"
BUILDINGS = ROOT / "data" / "scenarios" / "bubenec-buildings.yaml"


def test_a_hovering_vehicle_has_no_gradient_limit_and_no_fillets() -> None:
    p = Performance("quad", 5.0, 3.0, 1.0, 45.0, hover=True)
    assert p.turn_radius == 0.0 and p.climb_gradient >= 1e6 and p.descent_gradient >= 1e6
    assert "on the spot" in p.describe() and "no fillets" in p.describe()
    assert p.as_dict()["hover"] is True and "climb_gradient" not in p.as_dict()


def test_a_multirotor_faster_than_it_flies_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["plan", str(BUBENEC), "--map-coords", "--start=-744100,-1041400"]
    args += ["--goal=-743650,-1040900", "--vehicle", "quadrotor", "--speed", "20"]
    assert main([*args, "-o", str(tmp_path / "m.yaml")]) == 2
    assert "above quadrotor's 12 m/s (speed_max)" in capsys.readouterr().err


@pytest.mark.slow
def test_a_quadrotor_plan_threads_the_city_block_below_its_roofs_and_is_flown(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The Bubenec block's 143 buildings (tops 212-235 m) as no-fly zones, the altitude band
    capped at 228 m (below the tallest roofs): the quadrotor's plan flies between them, and the
    replay -- the buildings as prism threats, the multirotor stack -- reaches the goal with no
    building entered."""
    doc = yaml.safe_load(BUILDINGS.read_text())
    prisms = [t for t in doc["threats"] if t["kind"] == "prism"]
    zones = [{"id": t["id"], "vertices": t["footprint"][:-1], "top": t["top"]} for t in prisms]
    zfile = tmp_path / "buildings.yaml"
    zfile.write_text(yaml.safe_dump({"terrapath": 1, "danger_zones": zones}))
    out = tmp_path / "q.yaml"
    args = ["plan", str(BUBENEC), "--map-coords", "--start=-744100,-1041400,225"]
    args += ["--goal=-743650,-1040900,225", "--vehicle", "quadrotor", "--clearance", "5"]
    args += ["--zmax", "228", "--zones", str(zfile), "--avoid-zones", "--zone-margin", "3"]
    assert main([*args, "-o", str(out)]) == 0
    m = load_mission(out)
    assert m.vehicle == "quadrotor" and m.turn_radius is None and m.plan["feasible"]
    assert m.plan["vehicle_limits"]["hover"] is True
    tallest = max(t["top"] for t in prisms)
    assert float(m.waypoints[:, 2].max()) <= 228.0 < tallest
    plan = json.loads(out.with_suffix(".plan").read_text())["mission"]
    assert plan["vehicleType"] == 2 and plan["items"][0]["command"] == 22
    assert plan["items"][0]["params"][0] == 0.0  # no take-off pitch for a multirotor
    capsys.readouterr()
    run = tmp_path / "q.mcap"
    fly = ["replay", str(out), "--threats", str(BUILDINGS), "-o", str(run), "--no-picture"]
    assert main([*fly, "--no-terrain-mesh", "--json"]) == 0
    got = json.loads(capsys.readouterr().out)["metrics"]
    assert got["success"] and got["reached_goal"] and not got["violations"]
    assert min(v["value"] for v in got["min_separation"].values()) > 0.0
