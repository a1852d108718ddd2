"""Online avoiders: one interface (:class:`replay.avoidance.base.Avoider`), one module each, listed
in an explicit table (:mod:`replay.avoidance.registry`)."""

from replay.avoidance.base import AvoidanceContext, Avoider, AvoiderBase, NoAvoidance
from replay.avoidance.registry import AVOIDERS, avoider_options, make_avoider
from replay.guidance import AvoidanceDecision

__all__ = [
    "AVOIDERS",
    "AvoidanceContext",
    "AvoidanceDecision",
    "Avoider",
    "AvoiderBase",
    "NoAvoidance",
    "avoider_options",
    "make_avoider",
]
