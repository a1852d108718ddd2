"""Rangefinders (seed 003 §III.A.2): ``beams`` beams (four: front, right, back, left) of range R,
by ray casting against the terrain and the threats, at ``period_s`` (10 Hz by default).

A :class:`Rangefinders` sensor has the radar's timing interface (:meth:`~Rangefinders.due`,
:meth:`~Rangefinders.reset`, :meth:`~Rangefinders.scan`) and returns a frozen
:class:`RangefinderPicture`: per beam its bearing, course, range to the first hit and what it
hit, and -- as a :class:`~replay.sensors.radar.RadarPicture`, which it is -- the beams that hit
something as returns, so that perception (:mod:`replay.avoidance.perception`) and the radar's avoiders
read them unchanged ("rangefinder hits as sensor returns").

**Beams.**  B beams evenly spaced from the front: beam j's bearing relative to the heading is
``2 pi j / B`` clockwise, wrapped to (-pi, pi] (B = 4: 0 front, pi/2 right, pi back, -pi/2
left; B = 1: seed 003 §I's single sensor, which needs a longer turn to scan).  The
heading (``yaw``) is the state's psi (rad clockwise from north, :mod:`replay.frames`); without
a state the vehicle faces north, level.  ``beam_courses = yaw + bearing`` (wrapped).

**Mount** -- ``"gimballed"`` (the default) or ``"body"``.  Seed 003 plans in a horizontal
plane: its set-points lie on a circle of radius R - tau about the vehicle at its altitude and a
direction is open when its beam's range is >= R - tau (§III.C.15-16), i.e. it takes beam ranges
for horizontal distances.  A multirotor flies by tilting: a body-fixed front beam pitched down
by theta reaches flat ground at the slant range h / sin theta from a height h, 1 / tan theta x h
ahead (20 deg: 2.92 h slant, 2.75 h ahead), and its back beam looks up by theta and misses low
obstacles behind.  Flown on ``data/scenarios/quadrotor-mission.yaml``, the ``quadrotor`` preset
cruises at 5 m/s 7.1 deg nose down (the ground at 8.1 h: a 20 m beam meets it from below 2.5 m),
pitches -44 to +19 deg when it accelerates and brakes at the corners and rolls to 43 deg in
them; at its 45 deg tilt limit a 20 m beam meets the ground from any height below 14.1 m.  The
gimballed mount holds the beams level at the heading's azimuths, as seed 003's horizontal
picture assumes; ``"body"`` keeps them fixed in the body frame, turned by roll, pitch and yaw
(3-2-1, :func:`replay.frames.rotation_body_to_ned`), to study that effect.  The unit directions
of the beams in the map frame are :attr:`RangefinderPicture.beam_directions`.

**Cone** (``spread_deg``, 0 by default: a line).  A real rangefinder has a field of view; a
beam of half-angle ``spread_deg`` is cast as five rays, its axis and four on its rim (turned down,
up, right and left by the spread, in the beam's own frame: level and at the heading when
gimballed, tilting with the body when body-mounted), and reads the ray whose hit is nearest
*horizontally* (seed 003's picture is horizontal; the axis wins a tie within ``TIE_M``, 1 um).  ``beam_ranges`` and
``beam_directions`` are that ray's, so ``beam_ends`` is the hit point; ``beam_reach`` is its
horizontal distance (``range_m`` for a beam that hit nothing).  The priority loop asks for
``atan(tau / (R - tau))`` (:mod:`replay.avoidance.priority`, "tau round the beams").

**What a beam hits.**  The nearest of: every threat active at t -- static spheres, each point's
sphere of a hill, intruders at their position at t, cylinders, prisms, convex bodies
(:mod:`replay.sensors.raycast`: exact for all but the body, which is searched to 1e-12 of the range on
its convex Gamma; any other threat kind by sphere tracing on its separation) -- and the terrain:
:meth:`terrain.model.TerrainModel.raycast` with a terrain model (float32 from the mesh's
centre: millimetres; no terrain outside the mesh), else flat ground at 0 m AMSL, as elsewhere in
the replay.  A beam that starts inside a threat or below the ground reads 0.  ``beam_ranges`` is
``range_m`` where nothing lies within range (``beam_sources`` ``""``); ``beam_sources`` holds
the threat's id (a hill's id, not its point's) or ``"terrain"``.  ``min_clearance`` is accepted
(the loop calls every sensor alike) and not used: a beam sees what it meets.

**Returns** (the RadarPicture part): one per hitting beam, threat hits first then terrain hits,
each in beam order, at the hit point, with the radar's range, bearing (course of the hit point)
and elevation.  A threat hit's id is ``"<point id>#beam<j>"`` (point id: the threat's id, a
hill's ``"<id>/<k>"``), its source the threat's id, ``extended`` as the radar's (True for
cylinders, prisms and bodies: perception keeps their surface points per cell).  Terrain hits
are named by cells of ``terrain_cell_m`` (1 m; the radar's ``"terrain/<i>/<j>"``); two beams
that hit one cell give the nearer return.  ``moving_code``: a rangefinder cannot tell a moving
echo from a still one, so threat returns are unknown (-1), unless the sensor is built with
``assume_static=True`` -- seed 003's environment of fixed obstacles (§III.B.2) -- when they are
stationary (0); terrain returns are stationary (0) as the radar's.  (Perception and PSO-CA,
CTGA and FGA act on stationary obstacles and moving tracks only: they ignore unknown returns;
the simulation loop builds the sensor with ``assume_static=True``.)

**Noise** (optional): Gaussian with standard deviation ``noise_m`` on the range of every beam
that hits (clipped to [0, range_m]; the return's position moves along its beam), drawn as B
numbers per scan in beam order from one generator (``seed``: an integer, a numpy Generator --
the simulation passes the run's -- or None for seed 0), so the same seed and calls give the
same pictures.

**Cost** (4 beams of 20 m, measured on the 2-core machine while a benchmark ran): 0.06 ms a
scan with nothing in reach, 0.34 ms with five shapes of every closed-form kind in reach, 0.45 ms
with a terrain model too, 0.17 ms among the 143 buildings of
``data/scenarios/bubenec-buildings.yaml`` (shapes out of reach are dropped by a bounding circle or
sphere first), 2.4 ms with a convex body in reach (its 85-step search); 8 body-mounted beams
0.46 ms.  The quadrotor mission (81 s, 808 scans at 10 Hz) runs in 0.09 s against 0.013 s with the
radar at 1 Hz.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, ClassVar

import numpy as np
import numpy.typing as npt

from replay.frames import PHI, PSI, THETA, course_of, ned_to_map, rotation_body_to_ned
from replay.sensors.base import check_own_position, scan_due, sensor_number, sensor_rng
from replay.sensors.radar import RadarPicture
from replay.sensors.raycast import (
    ray_cylinders,
    ray_flat_ground,
    ray_prisms,
    ray_separation,
    ray_spheres,
    ray_superellipsoid,
)
from replay.threats.body import BodyThreat
from replay.threats.kinds import (
    CylinderThreat,
    HillThreat,
    IntruderThreat,
    PrismThreat,
    StaticThreat,
    Threat,
)
from terrain.errors import InputError

if TYPE_CHECKING:
    from terrain.model import TerrainModel

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]

SENSOR_NAME = "rangefinder"
MOUNTS = ("gimballed", "body")
TERRAIN_SOURCE = "terrain"
TIE_M = 1e-6  # a cone's rim ray reads only when nearer than its axis by more than this (m)


def wrap_bearing(a: npt.ArrayLike) -> FloatArray:
    """Angle(s) wrapped to (-pi, pi] (the radar's bearing convention: back is +pi)."""
    return np.asarray(np.pi - np.mod(np.pi - np.asarray(a, dtype=np.float64), 2.0 * np.pi))


@dataclass(frozen=True, eq=False)
class RangefinderPicture(RadarPicture):
    """One scan of the rangefinders: a :class:`~replay.sensors.radar.RadarPicture` of the beams that hit
    (module docstring) plus every beam, in beam order."""

    yaw: float  # heading at the scan, rad clockwise from north
    range_m: float
    beam_bearings: FloatArray  # (B,) relative to the heading, clockwise, (-pi, pi]
    beam_courses: FloatArray  # (B,) yaw + bearing, wrapped to (-pi, pi]
    beam_ranges: FloatArray  # (B,) to the first hit; range_m when nothing within range
    beam_sources: tuple[str, ...]  # (B,) threat id, "terrain" or ""
    beam_directions: FloatArray  # (B, 3) unit vectors in the map frame (x east, y north, z up)

    sensor: ClassVar[str] = SENSOR_NAME

    @property
    def beams(self) -> int:
        return len(self.beam_ranges)

    @cached_property
    def beam_hits(self) -> BoolArray:
        """(B,) whether each beam hit something within range."""
        return np.array([s != "" for s in self.beam_sources], dtype=bool)

    @cached_property
    def beam_reach(self) -> FloatArray:
        """(B,) horizontal distance to each beam's hit; ``range_m`` where it hit nothing (a ray
        of the cone's rim reaches ``range_m cos(spread)`` horizontally, the axis ``range_m``)."""
        flat = np.hypot(self.beam_directions[:, 0], self.beam_directions[:, 1])
        return np.where(self.beam_hits, self.beam_ranges * flat, self.range_m)

    @cached_property
    def beam_ends(self) -> FloatArray:
        """(B, 3) map points where the beams end: the hit, or the full range."""
        return np.asarray(self.own_position + self.beam_ranges[:, None] * self.beam_directions)


@dataclass(frozen=True, eq=False)
class _Targets:
    """The threats of a scenario as arrays by kind, for the beams (built once per threat
    tuple): map coordinates, each primitive's point id, its threat's id and row."""

    threats: tuple[Threat, ...]
    appears: FloatArray
    disappears: FloatArray
    sphere_c: FloatArray  # (S, 3) static centres and hill points
    sphere_r: FloatArray
    sphere_ids: tuple[str, ...]
    sphere_owner: IntArray
    cyl_c: FloatArray  # (C, 2)
    cyl_r: FloatArray
    cyl_bottom: FloatArray
    cyl_top: FloatArray
    cyl_owner: IntArray
    prism_edges: FloatArray  # (E, 4) every prism's edges
    prism_off: IntArray  # (P + 1,)
    prism_c: FloatArray  # (P, 2) centroid
    prism_r: FloatArray  # (P,) enclosing radius about it
    prism_bottom: FloatArray
    prism_top: FloatArray
    prism_owner: IntArray
    others: tuple[int, ...]  # intruders, bodies, any other kind: one by one

    @classmethod
    def of(cls, threats: tuple[Threat, ...]) -> _Targets:
        from terrain.prisms import ring_edges

        sc: list[Sequence[float]] = []
        sr: list[float] = []
        sid: list[str] = []
        so: list[int] = []
        cyl: list[tuple[float, float, float, float, float, int]] = []
        edges: list[FloatArray] = []
        prisms: list[tuple[float, float, float, float, float, int]] = []
        others: list[int] = []
        for i, th in enumerate(threats):
            if isinstance(th, StaticThreat):
                sc.append(th.center)
                sr.append(th.radius)
                sid.append(th.id)
                so.append(i)
            elif isinstance(th, HillThreat):
                for k, (c, r) in enumerate(zip(th.points, th.radii, strict=True)):
                    sc.append(c)
                    sr.append(r)
                    sid.append(f"{th.id}/{k}")
                    so.append(i)
            elif isinstance(th, CylinderThreat):
                cyl.append((*th.center, th.radius, th.bottom, th.top, i))
            elif isinstance(th, PrismThreat):
                edges.append(ring_edges(th.ring))
                prisms.append((*th.centroid, th.enclosing_radius, th.bottom, th.top, i))
            else:
                others.append(i)
        cy = np.array(cyl, dtype=np.float64).reshape(-1, 6)
        pr = np.array(prisms, dtype=np.float64).reshape(-1, 6)
        sizes = [len(e) for e in edges]
        return cls(
            threats=threats,
            appears=np.array([th.appears_at for th in threats], dtype=np.float64),
            disappears=np.array(
                [math.inf if th.disappears_at is None else th.disappears_at for th in threats],
                dtype=np.float64,
            ),
            sphere_c=np.array(sc, dtype=np.float64).reshape(-1, 3),
            sphere_r=np.array(sr, dtype=np.float64),
            sphere_ids=tuple(sid),
            sphere_owner=np.array(so, dtype=np.int64),
            cyl_c=cy[:, :2],
            cyl_r=cy[:, 2],
            cyl_bottom=cy[:, 3],
            cyl_top=cy[:, 4],
            cyl_owner=cy[:, 5].astype(np.int64),
            prism_edges=np.vstack(edges) if edges else np.zeros((0, 4)),
            prism_off=np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64),
            prism_c=pr[:, :2],
            prism_r=pr[:, 2],
            prism_bottom=pr[:, 3],
            prism_top=pr[:, 4],
            prism_owner=pr[:, 5].astype(np.int64),
            others=tuple(others),
        )


class Rangefinders:
    """Rangefinder beams with one random generator (module docstring)."""

    name = SENSOR_NAME

    def __init__(
        self,
        range_m: float = 20.0,
        period_s: float = 0.1,
        beams: int = 4,
        mount: str = "gimballed",
        noise_m: float = 0.0,
        seed: int | np.random.Generator | None = None,
        *,
        spread_deg: float = 0.0,
        terrain_cell_m: float = 1.0,
        assume_static: bool = False,
    ) -> None:
        self.range_m = sensor_number(SENSOR_NAME, "range_m", range_m, 0.0, True)
        self.period_s = sensor_number(SENSOR_NAME, "period_s", period_s, 0.0, True)
        self.noise_m = sensor_number(SENSOR_NAME, "noise_m", noise_m, 0.0, False)
        self.spread_deg = sensor_number(SENSOR_NAME, "spread_deg", spread_deg, 0.0, False)
        if self.spread_deg >= 45.0:
            raise InputError(f"rangefinder spread_deg must be below 45 deg; got {spread_deg!r}")
        self.terrain_cell_m = sensor_number(
            SENSOR_NAME, "terrain_cell_m", terrain_cell_m, 0.0, True
        )
        if isinstance(beams, bool) or not isinstance(beams, int | np.integer) or beams < 1:
            raise InputError(f"rangefinder beams must be an integer >= 1; got {beams!r}")
        if mount not in MOUNTS:
            raise InputError(f"rangefinder mount must be one of {', '.join(MOUNTS)}; got {mount!r}")
        self.beams = int(beams)
        self.mount = mount
        self.assume_static = bool(assume_static)
        self.rng, self.seed = sensor_rng(SENSOR_NAME, 0 if seed is None else seed)
        self.bearings = wrap_bearing(np.arange(self.beams) * (2.0 * np.pi / self.beams))
        self.bearings.setflags(write=False)
        self.last_scan_t: float | None = None
        self._targets: _Targets | None = None

    # -- timing -----------------------------------------------------------------------------------
    def due(self, t: float) -> bool:
        """True when no scan happened yet or ``period_s`` has passed since the last one."""
        return scan_due(self.last_scan_t, self.period_s, t)

    def reset(self) -> None:
        """Forget the scan time (the random generator runs on)."""
        self.last_scan_t = None

    # -- scanning ---------------------------------------------------------------------------------
    def directions(self, state: npt.ArrayLike | None = None) -> tuple[float, FloatArray]:
        """(yaw, unit beam directions (B, 3) in the map frame) for the vehicle ``state`` (the
        12-state NED vector; None: facing north, level)."""
        if state is None:
            phi = theta = psi = 0.0
        else:
            x = np.asarray(state, dtype=np.float64).reshape(-1)
            if x.shape != (12,) or not np.all(np.isfinite(x[[PHI, THETA, PSI]])):
                raise InputError(
                    f"rangefinder state must be the 12-state vector with finite angles; got "
                    f"shape {x.shape}"
                )
            phi, theta, psi = float(x[PHI]), float(x[THETA]), float(x[PSI])
        yaw = float(wrap_bearing(psi))
        return yaw, self._rays(phi, theta, psi, yaw)

    def _rays(
        self,
        phi: float,
        theta: float,
        psi: float,
        yaw: float,
        turns: Sequence[tuple[float, float]] = ((0.0, 0.0),),
    ) -> FloatArray:
        """(K B, 3) unit directions in the map frame of the beams' rays turned ``right`` and
        depressed by ``down`` (rad) from their axes, B rays for each of the K ``turns``
        ``(down, right)`` in turn (the cone's five at once: the same numbers)."""
        b = self.bearings + np.array([[right] for _, right in turns])  # (K, B)
        c = np.array([[math.cos(down)] for down, _ in turns])
        s = np.array([[math.sin(down)] for down, _ in turns])
        out = np.empty((*b.shape, 3))
        if self.mount == "gimballed":
            az = yaw + b
            out[..., 0] = c * np.sin(az)
            out[..., 1] = c * np.cos(az)
            out[..., 2] = -s
            return out.reshape(-1, 3)
        # FRD: x forward, y right, z down
        out[..., 0] = c * np.cos(b)
        out[..., 1] = c * np.sin(b)
        out[..., 2] = s
        rot = rotation_body_to_ned(phi, theta, psi).T
        return np.vstack([ned_to_map(body @ rot) for body in out])

    def scan(
        self,
        t: float,
        own_position: npt.ArrayLike,
        threats: Iterable[Threat],
        terrain_model: TerrainModel | None = None,
        min_clearance: float | None = None,
        state: npt.ArrayLike | None = None,
    ) -> RangefinderPicture:
        """Cast every beam now (module docstring)."""
        own = check_own_position(own_position)
        t = sensor_number(SENSOR_NAME, "scan time", t, -math.inf, False)
        yaw, dirs = self.directions(state)
        n = len(dirs)
        if self.spread_deg > 0.0:  # the axes, then the cone's rim: down, up, right, left of each
            x = np.zeros(12) if state is None else np.asarray(state, dtype=np.float64).reshape(-1)
            a = math.radians(self.spread_deg)
            turns = ((0.0, 0.0), (a, 0.0), (-a, 0.0), (0.0, a), (0.0, -a))
            dirs = self._rays(float(x[PHI]), float(x[THETA]), float(x[PSI]), yaw, turns)
        dist, labels = self._cast(t, own, dirs, threats)
        if terrain_model is not None:
            ground = terrain_model.raycast(np.broadcast_to(own, dirs.shape), dirs, self.range_m)
        else:
            ground = ray_flat_ground(dirs, float(own[2]))
        dist = np.column_stack([dist, ground])  # the terrain last: a tie goes to the threat
        best = np.argmin(dist, axis=1)
        ranges = dist[np.arange(len(dirs)), best]
        if len(dirs) > n:  # per beam the ray whose hit is nearest horizontally (axis on a tie)
            flat = np.hypot(dirs[:, 0], dirs[:, 1])
            reach = np.where(ranges <= self.range_m, ranges * flat, math.inf).reshape(-1, n)
            rim = 1 + np.argmin(reach[1:], axis=0)
            cols = np.arange(n)
            # the axis unless a rim ray is nearer by more than rounding (a wall: all alike)
            closer = reach[rim, cols] < reach[0] - TIE_M
            pick = cols + n * np.where(closer, rim, 0)
            dirs, best, ranges = dirs[pick], best[pick], ranges[pick]
        hit = ranges <= self.range_m
        if self.noise_m > 0:
            noise = self.rng.normal(0.0, self.noise_m, len(dirs))
            ranges = np.where(hit, np.clip(ranges + noise, 0.0, self.range_m), ranges)
        ranges = np.where(hit, ranges, self.range_m)
        n_lab = len(labels)
        sources = tuple(
            "" if not h else TERRAIN_SOURCE if k == n_lab else labels[k][1]
            for h, k in zip(hit.tolist(), best.tolist(), strict=True)
        )
        picture = self._picture(t, own, yaw, dirs, ranges, sources, best, labels)
        self.last_scan_t = t
        return picture

    def _cast(
        self, t: float, own: FloatArray, dirs: FloatArray, threats: Iterable[Threat]
    ) -> tuple[FloatArray, list[tuple[str, str, bool]]]:
        """Distances (B, M) of the beams to the M candidate primitives within reach, and each
        one's (point id, threat id, extended)."""
        tg = self._table(threats)
        on = (tg.appears <= t) & (t < tg.disappears)
        reach = self.range_m
        cols: list[FloatArray] = []
        labels: list[tuple[str, str, bool]] = []
        ths = tg.threats
        if len(tg.sphere_r):
            c = tg.sphere_c - own
            near = on[tg.sphere_owner] & (np.linalg.norm(c, axis=1) - tg.sphere_r <= reach)
            k = np.flatnonzero(near)
            if k.size:
                cols.append(ray_spheres(dirs, c[k], tg.sphere_r[k]))
                labels += [(tg.sphere_ids[i], ths[tg.sphere_owner[i]].id, False) for i in k]
        if len(tg.cyl_r):
            c = tg.cyl_c - own[:2]
            near = on[tg.cyl_owner] & (np.hypot(c[:, 0], c[:, 1]) - tg.cyl_r <= reach)
            k = np.flatnonzero(near)
            if k.size:
                z = own[2]
                cols.append(
                    ray_cylinders(dirs, c[k], tg.cyl_r[k], tg.cyl_bottom[k] - z, tg.cyl_top[k] - z)
                )
                labels += [(ths[tg.cyl_owner[i]].id,) * 2 + (True,) for i in k]
        if len(tg.prism_r):
            c = tg.prism_c - own[:2]
            near = on[tg.prism_owner] & (np.hypot(c[:, 0], c[:, 1]) - tg.prism_r <= reach)
            k = np.flatnonzero(near)
            if k.size:
                off = tg.prism_off
                idx = np.concatenate([np.arange(off[i], off[i + 1]) for i in k])
                sizes = off[k + 1] - off[k]
                edges = tg.prism_edges[idx] - np.tile(own[:2], 2)
                z = own[2]
                cols.append(
                    ray_prisms(
                        dirs,
                        edges,
                        np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64),
                        tg.prism_bottom[k] - z,
                        tg.prism_top[k] - z,
                    )
                )
                labels += [(ths[tg.prism_owner[i]].id,) * 2 + (True,) for i in k]
        for i in tg.others:
            th = ths[i]
            if not on[i]:
                continue
            col = self._other(th, t, own, dirs)
            if col is not None:
                cols.append(col[:, None])
                labels.append((th.id, th.id, bool(th.extended)))
        dist = np.hstack(cols) if cols else np.zeros((len(dirs), 0))
        return dist, labels

    def _other(self, th: Threat, t: float, own: FloatArray, dirs: FloatArray) -> FloatArray | None:
        """(B,) distances to an intruder, a body or any other kind (None when out of reach)."""
        reach = self.range_m
        if isinstance(th, IntruderThreat):
            c = th.position(t) - own
            if float(np.linalg.norm(c)) - th.radius > reach:
                return None
            return ray_spheres(dirs, c[None, :], np.array([th.radius]))[:, 0]
        if isinstance(th, BodyThreat):
            c = np.asarray(th.center, dtype=np.float64) - own
            ax = np.asarray(th.axes, dtype=np.float64)
            if float(np.linalg.norm(c) - np.linalg.norm(ax)) > reach:
                return None
            powers = 2.0 * np.asarray(th.exponents, dtype=np.float64)
            return ray_superellipsoid(dirs, c, ax, powers, reach)

        def separation(p: FloatArray) -> FloatArray:
            return np.asarray(th.separation(p + own, t), dtype=np.float64)

        return ray_separation(dirs, separation, reach)

    def _table(self, threats: Iterable[Threat]) -> _Targets:
        seq = threats if isinstance(threats, tuple) else tuple(threats)
        cached = self._targets
        if cached is not None and (cached.threats is seq or cached.threats == seq):
            return cached
        self._targets = _Targets.of(seq)
        return self._targets

    def _picture(
        self,
        t: float,
        own: FloatArray,
        yaw: float,
        dirs: FloatArray,
        ranges: FloatArray,
        sources: tuple[str, ...],
        best: IntArray,
        labels: list[tuple[str, str, bool]],
    ) -> RangefinderPicture:
        """The picture: every beam, and the hitting beams as radar returns."""
        pts = own + ranges[:, None] * dirs
        beam_threat = [j for j, s in enumerate(sources) if s and s != TERRAIN_SOURCE]
        beam_ground = np.array([j for j, s in enumerate(sources) if s == TERRAIN_SOURCE], int)
        ids = tuple(f"{labels[best[j]][0]}#beam{j}" for j in beam_threat)
        srcs = tuple(sources[j] for j in beam_threat)
        ext = [labels[best[j]][2] for j in beam_threat]
        cells = np.zeros((0, 2), dtype=np.int64)
        if beam_ground.size:
            cells = np.floor(pts[beam_ground, :2] / self.terrain_cell_m).astype(np.int64)
            order = np.lexsort((ranges[beam_ground], cells[:, 1], cells[:, 0]))
            cells, beam_ground = cells[order], beam_ground[order]
            first = np.ones(len(cells), dtype=bool)
            first[1:] = np.any(cells[1:] != cells[:-1], axis=1)
            keep = np.sort(np.flatnonzero(first).astype(np.int64), kind="stable")
            back = np.argsort(beam_ground[keep], kind="stable")  # beam order again
            cells, beam_ground = cells[keep][back], beam_ground[keep][back]
        rows = np.concatenate([np.array(beam_threat, dtype=np.int64), beam_ground])
        positions = pts[rows]
        d = positions - own
        horiz = np.hypot(d[:, 0], d[:, 1])
        code = np.zeros(len(rows), dtype=np.int8)
        if not self.assume_static:
            code[: len(beam_threat)] = -1
        return RangefinderPicture(
            t=float(t),
            own_position=own.copy(),
            threat_ids=ids,
            threat_sources=srcs,
            terrain_cells=cells,
            positions=positions,
            ranges=ranges[rows].copy(),
            bearings=course_of(d[:, 0], d[:, 1]),
            elevations=np.arctan2(d[:, 2], horiz),
            moving_code=code,
            extended=np.concatenate([np.array(ext, dtype=bool), np.zeros(len(cells), bool)]),
            yaw=yaw,
            range_m=self.range_m,
            beam_bearings=self.bearings.copy(),
            beam_courses=wrap_bearing(yaw + self.bearings),
            beam_ranges=ranges,
            beam_sources=sources,
            beam_directions=dirs,
        )
