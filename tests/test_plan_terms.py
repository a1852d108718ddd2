"""The planner's optional cost terms (issue 20): an above-ground band, a preferred height above
the ground (SPSO's altitude term) and a smoothness term (SPSO's J4), each reported like the
others; and the bad input each refuses."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from planner.cost import smoothness_of
from planner.performance import Performance
from planner.plan import plan
from planner.problem import PlanningProblem
from terrain.errors import InputError
from terrapath.cli import main
from tests.conftest import DATA_MAPS, make_grid

PERF = Performance("test", 25.0, 5.0, 3.0, 30.0)


def _ridge() -> np.ndarray:
    """A 6 km square (50 m cells, north up), flat at 0 m but for a ridge across it: rising from
    y = 0.8 km to 150 m at y = 2.8 km (7.5 %), flat to y = 3.2 km, falling to 0 at y = 5.2 km."""
    y = 6000.0 - (np.arange(120) + 0.5) * 50.0  # cell centres, north first
    h = np.clip(np.minimum(y - 800.0, 5200.0 - y) * 0.075, 0.0, 150.0)
    return np.repeat(h[:, None], 120, axis=1)


def _problem(**kw: object) -> PlanningProblem:
    grid = make_grid(_ridge(), cell=50.0, x0=0.0, y0=6000.0)
    start, goal = np.array([3000.0, 500.0, 100.0]), np.array([3000.0, 5500.0, 100.0])
    opts: dict[str, object] = {"clearance": 20.0, "performance": PERF, "zmax": 800.0}
    opts.update(kw)
    return PlanningProblem(grid, start, goal, 4, **opts)  # type: ignore[arg-type]


def test_smoothness_is_the_mean_turn_and_climb_change_in_units_of_pi() -> None:
    straight = np.array([[[0, 0, 0], [0, 100, 0], [0, 200, 0]]], dtype=float)
    assert smoothness_of(straight, 1.0)[0] == 0.0
    corner = np.array([[[0, 0, 0], [0, 100, 0], [100, 100, 0]]], dtype=float)
    assert smoothness_of(corner, 1.0)[0] == pytest.approx(0.5)  # 90 deg at the one vertex
    assert smoothness_of(corner, 0.2)[0] == pytest.approx(0.1)
    climb = np.array([[[0, 0, 0], [0, 100, 100], [0, 200, 100]]], dtype=float)
    assert smoothness_of(climb, 1.0)[0] == pytest.approx(0.25)  # 45 deg climb, then level
    zigzag = np.array([[[0, 0, 0], [100, 100, 0], [0, 200, 0], [100, 300, 0]]], dtype=float)
    assert smoothness_of(zigzag, 1.0)[0] == pytest.approx(0.5)  # two 90 deg turns, mean 0.5
    assert smoothness_of(zigzag, 0.0)[0] == 0.0


def test_a_smoothness_weight_makes_the_plan_turn_less() -> None:
    plain = plan(_problem(), "ampso", seed=0, population=30, iterations=80)
    smooth = plan(_problem(smoothness=1.0), "ampso", seed=0, population=30, iterations=80)
    assert plain.terms["smoothness"] == 0.0 and smooth.terms["smoothness"] > 0.0
    assert smooth.feasible
    w = smooth.waypoints[None]
    assert smoothness_of(w, 1.0)[0] <= smoothness_of(plain.waypoints[None], 1.0)[0] + 1e-9
    assert smooth.terms["smoothness"] == pytest.approx(smoothness_of(w, 1.0)[0])


def test_the_band_top_is_a_hard_limit_checked_densely_on_the_flown_path() -> None:
    """Flown level at 350 m the aircraft is 350 m above the plain: with the band topped at 120 m
    above the ground the plan must follow the ridge up and down (within 20-120 m of it)."""
    pr = _problem(agl_max=120.0)
    high = np.array([[3000, 1500, 350, 3000, 2500, 350, 3000, 3500, 350, 3000, 4500, 350]], float)
    terms = pr.terms(high)
    assert terms.above_length[0] > 0 and terms.above[0] > 3.0 and not pr.feasible(terms)[0]
    r = plan(pr, "ampso", seed=0, population=40, iterations=150)
    assert r.feasible and r.terms["above_band_m"] == 0.0
    assert r.terms["max_above_ground_m"] <= 120.0 and r.terms["min_clearance_m"] >= 20.0
    assert r.waypoints[:, 2].max() > 150.0  # it went up the ridge
    from planner.result import find_violations

    found = find_violations(pr, pr.paths(high[0]))
    above = [v for v in found if v.kind == "above_band"]
    assert above and "more than --agl-max 120 m above the ground" in above[0].detail


def test_the_preferred_height_replaces_the_altitude_term() -> None:
    pr = _problem(agl_pref=100.0)
    low = np.array([[3000, 1500, 100, 3000, 2000, 100, 3000, 4000, 100, 3000, 4500, 100]], float)
    t = pr.terms(low)
    assert t.altitude[0] == 0.0  # replaced
    band = pr.band[1] - pr.band[0]
    # 100 m above the plain, but under the ridge's 300 m for the 1 km across it: the cost also
    # collides; the preferred-height term is the mean |h - 100| over the path
    assert t.preferred[0] > 0.0
    flat = _problem(agl_pref=150.0)
    t2 = flat.terms(low)
    assert t2.preferred[0] > t.preferred[0] - 1e-12
    assert 0.0 < t2.preferred[0] < 400.0 / band


@pytest.mark.parametrize(
    ("kw", "message"),
    [
        (
            {"agl_max": 15.0},
            r"above-ground band is empty: --agl-max 15 m is not above its floor, 20",
        ),
        ({"agl_min": 300.0, "agl_max": 200.0}, r"band is empty: --agl-max 200 m .* floor, 300 m"),
        (
            {"agl_pref": 500.0, "agl_max": 400.0},
            r"--agl-pref 500 m lies outside the above-ground band \(\[20, 400\] m\)",
        ),
        (
            {"agl_pref": 10.0},
            r"--agl-pref 10 m lies outside the above-ground band \(at least 20 m\)",
        ),
        ({"agl_min": -1.0}, r"--agl-min must be a height above the ground in metres >= 0"),
        ({"smoothness": -0.5}, r"--smoothness must be a weight >= 0"),
        ({"agl_max": 60.0}, r"start .* 100 m above the ground, above --agl-max 60 m"),
        ({"agl_min": 50.0, "zmax": 40.0}, r"above-ground band lies above the altitude band"),
    ],
)
def test_bad_bands_are_refused_naming_the_option(kw: dict[str, float], message: str) -> None:
    with pytest.raises(InputError, match=message) as err:
        _problem(**kw)
    assert "\n" not in str(err.value)


def test_terrapath_plan_takes_and_reports_the_terms(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    dem = str(DATA_MAPS / "mpl_jacksboro_fault" / "jacksboro_fault_dem.tif")
    out = tmp_path / "m.yaml"
    args = ["plan", dem, "--start=-84.40,36.46", "--goal=-84.10,36.72", "--agl-max", "400"]
    args += ["--agl-pref", "200", "--smoothness", "0.2", "-o", str(out)]
    assert main(args) in (0, None)
    text = capsys.readouterr().out
    assert "preferred height" in text and "smoothness" in text and "feasible" in text
    assert main([*args[:-2], "--agl-max", "40", "-o", str(tmp_path / "x.yaml")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "above-ground band is empty" in err
    assert not (tmp_path / "x.yaml").exists()


# -- local DEMs whose cells are not metres -------------------------------------------------------
def _local_tif(path: Path, heights: np.ndarray) -> Path:
    """A GeoTIFF without a CRS, one unit per cell (a picture's pixels), origin at the top left."""
    import rasterio
    from affine import Affine

    with rasterio.open(path, "w", driver="GTiff", height=heights.shape[0], width=heights.shape[1],
                       count=1, dtype="float32", transform=Affine(1, 0, 0, 0, -1, 0)) as dst:  # fmt: skip
        dst.write(heights.astype(np.float32), 1)
    return path


def test_a_local_cell_size_scales_a_dem_without_a_crs_and_is_refused_otherwise(
    tmp_path: Path,
) -> None:
    from terrain.load import load_dem

    tif = _local_tif(tmp_path / "pixels.tif", np.arange(200.0).reshape(10, 20))
    units = load_dem(str(tif))
    metres = load_dem(str(tif), local_cell_size=5.0)
    assert units.cell_size == (1.0, 1.0) and metres.cell_size == (5.0, 5.0)
    assert metres.bounds == tuple(5.0 * b for b in units.bounds) == (0.0, -50.0, 100.0, 0.0)
    np.testing.assert_array_equal(metres.heights, units.heights)  # heights stay metres
    geo = str(DATA_MAPS / "mpl_jacksboro_fault" / "jacksboro_fault_dem.tif")
    with pytest.raises(InputError, match=r"is georeferenced \(EPSG:4326\): its cells already"):
        load_dem(geo, local_cell_size=5.0)
    with pytest.raises(InputError, match="give --local-cell-size or --cell-size, not both"):
        load_dem(str(tif), local_cell_size=5.0, cell_size=10.0)
    with pytest.raises(InputError, match="--local-cell-size must be a positive number"):
        load_dem(str(tif), local_cell_size=-1.0)


def test_a_plan_on_a_local_dem_reports_metres_and_its_mission_reloads_the_same_grid(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from planner.mission import load_mission

    tif = _local_tif(tmp_path / "pixels.tif", np.zeros((100, 100)))
    out = tmp_path / "m.yaml"
    args = ["plan", str(tif), "--map-coords", "--start=50,-500,100", "--goal=950,-500,100"]
    args += [
        "--local-cell-size",
        "10",
        "--vehicle",
        "small-uas",
        "--clearance",
        "10",
        "-o",
        str(out),
    ]
    assert main(args) in (0, None), capsys.readouterr().err
    m = load_mission(out)
    assert m.terrain is not None and m.terrain.local_cell_size == 10.0
    grid = m.terrain.load()
    assert grid.cell_size == (10.0, 10.0) and grid.bounds == (0.0, -1000.0, 1000.0, 0.0)
    length = float(np.linalg.norm(np.diff(m.waypoints[:, :2], axis=0), axis=1).sum())
    assert 900.0 <= length < 1100.0  # 900 m straight: the plan is in metres, not cells


@pytest.mark.parametrize("kw", [{}, {"smoothness": 0.5}, {"zones": ()}])
def test_a_path_s_cost_does_not_depend_on_the_other_paths_of_the_call(kw: dict) -> None:
    """``rowwise`` (issue 38: the optimisers batch their calls on it): each row's terms are the
    same bits alone, in a slice, or behind other rows; not so with the above-ground terms."""
    problem = _problem(**kw)
    assert problem.rowwise
    assert not _problem(agl_max=300.0).rowwise and not _problem(agl_pref=60.0).rowwise
    lo, hi = problem.bounds()
    rng = np.random.default_rng(2)
    X = lo + rng.random((37, lo.size)) * (hi - lo)
    whole = problem(X)
    np.testing.assert_array_equal(problem(X[:5]), whole[:5])
    np.testing.assert_array_equal(problem(X[30:]), whole[30:])
    np.testing.assert_array_equal(problem(np.concatenate([X[7:9], X])), np.r_[whole[7:9], whole])
    for i in (0, 13, 36):
        assert problem(X[i : i + 1])[0] == whole[i]
