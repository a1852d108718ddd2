"""``terrapath check``: a mission's offline feasibility report before upload (issue 35) -- the
path as the aircraft flies it against the measured terrain, the map, unknown terrain and the
zones (:mod:`planner.check`), and against the vehicle: each leg's climb or descent at its
altitudes, the ceiling, the turn radius, the spirals (:mod:`replay.preflight`, the same
judgement ``replay`` refuses a mission with).

A leg's gradients are reported both ways: the leg's own (rise over run between the altitude it
leaves at and the one it arrives at) and the steepest the aircraft flies there at the speed
(``tan(asin(rate / V))`` of the rate available, fixed wing; a multirotor climbs on the spot). A
terrain-frame leg is not judged on its straight line but on the ground it follows
(:mod:`planner.check`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from planner.check import Finding, GeometryCheck, check_geometry, leg_name
from planner.mission import Mission
from planner.performance import Performance
from replay.flight.fixedwing.params import VehicleParams
from replay.flight.multirotor.model import MultirotorParams
from replay.preflight import Preflight, preflight
from terrain.grid import HeightGrid
from terrain.zones import Zone


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
    return Feasibility(
        mission,
        params.name,
        float(speed),
        float(clearance),
        turn_model,
        geometry,
        flight,
        tuple(findings),
    )


__all__ = ["Feasibility", "feasibility", "leg_name", "vehicle_findings"]
