"""Vehicle presets and vehicle files.

Presets (``load_vehicle(name)``):

``aerosonde`` (default)
    The Aerosonde UAV parameter set of Beard & McLain, *Small Unmanned Aircraft: Theory and
    Practice* (Princeton University Press, 2012), Appendix E (Tables E.1-E.2, their
    ``aerosonde_parameters``): 13.5 kg, 2.9 m span, every derivative as printed except the
    elevator's: the book pairs ``CLde = -0.36`` with ``Cmde = -0.5``, inconsistent for a tail
    behind the centre of gravity (a trailing-edge-down elevator lifts the tail: more lift and a
    nose-down moment), so ``CLde = 0.13, Cmde = -0.99`` of Beard's later published parameter
    files (the MAVsim ``aerosonde_parameters`` of the second edition, 2021); likewise the rudder:
    ``CYdr = -0.17`` with ``Cndr = -0.032`` becomes their ``CYdr = 0.19, Cndr = -0.069`` (a
    rudder deflected to yaw the nose left pushes the tail right).
    Propulsion: the second edition's motor and propeller (§4.3: 44.4 V, KV = KQ = 0.0659,
    0.042 ohm, 1.5 A, a 0.508 m propeller and its CT/CQ), which replace the 2012 propeller
    (``k_motor = 80``, 6.2 times the weight of static thrust): static thrust 0.62 W, top level
    speed 32 m/s, best climb 6.0 m/s at sea level and 4.2 m/s at 3,000 m. Not in the book and
    chosen here: surface travel +-25 deg, cruise 25 m/s (the default cruise of terrapath
    missions), envelope 18-30 m/s (equivalent airspeed), climb limit 5 m/s, descent limit 3 m/s.
``solar-uav``
    Seed 000's UAV (Krishnan & Manimala 2020 §2.1: a 6-DOF solar UAV at 15 m/s, bank limit 30 deg,
    climb speed 3 m/s). The paper does not print its airframe, so this is a consistent set derived
    from the Aerosonde by geometric scaling: a light, high-aspect-ratio glider-like airframe of
    6 kg, 3.5 m span and 0.75 m^2 (AR 16.3, near the Aerosonde's 15.2, so the non-dimensional
    derivatives are kept); inertias scaled as ``Jx, Jz, Jxz ~ m b^2`` (wing-dominated) and
    ``Jy ~ m S``; parasitic drag lowered to CDp = 0.025 (a clean sailplane-like airframe: best
    L/D about 20, L/D 18 at 15 m/s); an electric drive of the Aerosonde's propeller family sized
    here (0.47 m propeller, 15.6 V, KV = KQ = 0.0273, 0.1 ohm): top level speed 23.5 m/s, best
    climb 3.5 m/s at sea level and 2.8 m/s at 3,000 m. Climb limit 3 m/s (the paper), descent
    limit 1.5 m/s, envelope 11-22 m/s. Its coordinated 30 deg turns at 15 m/s need 12 deg of
    rudder (the Aerosonde's yaw damping at a low speed).
``cessna172``
    A Cessna-172-class aircraft for seed 001 (Guo et al. 2021 §4.1: 50 m/s cruise, roll +-30 deg,
    pitch +-20 deg). Derivatives from the LaRCsim ``c172_aero.c`` model by Tony Peden in
    FlightGear (based on Roskam, *Airplane Flight Dynamics and Automatic Flight Controls* Part I),
    geometry, weight (2300 lb) and inertias (948/1346/1967 slug ft^2) from the UIUC Cessna 172
    model pages (J. Scott, M. Selig, 2000, after Sivier's Frasca data), converted to SI. His
    aileron is positive right-wing-up, so Clda and Cnda change sign here. The alpha-dot terms
    are JSBSim's c172p's (CLadot 1.7, Cmadot -7.27). Changed from LaRCsim after the comparison with JSBSim's
    c172p (benchmarks/validate_jsbsim.py), whose aerodynamic tables are Peden's: lift and drag
    are fitted (least squares, alpha -5..16 deg) to its CLwbh(alpha) and CDo + CDwbh(alpha)
    tables through this model's blend and its drag of the attached-flow lift (``params.py``):
    CL0 0.25, CLalpha 5.75 /rad, M = 10.8, alpha0 = 0.39 rad (lift within 0.04 of the table to
    the stall, CLmax 1.48 against its 1.47: the smooth blend peaks at 18 deg, the table at 16),
    CDp 0.0278 and 1/(pi e AR) 0.0816 (drag within 6 %). Peden's linear CLalpha 5.5 with M = 20
    kept the lift curve straight to 14 deg, and eq. 4.11 on it gave a third too much drag at 12 deg:
    the Cessna could not fly 30 m/s at 1,500 m, which JSBSim trims at 13.6 deg. CDde = 0.06 is on
    |delta_e| (LaRCsim's signed 0.06 delta_e made an up elevator reduce drag); the aileron's
    Clda is 0.23 (JSBSim's c172 models; LaRCsim's 0.09 rolled at 30 deg/s against their 67-96);
    Cm0 is JSBSim's 0.10 (LaRCsim's -0.02 trimmed with 7 deg of up elevator at 40 m/s where
    JSBSim needs half a degree: 30 % more parasitic drag from the elevator, and 0.35 deg too much
    angle of attack). Propulsion: a 160 hp engine (Gagg-Ferrar lapse) on a fixed-pitch 75 in propeller
    held to 2,700 rpm, its CT(J) and CP(J) chosen here (static thrust 2.6 kN; efficiency 0.70 at
    46 m/s and 0.84 at 65 m/s at full power, near JSBSim's 0.71 and 0.84); closed throttle
    windmills (CP = 0). Top level speed and best climb: see benchmarks/RESULTS.md
    (validate_jsbsim). Envelope 35-58 m/s, climb limit 3 m/s, descent limit 4 m/s.
``small-uas``
    Seed 004's small UAS (Lin, Castano & Xu: a UMD RMRC Anaconda-class aircraft, 13-19 m/s,
    cruise 15 m/s, Table II). Scaled from the Aerosonde like ``solar-uav``: 3 kg, 2.2 m span,
    0.48 m^2 (AR 10), Aerosonde non-dimensional derivatives; electric drive sized here (0.35 m
    propeller, 14.8 V, KV = KQ = 0.0195, 0.12 ohm): top level speed 21 m/s, best climb 3.9 m/s
    at sea level; envelope 13-19 m/s as in the paper; climb limit 3 m/s, descent limit 2 m/s.
``seed004-uas``
    ``small-uas`` with a 38 deg bank limit: seed 004 eq 5 assumes a minimum turn radius of d_m =
    30 m at 15 m/s, which needs 37.4 deg (30 deg gives 39.7 m); 29.4 m at 38 deg, 30.4 m measured
    on the 6-DOF aircraft (``benchmarks/bench_fga.py turn``).

Energy (``params.py``'s ``battery_wh``, ``fuel_kg``, ``esc_efficiency``, ``bsfc_g_per_kwh``;
what the engine draws: ``kernels.drain``). Fixed before any comparison with a reference
(:mod:`replay.flight.energy` holds the numbers), none tuned to meet a target:

- **aerosonde**: the preset is electric (Beard & McLain's second edition: a 12-cell, 44.4 V
  motor) while the real Aerosonde burns avgas (Mk 2: "Engine 26 cc, Avgas 100LL, 1 kW"; the Mk 1
  Laima crossed the Atlantic in 1998, 3,270 km in 26 h 45 min, "using only 6 litres (2 US gal) of
  fuel", Flight International). Its battery takes the place of that fuel: the 4.3 kg of 6 litres
  of avgas (6.0 lb per US gallon, as the Cessna POHs weigh it) as a LiPo pack of 150 Wh/kg
  (S. D. Prior, "Lithium Polymer Battery Power Supply", in *Optimizing Small Multi-Rotor
  Unmanned Aircraft*, CRC 2019: "150-200 Wh/kg"; the low end, a pack's rather than a cell's):
  647 Wh, about 1.6 h at cruise, where the gasoline Aerosonde flies more than a day -- the
  electric preset is not the real aircraft's endurance.
- **small-uas**, **seed004-uas** and the multirotor **quadrotor**: the same battery fraction of
  the take-off mass as the aerosonde (0.32) at 150 Wh/kg: 144, 144 and 33 Wh (the papers give
  none).
- **solar-uav**: no capacity (``battery_wh: 0``): seed 000's aircraft is solar powered, its
  panels charge it in flight and are not modelled, so what it draws is reported and no battery
  runs out (seed 000's missions last 8 hours).
- Speed controllers 95 % efficient (``esc_efficiency``; chosen here, no measurement found to
  cite); the fixed wings' motor losses are in their motor model (resistance, no-load current);
  the multirotor, without a motor model, 0.75 x 0.95 (``power_efficiency``: Vorkoetter, "assume
  a motor that is about 75% efficient", Sailplane & Electric Modeler, 2001).
- **cessna172**: the 160 hp Cessna 172N's standard tanks, 40 US gallons usable (Cessna 172N
  Pilot's Operating Handbook, 1978, section 1: "40 Gallons Usable Fuel"), at 6.0 lb/gal: 108.9
  kg; brake-specific fuel consumption 0.45 lb/(bhp h) (273.7 g/kWh), the middle of "0.4 to 0.5
  lb/bhp-h for cruise power" of Yechout et al., *Introduction to Aircraft Flight Mechanics*
  (AIAA 2003), ch. 2. The mass is held at the 2,300 lb gross weight as the fuel burns (3 % of
  it an hour at cruise); closed throttle burns nothing (the idle's flow is not modelled).

Vehicle files (``load_vehicle(path)``): YAML read with ``yaml.safe_load``::

    terrapath: 1
    name: my-uav
    base: aerosonde          # optional: a preset whose values are the defaults (default aerosonde)
    mass: 12.0               # any VehicleParams field overrides the base
    cruise_speed: 22.0

Unknown keys are refused with the allowed names; impossible values (mass <= 0, an inertia that is
not positive definite, S <= 0, ...) are refused naming the file and the field.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from replay.flight.base import file_overrides
from replay.flight.energy import (
    AVGAS_KG_PER_L,
    BSFC_G_PER_KWH,
    battery_wh,
)
from replay.flight.fixedwing.params import ENGINE_PARAMETERS, ENGINES, FIELD_NAMES, VehicleParams
from terrain.docfile import parse_yaml
from terrain.errors import DataFileError, InputError, PluginError, where
from terrain.plugins import Plugin, Registry

if TYPE_CHECKING:
    from replay.flight.multirotor.model import MultirotorParams

FORMAT_VERSION = 1
DEFAULT_VEHICLE = "aerosonde"
FILE_KEYS: tuple[str, ...] = ("terrapath", "base", *FIELD_NAMES)

_SLUG_FT2 = 1.3558179483314004  # kg m^2 per slug ft^2

_LB = 0.45359237  # kg per lb
_FT = 0.3048

AEROSONDE = VehicleParams(
    name="aerosonde",
    mass=13.5,
    Jx=0.8244,
    Jy=1.135,
    Jz=1.759,
    Jxz=0.1204,
    S=0.55,
    b=2.8956,
    c=0.18994,
    e=0.9,
    CL0=0.28,
    CLalpha=3.45,
    CLq=0.0,
    CLde=0.13,
    CDp=0.0437,
    CDq=0.0,
    CDde=0.0,
    Cm0=-0.02338,
    Cmalpha=-0.38,
    Cmq=-3.6,
    Cmde=-0.99,
    CY0=0.0,
    CYbeta=-0.98,
    CYp=0.0,
    CYr=0.0,
    CYda=0.0,
    CYdr=0.19,
    Cl0=0.0,
    Clbeta=-0.12,
    Clp=-0.26,
    Clr=0.14,
    Clda=0.08,
    Cldr=0.105,
    Cn0=0.0,
    Cnbeta=0.25,
    Cnp=0.022,
    Cnr=-0.35,
    Cnda=0.06,
    Cndr=-0.069,
    M=50.0,
    alpha0=0.4712,
    elevator_min_deg=-25.0,
    elevator_max_deg=25.0,
    aileron_max_deg=25.0,
    rudder_max_deg=25.0,
    cruise_speed=25.0,
    airspeed_min=18.0,
    airspeed_max=30.0,
    climb_rate_max=5.0,
    descent_rate_max=3.0,
    engine="electric",
    prop_diameter=0.508,
    battery_voltage=44.4,
    motor_kv=0.0659,
    motor_kq=0.0659,
    motor_resistance=0.042,
    motor_no_load_current=1.5,
    CT0=0.09357,
    CT1=-0.06044,
    CT2=-0.1079,
    CQ0=0.005230,
    CQ1=0.004970,
    CQ2=-0.01664,
    battery_wh=battery_wh(13.5),
    source=(
        "Beard & McLain, Small Unmanned Aircraft (2012), Appendix E (Aerosonde); motor and "
        "propeller of the second edition (2021, §4.3); battery: the real Aerosonde's 6 L fuel "
        "load as LiPo at 150 Wh/kg (chosen here)"
    ),
)


def _scaled(
    base: VehicleParams, name: str, mass: float, b: float, S: float, **changes: Any
) -> VehicleParams:
    """Geometric scaling of ``base``: non-dimensional derivatives kept; Jx, Jz, Jxz ~ m b^2;
    Jy ~ m S (fuselage and tail length taken proportional to sqrt(S))."""
    km = mass / base.mass
    kb = (b / base.b) ** 2
    ks = S / base.S
    return dataclasses.replace(
        base,
        name=name,
        mass=mass,
        b=b,
        S=S,
        c=S / b,
        Jx=base.Jx * km * kb,
        Jz=base.Jz * km * kb,
        Jxz=base.Jxz * km * kb,
        Jy=base.Jy * km * ks,
        **changes,
    )


def _motor(diameter: float, voltage: float, k: float, resistance: float) -> dict[str, float]:
    """An electric drive of the Aerosonde's propeller family (its CT, CQ) resized: propeller
    ``diameter`` (m), battery ``voltage`` (V), motor constants KV = KQ = ``k``, ``resistance``;
    the no-load current scaled with KQ (1.5 A for the Aerosonde's 0.0659)."""
    return {
        "prop_diameter": diameter,
        "battery_voltage": voltage,
        "motor_kv": k,
        "motor_kq": k,
        "motor_resistance": resistance,
        "motor_no_load_current": 1.5 * k / 0.0659,
    }


# Electric drives sized here by a search over propeller diameter, voltage and KV = KQ (the
# Aerosonde's propeller coefficients kept): best climb at the 15 m/s cruise 3.5 m/s at sea level,
# top level speed 23.6 m/s (solar-uav) and 21.1 m/s (small-uas).
SOLAR_UAV = _scaled(
    AEROSONDE,
    "solar-uav",
    mass=6.0,
    b=3.5,
    S=0.75,
    CDp=0.025,
    **_motor(0.47, 15.6, 0.0273, 0.1),
    elevator_min_deg=-25.0,
    elevator_max_deg=25.0,
    cruise_speed=15.0,
    airspeed_min=11.0,
    airspeed_max=22.0,
    climb_rate_max=3.0,
    descent_rate_max=1.5,
    battery_wh=0.0,  # solar: its panels charge it (not modelled), nothing to run out of
    source=(
        "scaled from the Aerosonde of Beard & McLain (2012): 6 kg, 3.5 m span, 0.75 m^2, "
        "CDp 0.025, propeller resized; seed 000 speed and limits"
    ),
)

SMALL_UAS = _scaled(
    AEROSONDE,
    "small-uas",
    mass=3.0,
    b=2.2,
    S=0.48,
    **_motor(0.35, 14.8, 0.0195, 0.12),
    cruise_speed=15.0,
    airspeed_min=13.0,
    airspeed_max=19.0,
    climb_rate_max=3.0,
    descent_rate_max=2.0,
    battery_wh=battery_wh(3.0),
    source=(
        "scaled from the Aerosonde of Beard & McLain (2012): 3 kg, 2.2 m span, 0.48 m^2; "
        "seed 004 Table II speed (15 m/s, 13-19 m/s)"
    ),
)

# Seed 004 assumes rho = d_m = 30 m at 15 m/s (eq 5); at small-uas's 30 deg bank eq 3 gives 39.7 m.
# V^2 / (g tan phi) = 30 m needs phi = 37.4 deg: the seed-004 preset is small-uas banking to 38 deg
# (29.4 m at 15 m/s; the 6-DOF aircraft's measured turn: tests/test_fga.py).
SEED004_UAS = dataclasses.replace(
    SMALL_UAS,
    name="seed004-uas",
    bank_max_deg=38.0,
    source=(
        "small-uas (scaled from the Aerosonde of Beard & McLain 2012) with a 38 deg bank limit: "
        "seed 004 eq 5's minimum turn radius of 30 m at 15 m/s"
    ),
)

_c172_S = 174.0 * _FT**2
_c172_b = 35.8 * _FT
CESSNA172 = VehicleParams(
    name="cessna172",
    mass=2300.0 * _LB,
    Jx=948.0 * _SLUG_FT2,
    Jy=1346.0 * _SLUG_FT2,
    Jz=1967.0 * _SLUG_FT2,
    Jxz=0.0,
    S=_c172_S,
    b=_c172_b,
    c=4.9 * _FT,
    e=1.0 / (math.pi * (_c172_b**2 / _c172_S) * 0.0816),
    CL0=0.25,
    CLalpha=5.75,
    CLq=3.9,
    CLde=1.28 / 3.682,
    CDp=0.0278,
    CDq=0.0,
    CDde=0.06,
    Cm0=0.10,
    Cmalpha=-1.8,
    Cmq=-12.4,
    Cmde=-1.28,
    CY0=0.0,
    CYbeta=-0.31,
    CYp=-0.037,
    CYr=0.21,
    CYda=0.0,
    CYdr=0.187,
    Cl0=0.0,
    Clbeta=-0.089,
    Clp=-0.47,
    Clr=0.096,
    Clda=0.23,
    Cldr=0.0147,
    Cn0=0.0,
    Cnbeta=0.065,
    Cnp=-0.03,
    Cnr=-0.099,
    Cnda=0.0053,
    Cndr=-0.0657,
    M=10.8,
    alpha0=0.39,
    elevator_min_deg=-28.0,
    elevator_max_deg=23.0,
    aileron_max_deg=17.5,
    rudder_max_deg=16.0,
    cruise_speed=50.0,
    airspeed_min=35.0,
    airspeed_max=58.0,
    climb_rate_max=3.0,
    descent_rate_max=4.0,
    engine="piston",
    prop_diameter=75.0 * 0.0254,
    power_max=160.0 * 745.699872,
    rated_rpm=2700.0,
    CT0=0.095,
    CT1=0.0095,
    CT2=-0.0952,
    CP0=0.050,
    CP1=0.046,
    CP2=-0.0731,
    CLadot=1.7,
    Cmadot=-7.27,
    bsfc_g_per_kwh=BSFC_G_PER_KWH,
    fuel_kg=round(40.0 * 3.785411784 * AVGAS_KG_PER_L, 1),  # the 172N's 40 US gal usable
    source=(
        "LaRCsim c172_aero.c (T. Peden, FlightGear; after Roskam Part I) derivatives; UIUC "
        "Cessna 172 model (Scott & Selig 2000, Sivier) mass and geometry; propeller fitted here; "
        "fuel: Cessna 172N POH (1978) 40 US gal usable, BSFC 0.45 lb/bhp/h"
    ),
)

PRESETS: dict[str, VehicleParams] = {
    p.name: p for p in (AEROSONDE, SOLAR_UAV, CESSNA172, SMALL_UAS, SEED004_UAS)
}


def _check_vehicle(obj: Any, plugin: Plugin) -> None:
    """An installed preset is a vehicle's parameters, named as its entry point."""
    from replay.flight.multirotor.model import MultirotorParams

    if not isinstance(obj, VehicleParams | MultirotorParams):
        raise PluginError(
            f"{plugin.describe()}: expected a VehicleParams or MultirotorParams, found "
            f"{type(obj).__name__}"
        )
    if obj.name != plugin.name:
        raise PluginError(
            f"{plugin.describe()}: the parameters are named {obj.name!r}; a preset's name is its "
            "entry point's (runs record it)"
        )


# the presets terrapath gives (fixed wings here, the multirotor in replay.flight.multirotor.model)
# and those installed packages give (entry points "terrapath.vehicles": a VehicleParams or a
# MultirotorParams object; terrain.plugins)
VEHICLES = Registry(
    "terrapath.vehicles",
    {
        **{
            n: f"replay.flight.fixedwing.presets:{v}"
            for n, v in (
                ("aerosonde", "AEROSONDE"),
                ("solar-uav", "SOLAR_UAV"),
                ("cessna172", "CESSNA172"),
                ("small-uas", "SMALL_UAS"),
                ("seed004-uas", "SEED004_UAS"),
            )
        },
        "quadrotor": "replay.flight.multirotor.model:QUADROTOR",
    },
    _check_vehicle,
)


def installed_vehicle(name: str) -> VehicleParams | MultirotorParams | None:
    """The preset an installed package gives as ``name`` (None: none does)."""
    if name in VEHICLES.builtins or name not in VEHICLES:
        return None
    obj = VEHICLES.load(name)
    assert isinstance(obj, VehicleParams) or type(obj).__name__ == "MultirotorParams"  # checked
    return obj


def preset(name: str) -> VehicleParams:
    """A preset by name (``aerosonde``, ``solar-uav``, ``cessna172``, ``small-uas``,
    ``seed004-uas``, or one an installed package gives)."""
    if name in PRESETS:
        VEHICLES.find(name)  # a name given twice (a package and terrapath) is named
        return PRESETS[name]
    found = installed_vehicle(name)
    if isinstance(found, VehicleParams):
        return found
    if found is not None:
        raise InputError(f"vehicle {name!r} is a multirotor; a fixed-wing aircraft is needed here")
    others = VEHICLES.plugin_names()
    raise InputError(
        f"unknown vehicle {name!r}: expected a preset ({', '.join([*PRESETS, *others])}) "
        "or the path of a vehicle file (.yaml)"
    )


def load_vehicle(
    name_or_path: str | Path | VehicleParams, *, base_dir: Path | None = None
) -> VehicleParams:
    """A preset by name, or a YAML vehicle file (relative paths against ``base_dir``)."""
    if isinstance(name_or_path, VehicleParams):
        return name_or_path
    text = str(name_or_path)
    if isinstance(name_or_path, str) and text in PRESETS:
        return preset(text)
    path = Path(text)
    if base_dir is not None and not path.is_absolute():
        path = base_dir / path
    looks_like_file = path.suffix.lower() in (".yaml", ".yml") or path.exists() or "/" in text
    if not looks_like_file:
        return preset(text)
    return vehicle_from_file(path)


def load_any_vehicle(
    name_or_path: str | Path, *, base_dir: Path | None = None
) -> VehicleParams | MultirotorParams:
    """:func:`load_vehicle`, and a multirotor: its preset by name (``quadrotor``) or a vehicle
    file whose ``base`` is one (:func:`replay.flight.multirotor.model.multirotor_from_dict`)."""
    from replay.flight.multirotor.model import MULTIROTOR_PRESETS, multirotor_from_dict

    text = str(name_or_path)
    if text in MULTIROTOR_PRESETS:
        return MULTIROTOR_PRESETS[text]
    if isinstance(name_or_path, str) and text not in PRESETS:
        found = installed_vehicle(text)
        if found is not None:
            return found
    path = Path(text)
    if base_dir is not None and not path.is_absolute():
        path = base_dir / path
    if path.suffix.lower() in (".yaml", ".yml") and path.is_file():
        try:
            raw = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):
            raw = ""  # load_vehicle says why
        data = parse_yaml(raw, repr(str(path))) if raw else None
        if isinstance(data, dict) and data.get("base") in MULTIROTOR_PRESETS:
            return multirotor_from_dict(data, str(path))
    return load_vehicle(name_or_path, base_dir=base_dir)


def vehicle_from_file(path: str | Path) -> VehicleParams:
    """Read and validate a vehicle file."""
    p = Path(path)
    try:
        raw = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise DataFileError(
            f"{where(p)}cannot read the vehicle file: {exc.strerror or exc}"
        ) from exc
    data = parse_yaml(raw, repr(str(p)))
    return vehicle_from_dict(data, str(p))


def vehicle_from_dict(data: Any, path: str | None = None) -> VehicleParams:
    """Validate a parsed vehicle document (``path`` only names the source in messages)."""
    if not isinstance(data, dict):
        raise DataFileError(
            f"{where(path)}expected a mapping (terrapath: 1, name: ..., base: ..., fields), "
            f"found {type(data).__name__}"
        )
    if "rho" in data:
        raise InputError(
            f"{where(path, 'rho')}air density is no longer a vehicle parameter: it comes from the "
            "ISA standard atmosphere at the aircraft's altitude; remove it (replay "
            "--temperature-offset sets a hot or cold day)"
        )
    unknown = sorted(str(k) for k in data if k not in FILE_KEYS)
    if unknown:
        raise InputError(
            f"{where(path)}unknown key(s) {', '.join(map(repr, unknown))}; "
            f"allowed: {', '.join(FILE_KEYS)}"
        )
    if data.get("terrapath") != FORMAT_VERSION:
        raise InputError(
            f"{where(path, 'terrapath')}expected format version {FORMAT_VERSION}, "
            f"found {data.get('terrapath')!r}"
        )
    base_name = data.get("base", DEFAULT_VEHICLE)
    if base_name not in PRESETS:
        raise InputError(
            f"{where(path, 'base')}expected a preset ({', '.join(PRESETS)}), found {base_name!r}"
        )
    overrides = file_overrides(data, path, ("name", "source", "engine"))
    if overrides.get("engine", ENGINES[0]) not in ENGINES:
        raise InputError(
            f"{where(path, 'engine')}expected one of {', '.join(ENGINES)}, "
            f"found {overrides['engine']!r}"
        )
    engine = overrides.get("engine")
    if engine is not None and engine != PRESETS[base_name].engine:
        # a new engine takes nothing from the base's: every parameter must be in the file
        needed = ENGINE_PARAMETERS[engine]
        missing = [k for k in needed if k not in overrides]
        if missing:
            raise InputError(
                f"{where(path, missing[0])}missing: engine {engine!r} (the base {base_name!r} has "
                f"{PRESETS[base_name].engine!r}) needs {', '.join(needed)}"
            )
    overrides.setdefault("source", f"{path or 'vehicle document'} (base {base_name})")
    try:
        return dataclasses.replace(PRESETS[base_name], **overrides)
    except InputError as exc:
        raise InputError(f"{where(path)}{exc}") from None
