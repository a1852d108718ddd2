"""The model-independent pieces of benchmarks/validate_jsbsim.py on synthetic cases with known
answers (no JSBSim needed), plus the script's own pieces that need jsbsim, skipped without it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks import _validate as v


def test_boundary_finds_the_edge_from_either_side() -> None:
    edge = math.pi
    assert abs(v.boundary(lambda x: x <= edge, 0.0, 10.0, 1e-9) - edge) < 1e-9
    assert v.boundary(lambda x: x <= edge, 0.0, 10.0, 1e-9) <= edge  # always a value inside
    assert abs(v.boundary(lambda x: x >= edge, 10.0, 0.0, 1e-9) - edge) < 1e-9
    assert v.boundary(lambda x: True, 0.0, 10.0, 1e-3) == 10.0  # the set reaches past the bracket


def test_maximise_finds_an_interior_peak_and_skips_undefined_points() -> None:
    def f(x: float) -> float:
        return -((x - 38.3) ** 2) + 4.0 if x >= 31.0 else math.nan  # undefined below 31

    best = v.maximise(f, 28.0, 52.0, 9, 1e-4)
    assert abs(best.x - 38.3) < 1e-3 and abs(best.value - 4.0) < 1e-6
    edge = v.maximise(lambda x: x, 0.0, 1.0, 5, 1e-6)  # monotone: the end of the range
    assert edge.x == 1.0 and edge.value == 1.0
    none = v.maximise(lambda x: -math.inf, 0.0, 1.0, 5, 1e-3)
    assert math.isnan(none.x) and math.isnan(none.value)


def _mode_signal(t: np.ndarray, wn: float, zeta: float, trend: float = 0.0) -> np.ndarray:
    sigma, wd = zeta * wn, wn * math.sqrt(1 - zeta * zeta)
    return 3.0 + trend * t + 2.0 * np.exp(-sigma * t) * np.sin(wd * t + 0.4)


@pytest.mark.parametrize(
    ("wn", "zeta", "span", "dt"),
    [
        (5.0, 0.5, 4.0, 0.01),  # a short period
        (6.0, 0.75, 4.0, 0.01),  # heavily damped: barely one overshoot
        (0.25, 0.08, 190.0, 0.01),  # a phugoid
        (1.5, 0.0, 30.0, 0.05),  # undamped
    ],
)
def test_fit_mode_recovers_frequency_and_damping(
    wn: float, zeta: float, span: float, dt: float
) -> None:
    t = np.arange(0.0, span, dt) + 7.0  # the fit's clock starts at the first sample
    y = _mode_signal(t - 7.0, wn, zeta, trend=0.01)
    m = v.fit_mode(t, y)
    assert abs(m.omega_n - wn) < 1e-4 * wn
    assert abs(m.zeta - zeta) < 1e-4
    assert abs(m.period - 2 * math.pi / (wn * math.sqrt(1 - zeta * zeta))) < 1e-3


def test_fit_mode_in_noise_and_refuses_short_series() -> None:
    rng = np.random.default_rng(14)
    t = np.arange(0.0, 150.0, 0.1)
    y = _mode_signal(t, 0.25, 0.1) + rng.normal(0.0, 0.02, t.size)
    m = v.fit_mode(t, y)
    assert abs(m.omega_n - 0.25) < 0.005 and abs(m.zeta - 0.1) < 0.01
    with pytest.raises(ValueError, match="8 samples"):
        v.fit_mode([0.0, 1.0], [0.0, 1.0])


def test_first_crossing_interpolates_and_uses_the_magnitude() -> None:
    t = np.array([0.0, 1.0, 2.0, 3.0])
    assert v.first_crossing(t, [0.0, -20.0, -40.0, -60.0], 30.0) == pytest.approx(1.5)
    assert math.isnan(v.first_crossing(t, [0.0, 1.0, 2.0, 3.0], 30.0))
    assert v.first_crossing(t, [31.0, 0.0, 0.0, 0.0], 30.0) == 0.0


def test_turn_radius_of_a_sampled_circle_across_the_course_wrap() -> None:
    r, speed = 441.0, 50.0
    t = np.arange(0.0, 60.0, 0.1)  # more than a full circle: the course wraps at +-pi
    course = np.angle(np.exp(1j * (2.0 + speed / r * t)))
    assert v.turn_radius(t, course, np.full_like(t, speed)) == pytest.approx(r, rel=1e-9)
    assert v.turn_radius(t, -course, np.full_like(t, speed)) == pytest.approx(r, rel=1e-9)


def test_physics_turn_radius() -> None:
    assert v.physics_turn_radius(50.0, math.radians(30.0), 9.81) == pytest.approx(
        2500.0 / (9.81 * math.tan(math.radians(30.0)))
    )
    assert v.physics_turn_radius(50.0, -0.5, 9.81) == v.physics_turn_radius(50.0, 0.5, 9.81)


def test_targets_judge_ratio_difference_and_nothing() -> None:
    ratio = v.Target("ratio", 0.2)
    assert ratio.passes(1.2, 1.0) and ratio.passes(0.8, 1.0)
    assert not ratio.passes(1.21, 1.0) and not ratio.passes(1.0, 0.0)
    assert not ratio.passes(math.nan, 1.0)  # a figure that could not be measured fails
    diff = v.Target("difference", 0.5)
    assert diff.passes(10.4, 10.0) and diff.passes(9.5, 10.0) and not diff.passes(10.6, 10.0)
    assert v.NO_TARGET.passes(1.0, 100.0) is None
    assert ratio.describe("m/s") == "ratio 0.80–1.20"
    assert diff.describe("deg") == "within 0.5 deg"
    with pytest.raises(ValueError, match="ratio, difference or none"):
        v.Target("percent", 5.0)


def test_comparison_rows_and_tally() -> None:
    rows = [
        v.Comparison("climb", "m/s", 5.26, 3.80, v.Target("ratio", 0.2), note="at 40 m/s"),
        v.Comparison("alpha", "deg", 1.92, 1.48, v.Target("difference", 0.5)),
        v.Comparison("period", "s", 25.6, 24.8, digits=1),
        v.Comparison("stall", "m/s", math.nan, 26.7, v.Target("ratio", 0.05)),
    ]
    table = v.table_rows(rows)
    assert table[0] == (
        "climb",
        "ours 5.26 m/s, JSBSim 3.80 m/s, ratio 1.384 (at 40 m/s)",
        "ratio 0.80–1.20: FAIL",
    )
    assert table[1] == (
        "alpha",
        "ours 1.92 deg, JSBSim 1.48 deg, ratio 1.297, difference +0.44 deg",
        "within 0.5 deg: PASS",
    )
    assert table[2] == ("period", "ours 25.6 s, JSBSim 24.8 s, ratio 1.032", "")
    assert table[3][1] == "ours n/a m/s, JSBSim 26.70 m/s, ratio n/a"
    assert table[3][2].endswith("FAIL")
    assert v.tally(rows) == (1, 3)
    physics = v.Comparison(
        "turn", "m", 443.7, 441.4, subject_name="JSBSim", reference_name="V²/(g tan φ)", digits=1
    )
    assert physics.row()[1] == "JSBSim 443.7 m, V²/(g tan φ) 441.4 m, ratio 1.005"


def test_script_without_jsbsim_says_how_to_install_and_exits_2(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from benchmarks import validate_jsbsim as script

    monkeypatch.setattr(script.importlib.util, "find_spec", lambda name: None)
    assert script.main(["--no-record"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "pip install -e '.[validate]'" in err and "pip install jsbsim" in err


def test_search_helpers_on_a_model_with_a_known_envelope() -> None:
    """stall_and_top / steepest / best_climb on a toy model whose envelope is known exactly:
    level flight trims for 27 <= V <= 61; the steepest climb is sin(gamma) = c(V) / V with
    c(V) = max(4 - (V - 38)^2 / 50, 0) (m/s), so the best climb is 4 m/s at 38 m/s."""
    from benchmarks import validate_jsbsim as script

    class Toy:
        name, g = "toy", 9.81

        def trims(self, airspeed: float, altitude: float, gamma: float) -> bool:
            if not 27.0 <= airspeed <= 61.0:
                return False
            c = max(4.0 - (airspeed - 38.0) ** 2 / 50.0, 0.0)
            return airspeed * math.sin(gamma) <= c and gamma >= -0.1

    toy = Toy()
    lo, hi = script.stall_and_top(toy, 0.0, 1e-3)
    assert abs(lo - 27.0) < 1e-3 and abs(hi - 61.0) < 1e-3
    plan = script.Plan(gamma_tol=1e-7, scan_tol=1e-3)
    rate, speed = script.best_climb(toy, 0.0, plan)
    assert abs(rate - 4.0) < 1e-4 and abs(speed - 38.0) < 0.01
    assert math.isnan(script.steepest(toy, 20.0, 0.0, 1e-4, +1))
    assert abs(script.steepest(toy, 40.0, 0.0, 1e-7, -1) + 0.1) < 1e-6


def test_elevator_norm_matches_the_c172p_surface_scale() -> None:
    from benchmarks import validate_jsbsim as script

    assert script._elevator_norm(23.0) == 1.0 and script._elevator_norm(-28.0) == -1.0
    assert script._elevator_norm(0.0) == 0.0 and script._elevator_norm(-14.0) == -0.5


def test_jsbsim_c172p_is_loaded_to_2300_lb() -> None:
    pytest.importorskip("jsbsim")
    from benchmarks import validate_jsbsim as script

    ref = script.Jsbsim()
    assert ref["inertia/weight-lbs"] == pytest.approx(2300.0)
    level = ref.level(50.0, 0.0)
    assert level is not None and 0.0 < level.alpha_deg < 3.0 and ref.held()
