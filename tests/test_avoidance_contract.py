"""The contract every avoider passes, on outcomes only (issue 13): terrapath's built-ins as users of
the test kit plugins use (:class:`terrapath.testing.AvoiderContract`, whose docstring says what
it flies and asserts).  Every registered built-in but ``none`` (the baseline the kit proves
each scenario a threat with) is under contract: a new one joins by registering (a test below
fails until it has its class here).  Hover-only avoiders (the priority loop) cannot fly the
kit's fixed-wing scenarios; they must refuse the fixed wing before the flight instead, and have
scenarios of their own.
"""

from __future__ import annotations

import numpy as np
import pytest

from replay.avoidance import AVOIDERS, make_avoider
from replay.avoidance.registry import avoider_class
from replay.flight.fixedwing.presets import load_vehicle
from terrain.errors import InputError
from terrapath.testing import AvoiderContract
from terrapath.testing.avoider import SCENARIOS, STRAIGHT, R, flown

HOVER_ONLY = sorted(name for name in AVOIDERS if getattr(avoider_class(name), "hover_only", False))
AVOIDERS_UNDER_TEST = sorted(name for name in AVOIDERS if name != "none" and name not in HOVER_ONLY)


class TestPsoCa(AvoiderContract):
    avoider = "pso-ca"


class TestCtga(AvoiderContract):
    avoider = "ctga"


class TestFga(AvoiderContract):
    avoider = "fga"


def test_every_registered_avoider_but_none_is_under_contract() -> None:
    under = sorted(c.avoider for c in (TestPsoCa, TestCtga, TestFga))
    assert under == AVOIDERS_UNDER_TEST
    assert sorted(AVOIDERS_UNDER_TEST + HOVER_ONLY) == sorted(set(AVOIDERS) - {"none"})
    for c in (TestPsoCa, TestCtga, TestFga):  # every scenario promised
        assert c.scenarios == tuple(SCENARIOS)


@pytest.mark.parametrize("avoider", HOVER_ONLY)
def test_hover_only_avoiders_refuse_the_fixed_wing(avoider: str) -> None:
    """A hover-only avoider says before the flight that the contract's aircraft cannot hover."""
    with pytest.raises(InputError, match="cannot hover"):
        make_avoider(avoider).check_vehicle(load_vehicle("solar-uav"), 15.0)


# -- PSO-CA's own way of getting there (seed 000 specifics, not part of the contract) ---------------
@pytest.mark.parametrize("scenario", ["single", "two", "near-waypoint", "hill", "head-on-intruder"])
def test_pso_ca_replans_waypoints_without_wild_detours(scenario: str) -> None:
    r = flown(scenario, "pso-ca")  # the flight the contract's goal test judged
    met = r.metrics
    assert met.decisions >= 1 and not np.array_equal(r.waypoints, r.initial_waypoints)
    if scenario == "near-waypoint":  # Fig. 9 / 23: the unsafe waypoint is replaced, not kept
        o = np.array(SCENARIOS[scenario][0]["position"][:2])
        assert np.hypot(*(r.waypoints[:, :2] - o).T).min() > R
    assert met.plr < 1.25  # no wild detour (path-length ratio of the flown track)
    np.testing.assert_allclose(r.waypoints[-1], STRAIGHT[-1])  # the goal is still the mission's
