"""The onboard radar of the replay (seed 000 §3): threats and terrain within range and line of sight.

A :class:`Radar` scans every ``period_s`` seconds (1 s, seed 000 §3.3; :meth:`Radar.due` says when
the next scan is due, :meth:`Radar.scan` scans whenever it is called) out to ``range_m`` (10 km,
seed 000 §2.1.3) and returns a frozen :class:`RadarPicture`: one :class:`Detection` per return, with
an id, the measured map position, range, bearing, elevation, ``kind`` ("threat" or "terrain") and
``moving`` (True, False, or None for "unknown").

Conventions: positions are map metres (x east, y north, z AMSL, :mod:`replay.frames`); range is the
3D distance from the aircraft; *bearing* is clockwise from north in (-pi, pi] (the course
convention of :func:`replay.frames.course_of`); *elevation* is above the horizontal, in
[-pi/2, pi/2].

**Threat returns.**  Every threat active at time t (``appears_at <= t < disappears_at``) offers the
points the radar can see (:meth:`replay.threats.kinds.Threat.radar_points`): the centre of a static
threat, each point of a hill (ids ``"<hill id>/<k>"``, so an avoider can cluster them as seed 000
§5.3 does: points closer than 1 km are one obstacle), the current position of an intruder, and for
the solid shapes (cylinder, prism, body) the point of the body nearest to the aircraft, clipped to
the body (the aircraft's own position when it is inside), and the left and right edges of its
outline -- the tangent points of its horizontal section at that point's altitude (a prism's extreme
vertices as seen from the aircraft), ids ``"<id>#left"`` and ``"<id>#right"``, none from inside
it -- as a scanning radar sees a solid's extent (seed 001 fits its obstacle circles to such
returns).  An edge slides round the body faster than the aircraft moves when the aircraft is
close: it is never judged on its own but takes its nearest point's classification (unknown
without it).  A point is detected when its range is <= ``range_m`` and, with a terrain model,
the segment aircraft -> point is clear of terrain:
:meth:`terrain.model.TerrainModel.line_of_sight`, one batched call for all candidate points per
scan, with ``los_tolerance_m`` (1 m) so a point resting on the ground is still seen.  The threats
are asked all at once, as arrays by kind (:class:`replay.threats.table.ThreatTable`, kept while
the same threats are scanned), with the same results, in the same order, as one by one.

**Sized returns.**  A ``static`` or ``intruder`` threat marked ``solid`` is a sphere the radar
sees whole (a balloon, a cloud, a declared volume), not seed 000's point with a safety distance
round it: its one return is the sphere's centre (range to the near surface plus the radius,
along the bearing of the centre), and :attr:`RadarPicture.radii` carries the radius it measures
from the sphere's angular width (``R = D sin(alpha)``, alpha the half-width seen at centre range
D).  It is in line of sight when its centre, its point nearest to the aircraft or its top is
(a sphere half sunk behind a ridge shows its top).  Every other return's radius is NaN (not
measured); a picture without a sized return has ``radii`` None.  :attr:`RadarPicture.radii_sigma` gives the
standard error of each sized return's radius and centre together (``sqrt(2 (r sigma_b)^2 +
sigma_r^2)``: the radius's cross-range error, the centre's cross-range and range errors); the
avoiders' perception keeps the radius plus two of them (:mod:`replay.avoidance.perception`).

**Terrain returns.**  With a terrain model, a fan of rays is cast in one
:meth:`~terrain.model.TerrainModel.raycast` call: ``terrain_azimuths`` azimuths (360: one degree,
175 m apart at 10 km) at each of ``terrain_elevations_deg`` (-0.5, 0, 0.5, 1.5, 3 degrees) from
the aircraft, plus one horizontal ring from ``clearance`` metres below the aircraft.  That ring's
first hit on an azimuth is the nearest terrain that rises above ``z - clearance`` there, and it is
always in line of sight of the aircraft (the segment from the aircraft to it runs above the ring,
which met no terrain before the hit); the rays from the aircraft add the terrain above it, up to
the crests.  Hits are kept when their altitude is >= own altitude - ``clearance`` (1 mm of float32
slack) and their range <= ``range_m``.  They are grouped by horizontal cell of ``terrain_cell_m``
(100 m) in map coordinates; each cell reports the hit nearest to the aircraft, with the id
``"terrain/<i>/<j>"`` (``i = floor(x / cell)``, ``j = floor(y / cell)``), so consecutive scans call
the same piece of terrain by the same name.  An unknown hill thus appears as seed 000 models hills:
a group of point obstacles.  Terrain does not move, and a radar knows ground returns (clutter
maps, Doppler): terrain returns are always ``moving=False``.

**Noise** (optional): Gaussian, added to range (``noise_range_m``) and bearing
(``noise_bearing_rad``) of every return; the elevation is not perturbed.  The reported position is
rebuilt from the noisy range, bearing and true elevation (and is the exact point when both sigmas
are 0).  Terrain cell ids come from the true hit (they stand for the tracker's association).  All
noise comes from one ``numpy.random.default_rng(seed)``, drawn in a fixed order (ranges, then
bearings, threat returns first, then terrain, then the radii of sized returns, whose error is
the cross-range one, ``r * noise_bearing_rad``, clipped at 0), so the same seed and the same
calls give the same pictures.

**Classification** (seed 000 Fig. 7, §3.7).  A threat return whose id was in the previous picture
is *moving* when its position changed by more than

    threshold = moving_sigmas * sqrt(2) * sqrt(sigma_r^2 + (r sigma_b)^2) + moving_floor_m
                (+ |own displacement| for returns of solid bodies)

(r the larger of the two ranges).  The first term is ``moving_sigmas`` standard deviations of the
difference of two noisy fixes: radial error sigma_r and cross-range error r sigma_b per fix.  With
the default 5 a stationary target is called moving with probability at most exp(-25) when the
two errors are equal (the squared normalised displacement is chi-square with 2 degrees of freedom)
and 5.7e-7 when one dominates (two-sided normal tail) -- per comparison.  The floor (1 m) absorbs
rounding.  The nearest point of a static convex body moves with the aircraft, but by no more than
the aircraft moved (projection onto a convex set is 1-Lipschitz), hence the last term -- which is
seed 000's own rule (moving when the range changed more than the UAV position) applied to the
point.  The price: the slowest target that can be called moving in one scan period moves
``threshold`` metres per period.  A return not in the previous picture is ``moving=None``.  The
previous picture is kept inside the radar (:attr:`Radar.previous`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Literal

import numpy as np
import numpy.typing as npt

from replay.frames import course_of
from replay.sensors.base import check_own_position, scan_due, sensor_number, sensor_rng
from replay.sensors.radar_kernel import terrain_returns
from replay.threats.kinds import EDGE_SUFFIXES, Threat
from replay.threats.table import ThreatTable
from terrain.errors import InputError

if TYPE_CHECKING:
    from terrain.model import TerrainModel

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]

DetectionKind = Literal["threat", "terrain"]
DEFAULT_ELEVATIONS_DEG = (-0.5, 0.0, 0.5, 1.5, 3.0)
TERRAIN_SOURCE = "terrain"
_ALT_SLACK_M = 1e-3  # float32 ray casting rounds hit altitudes by up to ~1 mm


@dataclass(frozen=True, eq=False)
class Detection:
    """One radar return (map metres, radians; see the module docstring for the conventions)."""

    id: str
    position: FloatArray
    range: float
    bearing: float
    elevation: float
    kind: DetectionKind
    moving: bool | None
    source: str  # the threat's id, or "terrain"


_TERRAIN_IDS: dict[tuple[int, int], str] = {}  # cell -> its id (a scan sees the last scan's cells)
_TERRAIN_IDS_KEPT = 200_000


def _terrain_ids(cells: npt.NDArray[np.int64]) -> tuple[str, ...]:
    """The ids of terrain returns: ``terrain/<i>/<j>``, their cell of the radar's grid (each
    cell's text made once: a scan over a mountain names hundreds, most of them the last
    scan's)."""
    memo = _TERRAIN_IDS
    if len(memo) > _TERRAIN_IDS_KEPT:
        memo.clear()
    get = memo.get
    out = []
    for i, j in cells.tolist():
        ident = get((i, j))
        if ident is None:
            ident = memo[i, j] = f"terrain/{i}/{j}"
        out.append(ident)
    return tuple(out)


@dataclass(frozen=True, eq=False)
class RadarPicture:
    """Everything one scan saw, as parallel arrays (threat returns first, then terrain returns)
    and, on demand, as :class:`Detection` objects."""

    t: float
    own_position: FloatArray
    threat_ids: tuple[str, ...]
    threat_sources: tuple[str, ...]  # the threat each threat return belongs to
    terrain_cells: npt.NDArray[np.int64]  # (M, 2) cell (i, j) of each terrain return
    positions: FloatArray  # (N, 3), N = len(threat_ids) + M
    ranges: FloatArray  # (N,)
    bearings: FloatArray
    elevations: FloatArray
    moving_code: npt.NDArray[np.int8]  # -1 unknown, 0 stationary, 1 moving
    extended: BoolArray  # returns of solid bodies (cylinder, prism, body)
    # measured radius of sized returns (NaN others); None: no sized return
    radii: FloatArray | None = field(default=None, kw_only=True)
    # the standard error of each sized return's radius plus centre (0 noise-free; NaN others)
    radii_sigma: FloatArray | None = field(default=None, kw_only=True)

    def __len__(self) -> int:
        return len(self.ranges)

    def __iter__(self) -> Iterator[Detection]:
        return iter(self.detections)

    @property
    def n_threat(self) -> int:
        return len(self.threat_ids)

    @cached_property
    def is_terrain(self) -> BoolArray:
        out = np.zeros(len(self), dtype=bool)
        out[self.n_threat :] = True
        return out

    @cached_property
    def ids(self) -> tuple[str, ...]:
        return self.threat_ids + _terrain_ids(self.terrain_cells)

    def ids_of(self, rows: IntArray) -> list[str]:
        """The ids of some returns (``rows`` into :attr:`ids`), without naming every terrain
        return of the scan (hundreds over a mountain) when a few are asked for."""
        if "ids" in self.__dict__:
            return [self.ids[i] for i in rows.tolist()]
        n = self.n_threat
        terrain = _terrain_ids(self.terrain_cells[rows[rows >= n] - n])
        it = iter(terrain)
        return [self.threat_ids[i] if i < n else next(it) for i in rows.tolist()]

    @cached_property
    def sources(self) -> tuple[str, ...]:
        return self.threat_sources + (TERRAIN_SOURCE,) * len(self.terrain_cells)

    @cached_property
    def detections(self) -> tuple[Detection, ...]:
        moving = {-1: None, 0: False, 1: True}
        out = []
        for i, (ident, source) in enumerate(zip(self.ids, self.sources, strict=True)):
            kind: DetectionKind = "threat" if i < self.n_threat else "terrain"
            out.append(
                Detection(
                    ident,
                    self.positions[i],
                    float(self.ranges[i]),
                    float(self.bearings[i]),
                    float(self.elevations[i]),
                    kind,
                    moving[int(self.moving_code[i])],
                    source,
                )
            )
        return tuple(out)

    @cached_property
    def index(self) -> dict[str, int]:
        """Row of each id."""
        return {ident: i for i, ident in enumerate(self.ids)}

    @cached_property
    def threat_index(self) -> dict[str, int]:
        """Row of each threat return's id."""
        return dict(zip(self.threat_ids, range(self.n_threat), strict=True))

    def get(self, ident: str) -> Detection:
        """The detection with this id (KeyError if it was not seen)."""
        return self.detections[self.index[ident]]

    def threats(self) -> tuple[Detection, ...]:
        return self.detections[: self.n_threat]

    def terrain(self) -> tuple[Detection, ...]:
        return self.detections[self.n_threat :]


def _sphere_marks(own: FloatArray, centres: FloatArray, radii: FloatArray) -> FloatArray:
    """Two points of each sphere besides its centre that the radar may see: the point nearest
    to ``own`` and the top, (2 K, 3) in that order per sphere."""
    d = own - centres
    dist = np.linalg.norm(d, axis=-1, keepdims=True)
    near = centres + d * (radii[:, None] / np.maximum(dist, 1e-9))
    top = centres + np.column_stack([np.zeros((len(radii), 2)), radii])
    return np.stack([near, top], axis=1).reshape(-1, 3)


def _number(name: str, value: float, minimum: float, strict: bool) -> float:
    return sensor_number("radar", name, value, minimum, strict)


class Radar:
    """Radar with one random generator; keeps the previous picture for classification."""

    name = "radar"

    def __init__(
        self,
        range_m: float = 10000.0,
        period_s: float = 1.0,
        noise_range_m: float = 0.0,
        noise_bearing_rad: float = 0.0,
        seed: int | np.random.Generator = 0,
        *,
        terrain_azimuths: int = 360,
        terrain_elevations_deg: Sequence[float] = DEFAULT_ELEVATIONS_DEG,
        terrain_clearance_m: float = 100.0,
        terrain_cell_m: float = 100.0,
        moving_sigmas: float = 5.0,
        moving_floor_m: float = 1.0,
        los_tolerance_m: float = 1.0,
    ) -> None:
        self.range_m = _number("range_m", range_m, 0.0, True)
        self.period_s = _number("period_s", period_s, 0.0, True)
        self.noise_range_m = _number("noise_range_m", noise_range_m, 0.0, False)
        self.noise_bearing_rad = _number("noise_bearing_rad", noise_bearing_rad, 0.0, False)
        self.terrain_clearance_m = _number("terrain_clearance_m", terrain_clearance_m, 0.0, False)
        self.terrain_cell_m = _number("terrain_cell_m", terrain_cell_m, 0.0, True)
        self.moving_sigmas = _number("moving_sigmas", moving_sigmas, 0.0, False)
        self.moving_floor_m = _number("moving_floor_m", moving_floor_m, 0.0, False)
        self.los_tolerance_m = _number("los_tolerance_m", los_tolerance_m, 0.0, False)
        if (
            isinstance(terrain_azimuths, bool)
            or not isinstance(terrain_azimuths, int | np.integer)
            or terrain_azimuths < 0
        ):
            raise InputError(
                f"radar terrain_azimuths must be an integer >= 0; got {terrain_azimuths!r}"
            )
        self.terrain_azimuths = int(terrain_azimuths)
        elev = tuple(
            _number("terrain_elevations_deg", e, -90.0, False) for e in terrain_elevations_deg
        )
        if any(e > 90.0 for e in elev):
            raise InputError(f"radar terrain elevations must lie in [-90, 90] degrees; got {elev}")
        self.terrain_elevations_deg = elev
        self.rng, self.seed = sensor_rng("radar", seed)
        self.previous: RadarPicture | None = None
        self.last_scan_t: float | None = None
        fan, ring = self._directions()
        self._n_fan = len(fan)
        self._rays = np.vstack([fan, ring])
        self._table_cache: ThreatTable | None = None

    def _directions(self) -> tuple[FloatArray, FloatArray]:
        """Unit rays (clockwise from north): the fan (E * N, 3) and the horizontal ring (N, 3)."""
        n = self.terrain_azimuths
        az = np.arange(n) * (2.0 * np.pi / max(n, 1))
        ring = np.column_stack([np.sin(az), np.cos(az), np.zeros(n)])
        el = np.radians(np.asarray(self.terrain_elevations_deg, dtype=np.float64))[:, None]
        fan = np.stack(
            [
                np.cos(el) * np.sin(az),
                np.cos(el) * np.cos(az),
                np.broadcast_to(np.sin(el), (len(el), n)),
            ],
            axis=-1,
        ).reshape(-1, 3)
        return fan, ring

    # -- timing -----------------------------------------------------------------------------------
    def due(self, t: float) -> bool:
        """True when no scan happened yet or ``period_s`` has passed since the last one."""
        return scan_due(self.last_scan_t, self.period_s, t)

    def reset(self) -> None:
        """Forget the previous picture and the scan time (the random generator runs on)."""
        self.previous = None
        self.last_scan_t = None

    # -- scanning ---------------------------------------------------------------------------------
    def scan(
        self,
        t: float,
        own_position: npt.ArrayLike,
        threats: Iterable[Threat],
        terrain_model: TerrainModel | None = None,
        min_clearance: float | None = None,
        state: npt.ArrayLike | None = None,
    ) -> RadarPicture:
        """Scan now (see the module docstring); the picture also becomes :attr:`previous`.
        ``state`` (the vehicle's attitude) is not read: the radar scans a stabilised sphere."""
        own = check_own_position(own_position)
        t = _number("scan time", t, -math.inf, False)
        clearance = (
            self.terrain_clearance_m
            if min_clearance is None
            else _number("min_clearance", min_clearance, 0.0, False)
        )
        table = self._table(threats)  # once: ``threats`` may be a one-pass iterable
        ids, sources, pts, ext = self._threat_points(t, own, table.threats)
        sized = table.sized
        if len(pts) and terrain_model is not None:
            targets, owner = pts, np.arange(len(pts))
            if sized:  # a sphere is seen when its centre, near point or top is
                rows = [i for i, src in enumerate(sources) if src in sized]
                if rows:
                    more = _sphere_marks(
                        own, pts[rows], np.array([sized[sources[i]] for i in rows])
                    )
                    targets = np.vstack([pts, more])
                    owner = np.concatenate([owner, np.repeat(rows, 2)])
            hit = terrain_model.line_of_sight(own, targets, tolerance=self.los_tolerance_m)
            seen = np.zeros(len(pts), dtype=bool)
            seen[owner[np.asarray(hit, dtype=bool)]] = True
            keep = np.flatnonzero(seen)
            ids = [ids[i] for i in keep]
            sources = [sources[i] for i in keep]
            pts, ext = pts[keep], ext[keep]
        cells = np.zeros((0, 2), dtype=np.int64)
        if terrain_model is not None and self.terrain_azimuths > 0:
            cells, t_pts = self._terrain_points(own, terrain_model, clearance)
            pts = np.vstack([pts, t_pts])
            ext = np.concatenate([ext, np.zeros(len(cells), dtype=bool)])
        picture = self._measure(t, own, tuple(ids), tuple(sources), cells, pts, ext)
        if sized:
            picture = self._sized(picture, sized)
        self.previous = picture
        self.last_scan_t = t
        return picture

    def _threat_points(
        self, t: float, own: FloatArray, threats: Iterable[Threat]
    ) -> tuple[list[str], list[str], FloatArray, BoolArray]:
        """Candidate threat returns within range (before the line-of-sight test), in the order
        the threats are given: every kind at once (:class:`replay.threats.table.ThreatTable`; a
        Table 6 scenario has 100 threats, scanned 28 800 times)."""
        return self._table(threats).radar_points(t, own, self.range_m)

    def _table(self, threats: Iterable[Threat]) -> ThreatTable:
        """The threats as arrays, kept for the last sequence seen (the simulation passes the
        same tuple at every scan)."""
        seq = threats if isinstance(threats, tuple) else tuple(threats)
        cached = self._table_cache
        if cached is not None and (cached.threats is seq or cached.threats == seq):
            return cached
        self._table_cache = ThreatTable(seq)
        return self._table_cache

    def _terrain_points(
        self, own: FloatArray, model: TerrainModel, clearance: float
    ) -> tuple[npt.NDArray[np.int64], FloatArray]:
        """Terrain returns: (cells (M, 2), points (M, 3)), the nearest hit in each occupied cell
        (the hits made returns in one compiled pass: :mod:`replay.sensors.radar_kernel`)."""
        dirs, n_fan = self._rays, self._n_fan
        origins = np.empty_like(dirs)
        origins[:n_fan] = own
        origins[n_fan:] = own - np.array([0.0, 0.0, clearance])
        dist = model.raycast(origins, dirs, max_range=self.range_m)
        return terrain_returns(
            own, clearance, dirs, n_fan, dist, self.range_m, self.terrain_cell_m, _ALT_SLACK_M
        )

    def _measure(
        self,
        t: float,
        own: FloatArray,
        ids: tuple[str, ...],
        sources: tuple[str, ...],
        cells: npt.NDArray[np.int64],
        true_pts: FloatArray,
        ext: BoolArray,
    ) -> RadarPicture:
        """Range, bearing, elevation, noise and classification of the returns."""
        n, n_threat = len(true_pts), len(ids)
        d = true_pts - own
        horiz = np.hypot(d[:, 0], d[:, 1])
        ranges = np.sqrt(horiz**2 + d[:, 2] ** 2)
        bearings = course_of(d[:, 0], d[:, 1])
        elevations = np.arctan2(d[:, 2], horiz)
        positions = true_pts.copy()
        noisy = self.noise_range_m > 0 or self.noise_bearing_rad > 0
        if noisy:
            if self.noise_range_m > 0:
                ranges = np.maximum(ranges + self.rng.normal(0.0, self.noise_range_m, n), 0.0)
            if self.noise_bearing_rad > 0:
                bearings = bearings + self.rng.normal(0.0, self.noise_bearing_rad, n)
                bearings = np.pi - np.mod(np.pi - bearings, 2.0 * np.pi)  # back into (-pi, pi]
            ce = np.cos(elevations)
            unit = np.column_stack(
                [ce * np.sin(bearings), ce * np.cos(bearings), np.sin(elevations)]
            )
            positions = own + ranges[:, None] * unit
        moving = np.full(n, -1, dtype=np.int8)
        moving[n_threat:] = 0  # terrain does not move
        prev = self.previous
        if prev is not None and n_threat:
            a: slice | IntArray
            b: slice | IntArray
            if ids == prev.threat_ids:  # the same returns as the last scan (the usual case)
                a = b = slice(0, n_threat)
            else:
                index = prev.threat_index
                j = np.fromiter((index.get(ident, -1) for ident in ids), np.int64, n_threat)
                a = np.flatnonzero(j >= 0)
                b = j[a]
            solid = ext[a]  # returns of solid bodies
            if (
                isinstance(a, slice)
                and not noisy
                and not ext[:n_threat].any()
                and bool((positions[:n_threat] == prev.positions[:n_threat]).all())
            ):
                # the same points where they were, none of a solid: none moved (the general
                # test below gives 0 > limit, False, for each)
                moving[:n_threat] = 0
            elif len(solid):
                moved = np.linalg.norm(positions[a] - prev.positions[b], axis=-1)
                limit: float | FloatArray = self.moving_floor_m  # exactly that when sigma is 0
                if self.noise_range_m > 0 or self.noise_bearing_rad > 0:
                    r = np.maximum(ranges[a], prev.ranges[b])
                    sigma = np.sqrt(self.noise_range_m**2 + (r * self.noise_bearing_rad) ** 2)
                    limit = self.moving_sigmas * math.sqrt(2.0) * sigma + self.moving_floor_m
                if solid.any():  # + the aircraft's displacement
                    step = float(np.linalg.norm(own - prev.own_position))
                    limit = limit + np.where(solid, step, 0.0)
                moving[a] = (moved > limit).astype(np.int8)
        if ext[:n_threat].any():
            # an outline edge of a solid slides round it faster than the aircraft moves: the
            # body's motion is judged on its nearest point, and its edges take that verdict
            row_of = {ident: k for k, ident in enumerate(ids)}
            for k, ident in enumerate(ids):
                if ident.endswith(EDGE_SUFFIXES):
                    near = row_of.get(sources[k], -1)
                    moving[k] = moving[near] if near >= 0 else np.int8(-1)
        return RadarPicture(
            t=float(t),
            own_position=own.copy(),
            threat_ids=ids,
            threat_sources=sources,
            terrain_cells=cells,
            positions=positions,
            ranges=ranges,
            bearings=bearings,
            elevations=elevations,
            moving_code=moving,
            extended=ext,
        )

    def _sized(self, picture: RadarPicture, sized: dict[str, float]) -> RadarPicture:
        """The picture with the radii of the spheres it sees whole (``sized``: radius by
        threat id), measured with the cross-range error (module docstring)."""
        radii = np.full(len(picture), np.nan)
        radii[: picture.n_threat] = [sized.get(src, math.nan) for src in picture.threat_sources]
        on = np.flatnonzero(np.isfinite(radii))
        if not len(on):
            return picture
        cross = picture.ranges[on] * self.noise_bearing_rad
        if self.noise_bearing_rad > 0:
            err = self.rng.normal(0.0, 1.0, len(on)) * cross
            radii[on] = np.maximum(radii[on] + err, 0.0)
        sigma = np.full(len(picture), np.nan)
        # the radius's error and the centre's (range and cross-range), independent
        sigma[on] = np.sqrt(2.0 * cross**2 + self.noise_range_m**2)
        return dataclasses.replace(picture, radii=radii, radii_sigma=sigma)
