"""The threats of one replay as arrays, by kind: what the radar scan and the separation metrics
ask of every threat at once.

A Table 6 scenario of seed 000 has 100 static threats, scanned 28 800 times (1 Hz for 8 hours),
and the separation to each of them is measured at every trajectory sample.  Asking the threat
objects one by one costs tens of microseconds each, per scan and per batch of samples; a
:class:`ThreatTable` asks them once and keeps, for each kind that has a closed form, one array:

- every threat: activity window (``appears_at <= t < disappears_at``, :meth:`active`),
  whether it moves (:attr:`moving`);
- ``static``: centres and radii;
- ``hill``: all points of all hills in one array, with their owner and index in the hill;
- ``cylinder``: centres, radii, tops and bottoms;
- ``intruder`` with a constant velocity: start, velocity, start and stop times.

Bodies (an iterative nearest-point solver), intruders on waypoint routes and any other
:class:`~replay.threats.Threat` are asked one by one through their own methods (they are rare).
Only the exact classes are put in arrays; a subclass of a kind is asked through its methods.

Every array operation is the threat's own formula applied elementwise (same operations in the
same order), so the results are bit for bit those of the threat objects:
:meth:`radar_points` returns the points :meth:`Threat.radar_points` would, within range, in threat
order (a hill's points in their order), and :meth:`separations` the values of
:meth:`Threat.separation` where the threat is active.  ``tests/test_threat_table.py`` compares
both with the threat-by-threat reference on random scenes of every kind.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, TypeVar, cast

import numpy as np
import numpy.typing as npt

from replay.threats import CylinderThreat, HillThreat, IntruderThreat, StaticThreat, Threat

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]
T = TypeVar("T", bound=Threat)


def _index(items: Sequence[int]) -> IntArray:
    return np.array(items, dtype=np.int64).reshape(-1)


def _floats(values: Sequence[Any], *shape: int) -> FloatArray:
    return np.array(values, dtype=np.float64).reshape(len(values), *shape)


def _of_kind(threats: Sequence[Threat], cls: type[T]) -> tuple[list[int], list[T]]:
    """Positions and threats of exactly the class ``cls`` (not its subclasses)."""
    rows = [i for i, th in enumerate(threats) if type(th) is cls]
    return rows, [cast(T, threats[i]) for i in rows]


class ThreatTable:
    """The threats ``threats`` (in their order) as arrays by kind; see the module docstring."""

    def __init__(self, threats: Sequence[Threat]) -> None:
        ths = tuple(threats)
        self.threats = ths
        self.ids = tuple(th.id for th in ths)
        self.appears = _floats([th.appears_at for th in ths])
        self.disappears = _floats(
            [math.inf if th.disappears_at is None else th.disappears_at for th in ths]
        )
        self.moving = np.array([bool(getattr(th, "moving", False)) for th in ths], dtype=bool)
        self.extended = np.array([th.extended for th in ths], dtype=bool)

        st, stat = _of_kind(ths, StaticThreat)
        self._st = _index(st)
        self._st_c = _floats([s.center for s in stat], 3)
        self._st_r = _floats([s.radius for s in stat])

        hl, hills = _of_kind(ths, HillThreat)
        counts = [len(h.points) for h in hills]
        self._hl = _index(hl)
        self._hl_p = _floats([p for h in hills for p in h.points], 3)
        self._hl_r = _floats([r for h in hills for r in h.radii])
        self._hl_owner = np.repeat(self._hl, counts).astype(np.int64)
        self._hl_k = _index([k for c in counts for k in range(c)])
        self._hl_ids = [f"{h.id}/{k}" for h, c in zip(hills, counts, strict=True) for k in range(c)]

        cy, cyl = _of_kind(ths, CylinderThreat)
        self._cy = _index(cy)
        self._cy_c = _floats([c.center for c in cyl], 2)
        self._cy_r = _floats([c.radius for c in cyl])
        self._cy_top = _floats([c.top for c in cyl])
        self._cy_bottom = _floats([c.bottom for c in cyl])

        iv, intr = _of_kind(ths, IntruderThreat)
        iv = [i for i, it in zip(iv, intr, strict=True) if it.velocity_mps is not None]
        intr = [it for it in intr if it.velocity_mps is not None]
        self._iv = _index(iv)
        self._iv_start = _floats([it.start for it in intr], 3)
        self._iv_vel = _floats([it.velocity_mps for it in intr], 3)
        self._iv_t0 = _floats([it.appears_at for it in intr])
        self._iv_stop = _floats([math.inf if it.stops_at is None else it.stops_at for it in intr])
        self._iv_r = _floats([it.radius for it in intr])

        arrayed = {*st, *hl, *cy, *iv}
        self._other = [i for i in range(len(ths)) if i not in arrayed]

    def __len__(self) -> int:
        return len(self.threats)

    # -- activity -------------------------------------------------------------------------------
    def active(self, t: float) -> BoolArray:
        """Which threats are active at time t (n,), as :meth:`Threat.active`."""
        return np.asarray((t >= self.appears) & (t < self.disappears))

    def active_at(self, ts: FloatArray) -> BoolArray:
        """Which threats are active at each time (k, n)."""
        col = np.asarray(ts, dtype=np.float64)[:, None]
        return np.asarray((col >= self.appears) & (col < self.disappears))

    # -- radar ----------------------------------------------------------------------------------
    def radar_points(
        self, t: float, own: FloatArray, max_range: float
    ) -> tuple[list[str], list[str], FloatArray, BoolArray]:
        """The radar's candidate returns at time t from ``own``: (ids, sources, points (N, 3),
        extended (N,)) of the points of active threats within ``max_range`` (3D), in threat
        order -- :meth:`Threat.radar_points` of each active threat, range-tested."""
        act = self.active(t)
        blocks: list[tuple[IntArray, IntArray, list[str], FloatArray]] = []

        def block(rows: IntArray, k: IntArray, ids: list[str], pts: FloatArray) -> None:
            near = np.flatnonzero(np.linalg.norm(pts - own, axis=-1) <= max_range)
            if len(near):
                blocks.append((rows[near], k[near], [ids[j] for j in near.tolist()], pts[near]))

        if len(self._st):
            on = np.flatnonzero(act[self._st])
            rows = self._st[on]
            block(rows, np.zeros(len(on), np.int64), [self.ids[i] for i in rows], self._st_c[on])
        if len(self._hl_p):
            on = np.flatnonzero(act[self._hl_owner])
            ids = [self._hl_ids[j] for j in on.tolist()]
            block(self._hl_owner[on], self._hl_k[on], ids, self._hl_p[on])
        if len(self._cy):
            on = np.flatnonzero(act[self._cy])
            if len(on):
                rows = self._cy[on]
                pts = self._cylinder_nearest(own, on)
                block(rows, np.zeros(len(on), np.int64), [self.ids[i] for i in rows], pts)
        if len(self._iv):
            on = np.flatnonzero(act[self._iv])
            if len(on):
                rows = self._iv[on]
                pts = self._intruder_positions(np.array(t, dtype=np.float64), on)
                block(rows, np.zeros(len(on), np.int64), [self.ids[i] for i in rows], pts)
        for i in self._other:
            if act[i]:
                tids, tp = self.threats[i].radar_points(t, own, max_range)
                block(np.full(len(tp), i, np.int64), np.arange(len(tp)), list(tids), tp)
        return self._merge(blocks)

    def _merge(
        self, blocks: list[tuple[IntArray, IntArray, list[str], FloatArray]]
    ) -> tuple[list[str], list[str], FloatArray, BoolArray]:
        if not blocks:
            return [], [], np.zeros((0, 3)), np.zeros(0, dtype=bool)
        if len(blocks) == 1:
            rows, _, ids, pts = blocks[0]
        else:
            rows = np.concatenate([b[0] for b in blocks])
            order = np.lexsort((np.concatenate([b[1] for b in blocks]), rows))
            every = [i for b in blocks for i in b[2]]
            ids = [every[j] for j in order.tolist()]
            pts = np.concatenate([b[3] for b in blocks])[order]
            rows = rows[order]
        sources = [self.ids[i] for i in rows.tolist()]
        return ids, sources, pts, self.extended[rows]

    def _cylinder_nearest(self, own: FloatArray, on: IntArray) -> FloatArray:
        """:meth:`CylinderThreat.nearest_point` of ``own`` for the cylinders ``on``."""
        cx, cy = self._cy_c[on, 0], self._cy_c[on, 1]
        radius = self._cy_r[on]
        q = np.empty((len(on), 3))
        dx, dy = own[0] - cx, own[1] - cy
        rho = np.hypot(dx, dy)
        scale = np.where(rho > radius, radius / np.where(rho > 0, rho, 1.0), 1.0)
        q[:, 0] = cx + dx * scale
        q[:, 1] = cy + dy * scale
        q[:, 2] = np.clip(own[2], self._cy_bottom[on], self._cy_top[on])
        return q

    def _intruder_positions(self, ts: FloatArray, on: IntArray) -> FloatArray:
        """:meth:`IntruderThreat.position` at time(s) ts (...) of the constant-velocity intruders
        ``on``: ts.shape + (len(on), 3)."""
        t0 = self._iv_t0[on]
        dt = np.clip(ts[..., None], t0, self._iv_stop[on]) - t0
        return np.asarray(self._iv_start[on] + dt[..., None] * self._iv_vel[on])

    # -- separation -----------------------------------------------------------------------------
    def separations(self, positions: FloatArray, ts: FloatArray) -> tuple[list[str], FloatArray]:
        """Separation of the samples (positions (k, 3) at times ts (k,)) from every threat active
        at one of them at least: (ids, values (k, m)) in threat order, +inf where the threat is
        not active -- :meth:`Threat.separation` where it is."""
        pos = np.asarray(positions, dtype=np.float64)
        ts = np.asarray(ts, dtype=np.float64)
        active = self.active_at(ts)
        live: BoolArray = np.asarray(active.any(axis=0))
        out = np.full(active.shape, math.inf)

        def fill(rows: IntArray, values: FloatArray) -> None:
            out[:, rows] = values

        if len(self._st):
            on = np.flatnonzero(live[self._st])
            if len(on):
                d = np.linalg.norm(pos[:, None, :] - self._st_c[on], axis=-1)
                fill(self._st[on], d - self._st_r[on])
        if len(self._hl):
            on = np.flatnonzero(live[self._hl])
            if len(on):
                pts = np.flatnonzero(live[self._hl_owner])
                d = np.linalg.norm(pos[:, None, :] - self._hl_p[pts], axis=-1) - self._hl_r[pts]
                counts = np.bincount(self._hl_owner[pts], minlength=len(self.threats))
                starts = np.concatenate([[0], np.cumsum(counts[self._hl[on]])[:-1]])
                fill(self._hl[on], np.minimum.reduceat(d, starts, axis=1))
        if len(self._cy):
            on = np.flatnonzero(live[self._cy])
            if len(on):
                fill(self._cy[on], self._cylinder_separation(pos, on))
        if len(self._iv):
            on = np.flatnonzero(live[self._iv])
            if len(on):
                d = pos[:, None, :] - self._intruder_positions(ts, on)
                fill(self._iv[on], np.linalg.norm(d, axis=-1) - self._iv_r[on])
        for i in self._other:
            if live[i]:
                out[:, i] = self.threats[i].separation(pos, ts)
        seps = np.where(active, out, math.inf)
        keep = np.flatnonzero(np.isfinite(seps).any(axis=0))
        return [self.ids[i] for i in keep.tolist()], seps[:, keep]

    def _cylinder_separation(self, q: FloatArray, on: IntArray) -> FloatArray:
        """:meth:`CylinderThreat.separation` of points q (k, 3) from the cylinders ``on``."""
        cx, cy = self._cy_c[on, 0], self._cy_c[on, 1]
        dr = np.hypot(q[:, 0, None] - cx, q[:, 1, None] - cy) - self._cy_r[on]
        z = q[:, 2, None]
        dz = np.maximum(self._cy_bottom[on] - z, z - self._cy_top[on])
        both = (dr > 0) & (dz > 0)
        return np.asarray(
            np.where(both, np.hypot(np.maximum(dr, 0), np.maximum(dz, 0)), np.maximum(dr, dz))
        )
