"""The cooperative sensor (ADS-B-like): every threat in range reports its own state.

Seeds 001 (CTGA, §3.1: "the position and velocity of the obstacles are given and accessible to
the aircraft") and 004 (FGA) assume the aircraft *knows* each obstacle's position, velocity and
size.  The radar (:mod:`replay.sensors.radar`) measures only positions; this sensor makes the seeds'
assumption explicit and selectable: each threat active and within range reports its true state,
optionally degraded by Gaussian noise and a latency.  It is a drop-in for the radar in the
simulation loop (:meth:`CooperativeSensor.due`, :meth:`CooperativeSensor.scan`) and its
:class:`CooperativePicture` has the radar picture's parallel arrays (``ids``, ``positions``,
``ranges``, ``moving_code``, ...), so code written for a :class:`~replay.sensors.radar.RadarPicture` reads
it unchanged; :mod:`replay.avoidance.perception` accepts both.

**What is reported.**  One report per radar point of a threat (:meth:`~replay.threats.kinds.Threat.
radar_points`: the same ids as the radar's, so ``--sensor radar|cooperative`` name things alike):

=========== ================================= ============================= ======================
kind        position                          size (``radius``)             ``top``
=========== ================================= ============================= ======================
static      the centre                        the safety radius             centre z + radius
hill        each point ``"<id>/<k>"``         that point's safety radius    point z + its radius
intruder    its position                      the safety radius             z + radius
cylinder    centre of the top face            the radius                    the top
prism       footprint centroid at the top     ``enclosing_radius``          the top
body        the centre (x0, y0, z0)           ``body_radius_at(own z)``     z0 + c
=========== ================================= ============================= ======================

(seed 001 eq 3: a body's size is the radius of its horizontal section at the aircraft's altitude,
:meth:`~replay.threats.body.BodyThreat.body_radius_at`; 0 when the aircraft flies above or below it --
``top`` then says where it ends.  A prism, a building, is reported as the smallest cylinder about
its footprint's centroid that holds it, :attr:`~replay.threats.kinds.PrismThreat.enclosing_radius`: a
report carries a position and a size, not a polygon, so an avoider that keeps clear of the circle
keeps clear of the building, at the price of a wider berth round a long or L-shaped one.)  The
velocity is :meth:`~replay.threats.kinds.Threat.velocity` (zero for everything but intruders).  Sizes and
tops are reported exactly (no noise).

**Range and activity.**  A threat reports the state it had at ``t_m = t - latency_s`` (below): it
reports when it was active then (``appears_at <= t_m < disappears_at``: a threat that appears is
heard ``latency_s`` later, and one that disappears is still heard for ``latency_s``) and the point
the radar would test is within ``range_m`` (3D) of the aircraft's position now -- for point kinds
the point itself, for solids (cylinder, prism, body) the point of the body nearest to the
aircraft, so a large body is heard when its surface, not its centre, comes within range.  There is no line of
sight test (a radio report needs none at these ranges; ``terrain_model`` is accepted and ignored,
so the loop can call either sensor alike) and no terrain returns.

**Noise** (optional): independent Gaussian errors on each axis, ``noise_position_m`` on the
position and ``noise_velocity_mps`` on the velocity (m and m/s, standard deviations per axis, so a
3D error has RMS ``sqrt(3)`` sigma).  All noise comes from one generator
(``numpy.random.default_rng(seed)`` or the Generator passed), drawn once per scan in a fixed order
-- every report's position error (N, 3) when that sigma is > 0, then every velocity error (N, 3)
when that sigma is > 0 -- so the same seed and the same calls give the same pictures.

**Latency** ``latency_s``: each report describes the threat at ``t_m = t - latency_s``.  By default
(``extrapolate=False``) it is delivered as such: the reported position is the measured one and
``measured_at`` is ``t_m``, so a tracker that fits positions against ``measured_at``
(:mod:`replay.avoidance.perception`) is not misled, but the position lags the truth by ``latency_s`` times
the threat's speed.  With ``extrapolate=True`` the receiver dead-reckons each report to now:
``position = measured + measured velocity * latency_s`` and ``measured_at = t`` -- exact for a
constant velocity without noise; with noise the position error grows to
``sqrt(sigma_p^2 + (latency_s sigma_v)^2)`` per axis, and a threat that turned during the latency
is placed where it would be had it not turned.

**Moving or stationary.**  A report is *moving* (``moving_code`` 1) when its reported speed
exceeds ``moving_sigmas * noise_velocity_mps + moving_floor_mps`` (5 sigma + 0.5 m/s), else
stationary (0); it is never unknown (-1): the velocity is in the report.  A stationary threat is
called moving when the norm of its 3D velocity error exceeds 5 sigma + the floor: less often than
``P(chi2(3) > 25) = 1.4e-5`` per report.  A threat slower than the threshold is called stationary.

Bad parameters (a negative noise or latency, a range or period <= 0, a seed that is neither an
integer nor a Generator) raise :class:`~terrain.errors.InputError` with a one-line message.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from replay.frames import course_of
from replay.sensors.base import check_own_position, scan_due, sensor_number, sensor_rng
from replay.threats.body import BodyThreat
from replay.threats.kinds import HillThreat, PrismThreat, StaticThreat, Threat
from terrain.errors import InputError

if TYPE_CHECKING:
    from terrain.model import TerrainModel

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]

SENSOR_NAME = "cooperative"


@dataclass(frozen=True, eq=False)
class Report:
    """One cooperative report (map metres, m/s, seconds; see the module docstring)."""

    id: str
    source: str  # the threat's id
    position: FloatArray  # (3,)
    velocity: FloatArray  # (3,) east, north, up
    radius: float  # the threat's size (safety radius, cylinder radius, prism's enclosing
    # radius, body section radius)
    top: float  # the highest altitude of its volume
    measured_at: float  # the time the position and velocity describe
    range: float  # from the aircraft now to the reported position
    moving: bool


@dataclass(frozen=True, eq=False)
class CooperativePicture:
    """Every report of one scan as parallel arrays (N rows), with the radar picture's attribute
    names (:class:`replay.sensors.radar.RadarPicture`) where they mean the same: ``ids``, ``sources``,
    ``positions``, ``ranges``, ``bearings``, ``elevations``, ``moving_code``, ``extended`` (all
    False: a report is a reference point and a size, not a point on a surface), ``terrain_cells``
    (none), ``n_threat`` (= N); and what only this sensor knows: ``velocities``, ``radii``,
    ``tops``, ``measured_at``."""

    t: float
    own_position: FloatArray
    threat_ids: tuple[str, ...]
    threat_sources: tuple[str, ...]
    positions: FloatArray  # (N, 3) reported
    velocities: FloatArray  # (N, 3) reported
    radii: FloatArray  # (N,)
    tops: FloatArray  # (N,)
    measured_at: FloatArray  # (N,)
    ranges: FloatArray  # (N,) from own_position to the reported position
    bearings: FloatArray  # (N,) clockwise from north, (-pi, pi]
    elevations: FloatArray  # (N,)
    moving_code: npt.NDArray[np.int8]  # 0 stationary, 1 moving (never -1)

    sensor = SENSOR_NAME

    def __len__(self) -> int:
        return len(self.threat_ids)

    def __iter__(self) -> Iterator[Report]:
        return iter(self.reports)

    @property
    def n_threat(self) -> int:
        return len(self.threat_ids)

    @property
    def ids(self) -> tuple[str, ...]:
        return self.threat_ids

    @property
    def sources(self) -> tuple[str, ...]:
        return self.threat_sources

    @cached_property
    def extended(self) -> BoolArray:
        return np.zeros(len(self), dtype=bool)

    @cached_property
    def is_terrain(self) -> BoolArray:
        return np.zeros(len(self), dtype=bool)

    @cached_property
    def terrain_cells(self) -> npt.NDArray[np.int64]:
        return np.zeros((0, 2), dtype=np.int64)

    @cached_property
    def reports(self) -> tuple[Report, ...]:
        return tuple(
            Report(
                ident,
                source,
                self.positions[i],
                self.velocities[i],
                float(self.radii[i]),
                float(self.tops[i]),
                float(self.measured_at[i]),
                float(self.ranges[i]),
                bool(self.moving_code[i]),
            )
            for i, (ident, source) in enumerate(zip(self.ids, self.sources, strict=True))
        )

    @cached_property
    def index(self) -> dict[str, int]:
        """Row of each id."""
        return {ident: i for i, ident in enumerate(self.threat_ids)}

    def get(self, ident: str) -> Report:
        """The report with this id (KeyError if it was not heard)."""
        return self.reports[self.index[ident]]


def _number(name: str, value: Any, minimum: float, strict: bool) -> float:
    return sensor_number("cooperative sensor", name, value, minimum, strict)


@dataclass(frozen=True, eq=False)
class _PointTable:
    """The fixed points of static threats and hills, for one threat tuple: one row per point."""

    threats: tuple[Threat, ...]
    threat_row: IntArray  # index of the owning threat in ``threats``
    sub: IntArray  # point number within the threat (0 for a static threat)
    ids: tuple[str, ...]
    centres: FloatArray  # (P, 3)
    radii: FloatArray
    appears: FloatArray
    disappears: FloatArray


def _point_table(threats: tuple[Threat, ...]) -> _PointTable:
    rows, subs, ids, centres, radii, t0, t1 = [], [], [], [], [], [], []
    for k, th in enumerate(threats):
        if isinstance(th, StaticThreat):
            pts, rad, names = [th.center], [th.radius], [th.id]
        elif isinstance(th, HillThreat):
            pts, rad = list(th.points), list(th.radii)
            names = [f"{th.id}/{j}" for j in range(len(pts))]
        else:
            continue
        stop = math.inf if th.disappears_at is None else th.disappears_at
        for j, (p, r, name) in enumerate(zip(pts, rad, names, strict=True)):
            rows.append(k)
            subs.append(j)
            ids.append(name)
            centres.append(p)
            radii.append(r)
            t0.append(th.appears_at)
            t1.append(stop)
    return _PointTable(
        threats,
        np.array(rows, dtype=np.int64),
        np.array(subs, dtype=np.int64),
        tuple(ids),
        np.array(centres, dtype=np.float64).reshape(-1, 3),
        np.array(radii, dtype=np.float64),
        np.array(t0, dtype=np.float64),
        np.array(t1, dtype=np.float64),
    )


class CooperativeSensor:
    """ADS-B-like sensor with one random generator (see the module docstring)."""

    name = SENSOR_NAME

    def __init__(
        self,
        range_m: float = 10000.0,
        period_s: float = 1.0,
        noise_position_m: float = 0.0,
        noise_velocity_mps: float = 0.0,
        latency_s: float = 0.0,
        seed: int | np.random.Generator = 0,
        *,
        extrapolate: bool = False,
        moving_sigmas: float = 5.0,
        moving_floor_mps: float = 0.5,
    ) -> None:
        self.range_m = _number("range_m", range_m, 0.0, True)
        self.period_s = _number("period_s", period_s, 0.0, True)
        self.noise_position_m = _number("noise_position_m", noise_position_m, 0.0, False)
        self.noise_velocity_mps = _number("noise_velocity_mps", noise_velocity_mps, 0.0, False)
        self.latency_s = _number("latency_s", latency_s, 0.0, False)
        self.moving_sigmas = _number("moving_sigmas", moving_sigmas, 0.0, False)
        self.moving_floor_mps = _number("moving_floor_mps", moving_floor_mps, 0.0, False)
        if not isinstance(extrapolate, bool):
            raise InputError(
                f"cooperative sensor extrapolate must be true or false; got {extrapolate!r}"
            )
        self.extrapolate = extrapolate
        self.rng, self.seed = sensor_rng("cooperative sensor", seed)
        self.last_scan_t: float | None = None
        self._table: _PointTable | None = None

    @property
    def moving_threshold_mps(self) -> float:
        """Reported speed above which a report is *moving*."""
        return self.moving_sigmas * self.noise_velocity_mps + self.moving_floor_mps

    # -- timing -----------------------------------------------------------------------------------
    def due(self, t: float) -> bool:
        """True when no scan happened yet or ``period_s`` has passed since the last one."""
        return scan_due(self.last_scan_t, self.period_s, t)

    def reset(self) -> None:
        """Forget the scan time (the random generator runs on)."""
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
    ) -> CooperativePicture:
        """The reports heard at time t (see the module docstring); ``terrain_model``,
        ``min_clearance`` and ``state`` are ignored (:class:`replay.sensors.base.Sensor`'s
        signature, so the loop calls any sensor alike)."""
        own = check_own_position(own_position)
        t = _number("scan time", t, -math.inf, False)
        tm = t - self.latency_s
        seq = threats if isinstance(threats, tuple) else tuple(threats)
        table = self._table
        if table is None or table.threats is not seq:
            table = self._table = _point_table(seq)
        # fixed points (static threats and hill points): one array operation
        near = (
            (table.appears <= tm)
            & (tm < table.disappears)
            & (np.linalg.norm(table.centres - own, axis=1) <= self.range_m)
        )
        keep = np.flatnonzero(near)
        order_key = [table.threat_row[keep]]
        sub_key = [table.sub[keep]]
        ids = [table.ids[i] for i in keep.tolist()]
        sources = [seq[k].id for k in table.threat_row[keep].tolist()]
        pos = [table.centres[keep]]
        vel = [np.zeros((len(keep), 3))]
        rad = [table.radii[keep]]
        top = [table.centres[keep, 2] + table.radii[keep]]
        # the others (intruders, cylinders, prisms, bodies): one by one
        for k, th in enumerate(seq):
            if isinstance(th, StaticThreat | HillThreat) or not th.active(tm):
                continue
            _, probe = th.radar_points(tm, own, self.range_m)
            if not len(probe) or float(np.linalg.norm(probe[0] - own)) > self.range_m:
                continue
            shape = th.shape(tm)
            p = np.asarray(th.position(tm), dtype=np.float64).reshape(3)
            if isinstance(th, BodyThreat):
                r = float(th.body_radius_at(own[2]))
            elif isinstance(th, PrismThreat):
                r = th.enclosing_radius
            else:
                r = float(shape["radius"])
            order_key.append(np.array([k]))
            sub_key.append(np.array([0]))
            ids.append(th.id)
            sources.append(th.id)
            pos.append(p[None, :])
            vel.append(np.asarray(th.velocity(tm), dtype=np.float64).reshape(1, 3))
            rad.append(np.array([r]))
            top.append(np.array([float(shape["top"])]))
        order = np.lexsort((np.concatenate(sub_key), np.concatenate(order_key)))
        picture = self._measure(
            t,
            tm,
            own,
            tuple(ids[i] for i in order.tolist()),
            tuple(sources[i] for i in order.tolist()),
            np.vstack(pos)[order],
            np.vstack(vel)[order],
            np.concatenate(rad)[order],
            np.concatenate(top)[order],
        )
        self.last_scan_t = t
        return picture

    def _measure(
        self,
        t: float,
        tm: float,
        own: FloatArray,
        ids: tuple[str, ...],
        sources: tuple[str, ...],
        true_pos: FloatArray,
        true_vel: FloatArray,
        radii: FloatArray,
        tops: FloatArray,
    ) -> CooperativePicture:
        """Noise, latency and classification of the reports."""
        n = len(ids)
        pos = true_pos.copy()
        vel = true_vel.copy()
        if self.noise_position_m > 0:
            pos += self.rng.normal(0.0, self.noise_position_m, (n, 3))
        if self.noise_velocity_mps > 0:
            vel += self.rng.normal(0.0, self.noise_velocity_mps, (n, 3))
        stamp = tm
        if self.extrapolate:
            pos += vel * self.latency_s
            stamp = t
        d = pos - own
        horiz = np.hypot(d[:, 0], d[:, 1])
        speed = np.linalg.norm(vel, axis=1)
        return CooperativePicture(
            t=float(t),
            own_position=own.copy(),
            threat_ids=ids,
            threat_sources=sources,
            positions=pos,
            velocities=vel,
            radii=np.asarray(radii, dtype=np.float64),
            tops=np.asarray(tops, dtype=np.float64),
            measured_at=np.full(n, stamp, dtype=np.float64),
            ranges=np.sqrt(horiz**2 + d[:, 2] ** 2),
            bearings=course_of(d[:, 0], d[:, 1]),
            elevations=np.arctan2(d[:, 2], horiz),
            moving_code=(speed > self.moving_threshold_mps).astype(np.int8),
        )
