"""The one validity layer (terrain.validity): points and legs against the map, unknown terrain,
terrain clearance, danger zones and moving volumes."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pytest
from affine import Affine

from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrain.validity import ValidityChecker
from terrain.zones import DangerZone, PolygonZone

CELL = 100.0


@pytest.fixture(scope="module")
def grid() -> HeightGrid:
    """2 km x 1 km, flat at 100 m except a 300 m block; cells (row 4, cols 10-11) unmeasured."""
    h = np.full((10, 20), 100.0, np.float32)
    h[2:4, 5:7] = 300.0
    known = np.ones((10, 20), bool)
    known[4, 10:12] = False
    return HeightGrid(h, Affine(CELL, 0, 0, 0, -CELL, 1000), None, known=known)


class Ring:
    """A volume that moves: a sphere of radius 50 m centred at (500 + 10 t, 500, 200)."""

    def separations(
        self, points: np.ndarray, times: np.ndarray
    ) -> tuple[Sequence[str], np.ndarray]:
        c = np.column_stack(
            [500 + 10 * times, np.full(len(times), 500.0), np.full(len(times), 200.0)]
        )
        return ["ring"], (np.linalg.norm(points - c, axis=1) - 50.0)[:, None]


def test_each_component_of_a_point(grid: HeightGrid) -> None:
    zone = DangerZone(1500, 200, 200, top=400, id="v")
    chk = ValidityChecker(
        grid=grid, ground=grid.height_at, terrain_clearance=50, zones=[zone], volumes=Ring()
    )
    pts = np.array(
        [
            [150, 850, 200],  # clear: 50 m above terrain + clearance
            [550, 750, 320],  # over the block: 20 m above it, 30 m short of the clearance
            [-10, 500, 500],  # off the map (10 m west)
            [1050, 550, 500],  # over unmeasured cell (row 4, col 10)
            [1500, 200, 300],  # inside the zone, 100 m from its wall
            [700, 500, 200],  # inside the ring at t = 20 (centre 700)
        ]
    )
    pv = chk.points(pts, np.array([0, 0, 0, 0, 0, 20.0]))
    np.testing.assert_allclose(pv.terrain[[0, 1]], [50.0, -30.0])
    assert pv.on_map.tolist() == [True, True, False, True, True, True]
    assert pv.known.tolist() == [True, True, True, False, True, True]
    assert pv.zones[4, 0] == pytest.approx(-100.0)
    assert pv.volume_ids == ("ring",) and pv.volumes[5, 0] == pytest.approx(-50.0)
    assert pv.valid.tolist() == [True, False, False, False, False, False]
    c = pv.clearance
    assert c[0] == pytest.approx(50.0) and c[1] == pytest.approx(-30.0)
    assert c[2] == c[3] == -math.inf
    # unknown terrain allowed: only the terrain under it constrains that point
    allowed = ValidityChecker(grid=grid, allow_unknown=True)
    assert allowed.is_valid(pts[[3]]).tolist() == [True]
    assert allowed.is_valid(pts[[2]]).tolist() == [False]  # off the map never is


def test_a_leg_that_cuts_a_zone_between_samples_is_invalid(grid: HeightGrid) -> None:
    """The zone is checked exactly: a leg grazing a 20 m-wide corner of a polygon, sampled every
    25 m with every sample outside it, is still invalid, and its clearance is negative."""
    corner = PolygonZone.from_vertices([[1000, 100], [1010, 110], [1020, 100]], id="tip")
    chk = ValidityChecker(grid=grid, zones=[corner], step=25.0)
    a, b = np.array([[990.0, 105.0, 200.0]]), np.array([[1030.0, 105.0, 200.0]])
    assert chk.points(np.vstack([a, b])).valid.all()
    sv = chk.segments(a, b)
    assert not sv.valid[0]
    assert sv.zone_lengths[0, 0] == pytest.approx(10.0)
    assert sv.clearance[0] <= -10.0
    # above the zone's top the same leg is valid
    high = ValidityChecker(grid=grid, zones=[PolygonZone.from_vertices(corner.rings[0], top=150)])
    assert high.segments(a, b).valid[0]


def test_legs_off_the_map_and_over_unknown_terrain(grid: HeightGrid) -> None:
    chk = ValidityChecker(grid=grid)
    a = np.array([[1900.0, 500.0, 500.0], [900.0, 550.0, 500.0], [100.0, 100.0, 500.0]])
    b = np.array([[2100.0, 500.0, 500.0], [1300.0, 550.0, 500.0], [300.0, 100.0, 500.0]])
    sv = chk.segments(a, b)
    np.testing.assert_allclose(sv.off_map_lengths, [100.0, 0.0, 0.0])
    assert sv.on_map.tolist() == [False, True, True]
    assert sv.known.tolist() == [True, False, True]
    assert sv.unknown_lengths[1] == pytest.approx(200.0, abs=CELL / 2)  # two cells of 100 m
    assert sv.valid.tolist() == [False, False, True]
    assert sv.clearance[0] == sv.clearance[1] == -math.inf
    # the candidate check without clearances gives the same verdicts
    fast = chk.segments(a, b, clearance=False)
    assert fast.valid.tolist() == sv.valid.tolist() and np.isnan(fast.clearance).all()


def test_a_leg_through_terrain_or_a_volume(grid: HeightGrid) -> None:
    chk = ValidityChecker(grid=grid, ground=grid.height_at, terrain_clearance=50, volumes=Ring())
    a = np.array([[100.0, 750.0, 200.0], [100.0, 500.0, 200.0]])
    b = np.array([[1000.0, 750.0, 200.0], [1000.0, 500.0, 200.0]])
    sv = chk.segments(a, b, t=0.0)
    assert sv.terrain_ok.tolist() == [False, True]  # row 2-3 carries the 300 m block
    assert sv.volumes_ok.tolist() == [True, False]  # through the ring at x = 500
    assert sv.valid.tolist() == [False, False]
    assert sv.clearance[1] == pytest.approx(-50.0, abs=1.0)
    # later the ring has moved east beyond the leg's end
    assert chk.segments(a[1:], b[1:], t=60.0).valid.tolist() == [True]


def test_without_a_grid_nothing_constrains() -> None:
    chk = ValidityChecker()
    pts = np.array([[-1e6, 1e6, -50.0]])
    assert chk.is_valid(pts).tolist() == [True] and chk.clearance(pts)[0] == math.inf
    assert chk.segments(pts, pts + 1000).valid.tolist() == [True]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"terrain_clearance": -1}, "terrain clearance must be a number of metres >= 0"),
        ({"zone_margin": math.nan}, "zone margin must be a number of metres >= 0"),
        ({"step": 0}, "step must be a positive number"),
    ],
)
def test_bad_settings_are_refused(kwargs: dict[str, float], message: str) -> None:
    with pytest.raises(InputError, match=message):
        ValidityChecker(**kwargs)  # type: ignore[arg-type]


def test_bad_points_are_refused() -> None:
    with pytest.raises(InputError, match=r"points must have shape \(N, 3\)"):
        ValidityChecker().points(np.zeros((2, 2)))
