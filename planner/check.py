"""A mission checked against the terrain before upload (issue 35): the geometry half of
``terrapath check`` (the vehicle half is :mod:`replay.preflight`).

The path checked is the one the aircraft flies (:func:`planner.spiral.flown_path`): the legs,
the turn fillets of the mission's turn radius (terrapath's turn model; a multirotor's legs meet
at points) and the helices of its spirals (loiters), sampled every half cell
(:func:`planner.profile.sample_path`). A terrain-frame leg (``Mission.terrain_heights``) is
flown at its height above the DEM's surface under every sample, as an autopilot following
terrain between items flies it, not on the straight line between its waypoints.

Judged on the measured, conservative heights (``grid.safety()``, the surface the replay judges
contact on) with the clearance asked:

- **terrain**: each leg's (each spiral's) lowest clearance and where; below the clearance asked
  it is a finding, with its depth; below the ground, a terrain contact;
- **off the map** and **unknown terrain** (a cell the DEM did not measure, or next to one, as
  the planner counts it): the length of each leg over them;
- **danger zones** (the mission's, imported geofences, airspace: with floors and tops): the
  length of each leg inside each;
- **terrain following**: a terrain-frame leg climbs as the ground rises under it: the steepest
  climb the ground asks over any ``FOLLOW_WINDOW_S`` seconds of flight, against the climb
  gradient the aircraft has at that altitude (``perf_at``).

Findings are ranked: terrain contact first, then zones, clearance, the map edge, unknown
terrain and the climb terrain following needs, each kind by its amount.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.mission import Mission
from planner.performance import Performance
from planner.problem import unknown_mask_grid
from planner.profile import PathSamples, sample_path
from planner.spiral import FlownPath, flown_path
from terrain.grid import HeightGrid
from terrain.zones import Zone
from terrain.zoneset import ZoneSet

FloatArray = npt.NDArray[np.float64]
FOLLOW_WINDOW_S = 10.0  # s of flight over which terrain following must make the ground's rise
RANK = (
    "contact",
    "zone",
    "terrain",
    "off_map",
    "unknown_terrain",
    "terrain_following",
)


@dataclass(frozen=True)
class Finding:
    """One thing wrong: its ``kind`` (one of :data:`RANK` or a vehicle's: ``climb``,
    ``descent``, ``ceiling``, ``turn``, ``spiral``), the leg (waypoint ``leg`` -> ``leg + 1``;
    -1 for the mission as a whole), how much (``amount``: metres, or a gradient excess), where
    (map x, y, z; NaN when nowhere in particular) and the message."""

    kind: str
    leg: int
    amount: float
    x: float
    y: float
    z: float
    message: str

    def as_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "leg": self.leg,
            "amount": _round(self.amount),
            "x": _round(self.x),
            "y": _round(self.y),
            "z": _round(self.z),
            "message": self.message,
        }


@dataclass(frozen=True)
class LegCheck:
    """A leg (or a spiral, ``spiral`` True, at waypoint ``leg``) as flown: its horizontal
    ``length``, its lowest clearance above the measured terrain and where (x, y, z, and the
    distance along the leg), its height above the ground when it is a terrain-frame leg."""

    leg: int
    label: str
    spiral: bool
    length: float
    min_clearance: float
    x: float
    y: float
    z: float
    along: float
    terrain_height: float | None

    def as_dict(self) -> dict[str, Any]:
        return {
            "leg": self.leg,
            "label": self.label,
            "spiral": self.spiral,
            "length_m": _round(self.length),
            "min_clearance_m": _round(self.min_clearance),
            "worst": [_round(self.x), _round(self.y), _round(self.z)],
            "worst_along_m": _round(self.along),
            "terrain_height_m": self.terrain_height,
        }


@dataclass(frozen=True)
class GeometryCheck:
    """The flown path, its samples (z as flown, ``ground`` the measured heights), each leg's
    summary and the findings, ranked."""

    flown: FlownPath
    samples: PathSamples
    sample_leg: npt.NDArray[np.int64]
    legs: tuple[LegCheck, ...]
    findings: tuple[Finding, ...]


def _xyz(p: FloatArray) -> tuple[float, float, float]:
    return float(p[0]), float(p[1]), float(p[2])


def _round(v: float, nd: int = 2) -> float | None:
    return None if not math.isfinite(v) else round(float(v), nd)


def leg_name(k: int, spiral: bool = False) -> str:
    return f"spiral at waypoint {k}" if spiral else f"leg {k} (waypoint {k} -> {k + 1})"


def check_geometry(
    mission: Mission,
    grid: HeightGrid,
    *,
    clearance: float,
    zones: Sequence[Zone] = (),
    allow_unknown: bool = False,
    perf_at: Callable[[float, float], Performance] | None = None,
    lonlat: Callable[[float, float], str] | None = None,
) -> GeometryCheck:
    """Check ``mission`` on ``grid`` (module docstring); ``zones`` are checked beside the
    mission's own; ``perf_at(low, high)`` gives the aircraft's limits over an altitude band
    (for the climb terrain following needs; None: not checked); ``lonlat(x, y)`` words a place
    for messages (default map metres)."""
    where = lonlat or (lambda x, y: f"x={x:.0f}, y={y:.0f}")
    w = np.asarray(mission.waypoints, dtype=np.float64)
    radius = float(mission.turn_radius or 0.0)
    flown = flown_path(w, mission.spirals, radius)
    safety = grid.safety()
    samples = sample_path(safety, flown.points)
    pts = samples.points.copy()
    seg_leg = np.asarray(flown.leg, dtype=np.int64)
    seg_spiral = np.asarray(flown.spiral, dtype=np.int64)
    s_leg = seg_leg[samples.segment]
    s_spiral = seg_spiral[samples.segment]
    # terrain-frame legs: at their height above the DEM's surface all along (not on spirals)
    for k_end, h in mission.terrain_heights.items():
        on = (s_leg == k_end - 1) & (s_spiral < 0)
        if k_end >= 1 and on.any():
            surface = np.asarray(grid.height_at(pts[on, 0], pts[on, 1]), dtype=np.float64)
            pts[on, 2] = np.where(np.isfinite(surface), surface + h, pts[on, 2])
    on_map = np.asarray(grid.contains(pts[:, 0], pts[:, 1]), dtype=bool)
    ground = np.where(on_map, samples.ground, np.nan)
    samples = PathSamples(samples.segment, samples.distance, pts, ground)
    clear = pts[:, 2] - ground
    # the length each sample stands for: half the distance to each neighbour
    d = samples.distance
    step = np.zeros_like(d)
    if len(d) > 1:
        gaps = np.diff(d)
        step[:-1] += 0.5 * gaps
        step[1:] += 0.5 * gaps
    mask = None if allow_unknown else unknown_mask_grid(grid)
    unknown = np.zeros(len(d), dtype=bool)
    if mask is not None and on_map.any():
        cells = mask.cell_of(pts[on_map, 0], pts[on_map, 1])
        unknown[on_map] = mask.heights[cells] > 0
    findings: list[Finding] = []
    legs: list[LegCheck] = []
    pieces = sorted({(int(a), int(b)) for a, b in zip(s_leg, s_spiral, strict=True)})
    for k, sp in pieces:
        on = (s_leg == k) & (s_spiral == sp)
        spiral = sp >= 0
        label = leg_name(sp if spiral else k, spiral)
        idx = np.flatnonzero(on)
        c = clear[idx]
        known = np.isfinite(c)
        along = d[idx] - d[idx[0]]
        height = None if spiral else mission.terrain_heights.get(k + 1)
        if known.any():
            j = int(idx[np.flatnonzero(known)[np.argmin(c[known])]])
            legs.append(
                LegCheck(
                    k if not spiral else sp,
                    label,
                    spiral,
                    float(along[-1]),
                    float(clear[j]),
                    *_xyz(pts[j]),
                    float(d[j] - d[idx[0]]),
                    height,
                )
            )
            low = float(clear[j])
            if low < clearance:
                kind = "contact" if low < 0 else "terrain"
                text = (
                    f"{label} runs into the terrain: {-low:.0f} m below the measured ground"
                    if low < 0
                    else f"{label} passes {clearance - low:.0f} m below the {clearance:g} m "
                    f"clearance asked ({low:.0f} m above the measured terrain)"
                )
                findings.append(
                    Finding(
                        kind,
                        k,
                        clearance - low,
                        *_xyz(pts[j]),
                        f"{text} at {where(pts[j, 0], pts[j, 1])}, {pts[j, 2]:,.0f} m AMSL, "
                        f"{(d[j] - d[idx[0]]) / 1000:.2f} km along it",
                    )
                )
        off = float(step[idx][~on_map[idx]].sum())
        if off > 0:
            j = int(idx[np.flatnonzero(~on_map[idx])[0]])
            findings.append(
                Finding(
                    "off_map",
                    k,
                    off,
                    *_xyz(pts[j]),
                    f"{label} leaves the map for {off:,.0f} m from {where(pts[j, 0], pts[j, 1])}",
                )
            )
        unk = float(step[idx][unknown[idx]].sum())
        if unk > 0:
            j = int(idx[np.flatnonzero(unknown[idx])[0]])
            findings.append(
                Finding(
                    "unknown_terrain",
                    k,
                    unk,
                    *_xyz(pts[j]),
                    f"{label} flies {unk:,.0f} m over terrain the DEM did not measure (or next "
                    f"to it) from {where(pts[j, 0], pts[j, 1])}",
                )
            )
        if height is not None and perf_at is not None and len(idx) > 2:
            findings.extend(_following(k, label, pts[idx], d[idx], float(height), perf_at, where))
    findings.extend(_zones(mission, zones, pts, s_leg, s_spiral, where))
    order = {k: i for i, k in enumerate(RANK)}
    findings.sort(key=lambda f: (order.get(f.kind, len(RANK)), -f.amount))
    return GeometryCheck(flown, samples, s_leg, tuple(legs), tuple(findings))


def _following(
    k: int,
    label: str,
    pts: FloatArray,
    dist: FloatArray,
    height: float,
    perf_at: Callable[[float, float], Performance],
    where: Callable[[float, float], str],
) -> list[Finding]:
    """The steepest climb a terrain-frame leg asks (the ground's rise over any
    :data:`FOLLOW_WINDOW_S` seconds of flight) against the aircraft's climb gradient there."""
    z = pts[:, 2]
    perf = perf_at(float(np.nanmin(z)), float(np.nanmax(z)))
    window = max(FOLLOW_WINDOW_S * perf.speed, 1.0)
    ahead = np.searchsorted(dist, dist + window)
    ahead = np.minimum(ahead, len(dist) - 1)
    run = dist[ahead] - dist
    ok = run > 0.5 * window
    if not ok.any():
        ok = run > 0
    if not ok.any():
        return []
    grad = np.full(len(dist), -np.inf)
    grad[ok] = (z[ahead[ok]] - z[ok]) / run[ok]
    j = int(np.argmax(grad))
    limit = perf.climb_gradient if not perf.hover else math.inf
    if not grad[j] > limit:
        return []
    return [
        Finding(
            "terrain_following",
            k,
            float(grad[j] - limit),
            *_xyz(pts[j]),
            f"{label} follows the ground {height:g} m above it: the ground rises "
            f"{100 * grad[j]:.1f} % over {run[j]:.0f} m from {where(pts[j, 0], pts[j, 1])}; "
            f"{perf.name} climbs {100 * limit:.1f} % at {perf.speed:g} m/s there",
        )
    ]


def _zones(
    mission: Mission,
    extra: Sequence[Zone],
    pts: FloatArray,
    s_leg: npt.NDArray[np.int64],
    s_spiral: npt.NDArray[np.int64],
    where: Callable[[float, float], str],
) -> list[Finding]:
    zones = (*mission.danger_zones, *extra)
    if not zones or len(pts) < 2:
        return []
    inside = ZoneSet.of(zones).segment_lengths(pts[:-1], pts[1:])
    out = []
    for z_i, zone in enumerate(zones):
        col = inside[:, z_i]
        if not (col > 0).any():
            continue
        name = zone.id or f"#{z_i}"
        for k in sorted(set(s_leg[:-1][col > 0].tolist())):
            on = (s_leg[:-1] == k) & (col > 0)
            amount = float(col[on].sum())
            j = int(np.flatnonzero(on)[0])
            sp = int(s_spiral[j])
            label = leg_name(sp if sp >= 0 else k, sp >= 0)
            out.append(
                Finding(
                    "zone",
                    k,
                    amount,
                    *_xyz(pts[j]),
                    f"{label} enters zone {name} for {amount:,.0f} m from "
                    f"{where(pts[j, 0], pts[j, 1])}, {pts[j, 2]:,.0f} m AMSL",
                )
            )
    return out
