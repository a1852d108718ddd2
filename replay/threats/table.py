"""The threats of one replay as arrays, by kind: what the radar scan and the separation metrics
ask of every threat at once.

A Table 6 scenario of seed 000 has 100 static threats, scanned 28 800 times (1 Hz for 8 hours),
and the separation to each of them is measured at every trajectory sample.  Asking the threat
objects one by one costs Python calls and small numpy operations per threat, per scan and per
batch of samples; a :class:`ThreatTable` asks them once and keeps, for each kind that has a
closed form, one array (``benchmarks/bench_replay.py obstacles`` measures the difference):

- every threat: activity window (``appears_at <= t < disappears_at``, :meth:`active`),
  whether it moves (:attr:`moving`);
- ``static``: centres and radii;
- ``hill``: all points of all hills in one array, with their owner and index in the hill;
- ``cylinder``: centres, radii, tops and bottoms;
- ``intruder`` with a constant velocity: start, velocity, start and stop times.

Bodies (an iterative nearest-point solver), prisms (a polygon each), intruders on waypoint
routes and any other :class:`~replay.threats.kinds.Threat` are asked one by one through their own
methods (they are rare; the 143 buildings of ``data/scenarios/bubenec-buildings.yaml`` cost
about 0.3 s per 1000 samples of separations and 20 ms per radar scan, one prism at a time).
Only the exact classes are put in arrays; a subclass of a kind is asked through its methods.

The radar asks the fixed points (static threats, hills' points) near the aircraft only
(:class:`replay.threats.index.NearIndex`), and keeps its answer while the aircraft cannot have
moved a point across the range edge (``_Points.seen``); the simulation's judge asks the
separations of the threats that can matter to a batch of samples
(:class:`replay.threats.book.SeparationBook`, :meth:`separation_columns` with ``only``).

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

from replay.threats.index import NearIndex
from replay.threats.kinds import (
    EDGE_SUFFIXES,
    CylinderThreat,
    HillThreat,
    IntruderThreat,
    StaticThreat,
    Threat,
    circle_edges,
    sized_radius,
    solid_separation,
)

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]
T = TypeVar("T", bound=Threat)
_BLOCK = 16384  # numbers per temporary array of the separations (128 KiB)
_HELD_SLACK_M = 1e-3  # a held radar answer's reach is this much shorter: rounding


def _index(items: Sequence[int]) -> IntArray:
    return np.array(items, dtype=np.int64).reshape(-1)


def _floats(values: Sequence[Any], *shape: int) -> FloatArray:
    return np.array(values, dtype=np.float64).reshape(len(values), *shape)


def _of_kind(threats: Sequence[Threat], cls: type[T]) -> tuple[list[int], list[T]]:
    """Positions and threats of exactly the class ``cls`` (not its subclasses)."""
    rows = [i for i, th in enumerate(threats) if type(th) is cls]
    return rows, [cast(T, threats[i]) for i in rows]


def norm3(dx: FloatArray, dy: FloatArray, dz: FloatArray) -> FloatArray:
    """Euclidean norm from the components: ``sqrt((dx^2 + dy^2) + dz^2)``, the operations of
    ``numpy.linalg.norm(d, axis=-1)`` over d = (dx, dy, dz) in the same order (so the same bits;
    the tests check it), without the (..., 3) temporaries and the reduction over a short axis.
    Works in place: ``dx`` is overwritten with the result, ``dy`` and ``dz`` with their squares."""
    out = np.multiply(dx, dx, out=dx)
    out += np.multiply(dy, dy, out=dy)
    out += np.multiply(dz, dz, out=dz)
    return np.asarray(np.sqrt(out, out=out))


class _Points:
    """Points of one kind as component arrays: x, y, z (P,), the threat row of each point,
    its index within the threat, its id and radius, and its threat's activity window."""

    def __init__(
        self,
        table: ThreatTable,
        rows: Sequence[int],
        points: Sequence[Any],
        radii: Sequence[float],
        ids: Sequence[str],
        index: Sequence[int],
    ) -> None:
        p = _floats(points, 3)
        self.x, self.y, self.z = (np.ascontiguousarray(p[:, j]) for j in range(3))
        self.xyz = p
        self.columns = np.ascontiguousarray(p.T)  # (3, P): x, y, z rows
        self.r = _floats(radii)
        self.rows = _index(rows)
        self.k = _index(index)
        self.ids = list(ids)
        self.t0 = table.appears[self.rows]
        self.t1 = table.disappears[self.rows]
        # no windows: every point is active from t = 0 on (appears_at is >= 0)
        self.always = bool(np.all(self.t0 == 0.0) and np.all(np.isinf(self.t1)))
        # the points near the aircraft (replay.threats.index), and their columns and windows
        self.index = NearIndex(p)
        self._near_columns, self._near_t0, self._near_t1 = self.columns, self.t0, self.t1
        # the last answer of :meth:`seen` and where it holds: (x, y, z, t, t_until, gap^2,
        # max_range), the aircraft within gap of (x, y, z) and t <= time < t_until
        self._held: tuple[float, ...] | None = None
        self._hit = np.zeros(0, dtype=np.int64)

    def __len__(self) -> int:
        return len(self.rows)

    def seen(self, t: float, own: FloatArray, max_range: float) -> IntArray:
        """Points active at t within ``max_range`` of ``own``: the same array object as the
        last call's while the answer cannot have changed.

        Only the points the index keeps near ``own`` are measured (the others are farther).
        Each measured point's range changes no faster than the aircraft moves, so the answer
        holds while the aircraft stays within the smallest ``|range - max_range|`` of where it
        was measured (and within the index's reach), and no activity window opens or closes."""
        x, y, z = float(own[0]), float(own[1]), float(own[2])
        h = self._held
        if (
            h is not None
            and h[6] == max_range
            and h[3] <= t < h[4]
            and (x - h[0]) ** 2 + (y - h[1]) ** 2 + (z - h[2]) ** 2 < h[5]
        ):
            return self._hit
        near, fresh = self.index.near(own, max_range)
        if fresh:
            self._near_columns = np.ascontiguousarray(self.columns[:, near])
            self._near_t0, self._near_t1 = self.t0[near], self.t1[near]
        self._held = None
        if not len(near):
            hit = near
            gap = self.index.margin(own)
        else:
            dx, dy, dz = self._near_columns - own[:, None]
            d = norm3(dx, dy, dz)
            if self.always:
                hit = np.flatnonzero(d <= max_range) if t >= 0.0 else np.zeros(0, np.int64)
            else:
                hit = np.flatnonzero((d <= max_range) & (t >= self._near_t0) & (t < self._near_t1))
            if len(near) != len(self.rows):
                hit = near[hit]
            gap = min(float(np.abs(d - max_range).min()), self.index.margin(own))
        gap -= _HELD_SLACK_M
        if gap > 0.0 and t >= 0.0:
            until = math.inf
            if not self.always:
                t0, t1 = self._near_t0, self._near_t1
                until = float(
                    min(t0[t0 > t].min(initial=math.inf), t1[t1 > t].min(initial=math.inf))
                )
            self._held = (x, y, z, t, until, gap * gap, max_range)
        self._hit = hit
        return hit

    def seen_all(self, t: float, own: FloatArray, max_range: float) -> IntArray:
        """:meth:`seen` testing every point (the reference the tests compare it with)."""
        dx, dy, dz = self.columns - own[:, None]
        d = norm3(dx, dy, dz)
        if self.always:
            return np.flatnonzero(d <= max_range) if t >= 0.0 else np.zeros(0, np.int64)
        return np.flatnonzero((d <= max_range) & (t >= self.t0) & (t < self.t1))

    def distances(self, pos: FloatArray, on: IntArray) -> FloatArray:
        """Distance (k, len(on)) of positions (k, 3) from the surfaces of the spheres ``on``."""
        x, y, z = pos[:, 0, None], pos[:, 1, None], pos[:, 2, None]
        d = norm3(x - self.x[on], y - self.y[on], z - self.z[on])
        d -= self.r[on]
        return d


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
        # the radius the radar measures of each threat it sees as a sphere (``solid``)
        self.sized = {th.id: r for th in ths if (r := sized_radius(th)) is not None}

        st, stat = _of_kind(ths, StaticThreat)
        self._static = _Points(
            self,
            st,
            [s.center for s in stat],
            [s.radius for s in stat],
            [s.id for s in stat],
            [0] * len(st),
        )

        hl, hills = _of_kind(ths, HillThreat)
        counts = [len(h.points) for h in hills]
        self._hills = _Points(
            self,
            [i for i, c in zip(hl, counts, strict=True) for _ in range(c)],
            [p for h in hills for p in h.points],
            [r for h in hills for r in h.radii],
            [f"{h.id}/{k}" for h, c in zip(hills, counts, strict=True) for k in range(c)],
            [k for c in counts for k in range(c)],
        )
        self._hl = _index(hl)

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
        self._static_only = len(st) == len(ths) > 0
        # the static returns of the last radar_points: (the seen rows, ids, points)
        self._static_returns: tuple[IntArray, list[str], FloatArray] | None = None
        # the kinds in arrays have a separation 1-Lipschitz in position (a signed distance to
        # spheres or a cylinder) and centres that move at most ``speed`` m/s
        # (replay.threats.book bounds a batch of samples with it)
        self.bounded = np.zeros(len(ths), dtype=bool)
        self.bounded[list(arrayed)] = True
        self.speed = np.zeros(len(ths))
        self.speed[self._iv] = np.linalg.norm(self._iv_vel, axis=-1).reshape(-1)

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
        if self._static_only:  # a static threat's one return is named after it
            hit = self._static.seen(t, own, max_range)
            last = self._static_returns
            if last is None or last[0] is not hit:
                ids = [self._static.ids[j] for j in hit.tolist()]
                last = self._static_returns = (hit, ids, self._static.xyz[hit])
            _, ids, xyz = last  # the same points (read-only) while the same are seen
            return list(ids), list(ids), xyz, np.zeros(len(ids), dtype=bool)
        blocks: list[tuple[IntArray, IntArray, list[str], FloatArray]] = []
        for kind in (self._static, self._hills):
            if len(kind):
                hit = kind.seen(t, own, max_range)
                if len(hit):
                    ids = [kind.ids[j] for j in hit.tolist()]
                    blocks.append((kind.rows[hit], kind.k[hit], ids, kind.xyz[hit]))
        act = self.active(t) if len(self._cy) or len(self._iv) or self._other else None

        def block(rows: IntArray, k: IntArray, ids: list[str], pts: FloatArray) -> None:
            near = np.flatnonzero(np.linalg.norm(pts - own, axis=-1) <= max_range)
            if len(near):
                blocks.append((rows[near], k[near], [ids[j] for j in near.tolist()], pts[near]))

        if act is not None and len(self._cy):
            on = np.flatnonzero(act[self._cy])
            if len(on):
                rows = self._cy[on]
                pts = self._cylinder_nearest(own, on)
                block(rows, np.zeros(len(on), np.int64), [self.ids[i] for i in rows], pts)
                # the outline's edges (CylinderThreat.radar_points)
                for k, (j, row) in enumerate(zip(on.tolist(), rows.tolist(), strict=True)):
                    c = (float(self._cy_c[j, 0]), float(self._cy_c[j, 1]))
                    edges = circle_edges(own, c, float(self._cy_r[j]), float(pts[k, 2]))
                    if edges is not None:
                        block(
                            np.full(2, row, np.int64),
                            np.arange(1, 3),
                            [self.ids[row] + s for s in EDGE_SUFFIXES],
                            edges,
                        )
        if act is not None and len(self._iv):
            on = np.flatnonzero(act[self._iv])
            if len(on):
                rows = self._iv[on]
                pts = self._intruder_positions(np.array(t, dtype=np.float64), on)
                block(rows, np.zeros(len(on), np.int64), [self.ids[i] for i in rows], pts)
        for i in self._other:
            if act is not None and act[i]:
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
        """Separation of the samples (positions (k, 3) at increasing times ts (k,)) from every
        threat active at one of them at least: (ids, values (k, m)) in threat order, +inf where
        the threat is not active -- :meth:`Threat.separation` where it is.

        An activity window is an interval, so a threat active at the first and the last sample
        is active at all of them; the others are masked sample by sample.  The kinds in arrays
        are computed a block of samples at a time (temporaries of ``_BLOCK`` numbers, which stay
        in cache); the others in one call over all the samples, as before."""
        cols, out = self.separation_columns(positions, ts)
        return [self.ids[i] for i in cols.tolist()], out

    def separation_columns(
        self, positions: FloatArray, ts: FloatArray, only: BoolArray | None = None
    ) -> tuple[IntArray, FloatArray]:
        """:meth:`separations` as (threat rows, values (k, m)), of the threats ``only`` (n,)
        marks (every threat when None): each column is the one :meth:`separations` gives."""
        pos = np.asarray(positions, dtype=np.float64)
        ts = np.asarray(ts, dtype=np.float64)
        k, n = len(ts), len(self.threats)
        none = np.zeros(0, dtype=np.int64)
        if not n or not k:
            return none, np.zeros((k, 0))
        whole = self.active(float(ts[0])) & self.active(float(ts[-1]))
        inside = (self.appears <= ts[-1]) & (self.disappears > ts[0])
        if only is not None:
            whole &= only
            inside &= only
        part = np.flatnonzero(~whole & inside)
        mask = (ts[:, None] >= self.appears[part]) & (ts[:, None] < self.disappears[part])
        live = whole.copy()
        live[part] = mask.any(axis=0)
        cols = np.flatnonzero(live)
        if not len(cols):
            return none, np.zeros((k, 0))
        column = np.full(n, -1, dtype=np.int64)
        column[cols] = np.arange(len(cols))
        out = np.empty((k, len(cols)))
        st = np.flatnonzero(live[self._static.rows])
        hl = np.flatnonzero(live[self._hills.rows])
        first = np.flatnonzero(np.diff(self._hills.rows[hl], prepend=-1))  # each hill's first
        cy = np.flatnonzero(live[self._cy])
        iv = np.flatnonzero(live[self._iv])
        step = max(1, _BLOCK // len(cols))
        for a in range(0, k, step):
            b = min(a + step, k)
            p = pos[a:b]
            if len(st):
                out[a:b, column[self._static.rows[st]]] = self._static.distances(p, st)
            if len(hl):  # a hill: the nearest of its spheres (its points are consecutive)
                d = self._hills.distances(p, hl)
                out[a:b, column[self._hills.rows[hl[first]]]] = np.minimum.reduceat(d, first, 1)
            if len(cy):
                out[a:b, column[self._cy[cy]]] = self._cylinder_separation(p, cy)
            if len(iv):
                q = self._intruder_positions(ts[a:b], iv)
                x, y, z = p[:, 0, None], p[:, 1, None], p[:, 2, None]
                d = norm3(x - q[..., 0], y - q[..., 1], z - q[..., 2])
                d -= self._iv_r[iv]
                out[a:b, column[self._iv[iv]]] = d
        for i in self._other:
            if live[i]:
                out[:, column[i]] = self.threats[i].separation(pos, ts)
        if len(part):
            on = live[part]
            c = column[part[on]]
            out[:, c] = np.where(mask[:, on], out[:, c], math.inf)
        finite = np.isfinite(out).any(axis=0)
        if not finite.all():
            cols, out = cols[finite], out[:, finite]
        return cols, out

    def _cylinder_separation(self, q: FloatArray, on: IntArray) -> FloatArray:
        """:meth:`CylinderThreat.separation` of points q (k, 3) from the cylinders ``on``."""
        cx, cy = self._cy_c[on, 0], self._cy_c[on, 1]
        dr = np.hypot(q[:, 0, None] - cx, q[:, 1, None] - cy) - self._cy_r[on]
        z = q[:, 2, None]
        dz = np.maximum(self._cy_bottom[on] - z, z - self._cy_top[on])
        return solid_separation(dr, dz)
