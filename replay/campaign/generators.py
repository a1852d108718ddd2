"""Threat generators of Monte Carlo campaigns: the seeds' protocols as functions of a mission, a
count and a random generator, each returning threat records (the entries of a threat file).

- ``seed000-normal`` (seed 000 §5.6): ``count`` static obstacles; obstacle k picks a mission
  waypoint uniformly, then x, y ~ N(waypoint, ``sigma``) per axis (3000 m), z the mission's cruise
  altitude (200 m for seed 000), safety radius ``radius`` (RS = 1000 m, §5.1); a draw closer
  than ``keep_clear`` (1500 m, horizontally) to the start or the final waypoint is redrawn round
  the same waypoint (an obstacle on the start cannot be avoided; one on the goal cannot be
  reached).
- ``seed000-hill`` (§5.3): the ``count`` obstacles and one hill: a ridge of 6 points 600 m apart
  (links < 1 km: one continuous obstacle), radius RS each, centred on a random leg at 30-70 % of
  its length and laid across it (perpendicular +- 30 deg).
- ``seed000-intruders`` (§5.1): the ``count`` obstacles and two intruders (15 m/s at the
  obstacles' altitude, safety sphere RS) launched on the undisturbed mission timeline so that
  they reach a meeting point at the same time as the aircraft: one head-on along leg 3 or 4 (the
  long legs: a head-on meeting does not depend on the timing), one crossing leg 1 at right angles
  from a random side (early in the flight, so the detours round the obstacles delay the aircraft
  by little); each appears 1200 s before the meeting and disappears 1200 s after it.
- ``uniform``: ``count`` static spheres of ``radius`` uniform in ``box`` ([xmin, ymin, xmax,
  ymax], map metres; default the waypoints' bounding box grown by ``sigma``) at the cruise
  altitude, kept ``keep_clear`` from the start and the goal.

- ``own-scenarios`` (issue 34, :mod:`replay.campaign.own`): a *case* generator of a user's kind
  of case on a real map -- a vehicle at its cruise speed, a straight mission over the terrain,
  one or two threats on its path sized in turn radii; its rows are ``maps: [...]``.
  ``own-planned``: the same, the mission the path ``terrapath plan`` gives between the leg's ends.
- ``own-buildings`` (issue 34, :mod:`replay.campaign.buildings`): a *case* generator for the
  priority loop -- a quadrotor among real (Bubenec) or drawn buildings on real terrain, start and
  target in the open with something in the way; its rows are layouts, ``maps: [...]``.
- installed packages add generators by entry point (group ``terrapath.generators``: a function
  like ``uniform`` or a :class:`CaseGenerator`; :mod:`terrain.plugins`), used by name as these.
- ``seed004-table2`` (seed 004 §II-C, Table II): a *case* generator -- each case is the
  aircraft's leg and its 10-20 obstacles, static cylinders or moving aircraft, with the number of
  true hazards drawn from Tables III / IV (:mod:`replay.campaign.seed004`).  A spec that uses it
  names no mission; its rows are ``dynamic: [false, true]``, the static and the dynamic set.

The obstacles of the hill and intruder rows are the ``count`` obstacles drawn first from the same
generator state, so "40 + 1 hill" holds the 40-obstacle scenario of the same seed when the
campaign derives both from one scenario seed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from replay.campaign.buildings import LAYOUTS, buildings_case, check_layout
from replay.campaign.buildings import VERSION as BUILDINGS_VERSION
from replay.campaign.own import MAPS as OWN_MAPS
from replay.campaign.own import VERSION as OWN_VERSION
from replay.campaign.own import map_path, own_case
from replay.campaign.seed004 import GENERATOR_VERSION as SEED004_VERSION
from replay.campaign.seed004 import seed004_case
from replay.threats.file import COMMON_KEYS, KIND_KEYS
from terrain.errors import PluginError
from terrain.plugins import Plugin, Registry

FloatArray = npt.NDArray[np.float64]

SIGMA_M = 3000.0  # §5.6: normal distribution round the waypoints, standard deviation 3000
RS_M = 1000.0  # §5.1: radius of the safety sphere
KEEP_CLEAR_M = 1500.0  # obstacles closer than this to the start / final waypoint are redrawn
HILL_POINTS = 6
HILL_SPACING_M = 600.0  # < 1 km: one continuous obstacle (§5.3)
HILL_TILT_DEG = 30.0  # the ridge lies across the leg, perpendicular +- this
HILL_LEG_SPAN = (0.3, 0.7)  # where along the leg the ridge is centred
INTRUDER_SPEED = 15.0  # §5.1: 6-DOF UAVs at 15 m/s
INTRUDER_LEAD_S = 1200.0  # appears this long before the meeting (18 km away), gone as long after
HEAD_ON_LEGS = (3, 4)  # 100 km and 150 km legs of seed 000's mission
CROSSING_LEGS = (1,)  # early in the flight: the obstacles' detours delay the aircraft little
MEET_SPAN = (0.4, 0.6)


@dataclass(frozen=True)
class Params:
    """A generator's settings (the spec's ``threats`` keys besides ``generator`` and
    ``counts``)."""

    sigma: float = SIGMA_M
    keep_clear: float = KEEP_CLEAR_M
    radius: float = RS_M
    altitude: float | None = None  # None: the mission's cruise altitude
    box: tuple[float, float, float, float] | None = None  # uniform only


def random_obstacles(
    waypoints: npt.ArrayLike,
    n: int,
    rng: np.random.Generator,
    sigma: float = SIGMA_M,
    keep_clear: float = KEEP_CLEAR_M,
) -> FloatArray:
    """``n`` obstacle centres (n, 2): per obstacle a waypoint chosen uniformly, then x and y from
    N(waypoint, sigma); a draw within ``keep_clear`` of the first or last waypoint (horizontal
    distance) is redrawn round the same waypoint."""
    w = np.asarray(waypoints, dtype=np.float64)[:, :2]
    ends = w[[0, -1]]
    out = np.empty((n, 2))
    for k in range(n):
        i = int(rng.integers(len(w)))
        while True:
            p = w[i] + rng.normal(0.0, sigma, 2)
            if np.hypot(*(ends - p).T).min() >= keep_clear:
                break
        out[k] = p
    return out


def hill_ridge(waypoints: npt.ArrayLike, rng: np.random.Generator) -> FloatArray:
    """A ridge of ``HILL_POINTS`` points (K, 2), ``HILL_SPACING_M`` apart, centred on a random leg
    at 30-70 % of its length and laid across it (perpendicular +- ``HILL_TILT_DEG``)."""
    w = np.asarray(waypoints, dtype=np.float64)[:, :2]
    leg = int(rng.integers(len(w) - 1))
    a, b = w[leg], w[leg + 1]
    centre = a + rng.uniform(*HILL_LEG_SPAN) * (b - a)
    heading = math.atan2(b[1] - a[1], b[0] - a[0])
    ang = heading + math.pi / 2 + math.radians(rng.uniform(-HILL_TILT_DEG, HILL_TILT_DEG))
    offsets = (np.arange(HILL_POINTS) - (HILL_POINTS - 1) / 2) * HILL_SPACING_M
    return np.asarray(centre + offsets[:, None] * np.array([math.cos(ang), math.sin(ang)]))


def mission_timeline(waypoints: npt.ArrayLike, speed: float) -> FloatArray:
    """Time (s) at which the undisturbed aircraft passes each waypoint (W,), flying the polyline
    at ``speed`` from the first one at t = 0."""
    w = np.asarray(waypoints, dtype=np.float64)
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(w, axis=0), axis=1))]) / speed


def intruder_records(
    waypoints: npt.ArrayLike,
    speed: float,
    rng: np.random.Generator,
    n: int = 2,
    altitude: float = 200.0,
    radius: float = RS_M,
) -> list[dict[str, Any]]:
    """Threat records of ``n`` intruders (alternately head-on on leg 3/4 and crossing leg 1; a
    mission with fewer legs uses its longest), timed to meet the undisturbed aircraft; each
    record also carries ``meet_t`` / ``meet_xy`` / ``meet_kind`` (not threat-file keys: see
    :data:`THREAT_KEYS`) for checks."""
    w = np.asarray(waypoints, dtype=np.float64)
    times = mission_timeline(w, speed)
    legs = len(w) - 1
    longest = int(np.argmax(np.linalg.norm(np.diff(w[:, :2], axis=0), axis=1)))
    out = []
    for k in range(n):
        head_on = k % 2 == 0
        choices = [g for g in (HEAD_ON_LEGS if head_on else CROSSING_LEGS) if g < legs]
        leg = int(rng.choice(choices)) if choices else longest
        frac = rng.uniform(*MEET_SPAN)
        a, b = w[leg], w[leg + 1]
        meet = a + frac * (b - a)
        t_meet = times[leg] + frac * (times[leg + 1] - times[leg])
        u = (b - a)[:2] / np.hypot(*(b - a)[:2])
        if head_on:
            direction = -u
        else:
            direction = np.array([-u[1], u[0]]) * (1.0 if rng.random() < 0.5 else -1.0)
        vel = np.array([direction[0], direction[1], 0.0]) * INTRUDER_SPEED
        appear = max(0.0, t_meet - INTRUDER_LEAD_S)
        start = np.array([meet[0], meet[1], altitude]) - vel * (t_meet - appear)
        out.append(
            {
                "id": f"intruder{k + 1}",
                "kind": "intruder",
                "position": [float(v) for v in start],
                "velocity": [float(v) for v in vel],
                "radius": radius,
                "appears_at": float(appear),
                "disappears_at": float(t_meet + INTRUDER_LEAD_S),
                "meet_t": float(t_meet),
                "meet_xy": [float(meet[0]), float(meet[1])],
                "meet_kind": "head-on" if head_on else "crossing",
            }
        )
    return out


THREAT_KEYS = tuple(dict.fromkeys([*COMMON_KEYS, *(k for ks in KIND_KEYS.values() for k in ks)]))


def file_records(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The records with only threat-file keys (the intruders' meeting notes dropped)."""
    return [{k: v for k, v in r.items() if k in THREAT_KEYS} for r in records]


def _altitude(mission: Any, p: Params) -> float:
    return float(mission.cruise_altitude if p.altitude is None else p.altitude)


def _obstacles(
    mission: Any, count: int, rng: np.random.Generator, p: Params
) -> list[dict[str, Any]]:
    z = _altitude(mission, p)
    return [
        {
            "id": f"obs{k + 1}",
            "kind": "static",
            "position": [float(x), float(y), z],
            "radius": p.radius,
        }
        for k, (x, y) in enumerate(
            random_obstacles(mission.waypoints, count, rng, p.sigma, p.keep_clear)
        )
    ]


def seed000_normal(
    mission: Any, count: int, rng: np.random.Generator, p: Params
) -> list[dict[str, Any]]:
    """seed 000 §5.6: static obstacles drawn round the mission's waypoints."""
    return _obstacles(mission, count, rng, p)


def seed000_hill(
    mission: Any, count: int, rng: np.random.Generator, p: Params
) -> list[dict[str, Any]]:
    """seed 000 §5.3: the obstacles and a ridge of points across a random leg."""
    recs = _obstacles(mission, count, rng, p)
    z = _altitude(mission, p)
    pts = hill_ridge(mission.waypoints, rng)
    recs.append(
        {
            "id": "hill",
            "kind": "hill",
            "points": [[float(x), float(y), z] for x, y in pts],
            "radius": p.radius,
        }
    )
    return recs


def seed000_intruders(
    mission: Any, count: int, rng: np.random.Generator, p: Params
) -> list[dict[str, Any]]:
    """seed 000 §5.1: the obstacles and two intruders, head-on and crossing."""
    recs = _obstacles(mission, count, rng, p)
    return recs + intruder_records(
        mission.waypoints, float(mission.cruise_speed), rng, 2, _altitude(mission, p), p.radius
    )


def uniform(mission: Any, count: int, rng: np.random.Generator, p: Params) -> list[dict[str, Any]]:
    """Static spheres uniform in a box round the waypoints, clear of the start and the goal."""
    w = np.asarray(mission.waypoints, dtype=np.float64)[:, :2]
    if p.box is None:
        lo, hi = w.min(axis=0) - p.sigma, w.max(axis=0) + p.sigma
    else:
        lo, hi = np.array(p.box[:2]), np.array(p.box[2:])
    ends = w[[0, -1]]
    z = _altitude(mission, p)
    out = []
    for k in range(count):
        while True:
            q = rng.uniform(lo, hi)
            if np.hypot(*(ends - q).T).min() >= p.keep_clear:
                break
        out.append(
            {
                "id": f"obs{k + 1}",
                "kind": "static",
                "position": [float(q[0]), float(q[1]), z],
                "radius": p.radius,
            }
        )
    return out


Generator = Callable[[Any, int, np.random.Generator, Params], list[dict[str, Any]]]
GENERATORS: Mapping[str, Generator] = {
    "seed000-normal": seed000_normal,
    "seed000-hill": seed000_hill,
    "seed000-intruders": seed000_intruders,
    "uniform": uniform,
}


@dataclass(frozen=True)
class CaseGenerator:
    """A generator that makes the whole case -- the aircraft's leg too: ``make(rng, row)``
    returns (mission document, threat records, notes) for the spec's row (``seed004-table2``:
    its ``dynamic`` flag; ``own-scenarios``: its ``map``); ``version`` is part of every run's
    identity (bumped when the cases change); ``rows`` names the spec key that lists the rows."""

    make: Callable[[np.random.Generator, Any], tuple[dict[str, Any], list[dict[str, Any]], Any]]
    version: int
    rows: str = "dynamic"
    # rows="maps": the row names a spec may give (default every one) and the check of one on
    # this machine (an InputError naming what is missing)
    maps: tuple[str, ...] = ()
    check: Callable[[str], Any] | None = None
    summary: str = ""  # one line for `terrapath plugins`


def _seed004(
    rng: np.random.Generator, row: Any
) -> tuple[dict[str, Any], list[dict[str, Any]], Any]:
    return seed004_case(rng, bool(row.dynamic))


def _own(rng: np.random.Generator, row: Any) -> tuple[dict[str, Any], list[dict[str, Any]], Any]:
    return own_case(rng, str(row.map))


def _own_planned(
    rng: np.random.Generator, row: Any
) -> tuple[dict[str, Any], list[dict[str, Any]], Any]:
    return own_case(rng, str(row.map), planned=True)


def _buildings(
    rng: np.random.Generator, row: Any
) -> tuple[dict[str, Any], list[dict[str, Any]], Any]:
    return buildings_case(rng, str(row.map))


SEED004_TABLE2 = CaseGenerator(
    _seed004,
    SEED004_VERSION,
    summary="seed 004 Table II: a leg and its 10-20 static or moving obstacles",
)
OWN_SCENARIOS = CaseGenerator(
    _own,
    OWN_VERSION,
    rows="maps",
    maps=tuple(OWN_MAPS),
    check=map_path,
    summary="a straight leg over a real map, one or two threats on it sized in turn radii",
)
OWN_PLANNED = CaseGenerator(
    _own_planned,
    OWN_VERSION,
    rows="maps",
    maps=tuple(OWN_MAPS),
    check=map_path,
    summary="own-scenarios with the leg planned by terrapath plan",
)
OWN_BUILDINGS = CaseGenerator(
    _buildings,
    BUILDINGS_VERSION,
    rows="maps",
    maps=tuple(LAYOUTS),
    check=check_layout,
    summary="a quadrotor among real or drawn buildings (the priority loop's cases)",
)
CASE_GENERATORS: Mapping[str, CaseGenerator] = {
    "seed004-table2": SEED004_TABLE2,
    "own-scenarios": OWN_SCENARIOS,
    "own-planned": OWN_PLANNED,
    "own-buildings": OWN_BUILDINGS,
}


def _check_plugin(obj: Any, plugin: Plugin) -> None:
    """An installed generator is a threat generator (a function of the mission, the count, the
    generator and the :class:`Params`) or a :class:`CaseGenerator`."""
    if not (isinstance(obj, CaseGenerator) or callable(obj)):
        raise PluginError(
            f"{plugin.describe()}: expected a function (mission, count, rng, params) -> threat "
            f"records or a replay.campaign.generators.CaseGenerator, found {obj!r}"
        )


# the generators terrapath gives and those installed packages give (entry points
# "terrapath.generators"; terrain.plugins)
_HERE = "replay.campaign.generators"
REGISTRY = Registry(
    "terrapath.generators",
    {
        **{n: f"{_HERE}:{g.__name__}" for n, g in GENERATORS.items()},
        **{n: f"{_HERE}:{n.upper().replace('-', '_')}" for n in CASE_GENERATORS},
    },
    _check_plugin,
)


def generator_names() -> list[str]:
    """Every generator's name: terrapath's threat generators, its case generators, then the
    installed ones (nothing imported)."""
    return [*GENERATORS, *CASE_GENERATORS, *REGISTRY.plugin_names()]


def _installed(name: Any) -> Any:
    if not isinstance(name, str) or name in REGISTRY.builtins or name not in REGISTRY:
        return None
    return REGISTRY.load(name)


def case_generator(name: Any) -> CaseGenerator | None:
    """The case generator ``name`` (None: no such name, or a threat generator)."""
    if isinstance(name, str) and name in REGISTRY:
        REGISTRY.find(name)  # a name given twice (a package and terrapath) is named
    if name in CASE_GENERATORS:
        return CASE_GENERATORS[name]
    found = _installed(name)
    return found if isinstance(found, CaseGenerator) else None


def threat_generator(name: Any) -> Generator | None:
    """The threat generator ``name`` (None: no such name, or a case generator)."""
    if isinstance(name, str) and name in REGISTRY:
        REGISTRY.find(name)  # a name given twice (a package and terrapath) is named
    if name in GENERATORS:
        return GENERATORS[name]
    found = _installed(name)
    return None if found is None or isinstance(found, CaseGenerator) else found


def generator_origin(name: Any) -> str | None:
    """``package NAME VERSION`` of an installed generator (a run's identity carries it: a new
    version of the package flies its runs again); None for terrapath's own."""
    if not isinstance(name, str) or name in REGISTRY.builtins or name not in REGISTRY:
        return None
    plugin = REGISTRY.find(name)
    return None if plugin is None else plugin.origin


__all__ = [
    "CASE_GENERATORS",
    "GENERATORS",
    "OWN_BUILDINGS",
    "OWN_PLANNED",
    "OWN_SCENARIOS",
    "REGISTRY",
    "SEED004_TABLE2",
    "THREAT_KEYS",
    "CaseGenerator",
    "Params",
    "case_generator",
    "file_records",
    "generator_names",
    "generator_origin",
    "hill_ridge",
    "intruder_records",
    "mission_timeline",
    "random_obstacles",
    "threat_generator",
]
