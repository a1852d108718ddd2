"""What an aircraft carries and draws: its energy source, and the plan's energy table.

The replay integrates the draw in the compiled flight loops (``kernels.drain``: a fixed wing's
battery power from its motor's current, or its fuel flow from its engine's shaft power and BSFC;
a multirotor's battery power from its rotors' shaft power); :class:`Source` turns what was drawn
into the vehicle's units and a state of charge. :func:`energy_model` reduces the same model to
the table the planner integrates along a mission (:mod:`planner.energy`): trims of the 6-DOF
aircraft (:func:`replay.flight.fixedwing.trim.trim`) at the cruise airspeed, by altitude and
climb rate, straight and in the planned turn, and what the engine draws at each trim's throttle;
for a multirotor, its steady flight solved for the rotor speed (:func:`multirotor_power`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.energy import UNITS, WH, EnergyModel
from replay.flight.atmosphere import RHO0, density_at
from replay.flight.base import G

N_ALTITUDES = 4
N_CLIMBS = 9

# The presets' capacities and efficiencies, fixed before any comparison with a reference
# (their sources in replay.flight.fixedwing.presets' docstring, "Energy"):
LIPO_WH_PER_KG = 150.0  # Prior (2019): LiPo packs give 150-200 Wh/kg; the low end (a pack's)
AVGAS_KG_PER_L = 6.0 * 0.45359237 / 3.785411784  # the Cessna POHs' 6.0 lb per US gallon
AEROSONDE_FUEL_KG = 6.0 * AVGAS_KG_PER_L  # the 6 litres the Aerosonde Laima crossed the Atlantic on
BATTERY_FRACTION = AEROSONDE_FUEL_KG / 13.5  # of the take-off mass, the aerosonde's battery's
BSFC_G_PER_KWH = 0.45 * 453.59237 / 0.745699872  # 0.45 lb/(bhp h): mid of Yechout's 0.4-0.5
ESC_EFFICIENCY = 0.95  # a speed controller's (chosen here: no measurement found to cite)
MOTOR_EFFICIENCY = 0.75  # Vorkoetter (2001): "assume a motor that is about 75% efficient"


def battery_wh(mass: float) -> float:
    """The usable battery (Wh) of an electric preset of take-off ``mass`` (kg): the aerosonde's
    battery fraction of the mass, as LiPo at :data:`LIPO_WH_PER_KG`."""
    return float(round(BATTERY_FRACTION * mass * LIPO_WH_PER_KG))


@dataclass(frozen=True)
class Source:
    """A vehicle's energy source: ``kind`` ``"battery"`` (``capacity`` Wh) or ``"fuel"``
    (``capacity`` kg); 0: the vehicle file gives none."""

    kind: str
    capacity: float

    @property
    def unit(self) -> str:
        return UNITS[self.kind]

    @property
    def per_unit(self) -> float:
        """A stack's ``energy_used`` (J of battery, kg of fuel) per unit of the capacity."""
        return WH if self.kind == "battery" else 1.0

    def amount(self, used: float) -> float:
        """What a stack's ``energy_used`` (J of battery, kg of fuel) is in this unit."""
        return used / self.per_unit

    def left(self, used: float) -> float | None:
        """The share of the capacity left (the state of charge, or of fuel), None without one."""
        if self.capacity <= 0:
            return None
        return 1.0 - self.amount(used) / self.capacity

    def exhausted(self, used: float) -> bool:
        return self.capacity > 0 and self.amount(used) >= self.capacity

    def as_dict(self, used: float) -> dict[str, Any]:
        out: dict[str, Any] = {
            "kind": self.kind,
            "unit": self.unit,
            "used": round(self.amount(used), 4),
        }
        left = self.left(used)
        if left is not None:
            out["capacity"] = self.capacity
            out["left"] = round(left, 4)
        return out


def source_of(params: Any) -> Source:
    """The source of a vehicle: a piston engine's fuel, else a battery."""
    if getattr(params, "engine", "electric") == "piston":
        return Source("fuel", float(getattr(params, "fuel_kg", 0.0)))
    return Source("battery", float(getattr(params, "battery_wh", 0.0)))


def energy_model(
    params: Any,
    speed: float,
    altitudes: tuple[float, float],
    *,
    turn_radius: float = math.inf,
    temperature_offset: float = 0.0,
) -> EnergyModel:
    """The planner's table of ``params`` at true airspeed ``speed`` over the band ``altitudes``
    (m AMSL): a fixed wing's trims (module docstring; ``turn_radius`` the planned turn's), a
    multirotor's steady flight."""
    from replay.flight.multirotor.model import MultirotorParams

    lo, hi = (float(a) for a in altitudes)
    if hi - lo < 1.0:
        hi = lo + 1.0
    alts = np.linspace(lo, hi, N_ALTITUDES)
    src = source_of(params)
    climbs = np.linspace(-float(params.descent_rate_max), float(params.climb_rate_max), N_CLIMBS)
    if 0.0 not in climbs:
        climbs = np.sort(np.append(climbs, 0.0))
    if isinstance(params, MultirotorParams):
        table = np.array(
            [
                [multirotor_power(params, speed, c, h, temperature_offset) for c in climbs]
                for h in alts
            ]
        )
        hover = np.array(
            [
                [multirotor_power(params, 0.0, c, h, temperature_offset) for c in climbs]
                for h in alts
            ]
        )
        return EnergyModel(
            params.name,
            "battery",
            src.capacity,
            float(speed),
            alts,
            climbs,
            table,
            table,
            0.0,
            hover,
            source=params.source,
        )
    straight = _fixed_wing_table(params, speed, alts, climbs, math.inf, temperature_offset)
    bank = 0.0
    if math.isfinite(turn_radius) and turn_radius > 0:
        turn = _fixed_wing_table(params, speed, alts, climbs, turn_radius, temperature_offset)
        bank = math.degrees(math.atan(speed * speed / (G * turn_radius)))
    else:
        turn = straight
    rate = 3600.0 if src.kind == "fuel" else 1.0  # kg/s -> kg/h; W
    return EnergyModel(
        params.name,
        src.kind,
        src.capacity,
        float(speed),
        alts,
        climbs,
        straight * rate,
        turn * rate,
        bank,
        source=params.source,
    )


def _fixed_wing_table(
    params: Any,
    speed: float,
    alts: np.ndarray,
    climbs: np.ndarray,
    turn_radius: float,
    dtemp: float,
) -> np.ndarray:
    """What the engine draws (W or kg/s) in the steady flight of each altitude and climb: the
    trim's throttle (full throttle for a climb steeper than any that trims; idle for a descent
    steeper than the idle glide)."""
    from replay.flight.fixedwing import kernels as kern
    from replay.flight.fixedwing.trim import trim
    from terrain.errors import InputError

    packed = params.pack(temperature_offset=dtemp)
    out = np.zeros((len(alts), len(climbs)))
    for i, h in enumerate(alts):
        rho = density_at(float(h), dtemp)
        for j, c in enumerate(climbs):
            gamma = math.asin(max(-0.99, min(0.99, float(c) / speed)))
            try:
                throttle = float(
                    trim(params, speed, float(h), gamma, turn_radius, dtemp, explain=False).u[3]
                )
            except InputError:  # beyond full throttle (a climb) or idle (a descent)
                throttle = 1.0 if c > 0 else 0.0
            out[i, j] = kern.drain(speed, throttle, rho, packed)
    # a climb that does not trim draws at least what a shallower one did (full throttle)
    return np.maximum.accumulate(out, axis=1)


def multirotor_power(
    params: Any, horizontal: float, climb: float, altitude: float, temperature_offset: float = 0.0
) -> float:
    """A multirotor's battery power (W) in steady flight at ``horizontal`` m/s through the air
    and ``climb`` m/s up, at ``altitude``: the four rotors at the one speed whose thrust balances
    the weight and the drags (the airframe's and the rotors' H-force, ``multirotor.model``) with
    the frame pitched to carry them, their shaft power ``4 sigma k_m w^3`` over the efficiency."""
    sigma = density_at(float(altitude), temperature_offset) / RHO0
    kf = sigma * params.k_f
    mg = params.mass * G
    vx, vz_ned = float(horizontal), -float(climb)
    speed = math.hypot(vx, vz_ned)
    theta = 0.0
    w = math.sqrt(mg / (4.0 * kf))
    for _ in range(50):
        ct, st = math.cos(theta), math.sin(theta)
        u = ct * vx - st * vz_ned
        wb = st * vx + ct * vz_ned
        thrust = max(mg * ct - sigma * speed * params.drag_z * wb, 1e-9)
        w = math.sqrt(thrust / (4.0 * kf))
        fx = -sigma * speed * params.drag_x * u - sigma * params.rotor_drag * 4.0 * w * u
        new = math.asin(max(-0.9, min(0.9, fx / mg)))
        if abs(new - theta) < 1e-10:
            break
        theta = new
    return 4.0 * sigma * params.k_m * w**3 / params.power_efficiency


__all__ = ["Source", "energy_model", "multirotor_power", "source_of"]
