"""Which fixed threat points may matter to a moving aircraft: a spatial index refreshed as it
flies (issue 38: the threat bookkeeping scales with the threats near the aircraft, not with all
of them).

A radar scans 28 800 times in an 8-hour replay; testing every point of every threat at every
scan costs the whole scene each time.  :class:`NearIndex` keeps the points within
``reach + step`` of the position of its last refresh (``step = STEP_FRACTION * reach``, one
``scipy.spatial.cKDTree`` query, the rows in increasing order) and answers from them until the
aircraft has moved more than ``step`` from there: by the triangle inequality, every point within
``reach`` of the aircraft is then among them.  ``SLACK_M`` more covers rounding (a map's
coordinates are below 1e7 m, their distances exact to about 1e-9 m).  The caller tests the few
points it gets with its own formula, so the results are those of testing every point: the index
only leaves out points that cannot pass.

Only fixed points are indexed (static threats, the points of hills); moving and solid threats
are few and are asked as before (:class:`replay.threats.table.ThreatTable`).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

STEP_FRACTION = 0.1  # refresh after flying this share of the reach (1 km for a 10 km radar)
SLACK_M = 1.0  # on top of reach + step: rounding, many orders of magnitude over
BRUTE_MAX = 64  # this many points or fewer: every point every time (an index costs more)


class NearIndex:
    """The rows of fixed points (P, 3) that may lie within ``reach`` of an observer; see the
    module docstring.  :meth:`near` returns the rows and whether they changed since the last
    call (the caller keeps what it derived from them until they do)."""

    def __init__(self, points: npt.ArrayLike) -> None:
        self.points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        self._tree: object | None = None
        self._at: tuple[float, float, float] | None = None
        self._reach = math.nan
        self._step = 0.0
        self.rows: IntArray = np.arange(len(self.points), dtype=np.int64)
        self.refreshes = 0

    def __len__(self) -> int:
        return len(self.points)

    def margin(self, own: FloatArray) -> float:
        """How much farther than ``reach`` (of the last :meth:`near`) from ``own`` every point
        left out lies, at least: the aircraft may move this far before one can be in reach."""
        if self._at is None or len(self.points) <= BRUTE_MAX or not math.isfinite(self._step):
            return math.inf
        at = self._at
        moved = math.sqrt((own[0] - at[0]) ** 2 + (own[1] - at[1]) ** 2 + (own[2] - at[2]) ** 2)
        return self._step + SLACK_M - float(moved)

    def near(self, own: FloatArray, reach: float) -> tuple[IntArray, bool]:
        """(rows of the points that may lie within ``reach`` of ``own``, increasing; True when
        they were refreshed by this call)."""
        if len(self.points) <= BRUTE_MAX:
            return self.rows, False
        x, y, z = float(own[0]), float(own[1]), float(own[2])
        at = self._at
        if (
            at is not None
            and reach == self._reach
            and (x - at[0]) ** 2 + (y - at[1]) ** 2 + (z - at[2]) ** 2 <= self._step**2
        ):
            return self.rows, False
        from scipy.spatial import cKDTree

        if self._tree is None:
            self._tree = cKDTree(self.points)
        tree = self._tree
        assert isinstance(tree, cKDTree)
        step = STEP_FRACTION * reach if math.isfinite(reach) else math.inf
        rows = (
            tree.query_ball_point([x, y, z], reach + step + SLACK_M)
            if math.isfinite(step)
            else None
        )
        self.rows = (
            np.arange(len(self.points), dtype=np.int64)
            if rows is None
            else np.sort(np.asarray(rows, dtype=np.int64))
        )
        self._at, self._reach, self._step = (x, y, z), reach, step
        self.refreshes += 1
        return self.rows, True


__all__ = ["BRUTE_MAX", "SLACK_M", "STEP_FRACTION", "NearIndex"]
