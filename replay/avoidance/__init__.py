"""Online avoiders: one interface (:class:`replay.avoidance.base.Avoider`), one module each."""

from replay.avoidance.base import (
    AVOIDERS,
    AvoidanceContext,
    AvoidanceDecision,
    Avoider,
    NoAvoidance,
    make_avoider,
)

__all__ = [
    "AVOIDERS",
    "AvoidanceContext",
    "AvoidanceDecision",
    "Avoider",
    "NoAvoidance",
    "make_avoider",
]
