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
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.performance import ground_speed
from planner.spiral import Spiral, flown_path

FloatArray = npt.NDArray[np.float64]
WH = 3600.0  # J per Wh


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
    notes: tuple[str, ...] = field(default=())

    @property
    def unit(self) -> str:
        return "Wh" if self.kind == "battery" else "kg"

    def per_second(self, altitude: float, climb: float, turning: bool = False) -> float:
        """The source's draw per second (Wh/s or kg/s) at ``altitude`` and ``climb`` m/s."""
        return self._lookup(self.turn_rate if turning else self.rate, altitude, climb)

    def hover_per_second(self, altitude: float, climb: float) -> float:
        """A multirotor's draw per second on the spot (Wh/s)."""
        table = self.hover_rate if self.hover_rate is not None else self.rate
        return self._lookup(table, altitude, climb)

    def _lookup(self, table: FloatArray, altitude: float, climb: float) -> float:
        a, c = self.altitudes, self.climbs
        h = min(max(altitude, float(a[0])), float(a[-1]))
        v = min(max(climb, float(c[0])), float(c[-1]))
        i = int(np.clip(np.searchsorted(a, h) - 1, 0, max(len(a) - 2, 0)))
        j = int(np.clip(np.searchsorted(c, v) - 1, 0, max(len(c) - 2, 0)))
        fa = 0.0 if len(a) < 2 else (h - a[i]) / max(float(a[i + 1] - a[i]), 1e-9)
        fc = 0.0 if len(c) < 2 else (v - c[j]) / max(float(c[j + 1] - c[j]), 1e-9)
        i1, j1 = min(i + 1, len(a) - 1), min(j + 1, len(c) - 1)
        r = (
            (1 - fa) * (1 - fc) * table[i, j]
            + fa * (1 - fc) * table[i1, j]
            + (1 - fa) * fc * table[i, j1]
            + fa * fc * table[i1, j1]
        )
        # W -> Wh/s; kg/h -> kg/s
        return float(r) / 3600.0


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

    @property
    def reserve(self) -> float | None:
        """What is left at the end (the unit's amount), None without a capacity."""
        return None if self.capacity <= 0 else self.capacity - self.total

    @property
    def enough(self) -> bool:
        return self.capacity <= 0 or self.total <= self.capacity

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
    what = "battery energy" if energy["kind"] == "battery" else "fuel"
    line = f"{what} {fmt(energy['total'])} {unit} over {energy['minutes']:.1f} min"
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


__all__ = ["EnergyModel", "MissionEnergy", "describe", "mission_energy"]
