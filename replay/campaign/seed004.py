"""Seed 004's Monte Carlo cases (§II-C (4)-(5), Table II): ``seed004-table2``, a *case* generator
-- it makes the aircraft's leg as well as its obstacles, so a campaign that uses it names no
mission.

**The aircraft** (Table II): ``seed004-uas`` at 15 m/s, level at ``ALTITUDE_M`` (120 m) over
flat ground, on a straight leg of ``LEG_M`` (1.2 km) due north from the origin (80 s).  The
sensor reaches 1500 m (50 d_m: the campaign's ``sensor_range``), FGA looks within R = 300 m.

**Hazards.**  The paper's text says 10-20 obstacles per case of which 20-30 % are true hazards,
but its Tables III and IV count 0, 1, 2, 3 and "> 3" hazards per case with means of 1.44 and
1.51, which 20-30 % of 10-20 (2-6) cannot give.  The tables are followed: the number of hazards
``H`` is drawn with the tables' frequencies (static: 1091, 1756, 1298, 571, 284 of 5000;
dynamic: 960, 1694, 1413, 680, 253), "> 3" being 4 (which reproduces both means: 1.44 and
1.51); the case has ``N ~ U{10..20}`` obstacles, ``max(N, H)``, of which ``N - H`` are not
hazards.  A *hazard* is an obstacle the undisturbed leg passes closer than ``d_m`` = 30 m to
(surface distance, exact); every other obstacle stays at least ``d_m + 5`` m from it, so the
count is unambiguous.

**Static set** (buildings, towers): vertical cylinders standing on the ground, radius
U(5, 20) m.  A hazard's axis is U(400, 1000) m along the leg and within ``radius + d_m`` of it
laterally, its top U(z - 25, z + 150) m (some just below the flight level: a climb of a few
metres clears them; the rest must be flown round).  Other cylinders anywhere in x in [-500,
500], y in [-200, 1700] m with tops U(20, 270) m.  Cylinders keep ``d_m`` apart (surface to
surface) and 150 m (5 d_m, eq 18) from the start.

**Dynamic set** (aircraft): intruders of radius 1 m at speed U(0, 25) m/s on a random course,
level, at the flight level + U(-40, 40) m.  A hazard meets the undisturbed aircraft at a time
U(15, 65) s with a 3-D miss vector of length U(0, 0.95) d_m perpendicular to the relative
velocity; the rest start anywhere in the same box as the cylinders.  Every intruder starts at
least 150 m from the aircraft.

All draws come from the case's generator in a fixed order, so a case is a function of its
scenario seed.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from replay.threats.kinds import solid_separation

FloatArray = npt.NDArray[np.float64]

SPEED_MPS = 15.0
ALTITUDE_M = 120.0
LEG_M = 1200.0
D_M = 30.0
SENSOR_RANGE_M = 1500.0  # 50 d_m
VEHICLE = "seed004-uas"
CLEAR_M = 5.0  # a non-hazard keeps d_m + this from the undisturbed leg
START_CLEAR_M = 150.0  # 5 d_m (eq 18: "in obstacle generation, r >= 5 d_m")
BOX = (-500.0, -200.0, 500.0, 1700.0)  # xmin, ymin, xmax, ymax of the obstacles
# Tables III and IV: cases with 0, 1, 2, 3 and > 3 (here 4) hazards, of 5000
HAZARD_BINS = (0, 1, 2, 3, 4)
STATIC_FREQ = (1091, 1756, 1298, 571, 284)
DYNAMIC_FREQ = (960, 1694, 1413, 680, 253)
GENERATOR_VERSION = 1  # bump when the cases change: it is part of every run's identity


def mission_doc() -> dict[str, Any]:
    """The case's mission: the straight leg (module docstring)."""
    return {
        "terrapath": 1,
        "name": "seed004-leg",
        "crs": "local",
        "vehicle": VEHICLE,
        "cruise": {"speed": SPEED_MPS, "altitude": ALTITUDE_M},
        "waypoints": [[0.0, 0.0, ALTITUDE_M], [0.0, LEG_M, ALTITUDE_M]],
    }


def _leg(times: FloatArray) -> FloatArray:
    return np.column_stack(
        [np.zeros_like(times), SPEED_MPS * times, np.full_like(times, ALTITUDE_M)]
    )


_TIMES = np.linspace(0.0, LEG_M / SPEED_MPS, 1601)


def cylinder_separation(center: tuple[float, float], radius: float, top: float) -> float:
    """The undisturbed leg's least distance to a ground-standing cylinder's surface."""
    p = _leg(_TIMES)
    dr = np.hypot(p[:, 0] - center[0], p[:, 1] - center[1]) - radius
    dz = p[:, 2] - top
    return float(solid_separation(dr, dz).min())


def intruder_separation(start: FloatArray, velocity: FloatArray, radius: float) -> float:
    """The undisturbed leg's least distance to an intruder's sphere."""
    own = _leg(_TIMES)
    other = start[None, :] + _TIMES[:, None] * velocity[None, :]
    return float((np.linalg.norm(own - other, axis=1) - radius).min())


def hazard_count(rng: np.random.Generator, dynamic: bool) -> int:
    freq = np.array(DYNAMIC_FREQ if dynamic else STATIC_FREQ, dtype=np.float64)
    return int(rng.choice(HAZARD_BINS, p=freq / freq.sum()))


def _static(rng: np.random.Generator, n: int, hazards: int) -> list[dict[str, Any]]:
    placed: list[tuple[float, float, float]] = []
    out: list[dict[str, Any]] = []

    def fits(x: float, y: float, r: float) -> bool:
        if math.hypot(x, y) - r < START_CLEAR_M:
            return False
        return all(math.hypot(x - a, y - b) - r - c >= D_M for a, b, c in placed)

    k = 0
    while len(out) < n:
        hazard = len(out) < hazards
        r = float(rng.uniform(5.0, 20.0))
        if hazard:
            y = float(rng.uniform(400.0, 1000.0))
            x = float(rng.uniform(-1.0, 1.0) * (r + D_M))
            top = float(rng.uniform(ALTITUDE_M - 25.0, ALTITUDE_M + 150.0))
        else:
            x = float(rng.uniform(BOX[0], BOX[2]))
            y = float(rng.uniform(BOX[1], BOX[3]))
            top = float(rng.uniform(20.0, 270.0))
        k += 1
        if k > 100_000:
            raise RuntimeError("seed004-table2: cannot place the obstacles")
        if not fits(x, y, r):
            continue
        sep = cylinder_separation((x, y), r, top)
        if (hazard and sep >= D_M) or (not hazard and sep < D_M + CLEAR_M):
            continue
        placed.append((x, y, r))
        out.append(
            {
                "id": f"{'hazard' if hazard else 'obs'}{len(out) + 1}",
                "kind": "cylinder",
                "center": [x, y],
                "radius": r,
                "top": top,
            }
        )
    return out


def _dynamic(rng: np.random.Generator, n: int, hazards: int) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    radius = 1.0
    k = 0
    while len(out) < n:
        hazard = len(out) < hazards
        speed = float(rng.uniform(0.0, 25.0))
        course = float(rng.uniform(0.0, 2.0 * math.pi))
        vel = np.array([speed * math.sin(course), speed * math.cos(course), 0.0])
        if hazard:
            t_meet = float(rng.uniform(15.0, 65.0))
            own = np.array([0.0, SPEED_MPS * t_meet, ALTITUDE_M])
            rel = np.array([0.0, SPEED_MPS, 0.0]) - vel  # aircraft relative to the intruder
            # a miss vector perpendicular to the relative velocity
            a = rng.normal(size=3)
            a -= rel * (a @ rel) / max(float(rel @ rel), 1e-9)
            norm = float(np.linalg.norm(a))
            if norm < 1e-9:
                continue
            miss = a / norm * float(rng.uniform(0.0, 0.95)) * (D_M + radius)
            meet = own + miss
            start = meet - vel * t_meet
        else:
            start = np.array(
                [
                    rng.uniform(BOX[0], BOX[2]),
                    rng.uniform(BOX[1], BOX[3]),
                    ALTITUDE_M + rng.uniform(-40.0, 40.0),
                ]
            )
        k += 1
        if k > 100_000:
            raise RuntimeError("seed004-table2: cannot place the obstacles")
        if abs(float(start[2]) - ALTITUDE_M) > 40.0 + 1e-9:
            continue
        if float(np.linalg.norm(start - np.array([0.0, 0.0, ALTITUDE_M]))) < START_CLEAR_M:
            continue
        sep = intruder_separation(start, vel, radius)
        if (hazard and sep >= D_M) or (not hazard and sep < D_M + CLEAR_M):
            continue
        out.append(
            {
                "id": f"{'hazard' if hazard else 'obs'}{len(out) + 1}",
                "kind": "intruder",
                "position": [float(v) for v in start],
                "velocity": [float(v) for v in vel],
                "radius": radius,
            }
        )
    return out


def seed004_case(
    rng: np.random.Generator, dynamic: bool
) -> tuple[dict[str, Any], list[dict[str, Any]], dict[str, Any]]:
    """One case: (mission document, threat records, notes: ``hazards``, ``obstacles``)."""
    hazards = hazard_count(rng, dynamic)
    n = max(int(rng.integers(10, 21)), hazards)
    records = _dynamic(rng, n, hazards) if dynamic else _static(rng, n, hazards)
    notes = {"hazards": hazards, "obstacles": n, "dynamic": dynamic}
    return mission_doc(), records, notes


def hazard_bin(hazards: int) -> str:
    """The table row of a case: "0" .. "3", or "> 3"."""
    return "> 3" if hazards > 3 else str(hazards)


__all__ = [
    "DYNAMIC_FREQ",
    "D_M",
    "GENERATOR_VERSION",
    "SENSOR_RANGE_M",
    "STATIC_FREQ",
    "hazard_bin",
    "mission_doc",
    "seed004_case",
]
