"""What the planner must know of the aircraft to plan a path it can fly.

A :class:`Performance` is the few numbers of a vehicle that make a path flyable or not: cruise
airspeed, the sustained climb and descent rates at that speed, the bank limit and the ceiling at
that speed (where the vehicle knows it: the altitude above which it climbs less than 0.5 m/s, or
flies slower than its envelope: ``terrapath plan`` prints it beside the limits). The planner
turns them into the limits it checks, each with a margin so the 6-DOF aircraft under its autopilot
(``replay/``) flies what was planned rather than just failing to:

- climb gradient ``climb_fraction * climb_rate / V`` and descent gradient
  ``climb_fraction * descent_rate / V`` (default fraction 0.8: the autopilot commands at most 95 %
  of the limits and needs some authority left to catch up after a transient);
- turns are planned as fillets of radius ``R = V^2 / (g tan(turn_bank_fraction * bank_max))``
  (default fraction 0.8, i.e. 24 deg for a 30 deg limit: the orbit follower keeps 6 deg of bank to
  correct with); ``R_min = V^2 / (g tan(bank_max))`` is seed 000's eq. 13, the tightest turn.

The planner is below ``replay/`` in the import order, so it cannot read vehicle presets itself:
``replay.flight.fixedwing.params.VehicleParams.performance()`` builds one from a vehicle, and the CLI and
the planning pipeline pass it down.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from terrain.errors import InputError

G = 9.81  # m/s^2, as replay/flight/fixedwing/params.py (seed 000 eq. 13)
CLIMB_FRACTION = 0.8
TURN_BANK_FRACTION = 0.8
# without a vehicle model: the climb in the planned turn as a share of the straight climb (the
# aerosonde's at 24 deg bank is 0.95-0.97 of it from 3,000 to 4,500 m)
TURN_CLIMB_SHARE = 0.9
# a multirotor's planned gradient: it climbs on the spot, so any (large and finite, so the
# flown-path arithmetic stays finite)
HOVER_GRADIENT = 1e6


@dataclass(frozen=True)
class Performance:
    """Cruise airspeed (m/s), sustained climb / descent rates at it (m/s), bank limit (deg);
    ``ceiling`` (m AMSL) at that airspeed, ``inf`` where not known."""

    name: str
    speed: float
    climb_rate: float
    descent_rate: float
    bank_max_deg: float
    climb_fraction: float = CLIMB_FRACTION
    turn_bank_fraction: float = TURN_BANK_FRACTION
    ceiling: float = math.inf
    # the climb rate (m/s) it sustains in a helix of the planned turn radius (a climb spiral,
    # planner.spiral): less than in straight flight (the bank's induced drag); None: unknown,
    # taken as ``turn_climb_share`` of the straight climb
    turn_climb_rate: float | None = None
    # a multirotor: it climbs and descends on the spot at its rates (any gradient), stops to
    # turn (no fillets), and flies no spirals
    hover: bool = False
    # the strongest horizontal wind the plan is made for (m/s; plan --wind): the gradients are
    # over the ground at the fastest ground speed (downwind, V + w: the shallowest a climb or a
    # descent gets), the fillets and spirals wide enough for the bank at that speed
    wind: float = 0.0

    def __post_init__(self) -> None:
        for fld in ("speed", "climb_rate", "descent_rate", "bank_max_deg"):
            v = getattr(self, fld)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise InputError(f"{self.name}: {fld} must be a finite number; got {v!r}")
            if v <= 0:
                raise InputError(f"{self.name}: {fld} must be > 0; got {v!r}")
            object.__setattr__(self, fld, float(v))
        if not self.bank_max_deg < 90.0:
            raise InputError(f"{self.name}: bank_max_deg must be below 90; got {self.bank_max_deg}")
        if math.isnan(self.ceiling):
            raise InputError(f"{self.name}: ceiling must be a number of metres or inf; got nan")
        if isinstance(self.wind, bool) or not (
            isinstance(self.wind, int | float) and 0.0 <= self.wind < self.speed
        ):
            raise InputError(
                f"{self.name}: the wind planned for must be >= 0 m/s and slower than its "
                f"{self.speed:g} m/s; got {self.wind!r}"
            )
        for fld in ("climb_fraction", "turn_bank_fraction"):
            v = getattr(self, fld)
            if not (isinstance(v, int | float) and 0.0 < v <= 1.0):
                raise InputError(f"{self.name}: {fld} must lie in (0, 1]; got {v!r}")

    @property
    def climb_gradient(self) -> float:
        """Steepest planned climb, metres up per metre of horizontal travel (a multirotor:
        ``HOVER_GRADIENT``, any: it slows down and climbs on the spot)."""
        if self.hover:
            return HOVER_GRADIENT
        return self.climb_fraction * self.climb_rate / self.ground_speed

    @property
    def descent_gradient(self) -> float:
        """Steepest planned descent, metres down per metre of horizontal travel."""
        if self.hover:
            return HOVER_GRADIENT
        return self.climb_fraction * self.descent_rate / self.ground_speed

    @property
    def ground_speed(self) -> float:
        """The fastest ground speed the plan allows for: the airspeed plus the wind."""
        return self.speed + self.wind

    @property
    def turn_climb_gradient(self) -> float:
        """Steepest planned climb in a climb spiral (metres up per metre flown round it): the
        climb fraction of the climb in the banked turn (:attr:`turn_climb_rate`; without it,
        ``TURN_CLIMB_SHARE`` of the straight climb), never more than the straight one."""
        rate = self.turn_climb_rate
        if rate is None:
            rate = TURN_CLIMB_SHARE * self.climb_rate
        return self.climb_fraction * min(rate, self.climb_rate) / self.ground_speed

    @property
    def turn_bank_deg(self) -> float:
        return self.turn_bank_fraction * self.bank_max_deg

    @property
    def turn_radius(self) -> float:
        """Radius of the planned turn fillets (m); 0 for a multirotor (it stops to turn)."""
        if self.hover:
            return 0.0
        return self.ground_speed**2 / (G * math.tan(math.radians(self.turn_bank_deg)))

    @property
    def min_turn_radius(self) -> float:
        """V^2 / (g tan(bank_max)): the tightest turn at cruise (seed 000 eq. 13); in a wind
        at the fastest ground speed, V + w."""
        return self.ground_speed**2 / (G * math.tan(math.radians(self.bank_max_deg)))

    def describe(self) -> str:
        """One line for messages: the limits the plan is held to (the climb as the violation
        messages of ``planner.result`` state it), and the ceiling at this speed where known."""
        ceiling = f", ceiling {self.ceiling:,.0f} m" if math.isfinite(self.ceiling) else ""
        if self.hover:
            return (
                f"{self.name} at {self.speed:g} m/s: climbs {self.climb_rate:g} m/s and descends "
                f"{self.descent_rate:g} m/s on the spot (any gradient), stops to turn (no "
                f"fillets){ceiling}"
            )
        wind = f" in up to {self.wind:g} m/s of wind (over the ground)" if self.wind else ""
        return (
            f"{self.name} at {self.speed:g} m/s{wind}: climb <= {100 * self.climb_gradient:.1f} % "
            f"({self.climb_fraction:g} x {self.climb_rate:g} m/s), descent <= "
            f"{100 * self.descent_gradient:.1f} %, turns of radius {self.turn_radius:.0f} m "
            f"({self.turn_bank_deg:.0f} deg bank){ceiling}"
        )

    def as_dict(self) -> dict[str, float | str]:
        """Plain data for the mission's provenance (the ceiling where known)."""
        out: dict[str, float | str] = {
            "vehicle": self.name,
            "speed": self.speed,
            "climb_rate": self.climb_rate,
            "descent_rate": self.descent_rate,
            "bank_max_deg": self.bank_max_deg,
            "climb_gradient": round(self.climb_gradient, 5),
            "descent_gradient": round(self.descent_gradient, 5),
            "turn_radius": round(self.turn_radius, 2),
            "turn_bank_deg": round(self.turn_bank_deg, 3),
        }
        if math.isfinite(self.ceiling):
            out["ceiling"] = self.ceiling
        if self.wind:
            out["wind"] = self.wind
        if self.hover:
            out["hover"] = True
            for k in ("climb_gradient", "descent_gradient", "turn_bank_deg"):
                out.pop(k)
            return out
        if self.turn_climb_rate is not None:
            out["turn_climb_rate"] = round(self.turn_climb_rate, 4)
        out["turn_climb_gradient"] = round(self.turn_climb_gradient, 5)
        return out


def ground_speed(
    horizontal: float, wind_ne: tuple[float, float], direction: npt.ArrayLike
) -> float:
    """The ground speed (m/s) along the unit horizontal ``direction`` (map x east, y north) of
    an aircraft whose speed through the air is ``horizontal`` m/s horizontally, crabbed into the
    wind ``(north, east)`` m/s: the air's speed less the cross wind, plus the along wind."""
    e = np.asarray(direction, dtype=np.float64)
    wn, we = (float(v) for v in wind_ne)
    along = we * e[0] + wn * e[1]
    across = -we * e[1] + wn * e[0]
    return math.sqrt(max(horizontal * horizontal - across * across, 0.0)) + along
