"""The aircraft a replay flies: flight stacks (a 6-DOF model and the controller that flies it)
behind one protocol (:mod:`replay.flight.base`), the flight log (:mod:`replay.flight.log`), the
atmosphere, and one subpackage per kind: :mod:`replay.flight.fixedwing`, :mod:`replay.flight.multirotor`."""
