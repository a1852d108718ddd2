"""Waypoint placement along an explored route: where exactly the ``N`` free waypoints go, and how
high, before the swarm starts (part of ``terrapath plan --init graph``).

The graph of :mod:`planner.explore` decides the route's topology (which valley, which side of a
field of zones), but its seed (the route's corners, string-pulled and simplified to ``N`` points)
sits 10-25 % above the best plans of that route (seed 002's Table 2 protocol, 200 runs a map:
Big Tujunga 0.550 against 0.504, rmnp 0.593 against 0.533, jacksboro 0.594 against 0.473),
and a swarm of 60 x 200 starting from it settles in whichever fine-scale local minimum its random
part finds (jacksboro: 0.47-0.55 over 200 runs).  The best plans fly *tents*: a waypoint on each
ridge crossing, the chords between sloping down into the valleys.  :func:`place` searches those
directly, by dynamic programming over a lattice of candidate waypoints round the route:

**Candidates.**  ``S`` stations evenly spaced along the route's polyline (``STATIONS`` = 25, at
least ``4 N``), at each ``OFFSETS`` (7) points across it, evenly spread over +-``WIDTH`` (3 %) of
the straight start-goal distance (1.2 km on the reference maps; the best runs of 200 lie 0.1-0.35
km from the explored route), the direction across taken from the route's chord over +-one
station spacing.  Each candidate has ``K`` altitude *levels*: the terrain floor under it (the
cost's conservative terrain + clearance + 1 m) plus ``LEVELS`` (0, 30, 70, 130, 220, 350, 550 m),
those above the band's top dropped; the start and the goal have their own altitude only.

**Chords.**  A chord may join a candidate to one at a later station no more than ``MAX_SPAN``
(40 % of the route) further on, whose horizontal segment crosses no danger zone's footprint
(grown by the margin, whatever its floor and top; soft zones too -- the placement is a seed, the
swarm may still cut a corner through one).  From level ``za`` the chord's lowest clear end is
``max_i za + (f_i - za) / t_i`` over the floor ``f_i`` sampled every half block at ``t_i`` along
it (on the upper convex hull of the samples: the same maximum, fewer terms); a level at least
that high, with the climb or descent within ``GRADIENT_USE`` of the aircraft's gradients, makes
an edge -- and where the plan may spiral
(:attr:`planner.problem.PlanningProblem.spiral_gradient`) a steeper one too, its length grown
by the helix that climbs the rest (excess / the climb gradient in a turn), as the cost prices
it, and taken only where no chain without one reaches the goal (each weighs more than any
chain's spread: the fewest spirals, then the cheapest).  The floor is taken in blocks of
``b x b`` cells (their maximum, so conservative; ``b`` the whole number of cells nearest the
start-goal distance / ``CELLS_ALONG`` (400): 3 on Big Tujunga's 30 m cells, 1 on jacksboro and
rmnp) so a chord costs the same number of samples on any DEM.  Terrain the DEM did not measure is an infinite floor (unless allowed).

**The objective.**  Seed 002's length and altitude terms, ``F = 1 - D / L + (A - Zmin) / dZ``
with ``A = (sum l_i z_i) / L``, do not add up along a path; to first order round a path of length
``L0`` and mean altitude ``A0`` they change as ``sum l_i (z_i + dZ D / L0 - A0)`` (times
``1 / (dZ L0)``), which does.  The chain of exactly ``N`` inner states minimising it is found
layer by layer (``planner.kernels.layered_dp``), ``(L0, A0)`` replaced by the chain's own and
the search repeated (``ITERATIONS`` = 4 at most, until the chain repeats; the first round from
``L0 = 1.05 D``, ``A0`` at 40 % of the band).  Every chain found is a candidate seed.

**Local rounds.**  The chain with the lowest ``F_length + F_altitude`` is then moved waypoint by
waypoint and all at once: each inner waypoint gets a ``LOCAL x LOCAL`` (3 x 3) grid round it,
along and across its mean heading (the mean of its two legs' directions), spaced ``FIRST`` (half)
the station spacing, then a quarter, an eighth, a sixteenth (``REFINE`` = 4 rounds), with the
finer ``LEVELS_FINE``; the same layered
search over those grids (layer ``i`` joined to layer ``i + 1`` only) keeps a round's chain when
its ``F_length + F_altitude`` is no higher.  The lattice round the route decides which ridges the
chords cross; the local rounds find a lower way over each.  Which basin the lattice picks still
depends on where its points fall (measured, AMPSO P 60 x 200, 20 runs: a 28 x 9 lattice spanning
half the route gives Big Tujunga 0.4831, rmnp 0.5326, jacksboro 0.4857; this 25 x 7 one 0.4839,
0.5313, 0.4730), but within one lattice the runs agree to a few thousandths.

**Finishing.**  A chain's altitudes are lowered as far as both chords of each waypoint allow
(:func:`finish_waypoints`, as for the graph's own seeds), then raised where the *flown* path
(turn fillets cut the corners, over terrain the chords do not cross) runs below the floor:
the waypoints next to each such piece go up by 1.5 x its depth + 2 m, up to ``REPAIR_ROUNDS`` (8)
times (:func:`repair`).  :func:`planner.explore.explore_pool` scores the seeds with the problem's
own cost and keeps the cheapest feasible ones.

**Polish.**  The surrogate is blind to the turn fillets and to the cost's cells, and the lattice
is coarse: the placements sat 2.1-2.5 % above the best of 2,400 swarm runs on each reference map,
so a swarm or GA that failed to improve on them (3 GA runs of 2,400 on rmnp) ended more than 2 %
above the best.  :func:`polish` runs a compass search on the problem's own cost from the
``POLISHED`` (2) cheapest placements (12 rounds, about 7 ms each); a polished seed replaces its
placement when it is cheaper and its flown path passes the result's checks.

With a preferred height above the ground (``--agl-pref``) the objective is a different one and
the placement is skipped.  Measured (``benchmarks/bench_plan.py``, ``benchmarks/RESULTS.md``):
see the issue-20 entries.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from typing import Any

import numpy as np
import numpy.typing as npt

from planner import kernels
from planner.problem import PlanningProblem
from terrain.grid import block_max
from terrain.segments import below_terrain_lengths
from terrain.zoneset import ZoneSet

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

GRADIENT_USE = 0.9  # share of the climb / descent gradients the seeds' legs use
STATIONS = 25  # stations along the route (at least 4 N)
OFFSETS = 7  # candidates across the route at each station
WIDTH = 0.03  # half the width of the lattice, share of the start-goal distance
MAX_SPAN = 0.4  # a chord spans at most this share of the route
LEVELS = (0.0, 30.0, 70.0, 130.0, 220.0, 350.0, 550.0)  # m above a candidate's floor
LEVELS_FINE = (0.0, 15.0, 30.0, 50.0, 70.0, 100.0, 130.0, 175.0, 220.0, 350.0, 550.0)
ITERATIONS = 4  # rounds of the linearised objective
REFINE = 4  # local rounds round the best chain
LOCAL = 3  # candidates along and across each waypoint in a local round
FIRST = 0.5  # the first local round's spacing, share of the station spacing
REPAIR_ROUNDS = 8
SAMPLE = 0.5  # the placement's chord samples, in (coarse) cells
CELLS_ALONG = 400  # the chords' floor: blocks of cells about the start-goal distance / this
POLISH_ROUNDS = 12  # compass-search rounds on the problem's own cost
POLISH_XY = 0.005  # its first horizontal step, share of the start-goal distance
POLISH_Z = 0.01  # its first vertical step, share of the altitude band


class Heights64:
    """A float32 height array read as float64: indexing it gives float64 values (what a float64
    copy would give, exactly), with no copy of the grid made (4 bytes a cell instead of 12)."""

    def __init__(self, heights: npt.NDArray[np.float32]) -> None:
        self.heights = heights

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(self.heights.shape)

    def __getitem__(self, index: Any) -> Any:
        return np.asarray(self.heights[index], dtype=np.float64)

    def __array__(self, dtype: Any = None, copy: Any = None) -> FloatArray:
        return np.asarray(self.heights, dtype=np.float64 if dtype is None else dtype)


# the corridor heights as the seeds' searches take them: a float64 view of the grid, or (tests)
# a float64 array
Terrain = Heights64 | FloatArray


def corridor_terrain(problem: PlanningProblem) -> Heights64:
    """The heights a seed's chords must clear: the conservative terrain the cost's Bresenham
    walk checks (the safety heights dilated by a cell), read as float64."""
    return Heights64(problem.check_grid.heights)


class Chords:
    """The terrain floor (corridor heights + clearance + 1 m) sampled every quarter cell along
    each chord of a polyline: ``t`` (0..1 from its first end) and ``floor`` per chord."""

    def __init__(self, problem: PlanningProblem, pts: FloatArray, heights: Terrain) -> None:
        xy = np.ascontiguousarray(np.asarray(pts, dtype=np.float64)[:, :2])
        raw = heights.heights if isinstance(heights, Heights64) else heights
        if not np.isfinite(xy).all() or raw.dtype not in (np.float32, np.float64):
            self.t, self.floor = _chord_samples_numpy(problem, xy, heights)
            return
        # compiled (planner.kernels.chord_samples): the seeds' finishing builds ~60 of these a
        # plan, a tenth of the map search in numpy (issue 38)
        grid = problem.grid
        dx, dy = grid.cell_size
        t, floor, at = kernels.chord_samples(
            xy,
            raw,
            float(problem.clearance),
            float(grid.transform.c),
            float(grid.transform.f),
            float(dx),
            float(dy),
            0.25 * min(grid.cell_size),
        )
        bounds = at.tolist()
        self.t = [t[a:b] for a, b in itertools.pairwise(bounds)]
        self.floor = [floor[a:b] for a, b in itertools.pairwise(bounds)]

    def clear(self, i: int, za: float, zb: float) -> bool:
        t = self.t[i]
        return bool(np.all(za + t * (zb - za) >= self.floor[i]))

    def lowest_end(self, i: int, za: float) -> float:
        """The lowest altitude of chord i's second end keeping it clear, its first end at za."""
        t, f = self.t[i][1:], self.floor[i][1:]
        return float(np.max(za + (f - za) / t))

    def lowest_start(self, i: int, zb: float) -> float:
        """The lowest altitude of chord i's first end keeping it clear, its second end at zb."""
        t, f = self.t[i][:-1], self.floor[i][:-1]
        return float(np.max(zb + (f - zb) / (1.0 - t)))


def _chord_samples_numpy(
    problem: PlanningProblem, pts: FloatArray, heights: Terrain
) -> tuple[list[FloatArray], list[FloatArray]]:
    """The numpy twin of ``planner.kernels.chord_samples``: :class:`Chords`' samples (t) and
    floors, chord by chord."""
    grid = problem.grid
    step = 0.25 * min(grid.cell_size)
    ts: list[FloatArray] = []
    floors: list[FloatArray] = []
    for p, q in itertools.pairwise(pts):
        m = max(2, int(math.ceil(float(np.hypot(*(q - p))) / step)) + 1)
        t = np.linspace(0.0, 1.0, m)
        line = p[None, :] + t[:, None] * (q - p)[None, :]
        ts.append(t)
        floors.append(heights[grid.cell_of(line[:, 0], line[:, 1])] + problem.clearance + 1.0)
    return ts, floors


def finish_waypoints(
    problem: PlanningProblem, xy: FloatArray, z: FloatArray, heights: Terrain
) -> FloatArray:
    """The solution vector (3N,) of the polyline ``xy`` (N + 2, 2) at altitudes ``z`` (start and
    goal at the ends): each waypoint lowered as far as both its chords allow (three sweeps), moved
    into an above-ground band or to a preferred height where the chords allow, then raised until
    the climbs and descents between waypoints use at most ``GRADIENT_USE`` of the aircraft's
    gradients; clipped to the search box."""
    n = problem.n_waypoints
    zlo, zhi = problem.band
    z = np.minimum(np.asarray(z, dtype=np.float64), zhi)
    ch = Chords(problem, xy, heights)
    for _ in range(3):  # lower each waypoint as far as both its chords allow
        for i in range(1, n + 1):
            low = max(ch.lowest_end(i - 1, z[i - 1]), ch.lowest_start(i, z[i + 1]), zlo)
            z[i] = min(z[i], low) if low <= z[i] else z[i]
    if problem.agl_pref is not None or problem.agl_max is not None:
        z = _into_band(problem, xy, z)
    perf = problem.performance
    if perf is not None:  # raise waypoints until the climbs and descents between them are flyable
        gap = np.hypot(*np.diff(xy, axis=0).T)
        climb, descent = GRADIENT_USE * perf.climb_gradient, GRADIENT_USE * perf.descent_gradient
        for i in range(n, 0, -1):  # able to climb to the next one
            z[i] = max(z[i], z[i + 1] - climb * gap[i])
        for i in range(1, n + 1):  # able to descend from the previous one
            z[i] = max(z[i], z[i - 1] - descent * gap[i - 1])
    x = np.column_stack([xy[1:-1], np.clip(z[1:-1], zlo, zhi)]).ravel()
    lo, hi = problem.bounds()
    return np.asarray(np.clip(x, lo, hi), dtype=np.float64)


def _into_band(problem: PlanningProblem, xy: FloatArray, low: FloatArray) -> FloatArray:
    """Waypoint altitudes between the lowest clear profile ``low`` and a target -- the preferred
    height above the ground at each waypoint, under the band's top there -- as far towards the
    target as keeps every chord under the band's top (the largest such blend, by bisection:
    the chords' heights above the ground grow with it).  Anything above ``low`` is clear."""
    ground = problem.grid.height_at(xy[1:-1, 0], xy[1:-1, 1])
    target = low.copy()
    if problem.agl_pref is not None:
        target[1:-1] = np.maximum(target[1:-1], ground + problem.agl_pref)
    top = problem.agl_max
    if top is None:
        return target
    target[1:-1] = np.maximum(np.minimum(target[1:-1], ground + top), low[1:-1])
    step = 0.5 * min(problem.grid.cell_size)
    ts, gs = [], []
    for p, q in itertools.pairwise(xy):
        m = max(2, int(math.ceil(float(np.hypot(*(q - p))) / step)) + 1)
        t = np.linspace(0.0, 1.0, m)
        line = p[None, :] + t[:, None] * (q - p)[None, :]
        ts.append(t)
        gs.append(problem.grid.height_at(line[:, 0], line[:, 1]))

    def under(z: FloatArray) -> bool:
        return all(
            float(np.max(z[i] + t * (z[i + 1] - z[i]) - g)) <= top
            for i, (t, g) in enumerate(zip(ts, gs, strict=True))
        )

    if under(target):
        return target
    if not under(low):  # no profile over these waypoints keeps the band: leave it to the swarm
        return low
    lo, hi = 0.0, 1.0
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if under(low + mid * (target - low)) else (lo, mid)
    return np.asarray(low + lo * (target - low), dtype=np.float64)


class Floor:
    """The altitudes a chord must keep above, per cell: ``heights`` + clearance + 1 m (float64),
    infinite over terrain the DEM did not measure (unless the problem allows it).  Computed
    where indexed (``floor[rows, cols]``), never for the whole map; ``np.asarray(floor)`` makes
    the whole array (for the tests)."""

    def __init__(self, problem: PlanningProblem, heights: Terrain) -> None:
        self.heights = heights.heights if isinstance(heights, Heights64) else heights
        self.lift = problem.clearance
        unknown = problem.unknown_grid
        self.unknown = None if unknown is None else unknown.heights
        # the grids whose cached block maxima are those of these heights (the corridor terrain
        # is the problem's check grid): built once per grid, not once per plan
        check = problem.check_grid
        self._grids = (check if self.heights is check.heights else None, unknown)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(self.heights.shape)

    def __getitem__(self, index: Any) -> Any:
        floor = np.asarray(self.heights[index], dtype=np.float64) + self.lift + 1.0
        if self.unknown is not None:
            floor = np.where(self.unknown[index] > 0, np.inf, floor)
        return floor

    def __array__(self, dtype: Any = None, copy: Any = None) -> FloatArray:
        whole = self[...]
        return np.asarray(whole, dtype=np.float64 if dtype is None else dtype)

    def block_max(self, b: int) -> FloatArray:
        """:func:`terrain.grid.block_max` of the floor, from the heights' blocks (adding the same
        float64 lift to every value keeps their order, so the maxima are the same numbers)."""
        grid, unknown = self._grids
        top = (block_max(self.heights, b) if grid is None else grid.block_max(b)) + self.lift + 1.0
        if self.unknown is not None:
            over = block_max(self.unknown, b) if unknown is None else unknown.block_max(b)
            top = np.where(over > 0, np.inf, top)
        return np.asarray(top, dtype=np.float64)


def floor_grid(problem: PlanningProblem, heights: Terrain) -> Floor:
    """The chords' floor over the map (:class:`Floor`)."""
    return Floor(problem, heights)


def candidates(problem: PlanningProblem, route_xy: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The lattice round a route (module docstring): points (M, 2), start first and goal last,
    and each one's station (distance along the route)."""
    route = np.asarray(route_xy, dtype=np.float64)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(route, axis=0).T))])
    total = float(s[-1])
    stations = max(STATIONS, 4 * problem.n_waypoints)
    u = np.linspace(0.0, total, stations + 2)[1:-1]
    spacing = total / (stations + 1)

    def at(w: FloatArray) -> FloatArray:
        return np.column_stack([np.interp(w, s, route[:, 0]), np.interp(w, s, route[:, 1])])

    mid = at(u)
    along = at(np.minimum(u + spacing, total)) - at(np.maximum(u - spacing, 0.0))
    norm = np.maximum(np.hypot(along[:, 0], along[:, 1]), 1e-9)
    across = np.column_stack([-along[:, 1], along[:, 0]]) / norm[:, None]
    span = float(np.hypot(*(problem.goal[:2] - problem.start[:2])))
    offsets = np.linspace(-WIDTH * span, WIDTH * span, OFFSETS)
    pts = (mid[:, None, :] + offsets[None, :, None] * across[:, None, :]).reshape(-1, 2)
    lo, hi = problem.bounds()
    pts = np.clip(pts, lo[:2], hi[:2])
    xy = np.vstack([problem.start[:2], pts, problem.goal[:2]])
    station = np.concatenate([[0.0], np.repeat(u, OFFSETS), [total]])
    return np.asarray(xy, dtype=np.float64), np.asarray(station, dtype=np.float64)


def levels_of(
    problem: PlanningProblem, xy: FloatArray, floor: Floor | FloatArray, above: tuple[float, ...]
) -> FloatArray:
    """Each candidate's altitude levels (M, K), infinite where not allowed; the start and the
    goal have their own altitude as their only level."""
    zlo, zhi = problem.band
    under = floor[problem.grid.cell_of(xy[:, 0], xy[:, 1])]
    levels = np.maximum(under, zlo)[:, None] + np.asarray(above)[None, :]
    levels[levels > zhi] = np.inf
    levels[0], levels[-1] = np.inf, np.inf
    levels[0, 0], levels[-1, 0] = problem.start[2], problem.goal[2]
    return np.asarray(levels, dtype=np.float64)


def chord_pairs(problem: PlanningProblem, xy: FloatArray, station: FloatArray) -> IntArray:
    """The candidate pairs (a, b) a chord may join (module docstring, "Chords")."""
    a, b = np.nonzero(
        (station[None, :] > station[:, None])
        & (station[None, :] - station[:, None] <= MAX_SPAN * station[-1])
    )
    return _zone_free(problem, xy, np.column_stack([a, b]))


def _zone_free(problem: PlanningProblem, xy: FloatArray, pairs: IntArray) -> IntArray:
    """The pairs whose horizontal segment crosses no danger zone's footprint (the zones as the
    cost sees them, grown by the margin, at any height: a chord's altitude is not known yet)."""
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    if not problem.zones or not len(pairs):
        return pairs
    tall = ZoneSet.of(tuple(replace(z, floor=None, top=None) for z in problem.cost_zones.zones))
    p = np.column_stack([xy[pairs[:, 0]], np.zeros(len(pairs))])
    q = np.column_stack([xy[pairs[:, 1]], np.zeros(len(pairs))])
    hit = (tall.segment_lengths(p, q) > 0.0).any(axis=1)
    return np.asarray(pairs[~hit], dtype=np.int64)


def _gradients(problem: PlanningProblem) -> tuple[float, float]:
    perf = problem.performance
    if perf is None:
        return math.inf, math.inf
    return GRADIENT_USE * perf.climb_gradient, GRADIENT_USE * perf.descent_gradient


class Lattice:
    """What the searches over one problem share: the chords' floor (blocks of cells), the
    gradients, the band and the straight distance."""

    def __init__(self, problem: PlanningProblem, heights: Terrain) -> None:
        self.problem = problem
        self.floor = floor_grid(problem, heights)
        span = float(np.hypot(*(problem.goal[:2] - problem.start[:2])))
        self.block = max(1, round(span / CELLS_ALONG / max(problem.grid.cell_size)))
        self.coarse = self.floor.block_max(self.block)
        self.climb, self.descent = _gradients(problem)
        # a chord too steep may climb the rest in a spiral, its helix counted in its length
        self.spiral = problem.spiral_gradient or 0.0
        self.zlo, zhi = problem.band
        self.dz = zhi - self.zlo
        self.d = float(np.linalg.norm(problem.goal - problem.start))

    def surrogate(self, pts: FloatArray) -> tuple[float, float, float]:
        """(F_length + F_altitude, L, A) of a polyline (M, 3)."""
        seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        length = float(seg.sum())
        mean_z = float((seg * 0.5 * (pts[1:, 2] + pts[:-1, 2])).sum()) / max(length, 1e-9)
        return 1.0 - self.d / max(length, 1e-9) + (mean_z - self.zlo) / self.dz, length, mean_z

    def search(
        self, xy: FloatArray, pairs: IntArray, levels: FloatArray, start: FloatArray | None
    ) -> list[FloatArray]:
        """The chains (N + 2, 3) of the linearised objective over candidates ``xy`` (start
        first, goal last) joined by ``pairs``, one per round (module docstring), the first round
        linearised round ``start`` (a polyline) or, without one, round 1.05 D and 40 % of the
        band."""
        problem = self.problem
        row, col = problem.grid.xy_to_index(xy[:, 0], xy[:, 1])
        rc = np.ascontiguousarray(np.column_stack([row, col]), dtype=np.float64)
        u, v, l3, zm = kernels.chord_edges(
            rc, xy, levels, self.coarse, self.block, SAMPLE * self.block, pairs, self.climb,
            self.descent, self.spiral,
        )  # fmt: skip
        k = levels.shape[1]
        if self.spiral > 0.0:
            # a chord that needs a spiral is taken only where no chain without one reaches the
            # goal, and as few as can be: it weighs more than the spread of any chain's weights
            # (each chord's weight is within +-2 x the band x its length, N + 1 chords a chain)
            steep = kernels.steep_chords(u, v, l3, xy, levels)  # _steep_chords_numpy's
            surcharge = 8.0 * self.dz * (problem.n_waypoints + 1) * float(l3.max(initial=1.0))
            extra = steep * surcharge  # the same every round
        n_states = len(xy) * k
        goal = (len(xy) - 1) * k
        inner = np.ones(n_states, dtype=np.bool_)
        inner[:k] = False
        inner[goal:] = False
        if start is None:
            length, mean_z = 1.05 * self.d, self.zlo + 0.4 * self.dz
        else:
            _, length, mean_z = self.surrogate(start)
        seen: set[tuple[int, ...]] = set()
        out: list[FloatArray] = []
        w = np.empty_like(l3)
        for _ in range(ITERATIONS):
            # w = l3 * (zm + dz d / length - mean_z) (+ extra), in one buffer, in that order
            np.add(zm, self.dz * self.d / length, out=w)
            np.subtract(w, mean_z, out=w)
            np.multiply(l3, w, out=w)
            if self.spiral > 0.0:
                np.add(w, extra, out=w)
            chain = kernels.layered_dp(u, v, w, n_states, 0, goal, problem.n_waypoints, inner)
            if chain.size == 0 or tuple(chain.tolist()) in seen:
                break
            seen.add(tuple(chain.tolist()))
            m, lev = chain // k, chain % k
            pts = np.column_stack([xy[m], levels[m, lev]])
            _, length, mean_z = self.surrogate(pts)
            out.append(pts)
        return out


def place(
    problem: PlanningProblem,
    route_xy: FloatArray,
    heights: Terrain,
    lattice: Lattice | None = None,
) -> list[FloatArray]:
    """Seeds (solution vectors) placed along the route ``route_xy`` (module docstring), each
    finished and repaired; empty when no chain of clear chords reaches the goal.  ``lattice``:
    the problem's :class:`Lattice` when several routes are placed (built when not given)."""
    lat = Lattice(problem, heights) if lattice is None else lattice
    xy, station = candidates(problem, route_xy)
    chains = lat.search(
        xy, chord_pairs(problem, xy, station), levels_of(problem, xy, lat.floor, LEVELS), None
    )
    if not chains:
        return []
    best = min(chains, key=lambda c: lat.surrogate(c)[0])
    step = float(station[1])  # the station spacing (the first station's distance)
    for r in range(REFINE):
        h = step * FIRST * 0.5**r
        xy = _around(problem, best, h)
        pairs = _zone_free(problem, xy, _layer_pairs(problem.n_waypoints, LOCAL**2))
        found = lat.search(xy, pairs, levels_of(problem, xy, lat.floor, LEVELS_FINE), best)
        if found:
            pick = min(found, key=lambda c: lat.surrogate(c)[0])
            if lat.surrogate(pick)[0] <= lat.surrogate(best)[0]:
                best = pick
        chains.append(best)
    out: list[FloatArray] = []
    seen: set[bytes] = set()
    for pts in chains:
        if pts.tobytes() in seen:
            continue
        seen.add(pts.tobytes())
        x = finish_waypoints(problem, pts[:, :2].copy(), pts[:, 2].copy(), heights)
        out.append(repair(problem, x, heights))
    return out


def _around(problem: PlanningProblem, chain: FloatArray, h: float) -> FloatArray:
    """Candidates round each inner waypoint of ``chain``: a ``LOCAL`` x ``LOCAL`` grid of
    spacing ``h`` along and across its mean heading (the waypoint itself at the centre), start first
    and goal last: (2 + N LOCAL^2, 2)."""
    p = chain[:, :2]
    into = p[1:-1] - p[:-2]
    out_of = p[2:] - p[1:-1]
    along = into / np.maximum(np.hypot(*into.T), 1e-9)[:, None]
    along = along + out_of / np.maximum(np.hypot(*out_of.T), 1e-9)[:, None]
    norm = np.hypot(*along.T)
    along = np.where(norm[:, None] > 1e-9, along / np.maximum(norm, 1e-9)[:, None], [1.0, 0.0])
    across = np.column_stack([-along[:, 1], along[:, 0]])
    g = (np.arange(LOCAL) - (LOCAL - 1) / 2) * h
    ga, gc = (a.ravel() for a in np.meshgrid(g, g, indexing="ij"))
    pts = (
        p[1:-1, None, :]
        + ga[None, :, None] * along[:, None, :]
        + gc[None, :, None] * across[:, None, :]
    )
    lo, hi = problem.bounds()
    pts = np.clip(pts.reshape(-1, 2), lo[:2], hi[:2])
    return np.asarray(np.vstack([p[:1], pts, p[-1:]]), dtype=np.float64)


def _layer_pairs(n: int, per: int) -> IntArray:
    """Pairs between consecutive layers of ``per`` candidates (start 0, layer i at
    1 + i per .. , goal last)."""
    first = np.arange(per)
    out = [np.column_stack([np.zeros(per, np.int64), 1 + first])]
    for i in range(n - 1):
        a, b = np.meshgrid(1 + i * per + first, 1 + (i + 1) * per + first, indexing="ij")
        out.append(np.column_stack([a.ravel(), b.ravel()]))
    out.append(np.column_stack([1 + (n - 1) * per + first, np.full(per, 1 + n * per)]))
    return np.asarray(np.vstack(out), dtype=np.int64)


def repair(problem: PlanningProblem, x: FloatArray, heights: Terrain) -> FloatArray:
    """``x`` with the waypoints next to each piece of the flown path that runs below the floor
    (the cost's Bresenham walk) raised by 1.5 x its depth + 2 m (at least 3 m deep), again until
    the flown path is clear or ``REPAIR_ROUNDS`` have passed; under the band's top."""
    x = np.array(x, dtype=np.float64)
    z = x.reshape(-1, 3)[:, 2]
    for _ in range(REPAIR_ROUNDS):
        deep = _depths(problem, x, heights)
        if not (deep > 0.0).any():
            break
        z += np.where(deep > 0.0, 1.5 * deep + 2.0, 0.0)
        np.minimum(z, problem.band[1], out=z)
    return x


def _depths(problem: PlanningProblem, x: FloatArray, heights: Terrain) -> FloatArray:
    """Per free waypoint, the deepest piece of the flown path next to it that runs below the
    floor (0 where none does)."""
    n = problem.n_waypoints
    flown = problem.flown(problem.paths(x))
    per = problem.chords + 1 if problem.performance is not None else 1
    below = below_terrain_lengths(problem.check_grid, flown[:-1], flown[1:], problem.clearance)
    out = np.zeros(n + 2)
    for j in np.flatnonzero(below > 0.0).tolist():
        p, q = flown[j], flown[j + 1]
        ch = Chords(problem, flown[j : j + 2, :2], heights)
        deep = max(float(np.max(ch.floor[0] - (p[2] + ch.t[0] * (q[2] - p[2])))), 3.0)
        for i in (j, j + 1):  # flown point i > 0 belongs to waypoint (i - 1) // per + 1
            wp = 0 if i == 0 else min((i - 1) // per + 1, n + 1)
            out[wp] = max(out[wp], deep)
    return out[1:-1]


def polish(problem: PlanningProblem, x: FloatArray) -> tuple[FloatArray, float]:
    """``x`` moved by a compass search on the problem's own cost (the placement's objective is a
    linearised surrogate on a lattice, blind to the fillets and the cost's cells): each round
    tries every coordinate one step up and one down (``2 * 3 N`` paths, one call of the cost),
    moves to the best of them if it is cheaper, else halves the steps; ``POLISH_ROUNDS`` (12)
    rounds, first steps ``POLISH_XY`` (0.5 %) of the start-goal distance east and north and
    ``POLISH_Z`` (1 %) of the altitude band up.  Returns the point and its cost (never higher
    than ``x``'s).  Measured on the three reference maps' best placements (433 evaluations,
    about 7 ms each): Big Tujunga 0.4916 -> 0.4869, rmnp 0.5368 -> 0.5294, jacksboro
    0.4804 -> 0.4756, within 1.1-1.4 % of the best plans of 2,400 swarm runs, where the
    placements were 2.1-2.5 % above them; 20 rounds gained another 0.0002-0.0011 for 70 %
    more time, a first step of 200 m / 20 m the same as this one within 0.001."""
    lower, upper = problem.bounds()
    span = float(np.hypot(*(problem.goal[:2] - problem.start[:2])))
    first = [POLISH_XY * span, POLISH_XY * span, POLISH_Z * (problem.band[1] - problem.band[0])]
    step = np.tile(first, x.size // 3)
    x = np.array(x, dtype=np.float64)
    f = float(problem(x[None, :])[0])
    for _ in range(POLISH_ROUNDS):
        moves = np.diag(step)
        trial = np.clip(np.vstack([x + moves, x - moves]), lower, upper)
        cost = np.asarray(problem(trial), dtype=np.float64)
        i = int(np.argmin(cost))
        if cost[i] < f:
            x, f = trial[i], float(cost[i])
        else:
            step = step / 2.0
    return x, f


def _chord_edges_py(
    rc: FloatArray,
    xy: FloatArray,
    levels: FloatArray,
    floor: FloatArray,
    block: int,
    step: float,
    pairs: IntArray,
    climb: float,
    descent: float,
    spiral: float = 0.0,
) -> tuple[IntArray, IntArray, FloatArray, FloatArray]:
    """Pure-numpy twin of ``planner.kernels.chord_edges`` (every sample, no hull)."""
    k = levels.shape[1]
    out: list[tuple[int, int, float, float]] = []
    for a, b in pairs.tolist():
        m = max(2, int(np.ceil(np.hypot(*(rc[b] - rc[a])) / step)) + 1)
        t = np.arange(m) / (m - 1)
        t[-1] = 1.0
        rows, cols = floor.shape[0] * block - 1, floor.shape[1] * block - 1
        r = np.clip(np.floor(rc[a, 0] + t * (rc[b, 0] - rc[a, 0]) + 0.5), 0, rows)
        c = np.clip(np.floor(rc[a, 1] + t * (rc[b, 1] - rc[a, 1]) + 0.5), 0, cols)
        f = floor[r.astype(np.int64) // block, c.astype(np.int64) // block]
        if not np.isfinite(f).all():
            continue
        length = float(np.hypot(*(xy[b] - xy[a])))
        for ka in range(k):
            za = levels[a, ka]
            if not np.isfinite(za) or za < f[0]:
                continue
            need = float(np.max(za + (f[1:] - za) / t[1:]))
            for kb in range(k):
                zb = levels[b, kb]
                dz = zb - za
                excess = max(dz - climb * length, -dz - descent * length, 0.0)
                if np.isfinite(zb) and zb >= need and (excess <= 0.0 or spiral > 0.0):
                    l3 = math.hypot(length, dz) + (excess / spiral if excess > 0.0 else 0.0)
                    out.append((a * k + ka, b * k + kb, l3, 0.5 * (za + zb)))
    arr = np.array(out, dtype=np.float64).reshape(-1, 4)
    return (
        arr[:, 0].astype(np.int64),
        arr[:, 1].astype(np.int64),
        np.asarray(arr[:, 2]),
        np.asarray(arr[:, 3]),
    )


def _steep_chords_numpy(
    u: IntArray, v: IntArray, l3: FloatArray, xy: FloatArray, levels: FloatArray
) -> npt.NDArray[np.bool_]:
    """Pure-numpy twin of ``planner.kernels.steep_chords``: the edges (u, v) longer than their
    straight 3-D chord by more than 1e-6 m (a helix added to them)."""
    k = levels.shape[1]
    a, b = u // k, v // k
    flat = np.hypot(xy[b, 0] - xy[a, 0], xy[b, 1] - xy[a, 1])
    plain = np.sqrt(flat**2 + (levels.flat[v] - levels.flat[u]) ** 2)
    return np.asarray(l3 > plain + 1e-6, dtype=np.bool_)


def _layered_dp_py(
    u: IntArray,
    v: IntArray,
    w: FloatArray,
    n_states: int,
    start: int,
    goal: int,
    layers: int,
    inner: npt.NDArray[np.bool_],
) -> tuple[float, IntArray]:
    """Pure-numpy twin of ``planner.kernels.layered_dp`` (dense): (cost, chain)."""
    weight = np.full((n_states, n_states), np.inf)
    np.minimum.at(weight, (u, v), w)
    best = np.full(n_states, np.inf)
    best[start] = 0.0
    back = []
    for _ in range(layers):
        total = best[:, None] + weight
        arg = np.argmin(total, axis=0)
        best = np.where(inner, total[arg, np.arange(n_states)], np.inf)
        back.append(arg)
    end = best + weight[:, goal]
    at = int(np.argmin(end))
    if not np.isfinite(end[at]):
        return math.inf, np.empty(0, dtype=np.int64)
    chain = [goal, at]
    for layer in range(layers - 1, 0, -1):
        at = int(back[layer][at])
        chain.append(at)
    chain.append(start)
    return float(end[chain[1]]), np.asarray(chain[::-1], dtype=np.int64)
