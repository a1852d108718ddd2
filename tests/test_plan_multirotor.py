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


def test_a_vehicle_file_based_on_the_quadrotor_is_planned_and_flown_as_itself(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A vehicle file with ``base: quadrotor`` (heavier, slower to climb, another cruise speed):
    the plan's limits are its own (climb 2 m/s, 6 m/s, hovering), the exports say multirotor,
    the replay flies it with the multirotor stack under its name; a bad field is one line naming
    the file and the field."""
    heavy = tmp_path / "heavy.yaml"
    heavy.write_text(
        "terrapath: 1\nname: heavy-quad\nbase: quadrotor\nmass: 0.9\ncruise_speed: 6.0\n"
        "climb_rate_max: 2.0\n"
    )
    out = tmp_path / "h.yaml"
    args = ["plan", str(BUBENEC), "--map-coords", "--start=-744100,-1041400,225"]
    args += ["--goal=-743650,-1040900,225", "--clearance", "5"]
    assert main([*args, "--vehicle", str(heavy), "-o", str(out)]) == 0
    m = load_mission(out)
    limits = m.plan["vehicle_limits"]
    assert limits["vehicle"] == "heavy-quad" and limits["hover"] is True
    assert limits["climb_rate"] == 2.0 and limits["speed"] == 6.0 and m.turn_radius is None
    assert json.loads(out.with_suffix(".plan").read_text())["mission"]["vehicleType"] == 2
    capsys.readouterr()
    run = ["replay", str(out), "-o", str(tmp_path / "h.mcap"), "--no-picture"]
    assert main([*run, "--no-terrain-mesh", "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert got["metrics"]["success"] and got["metrics"]["reached_goal"]
    assert main(["inspect", str(tmp_path / "h.mcap")]) == 0
    shown = capsys.readouterr().out
    assert any(ln.split() == ["vehicle", "heavy-quad"] for ln in shown.splitlines())
    assert "vehicle.yaml" in shown  # the file flown travels with the recording
    bad = tmp_path / "bad.yaml"
    bad.write_text("terrapath: 1\nname: bad\nbase: quadrotor\nmass: -1\n")
    assert main([*args, "--vehicle", str(bad), "-o", str(tmp_path / "b.yaml")]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(bad) in err and "'mass'" in err
    unknown = tmp_path / "unknown.yaml"
    unknown.write_text("terrapath: 1\nname: u\nbase: quadrotor\nwingspan: 2\n")
    assert main([*args, "--vehicle", str(unknown), "-o", str(tmp_path / "u.yaml")]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "'wingspan'" in err and "multirotor" in err
