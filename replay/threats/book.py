"""Separation bookkeeping that scales with the threats near the aircraft (issue 38): which
threats' separations a batch of trajectory samples must measure now, and the smallest
separation from each of the others, found once the flight is over.

The judge (:class:`replay.metrics.MetricsTracker`) needs, of each threat: its smallest
separation over the flight and the first time of it; every sample below the success margin
(violations); and, for the recording, the few nearest threats at each recorded sample.  Measuring
every threat at every sample (``ThreatTable.separations``) costs samples x threats; most threats
are kilometres away and change nothing a batch judges.

For a batch of samples :class:`SeparationBook` takes the sphere (centre q, radius rho) round them
and, for each threat whose separation is 1-Lipschitz in position and known in closed form
(static spheres, hills, cylinders; constant-velocity intruders, whose centre moves at most
``|v| * span / 2`` from where it is at the batch's middle time), the separation s at q: every
sample's separation lies in [s - rho - motion, s + rho + motion] (``SLACK_M`` wider, for
rounding).  A threat is measured exactly on the batch (:meth:`SeparationBook.batch`) when that
interval reaches below the margin (a violation may begin), when it is inside the margin already,
when its activity window begins or ends within the batch, when its kind has no bound (bodies,
prisms, intruders on routes: few), or -- with ``nearest`` -- when it may be one of the
``nearest`` threats of a sample.  The others are put off: the batch keeps its samples and
each put-off threat's lower bound; the upper bounds give, per threat, a value its smallest
separation cannot exceed.  :meth:`SeparationBook.lowest` then measures each put-off threat
exactly on the batches whose lower bound does not exceed that value -- the only ones that can
hold its smallest separation, a few per threat -- so the (value, first time) it returns is what
measuring every sample gives, bit for bit (the same formula on the same samples; the tests
compare both on random scenes of every kind).
"""

from __future__ import annotations

import math
from collections.abc import Collection

import numpy as np
import numpy.typing as npt

from replay.threats.table import ThreatTable

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]

SLACK_M = 1e-3  # widening of every bound: a map's distances are exact to ~1e-9 m


class SeparationBook:
    """The separation bookkeeping of one replay's threats (``table``), batch by batch; see the
    module docstring.  ``margin``: the success margin (a sample below it is a violation)."""

    def __init__(self, table: ThreatTable, margin: float = 0.0) -> None:
        self.table = table
        self.margin = float(margin)
        n = len(table)
        self.bounded, self.speed = table.bounded, table.speed  # closed-form bounds, motion
        self.row = {tid: i for i, tid in enumerate(table.ids)}
        self.upper = np.full(n, math.inf)  # the smallest separation is at most this
        self._batches: list[tuple[FloatArray, FloatArray, FloatArray]] = []  # ts, pos, lower
        self.measured = 0  # threat-batches measured exactly (for the benchmarks)

    def batch(
        self,
        ts: FloatArray,
        pos: FloatArray,
        inside: Collection[str] = (),
        nearest: int = 0,
    ) -> tuple[list[str], FloatArray]:
        """The separations (ids, values (k, m)) of the samples ``pos`` (k, 3) at times ``ts``
        (k,, increasing) from the threats that must be measured now (module docstring), in
        threat order -- each column the one ``ThreatTable.separations`` gives.  ``inside``: the
        ids of the threats inside the margin at the end of the previous batch; ``nearest``: the
        number of nearest threats wanted at every sample (0: none)."""
        table = self.table
        ts = np.asarray(ts, dtype=np.float64)
        pos = np.asarray(pos, dtype=np.float64)
        n = len(table)
        if not n or not len(ts):
            return [], np.zeros((len(ts), 0))
        ta, tb = float(ts[0]), float(ts[-1])
        whole = table.active(ta) & table.active(tb)
        never = (table.appears > tb) | (table.disappears <= ta)
        lo, hi = pos.min(axis=0), pos.max(axis=0)
        q = 0.5 * (lo + hi)
        rho = float(np.sqrt(((pos - q) ** 2).sum(axis=1).max()))
        tm = 0.5 * (ta + tb)
        lower = np.full(n, math.inf)
        upper = np.full(n, math.inf)
        cheap = self.bounded & whole
        if cheap.any():
            rows, s = table.separation_columns(q[None, :], np.array([tm]), only=cheap)
            spread = rho + self.speed[rows] * (0.5 * (tb - ta)) + SLACK_M
            lower[rows] = s[0] - spread
            upper[rows] = s[0] + spread
        need = ~never & ~cheap  # windows that open or close in the batch; kinds without bound
        need |= lower < self.margin
        for tid in inside:
            i = self.row.get(tid)
            if i is not None:
                need[i] = True
        if nearest > 0:
            finite = np.flatnonzero(np.isfinite(upper))
            if len(finite) > nearest:
                u = np.partition(upper[finite], nearest - 1)[nearest - 1]
                need |= lower <= u
            else:
                need |= np.isfinite(lower)
        rows, out = table.separation_columns(pos, ts, only=need)
        self.measured += len(rows)
        if len(rows):
            lows = out.min(axis=0)
            self.upper[rows] = np.minimum(self.upper[rows], lows)
        put_off = np.isfinite(lower) & ~need
        if put_off.any():
            self.upper = np.minimum(self.upper, np.where(put_off, upper, math.inf))
            self._batches.append((ts, pos, np.where(put_off, lower, math.inf)))
        return [table.ids[i] for i in rows.tolist()], out

    def lowest(self) -> dict[str, tuple[float, float]]:
        """The smallest separation and its first time, (value, t), of every threat some batch
        put off, over the batches that put it off (module docstring); a threat measured on
        other batches too takes the lower of this and what those gave (the earlier on a tie)."""
        best: dict[int, tuple[float, float]] = {}
        for ts, pos, lower in self._batches:
            maybe = np.isfinite(lower) & (lower <= self.upper)
            if not maybe.any():
                continue
            rows, out = self.table.separation_columns(pos, ts, only=maybe)
            self.measured += len(rows)
            if not len(rows):
                continue
            k = np.argmin(out, axis=0)
            lows = out[k, np.arange(len(rows))].tolist()
            when = ts[k].tolist()
            for i, v, t in zip(rows.tolist(), lows, when, strict=True):
                if v < best.get(i, (math.inf, math.nan))[0]:
                    best[i] = (float(v), float(t))
        self._batches.clear()
        return {self.table.ids[i]: vt for i, vt in sorted(best.items())}


__all__ = ["SLACK_M", "SeparationBook"]
