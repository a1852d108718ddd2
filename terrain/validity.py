"""Is a point or a leg of flight valid, and by how much: one checker for the planner's result, the
avoiders' candidates and the replay's metrics.

The model is OMPL's state-validity checker (``isValid`` and ``clearance``), for map points and for
straight segments.  A :class:`ValidityChecker` is built from what is known of the world:

- **the map** (``grid``): outside its bounds the terrain is unknown, so a point off the map is
  invalid -- an avoider keeps its waypoints on the map, the replay counts time off it;
- **unknown terrain** (the grid's ``known`` mask, or a ``unknown`` mask grid the caller dilated):
  a point over a cell the DEM did not measure is invalid unless ``allow_unknown``;
- **terrain** (``ground``: a function of (x, y), e.g. the conservative ``grid.safety().height_at``)
  with the ``terrain_clearance`` required above it: its component is ``z - ground - clearance``;
- **danger zones** (``zones``: cylinders and polygon prisms, :mod:`terrain.zones`), no-fly
  volumes: the component of each is its signed separation (``zone.separation``: negative inside)
  minus ``zone_margin``;
- **volumes** that move or appear over time (the replay's threats): any object with
  ``separations(points, times) -> (ids, (N, V) separations)`` and the same sign convention.

:meth:`ValidityChecker.points` returns every component per point (:class:`PointValidity`); its
``clearance`` is the smallest metric component (``-inf`` off the map or over forbidden unknown
terrain) and ``valid`` is ``clearance >= 0``.  :meth:`ValidityChecker.segments` checks straight
legs: the map exactly (the map is a rectangle, so a leg is on it when both ends are), the zones
exactly (length of the leg inside each, :class:`~terrain.zoneset.ZoneSet`; any length > 0 is
invalid, even a leg that cuts a corner between two samples), and terrain, unknown cells and
volumes on samples every ``step`` metres (default: half the grid's cell, 25 m without a grid).
What a component is not given does not constrain (no grid: everywhere is on the map).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import numpy.typing as npt

from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrain.zones import Zone, inflated
from terrain.zoneset import ZoneSet

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

DEFAULT_STEP_M = 25.0  # sample spacing along a leg without a grid


class Volumes(Protocol):
    """Time-dependent no-fly volumes, e.g. :class:`replay.threats.table.ThreatTable`."""

    def separations(
        self, points: FloatArray, times: FloatArray
    ) -> tuple[Sequence[str], FloatArray]: ...


@dataclass(frozen=True, eq=False)
class PointValidity:
    """Every component of the check at N points (see the module docstring)."""

    on_map: BoolArray  # (N,)
    known: BoolArray  # (N,) over measured terrain (True without a mask)
    terrain: FloatArray  # (N,) z - ground - required clearance (+inf without terrain)
    zones: FloatArray  # (N, K) separation from each zone's surface - zone margin
    zone_ids: tuple[str, ...]
    volumes: FloatArray  # (N, V) separation from each volume's surface
    volume_ids: tuple[str, ...]
    allow_unknown: bool

    @property
    def clearance(self) -> FloatArray:
        """(N,) the smallest metric component; -inf off the map or over forbidden unknown
        terrain; +inf when nothing constrains the point."""
        out = np.array(self.terrain, dtype=np.float64, copy=True)
        if self.zones.shape[1]:
            out = np.minimum(out, self.zones.min(axis=1))
        if self.volumes.shape[1]:
            out = np.minimum(out, self.volumes.min(axis=1))
        bad = ~self.on_map if self.allow_unknown else ~(self.on_map & self.known)
        out[bad] = -math.inf
        return out

    @property
    def valid(self) -> BoolArray:
        return np.asarray(self.clearance >= 0.0)


@dataclass(frozen=True, eq=False)
class SegmentValidity:
    """The check of M straight legs: ``valid`` (M,), the smallest sampled ``clearance`` (M,), the
    length of each leg inside each zone (M, K), and whether each leg stays on the map, over
    measured terrain (every sample), above the terrain and clear of the volumes.  A leg that crosses a zone between two samples has a
    clearance of at most minus its length inside."""

    valid: BoolArray
    clearance: FloatArray
    zone_lengths: FloatArray
    zone_ids: tuple[str, ...]
    on_map: BoolArray
    known: BoolArray
    terrain_ok: BoolArray
    volumes_ok: BoolArray
    unknown_lengths: FloatArray  # (M,) metres of each leg over unknown terrain (sampled)
    off_map_lengths: FloatArray  # (M,) metres of each leg off the map

    @property
    def outside_lengths(self) -> FloatArray:
        """(M,) metres of each leg off the map or inside a zone (each zone counted)."""
        return np.asarray(self.zone_lengths.sum(axis=1) + self.off_map_lengths)


class ValidityChecker:
    """The world's validity for points and legs (module docstring).  Positions are map metres
    (x east, y north, z AMSL)."""

    def __init__(
        self,
        *,
        grid: HeightGrid | None = None,
        ground: Callable[[FloatArray, FloatArray], FloatArray] | None = None,
        terrain_clearance: float = 0.0,
        unknown: HeightGrid | None = None,
        allow_unknown: bool = False,
        zones: Sequence[Zone] = (),
        zone_margin: float = 0.0,
        volumes: Volumes | None = None,
        step: float | None = None,
    ) -> None:
        for name, v in (("terrain clearance", terrain_clearance), ("zone margin", zone_margin)):
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise InputError(f"validity {name} must be a number of metres >= 0; got {v!r}")
        if step is not None and not (isinstance(step, int | float) and 0 < step < math.inf):
            raise InputError(f"validity step must be a positive number of metres; got {step!r}")
        self.grid = grid
        self.ground = ground
        self.terrain_clearance = float(terrain_clearance)
        self.unknown = unknown
        self.allow_unknown = bool(allow_unknown)
        self.zones = tuple(zones)
        self.zone_margin = float(zone_margin)
        self.zone_ids = tuple(z.id or f"#{k}" for k, z in enumerate(self.zones))
        self._zoneset = (
            ZoneSet.of(tuple(inflated(z, self.zone_margin) for z in self.zones))
            if self.zones
            else None
        )
        self.volumes = volumes
        if step is None:
            step = 0.5 * min(grid.cell_size) if grid is not None else DEFAULT_STEP_M
        self.step = float(step)

    @property
    def bounded(self) -> bool:
        """True when a leg can leave something here: a map, or danger zones."""
        return self.grid is not None or bool(self.zones)

    # -- components ---------------------------------------------------------------------------------
    def on_map(self, x: npt.ArrayLike, y: npt.ArrayLike) -> BoolArray:
        if self.grid is None:
            return np.ones(np.shape(x), dtype=bool)
        return np.asarray(self.grid.contains(x, y))

    def known(self, x: npt.ArrayLike, y: npt.ArrayLike) -> BoolArray:
        """Over measured terrain: the caller's ``unknown`` mask grid (cells > 0 are unknown), else
        the grid's ``known`` mask; True where neither says otherwise."""
        if self.unknown is not None:
            mask = self.unknown
            return np.asarray(mask.heights[mask.cell_of(x, y)] <= 0)
        g = self.grid
        if g is None or g.known is None or not g.has_unknown:
            return np.ones(np.shape(x), dtype=bool)
        return np.asarray(g.known[g.cell_of(x, y)])

    def points(
        self, points: npt.ArrayLike, times: npt.ArrayLike | None = None, *, zones: bool = True
    ) -> PointValidity:
        """Every component at (N, 3) points (at ``times`` (N,) for the volumes; 0 when None);
        ``zones=False`` leaves the zones out (no columns)."""
        p = _points(points, "points")
        x, y, z = p[:, 0], p[:, 1], p[:, 2]
        terrain = (
            z - np.asarray(self.ground(x, y), dtype=np.float64) - self.terrain_clearance
            if self.ground is not None
            else np.full(len(p), math.inf)
        )
        seps = np.zeros((len(p), 0))
        if self.zones and zones:
            seps = np.column_stack([np.asarray(z.separation(p), np.float64) for z in self.zones])
            seps = seps - self.zone_margin
        volume_ids: tuple[str, ...] = ()
        volumes = np.zeros((len(p), 0))
        if self.volumes is not None:
            t = np.zeros(len(p)) if times is None else np.asarray(times, dtype=np.float64)
            ids, vs = self.volumes.separations(p, t)
            volume_ids, volumes = tuple(ids), np.asarray(vs, dtype=np.float64).reshape(len(p), -1)
        return PointValidity(
            self.on_map(x, y),
            self.known(x, y),
            np.asarray(terrain, dtype=np.float64),
            seps,
            self.zone_ids if zones else (),
            volumes,
            volume_ids,
            self.allow_unknown,
        )

    def is_valid(self, points: npt.ArrayLike, times: npt.ArrayLike | None = None) -> BoolArray:
        return self.points(points, times).valid

    def clearance(self, points: npt.ArrayLike, times: npt.ArrayLike | None = None) -> FloatArray:
        return self.points(points, times).clearance

    # -- legs ---------------------------------------------------------------------------------------
    def segments(
        self,
        a: npt.ArrayLike,
        b: npt.ArrayLike,
        t: float | None = None,
        *,
        clearance: bool = True,
    ) -> SegmentValidity:
        """Check the straight legs a[m] -> b[m] ((M, 3) each); volumes at time ``t`` (0: None).

        The map and the zones are exact; unknown terrain, terrain and volumes are sampled.  With
        ``clearance=False`` (a candidate check that needs only ``valid`` and the lengths) the
        samples are taken only for the components that need them, and ``clearance`` is NaN."""
        p0, p1 = _points(a, "leg starts"), _points(b, "leg ends")
        if p0.shape != p1.shape:
            raise InputError(f"leg starts and ends must match; got {p0.shape} and {p1.shape}")
        m = len(p0)
        on_map = self.on_map(p0[:, 0], p0[:, 1]) & self.on_map(p1[:, 0], p1[:, 1])
        off_len = self._off_map_lengths(p0, p1)
        zone_lengths = (
            self._zoneset.segment_lengths(p0, p1) if self._zoneset is not None else np.zeros((m, 0))
        )
        inside = zone_lengths.max(axis=1) if zone_lengths.shape[1] else np.zeros(m)
        check_unknown = not self.allow_unknown and self._has_unknown
        needs_samples = (
            clearance or check_unknown or self.ground is not None or self.volumes is not None
        )
        unknown_len = np.zeros(m)
        known = np.ones(m, dtype=bool)
        terrain_ok = np.ones(m, dtype=bool)
        volumes_ok = np.ones(m, dtype=bool)
        low = np.full(m, math.nan)
        if needs_samples and m:
            length = np.linalg.norm(p1 - p0, axis=1)
            n = np.maximum(1, np.ceil(length / self.step).astype(np.int64))
            seg = np.repeat(np.arange(m), n + 1)
            # np.linspace(0, 1, k + 1) of every leg at once, bit for bit: i * (1 / k), the last 1
            first = np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)
            i = np.arange(len(seg)) - first
            frac = i * (1.0 / n)[seg]
            frac[i == n[seg]] = 1.0
            pts = p0[seg] + (p1 - p0)[seg] * frac[:, None]
            times = None if t is None else np.full(len(pts), float(t))
            pv = self.points(pts, times, zones=clearance)
            unknown = pv.on_map & ~pv.known
            # each sample stands for a share of its leg (the two ends for half a share each)
            w = np.where((frac == 0.0) | (frac == 1.0), 0.5, 1.0) * (length / n)[seg]
            unknown_len = np.asarray(np.bincount(seg, weights=w * unknown, minlength=m), float)
            known = np.bincount(seg, weights=unknown.astype(float), minlength=m) == 0
            terrain_ok = _min_by(seg, pv.terrain, m) >= 0.0
            vol = pv.volumes.min(axis=1) if pv.volumes.shape[1] else np.full(len(pts), math.inf)
            volumes_ok = _min_by(seg, vol, m) >= 0.0
            if clearance:
                metric = np.minimum(pv.terrain, vol)
                if pv.zones.shape[1]:
                    metric = np.minimum(metric, pv.zones.min(axis=1))
                low = _min_by(seg, metric, m)
                # a leg that crosses a zone between two samples: at most minus its length inside
                low = np.minimum(low, np.where(inside > 0, -inside, math.inf))
                bad_area = ~on_map if self.allow_unknown else ~(on_map & known)
                low = np.where(bad_area, -math.inf, low)
        valid = on_map & (known | self.allow_unknown) & terrain_ok & volumes_ok & ~(inside > 0)
        return SegmentValidity(
            np.asarray(valid),
            np.asarray(low, dtype=np.float64),
            zone_lengths,
            self.zone_ids,
            on_map,
            known,
            terrain_ok,
            volumes_ok,
            np.asarray(unknown_len, dtype=np.float64),
            off_len,
        )

    @property
    def _has_unknown(self) -> bool:
        if self.unknown is not None:
            return True
        g = self.grid
        return g is not None and g.known is not None and g.has_unknown

    def _off_map_lengths(self, p0: FloatArray, p1: FloatArray) -> FloatArray:
        """Metres of each leg outside the map's rectangle (Liang-Barsky clipping; horizontal
        length share times the 3-D length)."""
        m = len(p0)
        if self.grid is None or not m:
            return np.zeros(m)
        xmin, ymin, xmax, ymax = self.grid.bounds
        d = p1 - p0
        lo, hi = np.zeros(m), np.ones(m)
        for k, (vmin, vmax) in enumerate(((xmin, xmax), (ymin, ymax))):
            start, delta = p0[:, k], d[:, k]
            moving = delta != 0.0
            outside = ~moving & ((start < vmin) | (start > vmax))
            hi = np.where(outside, -1.0, hi)
            with np.errstate(divide="ignore", invalid="ignore"):
                ta = np.where(moving, (vmin - start) / delta, -math.inf)
                tb = np.where(moving, (vmax - start) / delta, math.inf)
            lo = np.maximum(lo, np.minimum(ta, tb))
            hi = np.minimum(hi, np.maximum(ta, tb))
        on = np.clip(hi - lo, 0.0, 1.0)
        return np.asarray((1.0 - on) * np.linalg.norm(d, axis=1), dtype=np.float64)

    def path(self, path: npt.ArrayLike, t: float | None = None) -> SegmentValidity:
        """:meth:`segments` of the legs of a (W, 3) polyline."""
        p = _points(path, "path")
        return self.segments(p[:-1], p[1:], t)

    def distance_off_map(self, x: npt.ArrayLike, y: npt.ArrayLike) -> FloatArray:
        """How far (m) each point lies outside the map's bounds (0 on it, and without a grid)."""
        xa, ya = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        if self.grid is None:
            return np.zeros(np.shape(xa))
        xmin, ymin, xmax, ymax = self.grid.bounds
        dx = np.maximum(0.0, np.maximum(xmin - xa, xa - xmax))
        dy = np.maximum(0.0, np.maximum(ymin - ya, ya - ymax))
        return np.asarray(np.hypot(dx, dy))


def _points(value: npt.ArrayLike, what: str) -> FloatArray:
    p = np.asarray(value, dtype=np.float64)
    if p.ndim == 1 and p.shape == (3,):
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 3:
        raise InputError(f"{what} must have shape (N, 3) in map metres; got {p.shape}")
    return p


def _min_by(group: npt.NDArray[np.int64], values: FloatArray, m: int) -> FloatArray:
    out = np.full(m, math.inf)
    np.minimum.at(out, group, values)
    return out


__all__ = ["PointValidity", "SegmentValidity", "ValidityChecker", "Volumes"]
