"""The energy a mission needs: the battery's energy or the fuel, leg by leg, against what the
aircraft carries.

The planner is below ``replay/`` in the import order, so it does not know the aircraft's
propulsion: an :class:`EnergyModel` is the vehicle's performance model reduced to a table --
what its source gives per second (battery power in W, or fuel flow in kg/h) in steady flight at
the cruise airspeed, by altitude and climb rate, straight and in the planned turn -- built from
the 6-DOF model's trims by :func:`replay.flight.energy.energy_model` and passed down by the CLI.

:func:`mission_energy` integrates it along the path the aircraft flies
(:func:`planner.spiral.flown_path`: legs, the turn fillets, the helices of climb spirals and
loiters): each piece takes its length over the ground speed (in a wind, the air's horizontal
speed crabbed into the cross wind plus the along wind, ``planner.performance.ground_speed``),
climbs at its height change over that time, and draws the table's rate at its altitude and climb
rate (linear in both; climbs steeper than the table's fastest draw its full-throttle rate,
descents steeper than its steepest its idle rate), straight or turning. A multirotor's table is
by altitude and climb rate at its cruise speed along the leg, and on the spot for its vertical
legs. Not counted: the accelerations (the replay's transients), the ground run and taxi.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.interpolate import RegularGridInterpolator

from planner.performance import ground_speed
from planner.spiral import Spiral, flown_path

FloatArray = npt.NDArray[np.float64]
WH = 3600.0  # J per Wh
UNITS = {"battery": "Wh", "fuel": "kg"}  # a source's kind -> the unit of its capacity
WHAT = {"battery": "battery energy", "fuel": "fuel"}  # ... and what it is called


@dataclass(frozen=True, eq=False)
class EnergyModel:
    """What the aircraft's source gives per second in steady flight at ``speed`` m/s.

    ``kind`` ``"battery"`` (rates in W, capacity in Wh) or ``"fuel"`` (rates in kg/h, capacity
    in kg); ``capacity`` the usable amount it carries (0: not given, nothing to compare with).
    ``rate[i, j]`` at ``altitudes[i]`` (m AMSL) and ``climbs[j]`` (m/s, ascending) in straight
    flight, ``turn_rate[i, j]`` in the planned turn (``turn_bank_deg``); ``hover_rate[i, j]`` a
    multirotor's on the spot (None for a fixed wing)."""

    vehicle: str
    kind: str
    capacity: float
    speed: float
    altitudes: FloatArray
    climbs: FloatArray
    rate: FloatArray
    turn_rate: FloatArray
    turn_bank_deg: float = 0.0
    hover_rate: FloatArray | None = None
    source: str = ""

    @property
    def unit(self) -> str:
        return UNITS[self.kind]

    def per_second(self, altitude: float, climb: float, turning: bool = False) -> float:
        """The source's draw per second (Wh/s or kg/s) at ``altitude`` and ``climb`` m/s."""
        return self._lookup(self._tables[1 if turning else 0], altitude, climb)

    def hover_per_second(self, altitude: float, climb: float) -> float:
        """A multirotor's draw per second on the spot (Wh/s)."""
        return self._lookup(self._tables[2], altitude, climb)

    @cached_property
    def _tables(self) -> tuple[RegularGridInterpolator, ...]:
        """Bilinear interpolators of the straight, turning and on-the-spot rates (a fixed wing
        has no on-the-spot table: its straight one)."""
        hover = self.hover_rate if self.hover_rate is not None else self.rate
        grid = (self.altitudes, self.climbs)
        return tuple(RegularGridInterpolator(grid, t) for t in (self.rate, self.turn_rate, hover))

    def _lookup(self, table: RegularGridInterpolator, altitude: float, climb: float) -> float:
        a, c = self.altitudes, self.climbs
        h = min(max(altitude, float(a[0])), float(a[-1]))
        v = min(max(climb, float(c[0])), float(c[-1]))
        return float(table((h, v))) / 3600.0  # W -> Wh/s; kg/h -> kg/s


@dataclass(frozen=True)
class MissionEnergy:
    """A mission's need: per leg (``legs``, of the waypoint list; spirals counted in the leg
    they start), its time (s), the total, and the reserve left of the capacity."""

    kind: str
    unit: str
    capacity: float
    legs: tuple[float, ...]
    leg_seconds: tuple[float, ...]
    climb: float  # the share spent climbing (the rate beyond level flight's, summed)
    spirals: float  # the share flown in spirals and loiters

    @property
    def total(self) -> float:
        return float(sum(self.legs))

    def as_dict(self) -> dict[str, Any]:
        d = 3 if self.unit == "kg" else 1
        out: dict[str, Any] = {
            "kind": self.kind,
            "unit": self.unit,
            "total": round(self.total, d),
            "legs": [round(v, d + 1) for v in self.legs],
            "climb": round(self.climb, d),
            "spirals": round(self.spirals, d),
            "minutes": round(sum(self.leg_seconds) / 60.0, 2),
        }
        if self.capacity > 0:
            out["capacity"] = self.capacity
            out["reserve"] = round(self.capacity - self.total, d)
        return out


def _fmt(unit: str, total: float) -> Callable[[float], str]:
    """Numbers of a mission's energy: a decimal more on a small one (a quadrotor's 2.4 Wh)."""
    digits = (1 if total >= 10 else 2) if unit == "kg" else (0 if total >= 100 else 1)
    return lambda v: f"{v:,.{digits}f}"


def describe(energy: dict[str, Any], per_leg: int = 12) -> str:
    """One line of a mission's energy (:meth:`MissionEnergy.as_dict`, the mission's
    ``plan.energy``): the total, the shares of climbs and spirals, the reserve, and each leg's
    when there are at most ``per_leg`` legs."""
    unit = str(energy["unit"])
    fmt = _fmt(unit, float(energy["total"]))
    line = f"{WHAT[energy['kind']]} {fmt(energy['total'])} {unit} over {energy['minutes']:.1f} min"
    extra = [f"{k} {fmt(energy[k])}" for k in ("climb", "spirals") if energy.get(k, 0) > 0]
    if extra:
        line += f" ({', '.join(extra)})"
    legs = energy.get("legs") or []
    if 1 < len(legs) <= per_leg:
        line += f"; legs {', '.join(fmt(v) for v in legs)} {unit}"
    if "capacity" not in energy:
        return line + "; no capacity in the vehicle file (battery_wh / fuel_kg): no reserve"
    cap, reserve = float(energy["capacity"]), float(energy["reserve"])
    if reserve >= 0:
        return line + f"; reserve {fmt(reserve)} {unit} of {fmt(cap)} ({100 * reserve / cap:.0f} %)"
    return line + f"; SHORT by {fmt(-reserve)} {unit}: it carries {fmt(cap)} {unit}"


def shortfall(energy: dict[str, Any], carrier: str = "the vehicle") -> str | None:
    """What a mission short of energy needs against what ``carrier`` carries (one line), None
    when it has enough or the vehicle gives no capacity (``energy``: :meth:`MissionEnergy.as_dict`)."""
    if energy.get("reserve", 0.0) >= 0:
        return None
    unit = energy["unit"]
    return (
        f"the mission needs {energy['total']:g} {unit} of {WHAT[energy['kind']]}; {carrier} "
        f"carries {energy['capacity']:g} {unit}"
    )


def mission_energy(
    waypoints: npt.ArrayLike,
    spirals: Sequence[Spiral],
    model: EnergyModel,
    turn_radius: float,
    *,
    hover: bool = False,
    climb_rate: float = math.inf,
    descent_rate: float = math.inf,
    wind_at: Callable[[float, float], tuple[float, float]] | None = None,
    ground: Callable[[float, float], float] | None = None,
) -> MissionEnergy:
    """What the mission needs (module docstring): the flown path of ``waypoints`` with its
    ``spirals`` and fillets of ``turn_radius`` (0: a multirotor's legs meet at points, ``hover``;
    its vertical speed kept within ``climb_rate`` / ``descent_rate``), each piece at the
    model's speed through the air over the ground speed in ``wind_at(altitude, height)``."""
    w = np.asarray(waypoints, dtype=np.float64)
    n_legs = max(len(w) - 1, 1)
    if hover or turn_radius <= 0:
        path = flown_path(w, (), 1e-9)  # legs meeting at points
    else:
        path = flown_path(w, spirals, turn_radius)
    pts = path.points
    legs = np.zeros(n_legs)
    secs = np.zeros(n_legs)
    climb_total = 0.0
    spiral_total = 0.0
    v = model.speed
    for k in range(len(pts) - 1):
        a, b = pts[k], pts[k + 1]
        d = b[:2] - a[:2]
        dl = float(np.hypot(*d))
        dz = float(b[2] - a[2])
        mid = 0.5 * (a + b)
        leg = min(max(int(path.leg[k]), 0), n_legs - 1)
        if hover:
            # along the leg at cruise, the vertical speed within the limits (slower if need be)
            t_h = dl / v if v > 0 else 0.0
            t_v = dz / climb_rate if dz > 0 else -dz / descent_rate
            t = max(t_h, t_v)
            if t <= 0.0:
                continue
            vz = dz / t
            rate = (
                model.hover_per_second(float(mid[2]), vz)
                if dl < 1e-6
                else model.per_second(float(mid[2]), vz)
            )
            level = model.per_second(float(mid[2]), 0.0)
        else:
            if dl <= 1e-9 and abs(dz) <= 1e-9:
                continue
            slope = math.atan2(abs(dz), dl) if dl > 0 else math.pi / 2
            horizontal = v * math.cos(slope)
            over = horizontal
            if wind_at is not None and dl > 0:
                h = float(mid[2]) - (ground(float(mid[0]), float(mid[1])) if ground else 0.0)
                over = ground_speed(horizontal, wind_at(float(mid[2]), h), d / dl)
            t = dl / max(over, 1e-9) if dl > 0 else abs(dz) / max(v, 1e-9)
            turning = not bool(path.straight[k])
            rate = model.per_second(float(mid[2]), dz / t, turning)
            level = model.per_second(float(mid[2]), 0.0, turning)
        e = rate * t
        legs[leg] += e
        secs[leg] += t
        if dz > 0:
            climb_total += max(rate - level, 0.0) * t
        if int(path.spiral[k]) >= 0:
            spiral_total += e
    return MissionEnergy(
        model.kind,
        model.unit,
        float(model.capacity),
        tuple(float(v) for v in legs),
        tuple(float(v) for v in secs),
        climb_total,
        spiral_total,
    )


__all__ = [
    "UNITS",
    "WHAT",
    "EnergyModel",
    "MissionEnergy",
    "describe",
    "mission_energy",
    "shortfall",
]
