"""Energy (issue 36): the propulsion's draw against references, and the plan's estimate against
the replay.

Run: ``.venv/bin/python benchmarks/bench_energy.py [golden|jsbsim|poh|electric|multirotor ...]
[--no-record]`` (default: all; ``jsbsim`` needs the optional extra:
``.venv/bin/pip install -e '.[validate]'``).

- ``golden``: each reference map's golden plan (``tests/golden``: AMPSO, the aerosonde at 25 m/s)
  flown by the 6-DOF replay with terrain following off, no threats, in still air and in 10 m/s
  from four directions: the battery energy the replay drew against the plan's estimate
  (:func:`replay.preflight.mission_energy_of`, with the wind: :func:`planner.energy.mission_energy`
  at the ground speeds). Target: within 10 %.
- ``jsbsim``: the ``cessna172`` preset's level flight beside JSBSim's ``c172p``
  (``validate_jsbsim.Jsbsim``, unheld: the airframe's figures) at 30-55 m/s, 0 and 1,500 m: the
  power required (thrust x airspeed), the engine's shaft power, the rpm and the fuel flow (ours:
  the preset's BSFC x shaft power; JSBSim's: its engine's, mixture leaned for best power).
  Target: power required within 15 %.
- ``poh``: the preset's fuel flow at the cruise conditions of the Cessna 172's Pilot's Operating
  Handbook (its cruise performance table: pressure altitude, rpm, true airspeed, gallons per
  hour) against the book's. Target: within 15 %.
- ``electric``: a published electric UAV's power curve against this model's built from that
  airframe's published parameters (the source in :data:`ELECTRIC`).
- ``multirotor``: the quadrotor preset's hover power and the endurance its battery gives.

Figures are appended to benchmarks/RESULTS.md (``_record.record``) unless ``--no-record``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._record import record  # noqa: E402

WIND_SPEED = 10.0
WIND_FROM = (0.0, 90.0, 180.0, 270.0)


def _pct(a: float, b: float) -> str:
    return f"{100.0 * (a / b - 1.0):+.1f} %"


Rows = list[tuple[str, str, str]]


def golden(rows: Rows) -> bool:
    """Plan estimate against the replay's draw on the golden missions, calm and in wind."""
    from replay.flight.fixedwing.presets import load_any_vehicle
    from replay.flight.wind import parse_wind
    from replay.preflight import mission_energy_of
    from replay.run import ReplayRequest, run_replay
    from terrain.errors import InputError
    from tests.golden.replays import _mission_file, mission_of
    from tests.golden.scenarios import MAPS

    ok = True
    for sc in MAPS:
        if not sc.available():
            rows.append((f"{sc.name}", "map not found", "-"))
            continue
        mission = mission_of(sc)
        path = _mission_file(sc)
        params = load_any_vehicle(mission.vehicle)
        grid = sc.prepared().grid
        winds: list[tuple[str, Any]] = [("calm", None)]
        winds += [
            (f"{WIND_SPEED:g} m/s from {d:03.0f}", parse_wind(f"{WIND_SPEED},{d}"))
            for d in WIND_FROM
        ]
        for label, wind in winds:
            plan = float(
                mission_energy_of(mission, params, mission.cruise_speed, wind=wind, grid=grid)[
                    "total"
                ]
            )
            t0 = time.perf_counter()
            request = ReplayRequest.of(
                str(path), terrain_following=0.0, wind=wind, seed=0, terrain_mesh=False
            )
            refused = ""
            try:
                result = run_replay(request)
            except InputError as exc:
                # the preflight refuses a leg the aircraft cannot climb in that wind: flown
                # anyway, for the energy (the outcome says how it went)
                refused = f"refused by the preflight ({str(exc).split(': ', 1)[-1][:90]}...), flown anyway: "
                result = run_replay(request.but(fly_anyway=True))
            m = result.metrics
            used = float(m.energy["used"])
            ratio = plan / used
            outcome = "success" if m.success else f"FAIL: {m.end_reason}"
            if m.end_reason in ("goal", "landed") or m.end_reason.startswith("missed the goal"):
                good = abs(ratio - 1.0) <= 0.10
                ok &= good
            else:  # the mission was not flown to its end: nothing to compare
                good = True
                outcome += " -- not flown to its end, not compared"
            rows.append(
                (
                    f"{sc.name}, {label}: plan / replay battery energy",
                    f"{plan:.1f} / {used:.1f} Wh = {ratio:.3f} ({refused}{outcome}, "
                    f"{m.flight_time_s / 60:.1f} min flown, {time.perf_counter() - t0:.0f} s)",
                    "within 10 %" + ("" if good else ": MISSED"),
                )
            )
            print(" | ".join(rows[-1]), flush=True)
    return ok


# Cessna 172N Pilot's Operating Handbook (1978), cruise performance at 2,300 lb, standard
# temperature: (pressure altitude ft, rpm, % BHP, KTAS, US gal/h), as transcribed in
# luisrnandezc/performance-cessna-172 data/power.csv (its README: "the Cessna 172N")
POH_CRUISE = (
    (2000, 2500, 75, 116, 8.4),
    (4000, 2400, 64, 110, 7.1),
    (6000, 2300, 54, 104, 6.2),
    (8000, 2650, 75, 122, 8.4),
    (8000, 2400, 58, 109, 6.5),
    (10000, 2300, 50, 102, 5.8),
    (12000, 2200, 44, 95, 5.4),
)
LB_PER_GAL = 6.0  # the POH's avgas
KT = 0.514444  # m/s per knot
FT = 0.3048


def _ours_level(
    params: Any, speed: float, altitude: float
) -> tuple[float, float, float, float] | None:
    """(thrust power W, shaft power W, rpm, fuel flow kg/h) of the preset's level trim, None where
    it does not trim."""
    from replay.flight.atmosphere import density_at
    from replay.flight.fixedwing import kernels as kern
    from replay.flight.fixedwing.trim import trim
    from terrain.errors import InputError

    try:
        tr = trim(params, speed, altitude, explain=False)
    except InputError:
        return None
    p = params.pack()
    rho = density_at(altitude, 0.0)
    throttle = float(tr.u[3])
    thrust = kern.propeller(speed, throttle, rho, p)[0]
    n = kern.shaft_speed(speed, throttle, rho, p)[0]
    flow = kern.drain(speed, throttle, rho, p)
    shaft = flow / p[kern.I_BSFC]
    return thrust * speed, shaft, n * 60.0, flow * 3600.0


def jsbsim(rows: Rows) -> bool:
    """The Cessna's level flight beside JSBSim's c172p (unheld: the airframe's figures)."""
    from benchmarks.validate_jsbsim import HP, INSTALL, Jsbsim
    from replay.flight.fixedwing.presets import load_vehicle

    try:
        ref = Jsbsim()
    except ImportError:
        rows.append(("JSBSim", INSTALL, "-"))
        return True
    params = load_vehicle("cessna172")
    ok = True
    with ref.unheld():
        for h in (0.0, 1500.0):
            for v in (30.0, 35.0, 40.0, 45.0, 50.0, 55.0):
                ours = _ours_level(params, v, h)
                if ref.level(v, h) is None or ours is None:
                    rows.append((f"{v:g} m/s at {h:,.0f} m", "does not trim on one side", "-"))
                    continue
                thrust = ref["propulsion/engine/thrust-lbs"] * 4.4482216 * v
                shaft = ref["propulsion/engine/power-hp"] * HP
                flow = ref["propulsion/engine/fuel-flow-rate-pps"] * 0.45359237 * 3600.0
                rpm = ref["propulsion/engine/engine-rpm"]
                good = abs(ours[0] / thrust - 1.0) <= 0.15
                ok &= good
                rows.append(
                    (
                        f"{v:g} m/s at {h:,.0f} m: power required (thrust x V), ours / JSBSim",
                        f"{ours[0] / 1000:.1f} / {thrust / 1000:.1f} kW ({_pct(ours[0], thrust)}); "
                        f"shaft {ours[1] / HP:.0f} / {shaft / HP:.0f} hp ({_pct(ours[1], shaft)}), "
                        f"{ours[2]:,.0f} / {rpm:,.0f} rpm; fuel {ours[3]:.1f} / {flow:.1f} kg/h "
                        f"({_pct(ours[3], flow)})",
                        "power required within 15 %" + ("" if good else ": MISSED"),
                    )
                )
    return ok


def poh(rows: Rows) -> bool:
    """The Cessna's fuel flow at the POH's cruise conditions."""
    from replay.flight.fixedwing.presets import load_vehicle

    params = load_vehicle("cessna172")
    ok = True
    for pa, rpm, bhp, ktas, gph in POH_CRUISE:
        h, v = pa * FT, ktas * KT
        ours = _ours_level(params, v, h)
        label = f"{pa:,} ft, {ktas} KTAS ({rpm} rpm, {bhp} % BHP in the POH)"
        if ours is None:
            rows.append(
                (label, f"beyond the preset's top level speed at {h:,.0f} m (POH {gph} gal/h)", "-")
            )
            continue
        ours_gph = ours[3] / 0.45359237 / LB_PER_GAL
        good = abs(ours_gph / gph - 1.0) <= 0.15
        ok &= good
        rows.append(
            (
                label + ": fuel flow, ours / POH",
                f"{ours_gph:.2f} / {gph} gal/h ({_pct(ours_gph, gph)}); ours "
                f"{100 * ours[1] / params.power_max:.0f} % BHP at {ours[2]:,.0f} rpm",
                "within 15 %" + ("" if good else ": MISSED"),
            )
        )
    return ok


def multirotor(rows: Rows) -> bool:
    """The quadrotor's hover power and the endurance of its battery."""
    from replay.flight.energy import multirotor_power
    from replay.flight.multirotor.model import QUADROTOR

    for v in (0.0, 5.0, 10.0):
        w = multirotor_power(QUADROTOR, v, 0.0, 100.0)
        rows.append(
            (
                f"quadrotor at {v:g} m/s, 100 m: battery power",
                f"{w:.1f} W; {QUADROTOR.battery_wh:g} Wh last {60 * QUADROTOR.battery_wh / w:.0f} min",
                "-",
            )
        )
    return True


SECTIONS = {"golden": golden, "jsbsim": jsbsim, "poh": poh, "multirotor": multirotor}
NOTES: dict[str, str] = {
    "golden": "aerosonde, terrain following off, no threats; plan = replay.preflight.mission_energy_of "
    "(calm) / planner.energy.mission_energy with the wind; a run the preflight refuses in that wind "
    "is flown anyway (fly_anyway) for the energy",
    "jsbsim": "cessna172 level trims beside JSBSim c172p (unheld, mixture leaned for best power, "
    "2,300 lb); our fuel = BSFC 0.45 lb/bhp/h x shaft power",
    "poh": "Cessna 172N POH (1978) cruise table at 2,300 lb, ISA; the preset's BSFC 0.45 lb/bhp/h "
    "(Yechout et al.), 6.0 lb/gal",
}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("sections", nargs="*", help=f"any of {', '.join(SECTIONS)} (default: all)")
    ap.add_argument("--no-record", action="store_true")
    args = ap.parse_args(argv)
    unknown = [s for s in args.sections if s not in SECTIONS]
    if unknown:
        ap.error(f"unknown section(s) {', '.join(unknown)}; expected {', '.join(SECTIONS)}")
    ok = True
    for name in args.sections or list(SECTIONS):
        rows: Rows = []
        ok &= SECTIONS[name](rows)
        if args.no_record:
            for r in rows:
                print(" | ".join(r))
        else:
            record(f"bench_energy {name}", rows, NOTES.get(name, ""))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
