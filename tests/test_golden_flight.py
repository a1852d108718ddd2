"""Proof by flight: every golden plan, flown by the 6-DOF aircraft it was planned for with
terrain following OFF (a real autopilot does not terrain-follow), reaches its goal without
touching the terrain and keeps at least half the planned clearance everywhere.

The replay flies the mission as written (waypoints, cruise speed, turn fillets of the planned
radius) over the map's bilinear terrain; the planner checked the flown path against its
conservative terrain. Slow-ish (12 flights of 20-35 min simulated, ~1 min in all)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from planner.pipeline import to_mission
from replay.avoidance.base import NoAvoidance
from replay.flight.fixedwing.presets import load_vehicle
from replay.sim import ReplayConfig, simulate
from replay.threats.kinds import ThreatSet
from terrapath.cli import main
from tests.conftest import ROOT
from tests.golden.scenarios import ALGORITHMS, MAPS, VEHICLE

CASES = [(sc, alg) for sc in MAPS for alg in ALGORITHMS]


@pytest.mark.slow
@pytest.mark.parametrize(("scenario", "algorithm"), CASES, ids=[f"{s.name}-{a}" for s, a in CASES])
def test_golden_plan_is_flown_clear_of_the_terrain(scenario, algorithm: str) -> None:  # type: ignore[no-untyped-def]
    if not scenario.available():
        pytest.skip(f"{scenario.dem} not found")
    prepared = scenario.prepared()
    result = scenario.run(algorithm, prepared.problem)
    assert result.feasible
    mission = to_mission(scenario.request(algorithm), prepared, result)
    assert mission.turn_radius == pytest.approx(load_vehicle(VEHICLE).performance().turn_radius)
    run = simulate(
        mission,
        ThreatSet(()),
        NoAvoidance(),
        load_vehicle(mission.vehicle),
        grid=prepared.grid,
        config=ReplayConfig(terrain_following=None, terrain_returns=False),
    )
    m = run.metrics
    assert m.end_reason == "goal" and m.success
    clearance = prepared.problem.clearance
    assert m.min_terrain_clearance_m >= 0.5 * clearance, (
        f"flown {m.min_terrain_clearance_m:.1f} m above the terrain at t="
        f"{m.min_terrain_clearance_t:.0f} s; planned {result.terms['min_clearance_m']:.1f} m"
    )


def _plan_and_fly(tmp_path: Path, plan_args: list[str], capsys: pytest.CaptureFixture[str]) -> dict:  # type: ignore[type-arg]
    mission = tmp_path / "m.yaml"
    assert main(["plan", *plan_args, "-o", str(mission)]) == 0
    capsys.readouterr()
    rc = main(
        [
            "replay",
            str(mission),
            "--terrain-following",
            "0",
            "--no-terrain-mesh",
            "--json",
            "-o",
            str(tmp_path / "flown.mcap"),
        ]
    )
    report = json.loads(capsys.readouterr().out)
    assert rc == 0, report["metrics"]
    return dict(report["metrics"])


@pytest.mark.slow
def test_the_readme_big_tujunga_example_is_flown_clear_of_the_terrain(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # issue 12: this example used to be "feasible" with a 657 m climb in 2.27 km and ended in
    # terrain contact after 3.6 minutes when flown without terrain following
    dem = ROOT.parent / "shared/maps/topotoolbox_bigtujunga/bigtujunga.tif"
    if not dem.is_file():
        pytest.skip(f"{dem} not found")
    m = _plan_and_fly(
        tmp_path,
        [str(dem), "--map-coords", "--start", "380000,3792000,900", "--goal", "408000,3805000"],
        capsys,
    )
    assert m["success"] and m["end_reason"] == "goal"
    assert m["min_terrain_clearance_m"] >= 25.0
