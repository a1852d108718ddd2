"""Can it fly this? A mission checked against its vehicle before take-off (issue 32).

The replay's aircraft flies straight lines between the waypoints at the cruise speed ``V`` (true
airspeed for a fixed wing, horizontal speed for a multirotor), on a day ``temperature_offset`` K
off the standard atmosphere. Before anything is flown, :func:`preflight` works out from the
vehicle model:

- **the ceiling at V**: for a fixed wing the lower of the altitude where its best steady climb at
  V falls below 0.5 m/s (:func:`replay.flight.fixedwing.trim.ceiling`, a bisection of trim
  solves to 25 m, cached) and the altitude where V, a true airspeed, falls below the envelope's
  slowest (an equivalent) airspeed (:meth:`VehicleParams.envelope_ceiling`); for a multirotor
  the altitude where its rotors at full speed lift it at less than 0.5 m/s (thrust falls with
  the density, the airframe's vertical drag ``drag_z`` holds the climb back; the controller's
  margin for attitude is not counted);
- **the climb each leg needs against the climb available**: a leg from waypoint k to k + 1 rises
  ``dz`` over the horizontal length ``L``; flown at V it needs ``V sin(atan(dz / L))`` m/s of
  climb (a multirotor keeps its horizontal speed: ``V dz / L``). A fixed wing climbs at most
  its autopilot's limit ``climb_rate_max``, and at most its best steady climb at V
  (:func:`replay.flight.fixedwing.trim.best_climb`): first asked at the leg's top, the
  conservative end (thinner air, less power: one trim solve); where that is short, over the
  whole leg -- the leg's height over the time the best rates take to climb it (Simpson's rule on
  1 / rate from the rates at the ends and the middle). The top alone would refuse climbs the
  aircraft makes: the golden RMNP plan's leg 1 needs 3.30 m/s from 2,670 to 3,542 m, the
  aerosonde makes 3.19 m/s at the top and 3.4 m/s on average. It descends at most
  ``descent_rate_max``, and at most its steepest idle descent at V
  (:func:`replay.flight.fixedwing.trim.best_descent`), asked the same way (the leg's top is the
  conservative end: the same true airspeed sinks less in thinner air): the solar UAV's 1.5 m/s
  limit is a 1.17 m/s glide at sea level, and a mission asking for the limit was flown 50-94 m
  above its profile (the planner plans with the same rate, VehicleParams.performance).
- ``cruise.turn_radius`` against the tightest turn at V, ``V^2 / (g tan(bank_max))`` (fixed
  wing only: a multirotor's legs meet at points).

**Refused** (:meth:`Preflight.check`, an :class:`InputError` of one line naming the leg, its
altitudes, the climb it needs and the climb available, and the ceiling when the leg goes above
it): a leg above the ceiling, a fixed wing's leg needing more climb or descent than available,
a turn radius tighter than the aircraft turns. A replay of such a mission only produces a
failure later (a Cessna asked to descend to 20 m in a few kilometres passes that waypoint at
1,466 m), so there is no override: an experiment that does not care about the mission's
altitudes (an avoider alone) can write its waypoints at altitudes the aircraft flies. A
multirotor's leg steeper than its climb or descent limit is **not** refused but warned: its
controller scales the velocity to the limits and flies the leg straight, slower.

``terrapath check`` (issue 35) extends it to the whole report a pilot wants before upload
(:func:`feasibility`): the path as the aircraft flies it against the measured terrain, the map,
unknown terrain and the zones (:mod:`planner.check`), with each leg's gradients reported both ways
-- the leg's own (rise over run between the altitude it leaves at and the one it arrives at) and
the steepest the aircraft flies there (``tan(asin(rate / V))`` of the rate available, fixed wing;
a multirotor climbs on the spot); a terrain-frame leg is judged on the ground it follows.

Before all that the level trim at the highest waypoint is asked for (as the fixed-wing flight
stack does at take-off), so a speed the aircraft cannot fly there is refused with the trim's own
message, naming the speeds it can.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from planner.check import Finding, GeometryCheck, check_geometry
from planner.energy import shortfall
from planner.mission import Mission
from planner.performance import Performance, ground_speed
from replay.flight.atmosphere import RHO0, check_offset, density_at
from replay.flight.base import G
from replay.flight.fixedwing.params import VehicleParams
from replay.flight.fixedwing.trim import (
    CEILING_CLIMB,
    CEILING_RESOLUTION,
    CEILING_TOP,
    best_climb,
    best_descent,
    holds_climb,
    trim,
)
from replay.flight.fixedwing.trim import ceiling as trim_ceiling
from replay.flight.multirotor.model import MultirotorParams
from replay.flight.wind import Wind
from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrain.zones import Zone

FloatArray = npt.NDArray[np.float64]

_best_climb = lru_cache(maxsize=512)(best_climb)
_holds_climb = lru_cache(maxsize=2048)(holds_climb)
_best_descent = lru_cache(maxsize=512)(best_descent)


@dataclass(frozen=True)
class LegProblem:
    """A leg the vehicle cannot fly as written: leg ``index`` (waypoint index -> index + 1) from
    altitude ``z0`` to ``z1`` (m AMSL) over ``length`` horizontal metres, needing ``need`` m/s of
    climb (negative: of descent) at the cruise speed where ``available`` m/s (a positive rate, of
    climb or of descent as ``need``) is what the vehicle has there (``limit`` names what sets it),
    above the ceiling or not; ``refused`` False for a warning."""

    index: int
    z0: float
    z1: float
    length: float
    need: float
    available: float
    limit: str
    above_ceiling: bool
    refused: bool
    speed: float | None = None  # the leg's own speed where the mission changes it
    windy: bool = False  # the wind makes it need more than in still air (over the ground)


@dataclass(frozen=True)
class Preflight:
    """What the vehicle can do on this mission at ``speed`` (m/s) on a day ``temperature_offset``
    K off standard: its ``ceiling`` (m AMSL; ``-inf`` when it cannot climb 0.5 m/s even at sea
    level, ``inf`` above 20 km) and what sets it (``ceiling_by``), the highest waypoint
    (``top``, m AMSL) and the climb available there (``climb_at_top``, m/s: the smaller of the
    limit and ``best_at_top``, the best steady climb there), the legs it cannot fly and other
    refusals (one line each, the mission's file first), and warnings."""

    vehicle: str
    kind: Literal["fixed-wing", "multirotor"]
    speed: float
    temperature_offset: float
    ceiling: float
    ceiling_by: str
    top: float
    climb_at_top: float
    best_at_top: float
    climb_limit: float
    legs: tuple[LegProblem, ...]
    refusals: tuple[str, ...]
    warnings: tuple[str, ...]

    @property
    def ok(self) -> bool:
        return not self.refusals

    def check(self) -> None:
        """Raise an :class:`InputError` naming the first refusal (and how many more) if any."""
        if self.refusals:
            more = len(self.refusals) - 1
            tail = f" (and {more} more problem{'s' if more > 1 else ''})" if more else ""
            raise InputError(self.refusals[0] + tail)

    def leg_message(self, p: LegProblem) -> str:
        """The line :meth:`check` would give for leg problem ``p`` (without the file)."""
        return _leg_text(p, self.vehicle, p.speed or self.speed, self.ceiling, self.ceiling_by)

    def describe(self) -> str:
        """One line for the replay's header, before take-off."""
        day = f" (ISA{self.temperature_offset:+g} K)" if self.temperature_offset else ""
        if math.isinf(self.ceiling):
            ceiling = "above 20,000 m" if self.ceiling > 0 else "below sea level"
        else:
            ceiling = f"{self.ceiling:,.0f} m"
        held = ""
        if self.best_at_top > self.climb_limit:
            held = (
                f" (its autopilot's limit; {_rate(self.best_at_top)} m/s its best steady climb)"
                if self.kind == "fixed-wing"
                else " (its limit)"
            )
        return (
            f"{self.vehicle} at {self.speed:g} m/s{day}: ceiling {ceiling} ({self.ceiling_by}), "
            f"climb {_rate(self.climb_at_top)} m/s{held} at the highest waypoint "
            f"({self.top:,.0f} m)"
        )


def _ceiling(params: VehicleParams, v: float, dt: float) -> tuple[float, str]:
    """(the ceiling at true airspeed ``v``, what sets it) (module docstring)."""
    aero = trim_ceiling(params, v, dt)  # cached
    envelope = params.envelope_ceiling(v, dt)
    by = (
        f"{v:g} m/s true is its slowest airspeed there, {params.airspeed_min:g} m/s equivalent"
        if envelope < aero
        else f"best climb {CEILING_CLIMB:g} m/s"
    )
    return min(aero, envelope), by


def leg_speeds(mission: Mission, speed: float) -> list[float]:
    """The speed each leg is flown at: ``speed``, changed from a waypoint on where the mission
    says so (``Mission.speeds``)."""
    out, v = [], float(speed)
    for k in range(len(mission.waypoints) - 1):
        v = float(mission.speeds.get(k, v))
        out.append(v)
    return out


def preflight(
    mission: Mission,
    params: VehicleParams | MultirotorParams,
    speed: float,
    temperature_offset: float = 0.0,
    *,
    changes: bool = True,
    wind: Wind | None = None,
) -> Preflight:
    """The mission's legs checked against the vehicle at ``speed`` (module docstring), or with
    ``changes`` at the mission's own speed changes from where they are made (``Mission.speeds``:
    each leg's climb, descent and ceiling at its speed). Raises only the level trim's refusal (a
    speed the fixed wing cannot fly at the highest waypoint it is flown to); everything else is
    in the result (:meth:`Preflight.check` raises it).

    In a ``wind`` a leg's climb or descent is flown over the ground: the rate it needs is its
    gradient times the ground speed along it (the air's horizontal speed crabbed into the
    wind's cross component, plus its along component) -- a descent downwind needs more than in
    still air, a climb into the wind less; a profile's wind is taken at its weakest and its
    strongest (the worse)."""
    v, dt = float(speed), check_offset(temperature_offset)
    w = np.asarray(mission.waypoints, dtype=np.float64)
    where = f"{mission.source}: " if mission.source else f"mission {mission.name!r}: "
    top = float(w[:, 2].max())
    if isinstance(params, MultirotorParams):
        return _multirotor(mission, params, v, dt, w, where, top)
    speeds = leg_speeds(mission, v) if changes and mission.speeds else [v] * (len(w) - 1)
    for s in sorted(set(speeds)):  # the trim's own message at the highest point flown at s
        high_s = max(max(w[k, 2], w[k + 1, 2]) for k, vk in enumerate(speeds) if vk == s)
        trim(params, s, altitude=float(high_s if s != v else top), temperature_offset=dt)
    ceiling, by = _ceiling(params, v, dt)
    arrive = w[:, 2].copy()  # a leg ends at the altitude its end is arrived at: a spiral's entry
    for sp in mission.spirals:
        arrive[sp.at] = sp.entry
    legs: list[LegProblem] = []
    cruise = v
    for k, (z0, z1, length, dz) in enumerate(_legs(w, arrive)):
        v = speeds[k]
        leg_ceiling = ceiling if v == cruise else _ceiling(params, v, dt)[0]
        high = max(z0, z1)
        above = high > leg_ceiling
        if dz != 0:
            # the rate the leg needs (negative: a descent) against the best the aircraft makes
            # at the leg's top (the conservative end both ways), else over the whole leg
            up = dz > 0
            need = math.copysign(v * math.sin(math.atan2(abs(dz), length)), dz)
            calm = need
            if wind is not None and length > 0:
                need = _need_in_wind(wind, w[k], w[k + 1], z0, z1, v, need, dz / length)
            cap = params.climb_rate_max if up else params.descent_rate_max
            if abs(need) <= cap and not above and _holds_climb(params, v, high, need, dt):
                continue  # it climbs (sinks) that fast even at the leg's top: one trim solve
            best = _best_climb if up else _best_descent
            rates = [min(cap, best(params, v, h, dt)) for h in (z0, 0.5 * (z0 + z1), z1)]
            available = _average_climb(rates)
            if abs(need) <= available and not above:
                continue
            if min(rates) >= cap:
                limit = f"its autopilot's {'climb' if up else 'descent'} limit"
            elif up:
                limit = f"its best steady climb over the leg, {_rate(rates[-1])} m/s at {z1:,.0f} m"
            else:
                limit = (
                    f"its steepest idle descent over the leg, {_rate(rates[0])} m/s at {z0:,.0f} m"
                )
        else:
            if not above:
                continue
            need, available, limit, calm = 0.0, 0.0, "", 0.0
        windy = dz != 0 and abs(need) > abs(calm) + 1e-9
        legs.append(LegProblem(k, z0, z1, length, need, available, limit, above, True, v, windy))
    v = cruise
    refusals = [where + _leg_text(p, params.name, p.speed or v, ceiling, by) for p in legs]
    refusals += [where + text for text in _spirals(mission, params, v, dt)]
    if mission.turn_radius is not None:
        fastest = max(speeds) if speeds else v  # a speed change's fastest leg turns widest
        r_min = params.min_turn_radius(fastest)
        if mission.turn_radius < r_min:
            refusals.insert(
                0,
                f"{where}cruise.turn_radius {mission.turn_radius:g} m is tighter than "
                f"{params.name} turns at {fastest:g} m/s: at least {r_min:.0f} m "
                f"(V^2 / (g tan {params.bank_max_deg:g} deg), its bank limit)",
            )
    if ceiling == -math.inf:
        refusals.insert(
            0,
            f"{where}{params.name} cannot climb {CEILING_CLIMB:g} m/s at {v:g} m/s even at sea "
            "level: choose another speed (cruise.speed)",
        )
    best_top = _best_climb(params, v, top, dt)
    return Preflight(
        params.name,
        "fixed-wing",
        v,
        dt,
        ceiling,
        by,
        top,
        min(params.climb_rate_max, best_top),
        best_top,
        params.climb_rate_max,
        tuple(legs),
        tuple(refusals),
        (),
    )


def multirotor_climb(params: MultirotorParams, altitude: float, temperature_offset: float) -> float:
    """The steady vertical climb (m/s) of a multirotor with its rotors at full speed at
    ``altitude``: ``T_max - W = sigma drag_z v^2`` (0 when it cannot hover; ``inf`` without
    vertical drag), before its controller's limit ``climb_rate_max``."""
    sigma = density_at(float(altitude), temperature_offset) / RHO0
    spare = params.thrust_max(altitude, temperature_offset) - params.mass * G
    if spare <= 0:
        return 0.0
    if params.drag_z <= 0:
        return math.inf
    return math.sqrt(spare / (sigma * params.drag_z))


@lru_cache(maxsize=64)
def multirotor_ceiling(params: MultirotorParams, temperature_offset: float = 0.0) -> float:
    """The altitude (m AMSL, rounded down to 25 m) above which :func:`multirotor_climb` is below
    0.5 m/s; ``-inf`` / ``inf`` as :func:`replay.flight.fixedwing.trim.ceiling`."""

    def ok(h: float) -> bool:
        return multirotor_climb(params, h, temperature_offset) >= CEILING_CLIMB

    if not ok(0.0):
        return -math.inf
    if ok(CEILING_TOP):
        return math.inf
    lo, hi = 0.0, CEILING_TOP
    while hi - lo > CEILING_RESOLUTION:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return math.floor(lo / CEILING_RESOLUTION) * CEILING_RESOLUTION


def _multirotor(
    mission: Mission,
    params: MultirotorParams,
    v: float,
    dt: float,
    w: FloatArray,
    where: str,
    top: float,
) -> Preflight:
    ceiling = multirotor_ceiling(params, dt)
    by = f"climb {CEILING_CLIMB:g} m/s at full rotor speed"
    arrive = w[:, 2].copy()  # a leg ends at the altitude its end is arrived at: a spiral's entry
    for sp in mission.spirals:
        arrive[sp.at] = sp.entry
    legs: list[LegProblem] = []
    for k, (z0, z1, length, dz) in enumerate(_legs(w, arrive)):
        high = max(z0, z1)
        above = high > ceiling
        available = (
            min(params.climb_rate_max, multirotor_climb(params, high, dt))
            if dz >= 0
            else params.descent_rate_max
        )
        if dz == 0:
            need = 0.0
        else:
            need = math.copysign(math.inf, dz) if length == 0 else v * dz / length
        steep = length > 0 and abs(need) > available
        if above or steep:
            limit = "its climb limit" if dz >= 0 else "its descent limit"
            legs.append(LegProblem(k, z0, z1, length, need, available, limit, above, above))
    refusals = [where + _leg_text(p, params.name, v, ceiling, by) for p in legs if p.refused]
    warnings = [
        f"{where}{_leg_text(p, params.name, v, ceiling, by)}: it flies that leg at "
        f"{v * p.available / abs(p.need):.1f} m/s (its velocity scaled to the limits)"
        for p in legs
        if not p.refused
    ]
    if ceiling == -math.inf:
        refusals.insert(
            0, f"{where}{params.name} cannot climb {CEILING_CLIMB:g} m/s even at sea level"
        )
    best_top = multirotor_climb(params, top, dt)
    return Preflight(
        params.name,
        "multirotor",
        v,
        dt,
        ceiling,
        by,
        top,
        min(params.climb_rate_max, best_top),
        best_top,
        params.climb_rate_max,
        tuple(legs),
        tuple(refusals),
        tuple(warnings),
    )


def _average_climb(rates: list[float]) -> float:
    """The mean climb rate (m/s) over a climb from z0 to z1 at the best rates ``rates`` at z0, the
    middle and z1: the height over the time it takes, that time by Simpson's rule on 1 / rate
    (0 when a rate is 0: it does not get there)."""
    if min(rates) <= 0:
        return 0.0
    r0, rm, r1 = rates
    return 6.0 / (1.0 / r0 + 4.0 / rm + 1.0 / r1)


def _need_in_wind(
    wind: Wind,
    a: FloatArray,
    b: FloatArray,
    z0: float,
    z1: float,
    v: float,
    need: float,
    gradient: float,
) -> float:
    """The climb (descent < 0) rate a leg from ``a`` to ``b`` (map) of ``gradient`` over the
    ground needs at airspeed ``v`` in ``wind``: the gradient times the ground speed along it,
    the worse of the wind's samples (mid-leg; a profile at its weakest and strongest);
    ``need``, the still air's, when the wind helps everywhere."""
    from replay.flight.wind import GRADIENT_HEIGHT_M, MIN_HEIGHT_M

    d = np.asarray(b[:2], dtype=np.float64) - np.asarray(a[:2], dtype=np.float64)
    e = d / max(float(np.hypot(*d)), 1e-9)
    horizontal = v * math.cos(math.atan(abs(gradient)))  # the air's horizontal speed
    worst = need
    for height in (MIN_HEIGHT_M, GRADIENT_HEIGHT_M):
        wn, we, _ = wind.velocity(0.5 * (z0 + z1), height)
        rate = gradient * ground_speed(horizontal, (wn, we), e)
        worst = max(worst, rate) if gradient > 0 else min(worst, rate)
    return worst


def _legs(
    w: FloatArray, arrive: FloatArray | None = None
) -> list[tuple[float, float, float, float]]:
    """(start altitude, end altitude, horizontal length, rise) of every leg, from the altitude
    its start is left at to the one its end is arrived at (``arrive``, default the waypoints'
    own); a leg with neither length nor rise (a repeated waypoint) rises 0 over 0 m and is
    never a problem."""
    end = w[:, 2] if arrive is None else arrive
    d = np.diff(w[:, :2], axis=0)
    length = np.hypot(d[:, 0], d[:, 1])
    return [
        (float(w[k, 2]), float(end[k + 1]), float(length[k]), float(end[k + 1] - w[k, 2]))
        for k in range(len(d))
    ]


def _spirals(mission: Mission, params: VehicleParams, v: float, dt: float) -> list[str]:
    """Each climb spiral the aircraft cannot climb in its banked turn (the trim in a helix of
    its radius at the spiral's top), and each descent spiral steeper than its descent limit or
    its idle glide at the spiral's top."""
    from replay.flight.fixedwing.trim import best_climb

    out = []
    w = mission.waypoints
    for sp in mission.spirals:
        dz = float(w[sp.at, 2]) - sp.entry
        run = 2.0 * math.pi * sp.radius * sp.turns
        need = v * math.sin(math.atan2(abs(dz), run))
        what = (
            f"the {'climb' if dz > 0 else 'descent'} spiral at waypoint {sp.at} "
            f"({sp.entry:,.0f} -> {w[sp.at, 2]:,.0f} m in {sp.turns} turns of {sp.radius:.0f} m)"
        )
        if dz > 0:
            have = min(
                params.climb_rate_max,
                best_climb(params, v, float(w[sp.at, 2]), dt, turn_radius=sp.radius),
            )
            if need > have:
                out.append(
                    f"{what} needs {_rate(need)} m/s of climb; {params.name} climbs "
                    f"{_rate(have)} m/s in that turn at its top"
                )
        else:  # the straight idle glide at the top: a banked turn sinks faster, so it is safe
            glide = _best_descent(params, v, sp.entry, dt)
            have = min(params.descent_rate_max, glide)
            if need > have:
                why = (
                    "descent_rate_max"
                    if glide >= params.descent_rate_max
                    else f"its idle glide at {sp.entry:,.0f} m"
                )
                out.append(
                    f"{what} needs {_rate(need)} m/s of descent; {params.name} has "
                    f"{_rate(have)} m/s ({why})"
                )
    return out


def _rate(x: float) -> str:
    """A climb rate as the messages print it: two decimals below 10 m/s, one above."""
    if math.isinf(x):
        return "unlimited"
    return f"{x:.2f}" if abs(x) < 10.0 else f"{x:.1f}"


def _leg_text(p: LegProblem, name: str, v: float, ceiling: float, by: str) -> str:
    """One line: the leg, its altitudes, the climb it needs and has, the ceiling if above."""
    leg = f"leg {p.index} (waypoint {p.index} -> {p.index + 1})"
    span = f"from {p.z0:,.0f} m to {p.z1:,.0f} m"
    over = f"in {p.length / 1000:.2f} km" if p.length > 0 else "with no horizontal length"
    if p.need == 0:
        text = f"{leg} flies level at {p.z0:,.0f} m"
    else:
        verb, what = ("climbs", "climb") if p.need > 0 else ("descends", "descent")
        need = (
            f"straight {'up' if p.need > 0 else 'down'}"
            if math.isinf(p.need)
            else f"{_rate(abs(p.need))} m/s of {what}"
        )
        text = (
            f"{leg} {verb} {span} {over}: at {v:g} m/s"
            f"{' in the wind (over the ground)' if p.windy else ''} that needs {need}; {name} has "
            f"{_rate(p.available)} m/s ({p.limit})"
        )
    if p.above_ceiling:
        high = max(p.z0, p.z1)
        text += f"; {high:,.0f} m is above its ceiling at {v:g} m/s, {ceiling:,.0f} m ({by})"
    return text


# -- terrapath check: the whole report -------------------------------------------------------


@dataclass(frozen=True)
class Feasibility:
    """The report: what was checked (vehicle, speed, clearance, turn model), the geometry
    (legs, samples), the vehicle's preflight, and every finding ranked."""

    mission: Mission
    vehicle: str
    speed: float
    clearance: float
    turn_model: str
    geometry: GeometryCheck
    preflight: Preflight
    findings: tuple[Finding, ...]
    # what the mission needs of the battery or the fuel (planner.energy.MissionEnergy.as_dict)
    energy: dict[str, Any] | None = None

    @property
    def ok(self) -> bool:
        return not self.findings

    def lines(self) -> list[str]:
        """The report for people: the header, each leg's margin, the findings ranked."""
        m = self.mission
        out = [
            f"mission   {m.source or m.name}: {len(m.waypoints)} waypoints, "
            f"{len(m.spirals)} spiral(s), {self.geometry.samples.distance[-1] / 1000:.2f} km "
            "as flown",
            f"vehicle   {self.preflight.describe()}",
            f"turns     {self.turn_model}",
            f"terrain   judged on the measured heights with {self.clearance:g} m of clearance",
        ]
        if self.energy is not None:
            from planner.energy import describe

            out.append(f"energy    {describe(self.energy)}")
        if m.terrain_heights:
            out.append(
                f"          {len(m.terrain_heights)} terrain-frame leg(s) flown at their height "
                "above the ground"
            )
        out.append("legs      lowest clearance above the measured terrain (where along it)")
        for leg in self.geometry.legs:
            agl = f", {leg.terrain_height:g} m above the ground" if leg.terrain_height else ""
            out.append(
                f"  {leg.label:<34} {leg.min_clearance:>8,.0f} m  ({leg.along / 1000:.2f} of "
                f"{leg.length / 1000:.2f} km{agl})"
            )
        if self.ok:
            out.append("feasible: no violation")
        else:
            out.append(f"NOT feasible: {len(self.findings)} violation(s), worst first")
            out += [f"  {i + 1}. {f.message}" for i, f in enumerate(self.findings)]
        return out

    def as_dict(self) -> dict[str, Any]:
        return {
            "mission": self.mission.source or self.mission.name,
            "feasible": self.ok,
            "vehicle": self.vehicle,
            "speed": self.speed,
            "clearance": self.clearance,
            "turn_model": self.turn_model,
            "ceiling": None if math.isinf(self.preflight.ceiling) else self.preflight.ceiling,
            "legs": [leg.as_dict() for leg in self.geometry.legs],
            "energy": self.energy,
            "violations": [f.as_dict() for f in self.findings],
        }


def _gradient(rate: float, speed: float) -> float:
    """The gradient (rise over run) of a climb at ``rate`` m/s flown at ``speed`` m/s."""
    if rate >= speed:
        return math.inf
    return math.tan(math.asin(max(rate, 0.0) / speed))


def vehicle_findings(mission: Mission, flight: Preflight) -> list[Finding]:
    """The preflight's refusals as findings, each leg's with both gradients; a terrain-frame
    leg's straight-line gradient is not judged (it follows the ground: :mod:`planner.check`)."""
    w = mission.waypoints
    out: list[Finding] = []
    leg_lines = set()
    for p in flight.legs:
        text = flight.leg_message(p)
        leg_lines.add(text)
        if (p.index + 1) in mission.terrain_heights and not p.above_ceiling:
            continue
        kind = "ceiling" if p.above_ceiling else ("climb" if p.need > 0 else "descent")
        grade = (p.z1 - p.z0) / p.length if p.length > 0 else math.copysign(math.inf, p.need)
        have = _gradient(p.available, flight.speed)
        if p.need != 0:
            text += (
                f" (the leg's gradient {100 * abs(grade):.1f} %, the aircraft's "
                f"{100 * have:.1f} % there)"
            )
        mid = 0.5 * (w[p.index] + w[p.index + 1])
        amount = abs(p.need) - p.available if p.need else max(p.z0, p.z1) - flight.ceiling
        x, y, z = (float(v) for v in mid)
        out.append(Finding(kind, p.index, float(amount), x, y, z, text))
    where = f"{mission.source}: " if mission.source else f"mission {mission.name!r}: "
    for text in flight.refusals:
        bare = text.removeprefix(where)
        if bare in leg_lines:
            continue
        kind = "turn" if "turn_radius" in bare else ("spiral" if "spiral" in bare else "vehicle")
        out.append(Finding(kind, -1, 0.0, math.nan, math.nan, math.nan, bare))
    return out


def feasibility(
    mission: Mission,
    grid: HeightGrid,
    params: VehicleParams | MultirotorParams,
    speed: float,
    *,
    clearance: float,
    zones: Sequence[Zone] = (),
    allow_unknown: bool = False,
    temperature_offset: float = 0.0,
    changes: bool = True,
) -> Feasibility:
    """Check ``mission`` flown by ``params`` at ``speed`` on ``grid`` (module docstring)."""
    from replay.source import performance_of

    flight = preflight(mission, params, speed, temperature_offset, changes=changes)
    cache: dict[tuple[int, int], Performance] = {}

    def perf_at(low: float, high: float) -> Performance:
        # the limits over 50 m bands (the top rounded up: the conservative end), cached
        key = (int(math.floor(low / 50.0)), int(math.ceil(high / 50.0)))
        if key not in cache:
            if isinstance(params, MultirotorParams):
                cache[key] = performance_of(params, speed)
            else:
                cache[key] = params.performance(speed, (50.0 * key[0], 50.0 * key[1]))
        return cache[key]

    if grid.is_georeferenced:
        to_ll = grid.lonlat_interpolator()

        def lonlat(x: float, y: float) -> str:
            lo, la = to_ll(x, y)
            return f"lon {float(lo):.5f}, lat {float(la):.5f}"

    else:

        def lonlat(x: float, y: float) -> str:
            return f"x={x:.0f}, y={y:.0f}"

    geometry = check_geometry(
        mission,
        grid,
        clearance=clearance,
        zones=zones,
        allow_unknown=allow_unknown,
        perf_at=perf_at,
        lonlat=lonlat,
    )
    radius = mission.turn_radius
    if isinstance(params, MultirotorParams):
        turn_model = "a multirotor: it stops at each waypoint and turns on the spot"
    elif radius:
        turn_model = (
            f"terrapath's fillets of {radius:.0f} m (the mission's turn radius; {params.name} "
            f"turns at least {params.min_turn_radius(speed):.0f} m at {speed:g} m/s)"
        )
    else:
        turn_model = "none given: the legs are checked as straight lines between the waypoints"
    findings = list(geometry.findings) + vehicle_findings(mission, flight)
    energy = mission_energy_of(mission, params, speed, temperature_offset)
    short_of = shortfall(energy, params.name)
    if short_of is not None:
        g = mission.waypoints[-1]
        findings.append(
            Finding(
                "energy",
                -1,
                -float(energy["reserve"]),
                float(g[0]),
                float(g[1]),
                float(g[2]),
                short_of,
            )
        )
    return Feasibility(
        mission,
        params.name,
        float(speed),
        float(clearance),
        turn_model,
        geometry,
        flight,
        tuple(findings),
        energy,
    )


def mission_energy_of(
    mission: Mission,
    params: VehicleParams | MultirotorParams,
    speed: float,
    temperature_offset: float = 0.0,
    *,
    wind: Any = None,
    grid: HeightGrid | None = None,
) -> dict[str, Any]:
    """What ``mission`` needs of the vehicle's battery or fuel flown at ``speed``
    (:func:`planner.energy.mission_energy` on :func:`replay.flight.energy.energy_model`'s
    table over the mission's altitudes), as :meth:`MissionEnergy.as_dict`: in still air, or in
    ``wind`` (:class:`replay.flight.wind.Wind`; a profile's height over ``grid``)."""
    from planner.energy import mission_energy
    from replay.flight.energy import energy_model

    hover = isinstance(params, MultirotorParams)
    radius = 0.0 if hover else float(mission.turn_radius or 0.0)
    zs = mission.waypoints[:, 2]
    model = energy_model(
        params,
        speed,
        (float(zs.min()), float(zs.max())),
        turn_radius=radius or math.inf,
        temperature_offset=temperature_offset,
    )
    wind_at = None
    if wind is not None and not wind.calm:

        def wind_at(altitude: float, height: float) -> tuple[float, float]:
            v = wind.velocity(altitude, height)
            return float(v[0]), float(v[1])

    return mission_energy(
        mission.waypoints,
        mission.spirals,
        model,
        radius,
        hover=hover,
        climb_rate=float(params.climb_rate_max),
        descent_rate=float(params.descent_rate_max),
        wind_at=wind_at,
        ground=None if grid is None else lambda x, y: float(grid.height_at(x, y)),
    ).as_dict()
