"""The 6-DOF vehicle: presets and vehicle files, the compiled model against its numpy twin, trim,
and physics checks (free fall, gliding)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from replay.flight.atmosphere import density
from replay.flight.fixedwing.dynamics import (
    Aircraft,
    air_data,
    derivatives,
    drag_coefficient,
    forces_moments,
    lift_coefficient,
    propeller,
    rk4_step,
)
from replay.flight.fixedwing.kernels import alpha_rate, rk4, step_n
from replay.flight.fixedwing.params import I_DPROP, I_ENGINE, I_PMAX, I_RPM, I_S, VehicleParams
from replay.flight.fixedwing.presets import PRESETS, load_vehicle
from replay.flight.fixedwing.trim import alpha_max_lift, best_climb, trim, trim_range
from replay.frames import (
    map_to_ned,
    ned_to_map,
    rotation_body_to_ned,
    velocities_ned,
    velocities_ned_numpy,
)
from terrain.errors import DataFileError, InputError

G = 9.81
NAMES = sorted(PRESETS)


def _near_trim(p: VehicleParams, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    x0, u0 = trim(p, p.cruise_speed, 300.0)
    scale = np.array([50, 50, 20, 1.0, 1.0, 1.0, 0.2, 0.1, 3.0, 0.3, 0.3, 0.3])
    x = x0 + rng.normal(size=12) * scale
    u = u0 + rng.normal(size=4) * np.array([0.03, 0.03, 0.03, 0.05])
    return x, u


# ---- presets and files ------------------------------------------------------------------------
def test_presets_are_the_documented_aircraft() -> None:
    assert set(PRESETS) == {"aerosonde", "solar-uav", "cessna172", "small-uas", "seed004-uas"}
    aero = load_vehicle("aerosonde")
    # Beard & McLain (2012) Appendix E values
    assert (aero.mass, aero.Jx, aero.Jxz, aero.S, aero.b) == (13.5, 0.8244, 0.1204, 0.55, 2.8956)
    assert (aero.CLalpha, aero.Cmalpha, aero.Cmq, aero.Cnbeta) == (3.45, -0.38, -3.6, 0.25)
    assert (aero.M, aero.alpha0) == (50.0, 0.4712)
    # the second edition's motor and propeller (Beard & McLain 2021, §4.3)
    assert (aero.engine, aero.prop_diameter, aero.battery_voltage) == ("electric", 0.508, 44.4)
    assert (aero.CT0, aero.CQ2) == (0.09357, -0.01664)
    # elevator and rudder signs of Beard's later parameter files (a tail behind the cg)
    assert (aero.CLde, aero.Cmde, aero.CYdr, aero.Cndr) == (0.13, -0.99, 0.19, -0.069)
    cruise = {n: load_vehicle(n).cruise_speed for n in NAMES}
    assert cruise == {
        "aerosonde": 25.0,
        "solar-uav": 15.0,
        "cessna172": 50.0,
        "small-uas": 15.0,
        "seed004-uas": 15.0,
    }
    # seed 004 eq 5: the seed-004 aircraft is small-uas banking to 38 deg, turning within 30 m
    s4, small = load_vehicle("seed004-uas"), load_vehicle("small-uas")
    assert s4.bank_max_deg == 38.0 and s4.mass == small.mass and s4.S == small.S
    assert s4.min_turn_radius(15.0) == pytest.approx(29.36, abs=0.01)
    c172 = load_vehicle("cessna172")
    assert c172.mass == pytest.approx(1043.3, abs=0.1)  # 2300 lb
    assert c172.S == pytest.approx(16.165, abs=1e-3)  # 174 ft^2
    # lift and drag fitted to JSBSim's c172p tables, its Cm0, its aileron (presets.py)
    assert 1 / (math.pi * c172.e * c172.aspect_ratio) == pytest.approx(0.0816)
    assert (c172.CDp, c172.CDde, c172.Clda, c172.Cm0) == (0.0278, 0.06, 0.23, 0.10)
    assert (c172.CLalpha, c172.M, c172.alpha0) == (5.75, 10.8, 0.39)
    for p in PRESETS.values():
        # seeds 000 and 001 bank to 30 deg; seed 004's aircraft to 38 (its eq 5)
        assert p.bank_max_deg == (38.0 if p.name == "seed004-uas" else 30.0)
        assert (p.pitch_min_deg, p.pitch_max_deg) == (-20.0, 20.0)
        assert p.source


def test_stall_is_where_the_blend_says() -> None:
    c172 = PRESETS["cessna172"]
    a = alpha_max_lift(c172)
    # Peden's (and JSBSim's c172p) table: CLmax 1.47 at 16 deg. The smooth blend fitted to the
    # table up to the stall cannot make its sharp peak: the same CLmax, 2 deg later
    assert math.degrees(a) == pytest.approx(18.0, abs=0.5)
    assert lift_coefficient(a, c172) == pytest.approx(1.47, abs=0.015)
    assert lift_coefficient(0.28, c172) == pytest.approx(1.47, abs=0.015)  # the table's peak
    assert lift_coefficient(0.14, c172) == pytest.approx(1.02, abs=0.035)  # the table at 8 deg
    aero = PRESETS["aerosonde"]
    assert lift_coefficient(0.0, aero) == pytest.approx(aero.CL0)
    assert lift_coefficient(0.05, aero) == pytest.approx(aero.CL0 + aero.CLalpha * 0.05, rel=1e-6)
    # far past the stall only the flat plate remains
    assert lift_coefficient(1.2, aero) == pytest.approx(2 * math.sin(1.2) ** 2 * math.cos(1.2))


def test_vehicle_file_with_base_and_overrides(tmp_path: Path) -> None:
    f = tmp_path / "heavy.yaml"
    f.write_text("terrapath: 1\nname: heavy-172\nbase: cessna172\nmass: 1100\ncruise_speed: 45\n")
    p = load_vehicle(str(f))
    assert (p.name, p.mass, p.cruise_speed) == ("heavy-172", 1100.0, 45.0)
    assert p.CLalpha == PRESETS["cessna172"].CLalpha
    assert "heavy.yaml" in p.source
    # the default base is the aerosonde; a relative path resolves against base_dir
    (tmp_path / "light.yml").write_text("terrapath: 1\nname: light\nmass: 12\n")
    q = load_vehicle("light.yml", base_dir=tmp_path)
    assert (q.mass, q.S) == (12.0, PRESETS["aerosonde"].S)


@pytest.mark.parametrize(
    ("body", "error", "field", "expected"),
    [
        ("terrapath: 1\nname: x\nwingspan: 3\n", InputError, "wingspan", "allowed: terrapath"),
        ("terrapath: 1\nname: x\nmass: 0\n", InputError, "mass", "> 0"),
        ("terrapath: 1\nname: x\nmass: -3\n", InputError, "mass", "found -3"),
        ("terrapath: 1\nname: x\nJxz: 2.0\n", InputError, "Jxz", "positive-definite"),
        ("terrapath: 1\nname: x\nJz: 5.0\n", InputError, "Jz", "triangle inequality"),
        ("terrapath: 1\nname: x\nS: 0\n", InputError, "S", "> 0"),
        ("terrapath: 1\nname: x\nmass: heavy\n", InputError, "mass", "expected a number"),
        ("terrapath: 1\nname: x\nbase: concorde\n", InputError, "base", "cessna172"),
        ("terrapath: 2\nname: x\n", InputError, "terrapath", "format version 1"),
        ("terrapath: 1\nmass: 3\n", InputError, "name", "missing"),
        ("terrapath: 1\nname: x\ncruise_speed: 99\n", InputError, "cruise_speed", "inside"),
        ("terrapath: 1\nname: x\nbank_max_deg: 95\n", InputError, "bank_max_deg", "(0, 80)"),
        ("terrapath: 1\nname: x\nrho: 0.9\n", InputError, "rho", "ISA standard atmosphere"),
        ("terrapath: 1\nname: x\nengine: jet\n", InputError, "engine", "electric, piston"),
        (
            "terrapath: 1\nname: x\nengine: piston\npower_max: 80000\nprop_diameter: 1.8\n",
            InputError,
            "rated_rpm",
            "engine 'piston' (the base 'aerosonde' has 'electric') needs prop_diameter, power_max",
        ),
        ("- just\n- a list\n", DataFileError, None, "expected a mapping"),
        ("terrapath: 1\nname: [unclosed\n", DataFileError, None, "not valid YAML"),
    ],
)
def test_bad_vehicle_files_name_file_and_field(
    tmp_path: Path, body: str, error: type[Exception], field: str | None, expected: str
) -> None:
    f = tmp_path / "bad.yaml"
    f.write_text(body)
    with pytest.raises(error) as info:
        load_vehicle(str(f))
    msg = str(info.value)
    assert "bad.yaml" in msg
    if field:
        assert repr(field) in msg
    assert expected in msg


def test_missing_file_and_unknown_preset() -> None:
    with pytest.raises(DataFileError, match="cannot read the vehicle file"):
        load_vehicle("/nonexistent/dir/plane.yaml")
    with pytest.raises(InputError, match="aerosonde, solar-uav, cessna172, small-uas"):
        load_vehicle("concorde")


def test_params_refuse_impossible_values_directly() -> None:
    base = PRESETS["aerosonde"]
    with pytest.raises(InputError, match="'Jxz'"):
        dataclasses.replace(base, Jxz=1.3)
    with pytest.raises(InputError, match="'airspeed_min/airspeed_max'"):
        dataclasses.replace(base, airspeed_min=50.0)
    with pytest.raises(InputError, match="'Cmalpha'"):
        dataclasses.replace(base, Cmalpha=0.1)
    with pytest.raises(InputError, match=r"'mass'.*finite"):
        dataclasses.replace(base, mass=float("nan"))


# ---- compiled model against the numpy reference ------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
def test_numba_rk4_matches_numpy_step_by_step(name: str) -> None:
    p = PRESETS[name]
    rng = np.random.default_rng(7)
    wind = rng.normal(0.0, 3.0, 3)
    packed = p.pack(wind)
    for _ in range(3):
        x, u = _near_trim(p, rng)
        xa = x.copy()
        xb = x.copy()
        worst_step = 0.0
        worst_run = 0.0
        for _ in range(1000):
            # one step from the same state
            na = rk4(xb, u, 0.01, packed)
            nb = rk4_step(xb, u, 0.01, p, wind)
            worst_step = max(worst_step, float(np.max(np.abs(na - nb) / (1 + np.abs(nb)))))
            # and the two trajectories running side by side
            xa = step_n(xa, u, 1, 0.01, packed)
            xb = nb
            worst_run = max(worst_run, float(np.max(np.abs(xa - xb) / (1 + np.abs(xb)))))
        assert worst_step < 1e-13
        assert worst_run < 1e-10
        out = Aircraft(p, x, wind=wind).fun(x, u)
        np.testing.assert_allclose(out, derivatives(x, u, p, wind), rtol=1e-13, atol=1e-12)


def test_alpha_dot_is_the_rate_of_change_of_alpha_in_wind() -> None:
    """The alpha-dot terms use d(alpha)/dt solved with the alpha-dot lift in it: it equals the
    central difference of alpha along the flown trajectory (a pitching Cessna in a wind), and
    the alpha-dot moment damps the short period (JSBSim's c172p: zeta 0.55 at 50 m/s)."""
    p = PRESETS["cessna172"]
    wind = np.array([4.0, -6.0, 1.0])
    x, u = trim(p, 50.0, 1500.0)
    x = x.copy()
    x[10] += 0.3  # a pitch-rate kick: alpha swings through the short period
    packed = p.pack(wind)
    h = 1e-4
    for _ in range(40):
        x = step_n(x, u, 2, 0.01, packed)
        before = air_data(step_n(x, u, 1, -h, packed), wind)[1]
        after = air_data(step_n(x, u, 1, h, packed), wind)[1]
        f, _ = forces_moments(x, u, dataclasses.replace(p, CLadot=0.0, Cmadot=0.0), wind)
        va = air_data(x, wind)[0]
        rel = x[3:6] - rotation_body_to_ned(*x[6:9]).T @ wind
        qs_m = 0.5 * density(-x[2]) * va * va * p.S / p.mass
        kad_m = qs_m * p.CLadot * p.c / (2.0 * va)
        # the lift of alpha-dot itself is part of the force
        adot = alpha_rate(*x[3:6], *rel, *x[9:12], f[0] / p.mass, f[2] / p.mass, kad_m)
        assert adot == pytest.approx((after - before) / (2 * h), rel=1e-4, abs=1e-6)

    # the damping it adds: the pitch-rate kick dies faster with the alpha-dot moment than without
    def kick_energy(q: VehicleParams) -> float:
        y, v = trim(q, 50.0, 1500.0)
        y = y.copy()
        y[10] += 0.3
        rates = []
        for _ in range(200):  # 2 s
            y = step_n(y, v, 1, 0.01, q.pack())
            rates.append(float(y[10]))
        return float(np.sum(np.square(rates)))

    assert kick_energy(p) < 0.9 * kick_energy(dataclasses.replace(p, Cmadot=0.0, CLadot=0.0))


def test_step_n_is_n_single_steps_and_clips_controls() -> None:
    p = PRESETS["aerosonde"]
    x, u = trim(p, 25.0, 100.0)
    packed = p.pack()
    y = x.copy()
    for _ in range(50):
        y = rk4(y, u, 0.01, packed)
    np.testing.assert_array_equal(step_n(x, u, 50, 0.01, packed), y)
    lo, hi = p.control_limits()
    wild = np.array([2.0, -3.0, 5.0, 7.0])
    np.testing.assert_array_equal(
        step_n(x, wild, 5, 0.01, packed), step_n(x, np.clip(wild, lo, hi), 5, 0.01, packed)
    )
    plane = Aircraft(p, x)
    plane.step(u, 100)
    assert plane.t == pytest.approx(1.0)
    np.testing.assert_allclose(plane.x, step_n(x, u, 100, 0.01, packed))


# ---- trim --------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
def test_trim_residual_is_zero_at_cruise(name: str) -> None:
    p = PRESETS[name]
    x, u = trim(p, p.cruise_speed, 500.0)
    xdot = derivatives(x, u, p)
    assert np.max(np.abs(xdot[2:])) < 1e-9  # no climb, no accelerations, no rotation
    va, alpha, beta = air_data(x)
    assert va == pytest.approx(p.cruise_speed, rel=1e-12)
    # coordinated (no aerodynamic side force) and wings level but for the electric propeller's
    # torque: the ailerons hold it, and a sideslip and bank of a fraction of a degree go with them
    small = 0.0 if p.engine == "piston" else math.radians(0.3)
    assert abs(beta) <= small + 1e-9 and abs(x[6]) <= small + 1e-9
    cy = p.CY0 + p.CYbeta * beta + p.CYda * u[1] + p.CYdr * u[2]
    assert cy == pytest.approx(0.0, abs=1e-7)
    assert 0 < alpha < alpha_max_lift(p)
    lo, hi = p.control_limits()
    assert np.all(u >= lo) and np.all(u <= hi) and 0.05 < u[3] < 0.95
    assert x[2] == -500.0


@pytest.mark.parametrize("name", ["aerosonde", "cessna172"])
def test_trim_in_a_climbing_turn(name: str) -> None:
    p = PRESETS[name]
    va, gamma, radius = p.cruise_speed, math.radians(3.0), -4.0 * p.min_turn_radius()
    x, u = trim(p, va, 100.0, gamma=gamma, turn_radius=radius)
    xdot = derivatives(x, u, p)
    assert xdot[2] == pytest.approx(-va * math.sin(gamma), abs=1e-9)  # climbing
    assert xdot[8] == pytest.approx(va * math.cos(gamma) / radius, abs=1e-9)  # turning left
    assert np.max(np.abs(xdot[3:8])) < 1e-9 and np.max(np.abs(xdot[9:])) < 1e-9
    assert x[6] < 0  # banked left


def test_a_remembered_trim_is_the_solved_one_and_not_shared() -> None:
    from replay.flight.fixedwing import trim as trim_module

    p = PRESETS["aerosonde"]
    trim_module._solved.cache_clear()
    packed = p.pack()
    fresh = trim_module._solve_now(p, packed, 24.0, 800.0, 0.02, math.inf, None)
    first = trim(p, 24.0, 800.0, gamma=0.02)
    again = trim(p, 24.0, 800.0, gamma=0.02)
    assert trim_module._solved.cache_info().hits >= 1
    np.testing.assert_array_equal(first.x, again.x)
    np.testing.assert_array_equal(first.u, again.u)
    z, r = trim_module._solve(p, packed, 24.0, 800.0, 0.02, math.inf, None)
    np.testing.assert_array_equal(z, fresh[0])
    assert r == fresh[1]
    z[:] = 0.0  # the caller's copy: the remembered one is untouched
    first.x[:] = 0.0
    np.testing.assert_array_equal(
        trim_module._solve(p, packed, 24.0, 800.0, 0.02, math.inf, None)[0], fresh[0]
    )
    np.testing.assert_array_equal(trim(p, 24.0, 800.0, gamma=0.02).x, again.x)
    # a failure is a failure again, with its explanation
    with pytest.raises(InputError, match="cannot"):
        trim(p, 300.0, 800.0)
    with pytest.raises(InputError, match="cannot"):
        trim(p, 300.0, 800.0)


def test_cannot_trim_names_speed_and_range() -> None:
    p = PRESETS["aerosonde"]
    lo, hi = trim_range(p)  # type: ignore[misc]
    assert 12.0 < lo < 17.0 and 28.0 < hi < 40.0  # stall at CLmax ~1.6; a power-limited motor
    with pytest.raises(InputError) as fast:
        trim(p, 100.0)
    msg = str(fast.value)
    assert msg.startswith("aerosonde cannot trim at 100 m/s at 0 m")
    assert f"level trim exists there for {lo:g}–{hi:g} m/s (true airspeed)" in msg
    assert "thrust" in msg
    with pytest.raises(InputError, match=r"cannot trim at 9 m/s at 0 m, below its stall speed"):
        trim(p, 9.0)
    # up high the air is thinner: the stall speed (true airspeed) is higher, as 1/sqrt(sigma)
    lo4, _ = trim_range(p, 4000.0)  # type: ignore[misc]
    assert lo4 == pytest.approx(lo * math.sqrt(1.225 / 0.81935), abs=0.15)
    with pytest.raises(InputError, match=r"cannot trim at 16 m/s at 4000 m, below its stall"):
        trim(p, 16.0, 4000.0)
    # the ends of the range really are the ends
    trim(p, lo + 0.05)
    trim(p, hi - 0.05)
    with pytest.raises(InputError):
        trim(p, hi + 0.2)


# ---- physics -----------------------------------------------------------------------------------
def test_free_fall_without_aerodynamics_is_9_81() -> None:
    p = PRESETS["aerosonde"]
    packed = p.pack()
    packed[I_S] = 0.0  # no wing: no lift, drag, side force or moments
    packed[I_ENGINE], packed[I_PMAX], packed[I_RPM] = 1.0, 0.0, 2700.0  # a piston of no power
    packed[I_DPROP] = 0.0  # and no propeller to windmill
    rng = np.random.default_rng(3)
    x = np.zeros(12)
    x[3:6] = rng.normal(0, 10, 3)
    x[6:9] = [0.4, -0.3, 2.0]
    x[9:12] = [0.5, -0.4, 0.3]
    v0 = rotation_body_to_ned(*x[6:9]) @ x[3:6]
    jm = np.array([[p.Jx, 0, -p.Jxz], [0, p.Jy, 0], [-p.Jxz, 0, p.Jz]])

    def momentum(s: np.ndarray) -> tuple[np.ndarray, float]:
        w = s[9:12]
        return rotation_body_to_ned(*s[6:9]) @ (jm @ w), 0.5 * w @ jm @ w

    h0, e0 = momentum(x)
    t = 2.0
    y = step_n(x, np.array([0.0, 0.0, 0.0, 1.0]), 200, 0.01, packed)
    v = rotation_body_to_ned(*y[6:9]) @ y[3:6]
    np.testing.assert_allclose(v - v0, [0.0, 0.0, G * t], atol=1e-8)
    np.testing.assert_allclose(y[0:3], v0 * t + np.array([0, 0, 0.5 * G * t * t]), atol=1e-7)
    h1, e1 = momentum(y)
    np.testing.assert_allclose(h1, h0, atol=1e-8)  # torque-free: angular momentum kept
    assert e1 == pytest.approx(e0, rel=1e-9)


@pytest.mark.parametrize("name", ["aerosonde", "cessna172", "small-uas"])
def test_glide_with_the_engine_off_is_the_airframe_less_the_windmilling_propeller(
    name: str,
) -> None:
    """With the engine off the aircraft sinks at the rate that pays for its drag and the
    windmilling propeller's: W sink = (D - T + m a) Va (energy; T < 0, a the slow deceleration
    as the air thickens). The Aerosonde, controls neutral, settles into a spiral (its freewheeling
    propeller's friction torque rolls it): the energy balance holds in a turn too."""
    p = PRESETS[name]
    x, u = trim(p, p.cruise_speed * 0.9, 3000.0)
    u = u.copy()
    u[1:] = 0.0  # engine off, elevator held at its trim, ailerons and rudder neutral
    x = step_n(x, u, 20000, 0.01, p.pack())  # 200 s for the phugoid to settle
    xdot = derivatives(x, u, p)
    va, alpha, _ = air_data(x)
    accel = float(x[3:6] @ xdot[3:6]) / va
    rho = density(-x[2])
    qs = 0.5 * rho * va * va * p.S
    drag = qs * (drag_coefficient(alpha, p) + p.CDde * abs(u[0]))
    windmill = propeller(va, 0.0, p, rho)[0]
    assert windmill < 0.0  # a closed throttle brakes
    sink = xdot[2]
    assert p.weight * sink == pytest.approx((drag - windmill + p.mass * accel) * va, rel=5e-3)
    glide_ratio = math.hypot(xdot[0], xdot[1]) / sink
    assert 4.0 < glide_ratio < 16.0  # a small UAV or a Cessna, not a brick or a sailplane


# JSBSim 1.3's c172p (aircraft/c172p/c172p.xml, flaps up, no stall hysteresis): CLwbh(alpha)
# and CDo + CDwbh(alpha) = 0.027 + the table, at alpha in rad
C172P_LIFT = {0.0: 0.25, 0.09: 0.73, 0.12: 0.92, 0.16: 1.08, 0.19: 1.19, 0.21: 1.25, 0.24: 1.35}
C172P_DRAG = {0.0: 0.0322, 0.0873: 0.0712, 0.1571: 0.1232, 0.2094: 0.1568, 0.2443: 0.1835}


def test_the_cessna_lift_and_drag_follow_the_c172p_tables_to_the_stall() -> None:
    """The lift curve bends before the stall as JSBSim's c172p's does, and the drag is that of
    the lift it makes: Beard & McLain's eq. 4.11, which squares the linear lift coefficient, gave
    0.21 at 12 deg where the table has 0.157, and the Cessna could not fly 30 m/s at 1,500 m."""
    p = PRESETS["cessna172"]
    for a, cl in C172P_LIFT.items():
        assert lift_coefficient(a, p) == pytest.approx(cl, abs=0.04)
    for a, cd in C172P_DRAG.items():
        assert drag_coefficient(a, p) == pytest.approx(cd, rel=0.06)
    assert 0.27 < alpha_max_lift(p) < 0.33  # the table's CLmax 1.47 at 0.28 rad
    assert lift_coefficient(alpha_max_lift(p), p) == pytest.approx(1.47, abs=0.02)
    x, _ = trim(p, 30.0, 1500.0)  # JSBSim trims it at alpha 13.6 deg
    assert math.degrees(air_data(x)[1]) == pytest.approx(13.6, abs=0.5)


@pytest.mark.parametrize("name", NAMES)
def test_drag_is_eq_4_11_below_the_stall_and_grows_past_it(name: str) -> None:
    """Where the flow is attached the drag is Beard & McLain's eq. 4.11 (so the UAVs' cruise is
    unchanged); past the stall the flat plate's drag takes over and keeps growing with alpha."""
    p = PRESETS[name]
    k = 1.0 / (math.pi * p.e * p.aspect_ratio)
    # the Cessna's blend is wider (M = 10.8 against the UAVs' 50): at 3 deg of alpha 2.5 % of
    # its lift is already the flat plate's
    rel = 0.04 if name == "cessna172" else 1e-6
    for a in (-0.05, 0.0, 0.05):
        assert drag_coefficient(a, p) == pytest.approx(
            p.CDp + k * (p.CL0 + p.CLalpha * a) ** 2, rel=rel
        )
    post = [drag_coefficient(a, p) for a in (0.8, 1.0, 1.2, 1.5)]
    assert post == sorted(post) and post[-1] == pytest.approx(2.0, rel=0.02)  # a flat plate


@pytest.mark.parametrize("name", NAMES)
def test_the_climb_rate_falls_with_altitude(name: str) -> None:
    """Thinner air, less thrust and lift: the best climb at cruise falls with height."""
    p = PRESETS[name]
    rates = [best_climb(p, p.cruise_speed * 1.1, h) for h in (0.0, 1500.0, 3000.0)]
    assert rates[0] > rates[1] > rates[2] > 0.0
    # the rate found is the limit: a little steeper does not trim
    gamma = math.asin(rates[2] / (p.cruise_speed * 1.1))
    trim(p, p.cruise_speed * 1.1, 3000.0, gamma)
    with pytest.raises(InputError):
        trim(p, p.cruise_speed * 1.1, 3000.0, gamma + 0.01)


@pytest.mark.parametrize("name", NAMES)
def test_a_steady_30_degree_turn_has_the_radius_of_physics(name: str) -> None:
    """Coordinated (no aerodynamic side force: the ball centred) and trimmed at the bank limit,
    every preset turns within 2 % of V^2 / (g tan(phi)) -- with beta = 0 instead, the rudder's
    side force made them 1-9 % tighter (or, with the consistent rudder signs, wider)."""
    p = PRESETS[name]
    va = p.cruise_speed
    radius = va * va / (G * math.tan(math.radians(p.bank_max_deg)))
    x, _ = trim(p, va, 500.0, turn_radius=radius)
    physics = va * va / (G * math.tan(x[6]))  # the radius the trimmed bank would give
    assert radius / physics == pytest.approx(1.0, abs=0.02)


def test_frames_compiled_velocities_and_the_axis_swap_are_their_numpy_forms() -> None:
    rng = np.random.default_rng(38)
    x = rng.uniform(-3.5, 3.5, (3000, 12))
    x[:, 3:6] *= 20.0
    np.testing.assert_array_equal(velocities_ned(x), velocities_ned_numpy(x))
    # one state, a wider state (a multirotor's rotor speeds after the 12), a strided view
    assert velocities_ned(x[0]).shape == (1, 3)
    wide = np.hstack([x[:5], rng.uniform(0, 900, (5, 4))])
    np.testing.assert_array_equal(velocities_ned(wide), velocities_ned_numpy(wide))
    np.testing.assert_array_equal(velocities_ned(x[::7]), velocities_ned_numpy(x[::7]))
    # each row is the rotation matrix applied to the body velocity
    for s in x[:20]:
        np.testing.assert_allclose(
            velocities_ned(s)[0], rotation_body_to_ned(*s[6:9]) @ s[3:6], rtol=1e-12, atol=1e-9
        )
    # map <-> NED: the first two swapped, the third negated, one point or many, its own inverse
    p = rng.uniform(-1e5, 1e5, (50, 3))
    want = np.stack([p[:, 1], p[:, 0], -p[:, 2]], axis=-1)
    np.testing.assert_array_equal(ned_to_map(p), want)
    np.testing.assert_array_equal(map_to_ned(p), want)
    np.testing.assert_array_equal(ned_to_map(p[0]), want[0])
    np.testing.assert_array_equal(map_to_ned(ned_to_map(p)), p)
    np.testing.assert_array_equal(ned_to_map(x[:4, :3]), ned_to_map(x[:4])[:, :3])
