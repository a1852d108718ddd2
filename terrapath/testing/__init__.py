"""The contracts terrapath's own algorithms pass, as a kit for a plugin's test suite (issue 39).

A plugin's tests subclass a contract and name what they test; pytest runs every inherited test::

    from terrapath.testing import AvoiderContract, OptimizerContract

    class TestSidestep(AvoiderContract):
        avoider = "sidestep"             # the name its entry point registers

    class TestMyOptimizer(OptimizerContract):
        NAME = "my-opt"                  # built with terrapath's make_optimizer
        SPHERE_BOUND = 1e-3              # what it promises on the stated budget
        RASTRIGIN_BOUND = 40.0

- :class:`AvoiderContract` (:mod:`terrapath.testing.avoider`): fixed scenarios on flat ground --
  one obstacle on the path, two, one beside a waypoint, a hill, a head-on and a crossing
  intruder -- each flown to the goal outside every safety volume, and the same flight again from
  the same seed, bit for bit.
- :class:`ReferenceContract` (:mod:`terrapath.testing.reference`): the outcomes on the
  reference maps (a real map's golden plan with pop-up threats) meet a baseline, as
  ``terrapath regress`` judges them (the plugin's own baseline, or terrapath's).
- :class:`OptimizerContract` (:mod:`terrapath.testing.optimizer`): the same seed gives the same
  result, every evaluated point inside the bounds, best-so-far history, step-by-step equals a
  run, seed points used, a typed result, stated bounds on the sphere and Rastrigin.

terrapath's own tests are users of this kit (tests/test_avoidance_contract.py,
tests/test_optimizers.py): there is one copy of each contract.  The kit needs pytest (the
``test`` extra) and nothing of pytest beyond ``parametrize`` and ``skip``.
"""

from terrapath.testing.avoider import AvoiderContract
from terrapath.testing.optimizer import OptimizerContract
from terrapath.testing.reference import ReferenceContract

__all__ = ["AvoiderContract", "OptimizerContract", "ReferenceContract"]
