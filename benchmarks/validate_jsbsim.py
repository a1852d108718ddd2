"""Validate the ``cessna172`` preset against JSBSim's ``c172p`` (issue 14): the same manoeuvres
flown on both, a table of figures with ratios (ours / JSBSim) and the issue's targets.

Run: ``.venv/bin/python benchmarks/validate_jsbsim.py [--no-record] [--quick]``
(needs the optional extra: ``.venv/bin/pip install -e '.[validate]'``, i.e. ``pip install jsbsim``).

What is measured, identically on both sides (``FlightModel`` below is all a side supplies):

- **Level trim** at 30 / 40 / 50 / 55 m/s true airspeed at 0 and 1,500 m: angle of attack (target:
  within 0.5 deg) and throttle (JSBSim's power and rpm shown).
- **Lowest and highest level trim speed** at 0 and 1,500 m (stall and top speed, target 5 %):
  bisection to 0.05 m/s on "level flight trims". A trim never stalls on either side (ours keeps
  alpha below the angle of maximum lift, JSBSim's trimmer below the model's alpha limit, 0.28 rad).
- **Best climb rate** at 0 / 1,500 / 3,000 m (target 20 %) and, near the ceiling, 3,500 / 4,000 m
  (target: within 0.28 m/s, :func:`climb_target`): for an airspeed V the steepest
  flight-path angle that trims (bisection to 1e-4 rad on "this climb trims"), climb rate
  V sin(gamma); the best over V (scan of 28-52 m/s, then golden-section search to 0.1 m/s).
- **Power-off glide** at 1,500 m: the same search for the shallowest descent at closed throttle
  (the lowest flight-path angle that trims with the throttle >= 0): best glide ratio 1/tan(-gamma)
  and least sink rate over V. JSBSim's closed throttle is its engine at idle (windmilling propeller,
  some idle thrust); ours is the propeller windmilling with the engine giving no torque (drag).
- **30 deg banked turn** at 50 m/s, 1,500 m: trimmed (ours: the turn radius whose coordinated trim
  banks 30 deg; JSBSim: its turn trim at 30 deg of bank), flown 30 s with the controls held; the
  radius is the mean horizontal speed over the course rate, compared with V^2 / (g tan(phi)) at the
  flown mean airspeed and bank, each side with its own g (target: ours within 2 %).
- **Elevator doublet** from level trim at 50 m/s, 1,500 m: 2 deg nose up for 1 s, 2 deg nose down
  for 1 s, then the trim elevator, flown 200 s. Short period: a damped sinusoid (plus a straight
  line for the slow phugoid underneath) fitted to the pitch rate in the 4 s after the doublet;
  phugoid: the same fitted to the airspeed from 10 s to 200 s (``_validate.fit_mode``).
- **Full-aileron roll** from level trim at 50 m/s, 1,500 m, rudder and elevator held: peak roll
  rate in the first 3 s and time to 30 deg of bank, the mean of a roll to the right and one to the
  left (JSBSim's aileron travel is 15 deg up / 20 deg down by direction, ours +-17.5 deg: the
  mean of the two directions compares like with like). Target: roll rate within 30 %.

Our side uses only public APIs: ``replay.flight.fixedwing.trim.trim`` (an ``InputError`` means "does not
trim") and ``replay.flight.fixedwing.dynamics.Aircraft`` (RK4 at 100 Hz). Altitude enters only through
``trim(..., altitude=h)`` and the state's down position (the standard atmosphere at that
altitude, as on JSBSim's side).

The reference, JSBSim's ``c172p`` as shipped with the ``jsbsim`` package:

- **Loaded to 2,300 lb** (our preset's mass): the model's 1,500 lb empty weight and 180 lb pilot,
  a 180 lb co-pilot, both tanks full (2 x 185 lb) and 35 lb in each rear seat; fuel burn frozen
  (``propulsion/fuel_freeze``) so the weight stays 2,300 lb; centre of gravity 43.5 in aft of the
  datum (the aerodynamic reference point is at 43.2 in). Its inertias are the 948 / 1,346 / 1,967
  slug ft^2 of the file (the same as ours) plus JSBSim's point masses' own contributions.
- **Held to 2,700 rpm and 160 hp.** The model pairs the IO-320 engine (160 hp at 2,700 rpm) with a
  fixed-pitch propeller (``prop_75in2f``) that absorbs too little power: at full throttle the engine
  overspeeds to about 2,940 rpm and 240 hp (the table shows it). The propeller is fixed-pitch
  (minimum pitch = maximum pitch), so JSBSim's constant-speed mode and ``blade-angle`` property do
  nothing on it, and the engine's rated power and rpm are file constants, not properties. So it is
  held the way a pilot holds it, with the throttle: a flight condition counts as flyable only if
  JSBSim trims it (its trimmer solves for the throttle in [0, 1]) with the engine at or below
  2,700 rpm (``propulsion/engine/engine-rpm``) and the rated power of the next point
  (``propulsion/engine/power-hp``). That is a throttle stop where the rated limits are reached,
  condition by condition. It applies to climb and top speed, the figures the engine sets. The
  level trims and the stall are the airframe's figures and are flown unheld: held, JSBSim's
  lowest level trim speed at 1,500 m is set by power, not by the stall (it cannot fly 30 m/s
  there with 125 hp at 2,350 rpm; the table shows that speed too).
- **The stop is the rated engine's torque, lapsing with altitude as JSBSim's own engine does.**
  160 hp at 2,700 rpm is a torque: at full throttle a fixed-pitch engine below 2,700 rpm makes
  proportionally less power, as JSBSim's own engine does (at sea level 221 hp at 2,722 rpm and
  230 hp at 2,843 rpm: power in proportion to rpm within 0.5 %). And a constant 160 hp stop hides
  the lapse: the overpowered engine still makes 200 hp at full throttle at 1,500 m, so held at
  160 hp it climbs there almost as at sea level (3.57 against 3.75 m/s, RESULTS.md 2026-11-24
  00:42), which no 160 hp engine does. So the stop is ``160 hp x (rpm / 2,700) x L(h)``, L(h)
  JSBSim's full-throttle torque (power over rpm) at the altitude over that at sea level (level
  flight at 38, 47 and 55 m/s, the mean of the three ratios; printed in the table): JSBSim's
  engine scaled to its rating, with its own lapse, not ours.
- **Mixture leaned for best power.** JSBSim's piston engine burns an equivalence ratio of
  1.3 x mixture x (sea-level pressure / ambient pressure): full rich is right at sea level but far
  too rich higher up (at 3,000 m the engine stops). A pilot leans for best power; here the mixture
  is set at every altitude to the equivalence ratio 1.4, which gave the most full-throttle power
  in this engine model at 0, 1,500 and 3,000 m (full rich at sea level).
- The ground is put 1,000 m below sea level (``ic/terrain-elevation-ft``) so that flights at
  0 m are clear of the gear and of ground effect. JSBSim's atmosphere is its standard atmosphere
  (1.225 kg/m^3 at sea level), as ours (replay.flight.atmosphere); all airspeeds are true airspeeds.
- Its ``c172x`` counts lift twice and is not a usable reference.

Figures are appended to benchmarks/RESULTS.md through ``_record.record`` (machine, date, command)
unless ``--no-record``. ``--quick`` is a coarse smoke run (fewer speeds, looser searches, shorter
flights): not for the record.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._record import record  # noqa: E402
from benchmarks._validate import (  # noqa: E402
    Comparison,
    Mode,
    Target,
    boundary,
    first_crossing,
    fit_mode,
    maximise,
    physics_turn_radius,
    table_rows,
    tally,
    turn_radius,
)
from replay.flight.atmosphere import density  # noqa: E402
from replay.flight.base import G  # noqa: E402
from replay.flight.fixedwing.dynamics import Aircraft, air_data  # noqa: E402
from replay.flight.fixedwing.kernels import piston_lapse  # noqa: E402
from replay.flight.fixedwing.params import VehicleParams  # noqa: E402
from replay.flight.fixedwing.presets import load_vehicle  # noqa: E402
from replay.flight.fixedwing.trim import trim  # noqa: E402
from replay.frames import DA, DE, DT, PD, PHI, PSI, THETA, rotation_body_to_ned  # noqa: E402
from terrain.errors import InputError  # noqa: E402

FloatArray = npt.NDArray[np.float64]

INSTALL = "jsbsim is not installed: .venv/bin/pip install -e '.[validate]' (or pip install jsbsim)"

FT = 0.3048  # m per ft
HP = 745.69987  # W per hp
RPM_HELD = 2700.0
HP_HELD = 160.0
LAPSE_SPEEDS = (38.0, 47.0, 55.0)  # m/s: where JSBSim's full-throttle power lapse is measured
GROSS_LB = 2300.0
BEST_POWER_PHI = 1.4  # JSBSim piston: equivalence ratio = 1.3 mixture p_sl / p
DT_S = 0.01  # both sides step at 100 Hz

DYN_SPEED = 50.0  # m/s: turn, doublet and roll
DYN_ALT = 1500.0  # m
BANK_DEG = 30.0
DOUBLET_DEG = 2.0
DOUBLET_S = 1.0
ROLL_LEVEL_DEG = 30.0


@dataclass(frozen=True)
class Plan:
    """What to fly and how finely to search (the full run or ``--quick``)."""

    trim_speeds: tuple[float, ...] = (30.0, 40.0, 50.0, 55.0)
    trim_altitudes: tuple[float, ...] = (0.0, 1500.0)
    climb_altitudes: tuple[float, ...] = (0.0, 1500.0, 3000.0, 3500.0, 4000.0)
    glide_altitude: float = 1500.0
    speed_tol: float = 0.05  # m/s, stall and top speed
    gamma_tol: float = 1e-4  # rad, climb and glide angles
    scan: tuple[float, float, int] = (28.0, 52.0, 9)  # climb / glide speed scan (m/s, m/s, points)
    scan_tol: float = 0.1  # m/s
    turn_s: float = 30.0
    doublet_s: float = 200.0


QUICK = Plan(
    trim_speeds=(30.0, 50.0),
    trim_altitudes=(0.0,),
    climb_altitudes=(0.0, 3000.0),
    speed_tol=0.5,
    gamma_tol=1e-3,
    scan=(30.0, 50.0, 5),
    scan_tol=1.0,
    turn_s=10.0,
    doublet_s=120.0,
)


@dataclass(frozen=True)
class LevelTrim:
    alpha_deg: float
    throttle: float
    detail: str = ""


@dataclass(frozen=True)
class Series:
    """Sampled flight: times (s from the start) and named channels (SI units, radians)."""

    t: FloatArray
    channels: dict[str, FloatArray]

    def __getitem__(self, name: str) -> FloatArray:
        return self.channels[name]


class FlightModel(Protocol):
    """What a side supplies: trims and three flown manoeuvres; every figure is derived from these
    the same way for both sides."""

    name: str
    g: float

    def level(self, airspeed: float, altitude: float) -> LevelTrim | None: ...

    def trims(self, airspeed: float, altitude: float, gamma: float) -> bool: ...

    def turn(self, airspeed: float, altitude: float, bank: float, seconds: float) -> Series: ...

    def doublet(
        self, airspeed: float, altitude: float, amplitude: float, pulse: float, seconds: float
    ) -> Series: ...

    def roll(self, airspeed: float, altitude: float, direction: int, seconds: float) -> Series: ...


# --- our side ------------------------------------------------------------------------------------


class Ours:
    """The ``cessna172`` preset through ``trim`` and ``Aircraft``."""

    def __init__(self, params: VehicleParams) -> None:
        self.params = params
        self.name = params.name
        self.g = G

    def level(self, airspeed: float, altitude: float) -> LevelTrim | None:
        try:
            x, u = trim(self.params, airspeed, altitude=altitude)
        except InputError:
            return None
        alpha = math.degrees(math.atan2(x[5], x[3]))
        return LevelTrim(alpha, float(u[DT]), f"δt {u[DT]:.2f}")

    def trims(self, airspeed: float, altitude: float, gamma: float) -> bool:
        try:
            trim(self.params, airspeed, altitude=altitude, gamma=gamma)
        except InputError:
            return False
        return True

    def turn(self, airspeed: float, altitude: float, bank: float, seconds: float) -> Series:
        # the radius whose coordinated trim banks ``bank``: phi ~ atan(V^2 / (g R)), so R is
        # rescaled by tan(phi) / tan(bank) until the trim's bank is ``bank``
        radius = physics_turn_radius(airspeed, bank, self.g)
        for _ in range(20):
            x, u = trim(self.params, airspeed, altitude=altitude, turn_radius=radius)
            if abs(x[PHI] - bank) < 1e-6:
                break
            radius *= math.tan(x[PHI]) / math.tan(bank)
        return self._fly(x, lambda t: u, seconds)

    def doublet(
        self, airspeed: float, altitude: float, amplitude: float, pulse: float, seconds: float
    ) -> Series:
        x, u = trim(self.params, airspeed, altitude=altitude)
        up, down = u.copy(), u.copy()
        up[DE] -= amplitude  # trailing edge up: nose up (Cm_de < 0)
        down[DE] += amplitude
        return self._fly(x, lambda t: up if t < pulse else down if t < 2 * pulse else u, seconds)

    def roll(self, airspeed: float, altitude: float, direction: int, seconds: float) -> Series:
        x, u = trim(self.params, airspeed, altitude=altitude)
        full = u.copy()
        full[DA] = direction * math.radians(self.params.aileron_max_deg)  # + rolls right
        return self._fly(x, lambda t: full, seconds)

    def _fly(
        self, x0: FloatArray, controls: Callable[[float], FloatArray], seconds: float
    ) -> Series:
        ac = Aircraft(self.params, x0, dt=DT_S)
        n = int(round(seconds / DT_S))
        rows = np.empty((n + 1, 12))
        rows[0] = ac.x
        for k in range(n):
            rows[k + 1] = ac.step(controls(k * DT_S), 1)
        t = np.arange(n + 1) * DT_S
        ned_v = np.array([rotation_body_to_ned(s[PHI], s[THETA], s[PSI]) @ s[3:6] for s in rows])
        airspeed = np.array([air_data(s)[0] for s in rows])
        return Series(
            t,
            {
                "phi": rows[:, PHI],
                "p": rows[:, 9],
                "q": rows[:, 10],
                "airspeed": airspeed,
                "altitude": -rows[:, PD],
                "course": np.arctan2(ned_v[:, 1], ned_v[:, 0]),
                "ground_speed": np.hypot(ned_v[:, 0], ned_v[:, 1]),
            },
        )


# --- JSBSim's c172p ------------------------------------------------------------------------------


class Jsbsim:
    """JSBSim's ``c172p`` at 2,300 lb, held to 2,700 rpm and 160 hp (see the module docstring)."""

    TERRAIN_M = -1000.0

    def __init__(self) -> None:
        import jsbsim

        self._jsbsim = jsbsim
        jsbsim.set_logger(jsbsim.DefaultLogger(jsbsim.LogLevel.FATAL))
        self.fdm = self._load()
        self.name = "JSBSim c172p"
        self._lapse: dict[int, float] = {}
        self.holding = True
        self._init(50.0, 0.0)
        weight = float(self.fdm["inertia/weight-lbs"])
        if abs(weight - GROSS_LB) > 0.5:
            raise RuntimeError(f"c172p loaded to {weight:.1f} lb, expected {GROSS_LB:g} lb")
        self.cg_in = float(self.fdm["inertia/cg-x-in"])
        self.g = float(self.fdm["accelerations/gravity-ft_sec2"]) * FT

    def _load(self) -> Any:
        """A fresh c172p, loaded to 2,300 lb. The flown manoeuvres and every condition after a failed
        trim start from a fresh one: JSBSim's trimmer starts from what the last trim left."""
        fdm = self._jsbsim.FGFDMExec(None)
        fdm.set_debug_level(0)
        if not fdm.load_model("c172p"):
            raise RuntimeError("JSBSim could not load its c172p model")
        # 1,500 lb empty + 180 lb pilot (the file's load) + co-pilot, full tanks, rear seats
        fdm["inertia/pointmass-weight-lbs[1]"] = 180.0
        fdm["propulsion/tank[0]/contents-lbs"] = 185.0
        fdm["propulsion/tank[1]/contents-lbs"] = 185.0
        fdm["inertia/pointmass-weight-lbs[2]"] = 35.0
        fdm["inertia/pointmass-weight-lbs[3]"] = 35.0
        fdm["propulsion/fuel_freeze"] = 1
        fdm.set_dt(DT_S)
        return fdm

    def __getitem__(self, prop: str) -> float:
        return float(self.fdm[prop])

    def _init(
        self, airspeed: float, altitude: float, gamma: float = 0.0, bank: float = 0.0
    ) -> None:
        fdm = self.fdm
        fdm["ic/terrain-elevation-ft"] = self.TERRAIN_M / FT
        fdm["ic/h-sl-ft"] = altitude / FT
        fdm["ic/vt-fps"] = airspeed / FT
        fdm["ic/gamma-deg"] = math.degrees(gamma)
        fdm["ic/phi-deg"] = math.degrees(bank)
        fdm["ic/psi-true-deg"] = 0.0
        fdm["ic/beta-deg"] = 0.0
        for cmd in ("elevator", "aileron", "rudder"):
            fdm[f"fcs/{cmd}-cmd-norm"] = 0.0
        fdm.run_ic()
        fdm["propulsion/set-running"] = -1  # also sets the mixture full rich
        # leaned for best power (see the module docstring): equivalence ratio BEST_POWER_PHI
        fdm["fcs/mixture-cmd-norm"] = min(
            1.0, BEST_POWER_PHI / 1.3 * float(fdm["atmosphere/delta"])
        )

    def _trim(self, mode: int) -> bool:
        """JSBSim's trimmer: 0 longitudinal, 1 full, 5 steady turn."""
        try:
            self.fdm["simulation/do_simple_trim"] = mode
        except self._jsbsim.TrimFailureError:
            # a failed trim can leave the model in a state later trims do not recover from
            # (seen: NaN rpm for the rest of the run), so the next condition starts afresh
            self.fdm = self._load()
            return False
        return True

    @contextmanager
    def unheld(self) -> Iterator[None]:
        """Fly without the rated-engine stop (the airframe's figures: level trims, stall)."""
        self.holding = False
        try:
            yield
        finally:
            self.holding = True

    def held(self) -> bool:
        if not self.holding:
            return True
        rpm, hp = self["propulsion/engine/engine-rpm"], self["propulsion/engine/power-hp"]
        altitude = self["ic/h-sl-ft"] * FT  # read before lapse() flies other conditions
        return rpm <= RPM_HELD and hp <= HP_HELD * rpm / RPM_HELD * self.lapse(altitude)

    def lapse(self, altitude: float) -> float:
        """JSBSim's full-throttle torque at ``altitude`` over that at sea level: the mean ratio in
        level flight at :data:`LAPSE_SPEEDS` (see the module docstring). Flies conditions of its
        own: call it for every altitude before the trims that are held to it."""
        key = round(altitude)
        if key not in self._lapse:
            if key == 0:
                self._lapse[key] = 1.0
            else:
                ratios = []
                for v in LAPSE_SPEEDS:
                    rpm, hp = self.full_throttle(v, altitude)
                    rpm0, hp0 = self.full_throttle(v, 0.0)
                    ratios.append((hp / rpm) / (hp0 / rpm0))
                self._lapse[key] = float(np.mean(ratios))
                self.fdm = self._load()
        return self._lapse[key]

    def level(self, airspeed: float, altitude: float) -> LevelTrim | None:
        self._init(airspeed, altitude)
        if not (self._trim(0) and self.held()):
            return None
        thr = self["fcs/throttle-cmd-norm"]
        return LevelTrim(
            self["aero/alpha-deg"],
            thr,
            f"δt {thr:.2f}, {self['propulsion/engine/power-hp']:.0f} hp, "
            f"{self['propulsion/engine/engine-rpm']:.0f} rpm",
        )

    def trims(self, airspeed: float, altitude: float, gamma: float) -> bool:
        self._init(airspeed, altitude, gamma)
        return self._trim(0) and self.held()

    def full_throttle(self, airspeed: float, altitude: float) -> tuple[float, float]:
        """(rpm, hp) of the unheld engine at full throttle, in level flight at ``airspeed``."""
        self._init(airspeed, altitude)
        self._trim(0)
        self.fdm["fcs/throttle-cmd-norm"] = 1.0
        self.fdm.run()
        self.fdm.get_propulsion().get_steady_state()
        return self["propulsion/engine/engine-rpm"], self["propulsion/engine/power-hp"]

    def turn(self, airspeed: float, altitude: float, bank: float, seconds: float) -> Series:
        self.fdm = self._load()
        self._init(airspeed, altitude, bank=bank)
        if not self._trim(5):
            raise RuntimeError(f"JSBSim cannot trim a {math.degrees(bank):g} deg turn")
        return self._fly(lambda t: None, seconds)

    def doublet(
        self, airspeed: float, altitude: float, amplitude: float, pulse: float, seconds: float
    ) -> Series:
        self.fdm = self._load()
        self._init(airspeed, altitude)
        if not self._trim(1):
            raise RuntimeError(f"JSBSim cannot trim level flight at {airspeed:g} m/s")
        de0 = self["fcs/elevator-pos-deg"]
        trim_norm = self["fcs/pitch-trim-cmd-norm"]
        up = _elevator_norm(de0 - math.degrees(amplitude)) - trim_norm
        down = _elevator_norm(de0 + math.degrees(amplitude)) - trim_norm

        def controls(t: float) -> None:
            cmd = up if t < pulse else down if t < 2 * pulse else 0.0
            self.fdm["fcs/elevator-cmd-norm"] = cmd

        return self._fly(controls, seconds)

    def roll(self, airspeed: float, altitude: float, direction: int, seconds: float) -> Series:
        self.fdm = self._load()
        self._init(airspeed, altitude)
        if not self._trim(1):
            raise RuntimeError(f"JSBSim cannot trim level flight at {airspeed:g} m/s")
        cmd = self["fcs/aileron-cmd-norm"] + direction  # + rolls right; the FCS clips to +-1

        def controls(t: float) -> None:
            self.fdm["fcs/aileron-cmd-norm"] = cmd

        return self._fly(controls, seconds)

    def _fly(self, controls: Callable[[float], Any], seconds: float) -> Series:
        fdm = self.fdm
        n = int(round(seconds / DT_S))
        names = {
            "phi": ("attitude/phi-rad", 1.0),
            "p": ("velocities/p-rad_sec", 1.0),
            "q": ("velocities/q-rad_sec", 1.0),
            "airspeed": ("velocities/vt-fps", FT),
            "altitude": ("position/h-sl-ft", FT),
            "course": ("flight-path/psi-gt-rad", 1.0),
            "ground_speed": ("velocities/vg-fps", FT),
        }
        out = {k: np.empty(n + 1) for k in names}

        def sample(k: int) -> None:
            for key, (prop, scale) in names.items():
                out[key][k] = float(fdm[prop]) * scale

        sample(0)
        for k in range(n):
            controls(k * DT_S)
            fdm.run()
            sample(k + 1)
        return Series(np.arange(n + 1) * DT_S, out)


def _elevator_norm(deg: float) -> float:
    """The c172p's normalised elevator for a surface angle: +1 is 23 deg (trailing edge down),
    -1 is -28 deg, each side scaled on its own (JSBSim's zero-centred aerosurface_scale)."""
    return deg / 23.0 if deg >= 0 else deg / 28.0


# --- the manoeuvres, the same for both sides ----------------------------------------------------


def stall(m: FlightModel, altitude: float, tol: float) -> float:
    """The lowest level trim speed (m/s)."""
    return boundary(lambda v: m.trims(v, altitude, 0.0), 40.0, 15.0, tol)


def stall_and_top(m: FlightModel, altitude: float, tol: float) -> tuple[float, float]:
    """(lowest, highest) level trim speed (m/s)."""
    top = boundary(lambda v: m.trims(v, altitude, 0.0), 50.0, 95.0, tol)
    return stall(m, altitude, tol), top


def steepest(m: FlightModel, airspeed: float, altitude: float, tol: float, sign: int) -> float:
    """The steepest climb (sign +1) or shallowest descent at closed throttle (sign -1): the
    flight-path angle (rad) at the edge of what trims; nan if level flight does not trim."""
    if not m.trims(airspeed, altitude, 0.0):
        return math.nan
    return boundary(lambda g: m.trims(airspeed, altitude, g), 0.0, sign * 0.5, tol)


CLIMB_RATIO = 0.20  # the best climb's target up to 3,000 m (issue 14)
CLIMB_NEAR_CEILING = 0.28  # m/s: above 3,000 m, |ours - JSBSim| (issue 32)


def climb_target(altitude: float) -> Target:
    """The best climb's target: a ratio within 20 % up to 3,000 m; above, where the climb falls
    towards zero at the ceiling and a ratio of two small numbers says little (0.43 / 0.63 m/s at
    4,000 m is 0.70, for a power lapse 4.6 % below JSBSim's engine there), the difference within
    0.28 m/s -- the allowance the 20 % gives at 3,000 m (JSBSim's 1.39 m/s)."""
    if altitude <= 3000.0:
        return Target("ratio", CLIMB_RATIO)
    return Target("difference", CLIMB_NEAR_CEILING)


def best_climb(m: FlightModel, altitude: float, plan: Plan) -> tuple[float, float]:
    """(best climb rate m/s, its airspeed m/s)."""
    lo, hi, n = plan.scan
    best = maximise(
        lambda v: v * math.sin(steepest(m, v, altitude, plan.gamma_tol, +1)),
        lo,
        hi,
        n,
        plan.scan_tol,
    )
    return best.value, best.x


def glide(m: FlightModel, altitude: float, plan: Plan) -> tuple[float, float, float, float]:
    """(best glide ratio, its airspeed, least sink rate m/s, its airspeed)."""
    lo, hi, n = plan.scan
    memo: dict[float, float] = {}

    def gamma(v: float) -> float:
        if v not in memo:
            memo[v] = steepest(m, v, altitude, plan.gamma_tol, -1)
        return memo[v]

    ratio = maximise(lambda v: 1.0 / math.tan(-gamma(v)), lo, hi, n, plan.scan_tol)
    sink = maximise(lambda v: v * math.sin(gamma(v)), lo, hi, n, plan.scan_tol)
    return ratio.value, ratio.x, -sink.value, sink.x


@dataclass(frozen=True)
class TurnFigures:
    radius: float
    physics: float
    bank_deg: float
    airspeed: float


def turn_figures(m: FlightModel, plan: Plan) -> TurnFigures:
    s = m.turn(DYN_SPEED, DYN_ALT, math.radians(BANK_DEG), plan.turn_s)
    va = float(np.mean(s["airspeed"]))
    bank = float(np.mean(s["phi"]))
    return TurnFigures(
        turn_radius(s.t, s["course"], s["ground_speed"]),
        physics_turn_radius(va, bank, m.g),
        math.degrees(bank),
        va,
    )


def modes(m: FlightModel, plan: Plan) -> tuple[Mode, Mode]:
    """(short period from the pitch rate, phugoid from the airspeed) after a doublet."""
    s = m.doublet(DYN_SPEED, DYN_ALT, math.radians(DOUBLET_DEG), DOUBLET_S, plan.doublet_s)
    end = 2 * DOUBLET_S
    sp = (s.t >= end) & (s.t <= end + 4.0)
    ph = s.t >= 10.0
    return fit_mode(s.t[sp], s["q"][sp]), fit_mode(s.t[ph], s["airspeed"][ph])


def roll_figures(m: FlightModel) -> tuple[float, float]:
    """(peak roll rate deg/s in 3 s, time s to 30 deg of bank), mean of right and left rolls."""
    rates, times = [], []
    for direction in (+1, -1):
        s = m.roll(DYN_SPEED, DYN_ALT, direction, 3.0)
        rates.append(math.degrees(float(np.max(np.abs(s["p"])))))
        dphi = np.degrees(s["phi"] - s["phi"][0])
        times.append(first_crossing(s.t, dphi, ROLL_LEVEL_DEG))
    return float(np.mean(rates)), float(np.mean(times))


# --- the table -----------------------------------------------------------------------------------


def compare(
    ours: FlightModel, ref: Jsbsim, plan: Plan, log: Callable[[str], None]
) -> tuple[list[Comparison], list[tuple[str, str, str]]]:
    """The comparison rows and plain notes (figure, value, target) shown after them."""
    rows: list[Comparison] = []
    notes: list[tuple[str, str, str]] = []
    km = "m/s"
    for h in {*plan.trim_altitudes, *plan.climb_altitudes, plan.glide_altitude}:
        ref.lapse(h)  # before any held trim (it flies conditions of its own)

    log("level trims")
    for h in plan.trim_altitudes:
        for v in plan.trim_speeds:
            a = ours.level(v, h)
            with ref.unheld():
                b = ref.level(v, h)
            fig = f"level trim α at {v:g} m/s, {h:,.0f} m"
            rows.append(
                Comparison(
                    fig,
                    "deg",
                    a.alpha_deg if a else math.nan,
                    b.alpha_deg if b else math.nan,
                    Target("difference", 0.5),
                    note=f"ours {a.detail if a else 'no trim'}; JSBSim {b.detail if b else 'no trim'}",
                )
            )

    log("stall and top speed")
    for h in plan.trim_altitudes:
        s_o, t_o = stall_and_top(ours, h, plan.speed_tol)
        s_held, t_r = stall_and_top(ref, h, plan.speed_tol)
        with ref.unheld():
            s_r = stall(ref, h, plan.speed_tol)
        rows.append(
            Comparison(
                f"lowest level trim speed (stall), {h:,.0f} m",
                km,
                s_o,
                s_r,
                Target("ratio", 0.05),
                note=f"JSBSim unheld; held, its lowest level trim speed is {s_held:.2f} m/s",
            )
        )
        rows.append(
            Comparison(
                f"highest level trim speed (top), {h:,.0f} m",
                km,
                t_o,
                t_r,
                Target("ratio", 0.05),
                note=f"JSBSim held to 2,700 rpm / {HP_HELD * ref.lapse(h):.0f} hp at 2,700",
            )
        )

    log("best climb")
    for h in plan.climb_altitudes:
        c_o, v_o = best_climb(ours, h, plan)
        c_r, v_r = best_climb(ref, h, plan)
        rows.append(
            Comparison(
                f"best climb rate, {h:,.0f} m",
                km,
                c_o,
                c_r,
                climb_target(h),
                note=(
                    f"at {v_o:.1f} / {v_r:.1f} m/s; JSBSim held to 2,700 rpm and the torque "
                    f"of {HP_HELD * ref.lapse(h):.0f} hp at 2,700"
                ),
            )
        )
    unheld = ", ".join(
        f"{v:g} m/s: {rpm:,.0f} rpm, {hp:.0f} hp"
        for v in (38.0, 55.0)
        for rpm, hp in [ref.full_throttle(v, 0.0)]
    )
    notes.append(
        (
            "why JSBSim is held: its c172p unheld at full throttle, level, 0 m",
            f"{unheld} (the IO-320 is rated 160 hp at 2,700 rpm)",
            "",
        )
    )
    lapses = ", ".join(f"{h:,.0f} m: {ref.lapse(h):.3f}" for h in plan.climb_altitudes)
    notes.append(
        (
            "JSBSim's full-throttle torque lapse (its torque over its sea-level torque)",
            f"{lapses} (ISA Gagg-Ferrar, ours: "
            + ", ".join(f"{piston_lapse(float(density(h))):.3f}" for h in plan.climb_altitudes)
            + ")",
            "",
        )
    )

    log("power-off glide")
    h = plan.glide_altitude
    g_o, gv_o, s_o, sv_o = glide(ours, h, plan)
    g_r, gv_r, s_r, sv_r = glide(ref, h, plan)
    rows.append(
        Comparison(
            f"best glide ratio, closed throttle, {h:,.0f} m",
            "",
            g_o,
            g_r,
            note=f"at {gv_o:.1f} / {gv_r:.1f} m/s; JSBSim's closed throttle is idle power",
        )
    )
    rows.append(
        Comparison(
            f"least sink rate, closed throttle, {h:,.0f} m",
            km,
            s_o,
            s_r,
            note=f"at {sv_o:.1f} / {sv_r:.1f} m/s",
        )
    )

    log("30° turn")
    to, tr = turn_figures(ours, plan), turn_figures(ref, plan)
    where = f"{BANK_DEG:g}° bank, {DYN_SPEED:g} m/s, {DYN_ALT:,.0f} m"
    rows.append(
        Comparison(
            f"turn radius vs V²/(g tan φ), {where}",
            "m",
            to.radius,
            to.physics,
            Target("ratio", 0.02),
            digits=1,
            reference_name="V²/(g tan φ)",
            note=f"flown bank {to.bank_deg:.2f}°, airspeed {to.airspeed:.2f} m/s",
        )
    )
    rows.append(
        Comparison(
            f"JSBSim turn radius vs V²/(g tan φ), {where}",
            "m",
            tr.radius,
            tr.physics,
            digits=1,
            reference_name="V²/(g tan φ)",
            subject_name="JSBSim",
            note=f"flown bank {tr.bank_deg:.2f}°, airspeed {tr.airspeed:.2f} m/s",
        )
    )
    rows.append(Comparison(f"turn radius, {where}", "m", to.radius, tr.radius, digits=1))

    log("doublet")
    (sp_o, ph_o), (sp_r, ph_r) = modes(ours, plan), modes(ref, plan)
    at = f"{DYN_SPEED:g} m/s, {DYN_ALT:,.0f} m"
    rows += [
        Comparison(f"short-period ω_n, {at}", "rad/s", sp_o.omega_n, sp_r.omega_n),
        Comparison(f"short-period ζ, {at}", "", sp_o.zeta, sp_r.zeta),
        Comparison(f"phugoid period, {at}", "s", ph_o.period, ph_r.period, digits=1),
        Comparison(f"phugoid ζ, {at}", "", ph_o.zeta, ph_r.zeta, digits=3),
    ]

    log("roll")
    (p_o, t_o), (p_r, t_r) = roll_figures(ours), roll_figures(ref)
    rows += [
        Comparison(
            f"full-aileron roll rate (peak in 3 s), {at}",
            "deg/s",
            p_o,
            p_r,
            Target("ratio", 0.30),
            digits=1,
            note="mean of right and left",
        ),
        Comparison(f"full-aileron time to 30° bank, {at}", "s", t_o, t_r),
    ]
    return rows, notes


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--no-record", action="store_true", help="print only; do not append to RESULTS.md"
    )
    ap.add_argument(
        "--quick", action="store_true", help="coarse smoke run (fewer points, shorter flights)"
    )
    args = ap.parse_args(argv)
    if importlib.util.find_spec("jsbsim") is None:
        print(INSTALL, file=sys.stderr)
        return 2
    plan = QUICK if args.quick else Plan()
    ref = Jsbsim()
    ours = Ours(load_vehicle("cessna172"))

    def log(msg: str) -> None:
        print(f"  {msg}...", file=sys.stderr, flush=True)

    rows, extra = compare(ours, ref, plan, log)
    passed, judged = tally(rows)
    table = table_rows(rows) + extra
    import jsbsim

    title = (
        "validate_jsbsim: cessna172 against JSBSim c172p "
        "(2,300 lb, held to 2,700 rpm and the torque of 160 hp at 2,700, with its own lapse)"
    )
    summary = (
        f"jsbsim {jsbsim.__version__}; {passed}/{judged} targets met; "
        f"c172p cg {ref.cg_in:.1f} in; {'quick run' if args.quick else 'full run'}; "
        "both fly the ISA standard atmosphere"
    )
    if args.no_record:
        print(f"\n## {title}\n- notes: {summary}\n\n| figure | value | target |\n|---|---|---|")
        for a, b, c in table:
            print(f"| {a} | {b} | {c} |")
    else:
        record(title, table, summary)
    return 0


if __name__ == "__main__":
    sys.exit(main())
