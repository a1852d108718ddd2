"""Global exploration before the swarm (``terrapath plan --init graph``, the default): the route's
topology comes from a search over the whole map, the swarm refines it.

Seed 002's PSO refines well and explores poorly: which corridor a plan takes (a valley, a
plateau, round a field of danger zones or through its gaps) was decided by the random initial
population.  :func:`explore` searches a coarse graph of the map for ``k`` short, mutually distinct
routes under a surrogate of the same cost and the same validity, and turns each into the
solution vector of ``N`` free waypoints; :func:`graph_population` puts them (and jittered copies)
into the first rows of the initial population, the rest of which stays the random corridor
population, so the paper's optimiser is still what runs.

**The graph (2.5-D).**  The DEM's cells are grouped into blocks of ``b x b`` (``b`` the smallest
integer giving at most ``cells`` blocks along the map's longer side; 64 by default: 1-2 km blocks
on the reference maps, every cell on a small DEM).  Each block is a node at its centre, flown at
the *node altitude* ``h = max(terrain over the 3 x 3 blocks round it) + clearance`` (the
planner's conservative terrain, :attr:`planner.problem.PlanningProblem.safety_grid` dilated as
the cost checks it), never below the band's floor.  A straight segment between two neighbouring
nodes (8-connected) stays inside the blocks both nodes' 3 x 3 maxima cover, so linear
interpolation between ``h_u`` and ``h_v`` clears the terrain all along it: every edge is valid.
A node is removed when ``h`` exceeds the band's top (a mountain the band does not allow over),
when its 3 x 3 blocks hold terrain the DEM did not measure (unless allowed), and an edge is removed
when, with danger zones as hard constraints, its segment enters a zone grown by the problem's
margin plus half a block's diagonal (a waypoint chord may stray that far from the route).  Start
and goal are the nodes of their blocks, kept whatever their surroundings.

**The edge weight** is a surrogate of seed 002's cost that adds up along a route: for a route of
3-D length ``L`` near the straight distance ``D``, ``F_length + F_altitude ~ (L - D) / D +
sum l_i a_i / L`` with ``a_i`` the segment's altitude normalised to the band, so an edge of
length ``l`` at normalised mid altitude ``a`` weighs ``l (1 + a)`` (up to the constant 1 and the
factor 1 / D, the same order).  With the aircraft's performance, ``l`` is at least ``|dz| / g``
(``g`` the smaller of its climb and descent gradients): a climb steeper than it can fly costs
the distance it needs to make it; where the plan may spiral, the edge's length plus the helix
that climbs the rest at the climb gradient in a turn, or ``g`` where that is less
(``l + (|dz| - g l) / min(g_turn, g)``: never less than the distance it needs), as the cost
prices it.  Soft danger zones (not ``avoid_zones``) add their cost term
the same way: an edge ``l_k`` metres inside zone ``k`` of size ``d_k`` (of ``n``) adds
``D l_k / (n d_k)`` (``D`` the straight start-goal distance; the term's cap at 1 per zone is
left out).

**k routes (via nodes).**  One Dijkstra from the start and one from the goal
(:func:`scipy.sparse.csgraph.dijkstra`) give every node ``v`` the cost ``d_s(v) + d_g(v)`` of the
best route through it.  Nodes are taken in that order (the first lies on the shortest route);
a node's route is kept when it costs at most ``1 + stretch`` (1.6) times the shortest, does not
turn back on itself (its halves share no node but ``v``: a spur), and less than ``overlap``
(half) of its nodes lie within ``r`` of a route already kept (``r`` the larger of three blocks
and 5 % of the start-goal distance, start and goal surroundings not counted).  The nodes within
``r`` of a kept route are not tried as via nodes again.  The search stops at ``k`` routes (5).

**Waypoints.**  A route's polyline (start, block centres, goal) is reduced to ``N`` interior
points by greedy Ramer-Douglas-Peucker: the point farthest from the current chords is added
until there are ``N`` (a straighter route than that gets its longest chords halved).  Each
waypoint's altitude is the least that keeps both of its chords above the terrain plus clearance
(sampled every half cell on the same conservative terrain), with the start's and goal's fixed
altitudes honoured exactly on the first and last chords, clipped to the band; then lowered as far
as both chords allow, raised to a preferred height above the ground and kept under an
above-ground band's top where the chords allow.  The swarm moves them from there.

**Placement.**  The graph fixes the corridor; where exactly the waypoints go in it, and how
high, decides the last 10-25 % of the cost.  :func:`explore_pool` hands the three best routes to
:func:`planner.placement.place` (a dynamic programme over a lattice of waypoints and altitude
levels round each route, then local rounds round its best chain), keeps the two cheapest
feasible placements of each beside the graph's own seeds, and polishes the two cheapest of all
on the problem's own cost (:func:`planner.placement.polish`).

Measured (``benchmarks/bench_plan.py``, ``benchmarks/RESULTS.md``): see the issue-20 entries.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from planner import kernels
from planner.placement import (
    Chords,
    Heights64,
    Lattice,
    Terrain,
    corridor_terrain,
    finish_waypoints,
    place,
    polish,
)
from planner.problem import PlanningProblem
from planner.result import flown_checks
from terrain.errors import InputError
from terrain.zones import inflated
from terrain.zoneset import ZoneSet

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

CELLS = 64  # blocks along the map's longer side
CHORD_SAMPLES = 1_000_000  # the most chord samples string pulling holds at once (memory)
ROUTES = 5  # k
STRETCH = 0.6  # a kept route costs at most (1 + STRETCH) x the shortest
OVERLAP = 0.5  # share of a route's nodes that may lie near a kept route
SEED_SHARE = 0.25  # share of the population seeded from the routes (route + jittered copies)
MAX_TRIES = 2000  # via routes built at most (the nodes near a kept route are not tried)
RESOLUTIONS = (48, 96, 160)  # graphs searched by explore_pool (blocks along the longer side)
PLACED = 3  # explore_pool: routes along which the waypoints are placed (planner.placement)
KEEP_PLACED = 2  # explore_pool: the cheapest feasible placements kept per route
POLISHED = 2  # explore_pool: the cheapest placements polished (planner.placement.polish)
DISTINCT = 0.05  # explore_pool: routes closer than this share of the start-goal distance are one
JITTER = 0.02  # graph_population: copies' horizontal jitter, share of the start-goal distance


@dataclass(frozen=True, eq=False)
class Route:
    """One route of the graph: its block centres (start and goal at the ends), its surrogate
    cost, and the solution vector of ``N`` free waypoints made from it."""

    xy: FloatArray  # (M, 2)
    cost: float
    x: FloatArray  # (3N,)
    f: float = math.nan  # the problem's cost of x (explore_pool)
    feasible: bool = False  # whether x is feasible (explore_pool)


@dataclass(frozen=True, eq=False)
class Exploration:
    """What :func:`explore` found: the routes (shortest first), the block size and grid shape,
    and the seconds it took.  From :func:`explore_pool`, ``routes`` are the swarm's seeds: the
    ``distinct`` routes kept of the ``candidates`` its graphs gave, and the placements of the
    waypoints along the best of them (``placed``)."""

    routes: tuple[Route, ...]
    block_m: float
    shape: tuple[int, int]
    nodes: int
    edges: int
    elapsed_s: float
    placement_s: float = 0.0  # of elapsed_s, placing waypoints along the routes (explore_pool)
    candidates: int | None = None  # routes found on every graph (None: those of ``routes``)
    distinct: int | None = None  # of them, kept as distinct (None: every one of ``routes``)
    graphs: int = 1  # graph resolutions searched

    @property
    def placed(self) -> int:
        """Seeds made by placing the waypoints along the best distinct routes."""
        return len(self.routes) - (len(self.routes) if self.distinct is None else self.distinct)

    def summary(self) -> dict[str, object]:
        """Plain data for a result's parameters."""
        return {
            "routes": len(self.routes),
            "candidates": len(self.routes) if self.candidates is None else self.candidates,
            "distinct": len(self.routes) - self.placed,
            "placed": self.placed,
            "graphs": self.graphs,
            "route_costs": [round(r.cost, 6) for r in self.routes],
            "route_F": [round(r.f, 6) for r in self.routes],
            # each route's seed, its free waypoints (drawn in the plan's picture)
            "route_waypoints": [np.round(r.x.reshape(-1, 3), 1).tolist() for r in self.routes],
            "block_m": round(self.block_m, 3),
            "graph": [int(self.shape[0]), int(self.shape[1])],
            "nodes": self.nodes,
            "edges": self.edges,
            "seconds": round(self.elapsed_s, 4),
            "placement_seconds": round(self.placement_s, 4),
        }


def check_routes(k: object) -> int:
    """``k`` as an integer >= 1 (one line naming the option otherwise)."""
    if isinstance(k, bool) or not isinstance(k, int | np.integer) or int(k) < 1:
        raise InputError(
            f"the number of graph routes (--routes) must be an integer >= 1; got {k!r}"
        )
    return int(k)


def explore(
    problem: PlanningProblem,
    k: int = ROUTES,
    *,
    cells: int = CELLS,
    stretch: float = STRETCH,
    overlap: float = OVERLAP,
) -> Exploration:
    """Up to ``k`` short, distinct routes from start to goal over ``problem``'s map (module
    docstring); none when the graph does not connect them."""
    k = check_routes(k)
    t0 = time.perf_counter()
    grid = problem.grid
    check = problem.check_grid  # the terrain the cost checks (conservative, dilated)
    rows, cols = grid.shape
    b = max(1, math.ceil(max(rows, cols) / int(cells)))
    dx, dy = grid.cell_size
    zlo, zhi = problem.band
    top = check.block_max(b)  # computed once per grid and block size, shared
    h = np.maximum(top + problem.clearance, zlo)  # a block's floor
    nr, nc = h.shape
    bad = h > zhi
    unknown = problem.unknown_grid
    if unknown is not None:
        bad |= unknown.block_max(b) > 0  # +1 over unknown terrain, -1 elsewhere
    # block centres (the middle of the block's cells that lie on the map), kept inside the
    # search box
    lo, hi = problem.bounds()
    r_mid = np.minimum(np.arange(nr) * b + (b - 1) / 2.0, (np.arange(nr) * b + rows - 1) / 2.0)
    c_mid = np.minimum(np.arange(nc) * b + (b - 1) / 2.0, (np.arange(nc) * b + cols - 1) / 2.0)
    cx, _ = grid.index_to_xy(np.zeros(nc), c_mid)
    _, cy = grid.index_to_xy(r_mid, np.zeros(nr))
    xs = np.clip(cx, lo[0], hi[0])
    ys = np.clip(cy, lo[1], hi[1])
    node_xy = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    sr, sc = grid.cell_of(problem.start[0], problem.start[1])
    gr, gc = grid.cell_of(problem.goal[0], problem.goal[1])
    s_node = int(sr) // b * nc + int(sc) // b
    g_node = int(gr) // b * nc + int(gc) // b
    bad.flat[[s_node, g_node]] = False
    node_xy[s_node] = problem.start[:2]
    node_xy[g_node] = problem.goal[:2]

    # edges: the four forward neighbours of every node, flown at the highest floor of the
    # blocks the segment crosses (both ends; a diagonal's two corner blocks too)
    idx = np.arange(nr * nc).reshape(nr, nc)
    us, vs = [], []
    for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1)):
        us.append(idx[: nr - di, max(0, -dj) : nc - max(0, dj)].ravel())
        vs.append(idx[di:, max(0, dj) : nc - max(0, -dj)].ravel())
    u = np.concatenate(us)
    v = np.concatenate(vs)
    e, blocked = _edge_floor(h, bad, u, v)
    u, v, e = u[~blocked], v[~blocked], e[~blocked]
    p_u = np.column_stack([node_xy[u], e])
    p_v = np.column_stack([node_xy[v], e])
    if problem.avoid_zones and problem.zones:
        pad = problem.zone_margin + 0.5 * b * math.hypot(dx, dy)
        zs = ZoneSet.of(tuple(inflated(z, pad) for z in problem.zones))
        free = ~(zs.segment_lengths(p_u, p_v) > 0.0).any(axis=1)
        u, v, e, p_u = u[free], v[free], e[free], p_u[free]
        p_v = p_v[free]
    d = p_v - p_u
    length = np.hypot(d[:, 0], d[:, 1])
    hu, hv = h.flat[u], h.flat[v]
    perf = problem.performance
    if perf is not None:  # a climb steeper than the aircraft's costs the distance it needs
        g = min(perf.climb_gradient, perf.descent_gradient)
        spiral = problem.spiral_gradient
        if spiral is None:
            length = np.maximum(length, np.abs(hv - hu) / g)
        else:  # flown in a helix at the climb gradient in a turn, after the leg's own climb
            length = length + np.maximum(0.0, np.abs(hv - hu) - g * length) / min(spiral, g)
    w = length * (1.0 + (e - zlo) / (zhi - zlo))
    if problem.zones and not problem.avoid_zones:  # soft zones: their cost term, in metres
        soft = problem.cost_zones  # the zones as the cost sees them (grown by the margin)
        inside = soft.segment_lengths(p_u, p_v)
        straight = float(np.linalg.norm(problem.goal - problem.start))
        w = w + straight * (inside / soft.sizes[None, :]).sum(axis=1) / len(soft)
    w = np.maximum(w, 1e-9)
    n = nr * nc
    graph = coo_matrix((w, (u, v)), shape=(n, n)).tocsr()
    dist, pred = dijkstra(graph, directed=False, indices=[s_node, g_node], return_predecessors=True)
    routes: list[Route] = []
    best = float(dist[0, g_node])
    if math.isfinite(best):
        routes = _via_routes(
            problem, dist, pred, node_xy, h, (nr, nc), (s_node, g_node), b, (dx, dy), k, best,
            stretch, overlap,
        )  # fmt: skip
    return Exploration(
        tuple(routes),
        float(b * max(dx, dy)),
        (nr, nc),
        int((~bad).sum()),
        len(w),
        time.perf_counter() - t0,
    )


def _edge_floor(
    h: FloatArray, bad: npt.NDArray[np.bool_], u: IntArray, v: IntArray
) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
    """(altitude, blocked) of the edges between neighbouring blocks ``u`` and ``v`` (flat
    indices): the highest floor ``h`` of the blocks the segment crosses -- both ends, and for a
    diagonal the two blocks at its corner -- and whether any of them is ``bad``."""
    nc = h.shape[1]
    ru, cu, rv, cv = u // nc, u % nc, v // nc, v % nc
    e = np.maximum(h[ru, cu], h[rv, cv])
    blocked = bad[ru, cu] | bad[rv, cv]
    diag = (ru != rv) & (cu != cv)
    if diag.any():
        e = np.where(diag, np.maximum(e, np.maximum(h[ru, cv], h[rv, cu])), e)
        blocked = blocked | (diag & (bad[ru, cv] | bad[rv, cu]))
    return np.asarray(e, dtype=np.float64), blocked


def _along(pred: IntArray, top: IntArray, flag: npt.NDArray[np.bool_]) -> FloatArray:
    """For every node, how many flagged nodes its tree path from the root holds (itself
    included); ``top`` lists the nodes root first (by distance), so a parent is counted before
    its children.  Unreached nodes count 0.  The loop runs compiled (``planner.kernels``);
    :func:`_along_py` is its twin."""
    return np.asarray(
        kernels.along(
            np.ascontiguousarray(pred, dtype=np.int64),
            np.ascontiguousarray(top, dtype=np.int64),
            np.ascontiguousarray(flag, dtype=np.bool_),
        )
    )


def _along_py(pred: IntArray, top: IntArray, flag: npt.NDArray[np.bool_]) -> FloatArray:
    """Pure-Python twin of :func:`_along`."""
    out = np.zeros(len(pred))
    f = flag.astype(np.float64)
    for v in top.tolist():
        p = pred[v]
        out[v] = f[v] + (out[p] if p >= 0 else 0.0)
    return out


def _chain(pred: IntArray, target: int) -> list[int]:
    """The nodes from a Dijkstra tree's root to ``target``."""
    out = [target]
    while pred[out[-1]] >= 0:
        out.append(int(pred[out[-1]]))
    return out[::-1]


def _via_routes(
    problem: PlanningProblem,
    dist: FloatArray,
    pred: IntArray,
    node_xy: FloatArray,
    floors: FloatArray,
    shape: tuple[int, int],
    ends_at: tuple[int, int],
    b: int,
    cell: tuple[float, float],
    k: int,
    best: float,
    stretch: float,
    overlap: float,
) -> list[Route]:
    """The via-node routes (module docstring)."""
    nr, nc = shape
    total = dist[0] + dist[1]
    limit = (1.0 + stretch) * best
    order = np.argsort(total, kind="stable")
    order = order[total[order] <= limit]
    # a node both trees enter from the same neighbour is the tip of a spur (the route through
    # it turns back on itself there): not a via node, and cheap to see for every node at once
    order = order[(pred[0][order] != pred[1][order]) | (order == ends_at[0])]
    span = float(np.hypot(*(problem.goal[:2] - problem.start[:2])))
    radius_m = max(3.0 * b * max(cell), 0.05 * span)
    ry, rx = radius_m / (b * cell[1]), radius_m / (b * cell[0])
    yy, xx = np.mgrid[-math.ceil(ry) : math.ceil(ry) + 1, -math.ceil(rx) : math.ceil(rx) + 1]
    disc = (yy / max(ry, 1e-9)) ** 2 + (xx / max(rx, 1e-9)) ** 2 <= 1.0
    ends = _discs((nr, nc), np.asarray(ends_at, dtype=np.int64), disc)
    near = np.zeros((nr, nc), dtype=bool)
    terrain = corridor_terrain(problem)
    routes: list[Route] = []
    tried = np.zeros(nr * nc, dtype=bool)  # on a route already built and refused
    tops = [np.argsort(dist[i], kind="stable") for i in (0, 1)]  # each tree's nodes, root first
    counted_flag = ~ends.ravel()
    lengths = [_along(pred[i], tops[i], counted_flag) for i in (0, 1)]
    share = np.zeros(nr * nc)  # of each via route's counted nodes, near a kept route
    tries = 0
    for via in order.tolist():
        if near.flat[via] or tried[via] or (routes and share[via] >= overlap):
            continue
        tries += 1
        if tries > MAX_TRIES:
            break
        first = _chain(pred[0], via)
        second = _chain(pred[1], via)
        shared = set(first) & set(second[:-1])
        if shared:  # a spur: the route would turn back on itself; its stem gives the same
            tried[list(shared)] = True
            continue
        nodes = first + second[::-1][1:]
        counted = [m for m in nodes if not ends.flat[m]]
        if routes and counted and np.mean(near.flat[counted]) >= overlap:
            # the other nodes of this route would give (nearly) the same route: not tried
            tried[nodes] = True
            continue
        ids = np.asarray(nodes, dtype=np.int64)
        e, _ = _edge_floor(floors, np.zeros_like(floors, dtype=bool), ids[:-1], ids[1:])
        z = np.concatenate([[problem.start[2]], np.maximum(e[:-1], e[1:]), [problem.goal[2]]])
        xyz = np.column_stack([node_xy[nodes], z])
        cost = float(total[via]) / span
        routes.append(Route(xyz[:, :2], cost, route_waypoints(problem, xyz, terrain)))
        near |= _discs((nr, nc), ids, disc)
        if len(routes) == k:
            break
        # every node's via-route share near the kept routes, from both trees at once
        flag = near.ravel() & counted_flag
        hits = [_along(pred[i], tops[i], flag) for i in (0, 1)]
        both = hits[0] + hits[1] - flag
        size = lengths[0] + lengths[1] - counted_flag
        share = np.where(size > 0, both / np.maximum(size, 1), 0.0)
    return routes


def _discs(
    shape: tuple[int, int], nodes: IntArray, disc: npt.NDArray[np.bool_]
) -> npt.NDArray[np.bool_]:
    """The nodes (flat indices into ``shape``) dilated by ``disc`` (odd sides, symmetric about
    its centre): ``scipy.ndimage.binary_dilation`` of their mask with that structure, the same
    cells, by stamping the disc round each node (issue 38: the dilation of the whole graph
    was a tenth of the route search)."""
    out = np.zeros(shape, dtype=bool)
    dy, dx = np.nonzero(disc)
    dy = dy - disc.shape[0] // 2
    dx = dx - disc.shape[1] // 2
    r = (nodes // shape[1])[:, None] + dy[None, :]
    c = (nodes % shape[1])[:, None] + dx[None, :]
    ok = (r >= 0) & (r < shape[0]) & (c >= 0) & (c < shape[1])
    out[r[ok], c[ok]] = True
    return out


def _simplify(xy: FloatArray, n: int) -> FloatArray:
    """``n`` interior points of the polyline ``xy`` by greedy Ramer-Douglas-Peucker (then the
    longest chords halved while there are fewer), start and end kept: (n + 2, 2)."""
    keep = [0, len(xy) - 1]
    while len(keep) < n + 2:
        keep.sort()
        best, at = 0.0, -1
        for a, c in itertools.pairwise(keep):
            if c - a < 2:
                continue
            seg = xy[c] - xy[a]
            pts = xy[a + 1 : c] - xy[a]
            norm = float(np.hypot(*seg))
            if norm > 0:
                dev = np.abs(seg[0] * pts[:, 1] - seg[1] * pts[:, 0]) / norm
            else:
                dev = np.hypot(pts[:, 0], pts[:, 1])
            j = int(np.argmax(dev))
            if dev[j] > best:
                best, at = float(dev[j]), a + 1 + j
        if at < 0 or best <= 1e-9:
            break
        keep.append(at)
    return _halve_longest([xy[i] for i in sorted(keep)], n + 2)


def _halve_longest(pts: list[FloatArray], count: int) -> FloatArray:
    """``pts`` (2-D or 3-D points) with the horizontally longest chord halved, again and again,
    until there are ``count`` of them."""
    pts = list(pts)
    while len(pts) < count:
        lens = [float(np.hypot(*(q - p)[:2])) for p, q in itertools.pairwise(pts)]
        j = int(np.argmax(lens))
        pts.insert(j + 1, 0.5 * (pts[j] + pts[j + 1]))
    return np.asarray(pts, dtype=np.float64)


def _pull(problem: PlanningProblem, xyz: FloatArray, heights: Terrain) -> FloatArray:
    """String pulling along a route in 3-D: from each kept vertex the farthest later route point
    whose straight chord (altitudes linear between their own) clears the terrain floor and enters
    no danger zone (as the cost sees them, grown by the margin), the chords up to the first that
    does not tested together in growing batches (the same answer as one at a time)."""
    zones = problem.cost_zones if problem.zones else None
    out = [0]
    a = 0
    m = len(xyz)
    while a < m - 1:
        j = a + 1
        batch = 4
        while j + 1 < m:
            ends = np.arange(j + 1, min(m, j + 1 + batch))
            ok = _clear_chords(problem, xyz[a], xyz[ends], heights)
            if zones is not None:
                starts = np.broadcast_to(xyz[a], (len(ends), 3))
                ok &= ~(zones.segment_lengths(starts, xyz[ends]) > 0.0).any(axis=1)
            bad = np.flatnonzero(~ok)
            if bad.size:
                j += int(bad[0])
                break
            j += len(ends)
            batch *= 2
        out.append(j)
        a = j
    return np.asarray(xyz[out], dtype=np.float64)


def _clear_chords(
    problem: PlanningProblem, p: FloatArray, qs: FloatArray, heights: Terrain
) -> npt.NDArray[np.bool_]:
    """For each chord p -> qs[i] (3-D, altitude linear), whether it clears the terrain floor at
    the samples :class:`Chords` takes (the same points, bit for bit: quarter-cell steps); the
    compiled loop of :func:`planner.kernels.clear_chords`, which leaves a chord at its first
    sample below (issue 38), :func:`_clear_chords_numpy` its twin."""
    grid = problem.grid
    dx, dy = grid.cell_size
    # the heights as stored (a float32 grid's values read as float64 in the kernel, the same
    # numbers): a float64 copy of the whole map per call was most of string pulling (issue 38)
    raw = heights.heights if isinstance(heights, Heights64) else heights
    return np.asarray(
        kernels.clear_chords(
            np.ascontiguousarray(p, dtype=np.float64),
            np.ascontiguousarray(qs, dtype=np.float64),
            raw if raw.dtype in (np.float32, np.float64) else np.asarray(raw, dtype=np.float64),
            float(grid.transform.c),
            float(grid.transform.f),
            float(dx),
            float(dy),
            0.25 * min(grid.cell_size),
            float(problem.clearance),
        )
    )


def _clear_chords_numpy(
    problem: PlanningProblem, p: FloatArray, qs: FloatArray, heights: FloatArray
) -> npt.NDArray[np.bool_]:
    """The numpy twin of :func:`_clear_chords`: every sample of every chord at once."""
    grid = problem.grid
    step = 0.25 * min(grid.cell_size)
    d = qs - p[None, :]
    counts = np.maximum(2, np.ceil(np.hypot(d[:, 0], d[:, 1]) / step).astype(np.int64) + 1)
    # the chords in groups of at most CHORD_SAMPLES samples (more when one chord has more): on a
    # fine DEM a batch of long chords would otherwise hold millions of samples at once
    ok = np.empty(len(qs), dtype=np.bool_)
    ends = np.cumsum(counts)
    i = 0
    while i < len(qs):
        j = max(i + 1, int(np.searchsorted(ends, ends[i] - counts[i] + CHORD_SAMPLES, "right")))
        ok[i:j] = _clear_group(problem, p, qs[i:j], d[i:j], counts[i:j], heights)
        i = j
    return ok


def _clear_group(
    problem: PlanningProblem,
    p: FloatArray,
    qs: FloatArray,
    d: FloatArray,
    counts: npt.NDArray[np.int64],
    heights: Terrain,
) -> npt.NDArray[np.bool_]:
    """:func:`_clear_chords` of a group of chords, all their samples at once."""
    grid = problem.grid
    idx = np.repeat(np.arange(len(qs)), counts)
    k = np.arange(idx.size) - np.repeat(np.cumsum(counts) - counts, counts)
    t = k * (1.0 / (counts[idx] - 1))  # np.linspace(0, 1, m)'s values, its last exactly 1
    t[np.cumsum(counts) - 1] = 1.0
    x = p[0] + t * d[idx, 0]
    y = p[1] + t * d[idx, 1]
    floor = heights[grid.cell_of(x, y)] + problem.clearance + 1.0
    below = p[2] + t * (qs[idx, 2] - p[2]) < floor
    return np.asarray(np.bincount(idx, weights=below, minlength=len(qs)) == 0, dtype=np.bool_)


def route_waypoints(
    problem: PlanningProblem, xyz: FloatArray, terrain: Terrain | None = None
) -> FloatArray:
    """The solution vector (3N,) of a route ((M, 3): start, block centres at their node
    altitudes, goal) (module docstring, "Waypoints").  ``terrain``: the conservative heights
    widened by the corridor (:func:`corridor_terrain`; computed when not given)."""
    n = problem.n_waypoints
    heights = corridor_terrain(problem) if terrain is None else terrain
    zlo = problem.band[0]
    pulled = _pull(problem, np.asarray(xyz, dtype=np.float64), heights)
    if len(pulled) <= n + 2:  # clear chords: halve the longest until there are N waypoints
        arr = _halve_longest(list(pulled), n + 2)
        xy, z = arr[:, :2].copy(), arr[:, 2].copy()
    else:  # more corners than waypoints: the farthest ones, lifted over their chords
        xy = _simplify(pulled[:, :2], n)
        z = np.full(n + 2, zlo)
        z[0], z[-1] = problem.start[2], problem.goal[2]
        ch = Chords(problem, xy, heights)
        for i in range(1, n + 1):
            z[i] = max(float(ch.floor[i - 1].max()), float(ch.floor[i].max()))
        z[1] = max(z[1], ch.lowest_end(0, z[0]))
        z[n] = max(z[n], ch.lowest_start(n, z[n + 1]))
    return finish_waypoints(problem, xy, z, heights)


def _polyline_gap(a: FloatArray, b: FloatArray, samples: int = 64) -> float:
    """Mean distance from points evenly spaced along polyline ``a`` to polyline ``b`` (2-D)."""

    def along(p: FloatArray) -> FloatArray:
        seg = np.hypot(*np.diff(p, axis=0).T)
        s = np.concatenate([[0.0], np.cumsum(seg)])
        u = np.linspace(0.0, s[-1], samples)
        return np.column_stack([np.interp(u, s, p[:, 0]), np.interp(u, s, p[:, 1])])

    pa, pb = along(a), along(b)
    d = np.hypot(pa[:, None, 0] - pb[None, :, 0], pa[:, None, 1] - pb[None, :, 1])
    return float(d.min(axis=1).mean())


def explore_pool(
    problem: PlanningProblem,
    k: int = ROUTES,
    resolutions: tuple[int, ...] = RESOLUTIONS,
    *,
    placed: int = PLACED,
    polished: int = POLISHED,
) -> Exploration:
    """:func:`explore` at several graph resolutions (a coarse graph sees the broad corridors, a
    fine one the narrow valleys and gaps, and which suits ``N`` waypoints differs from map to
    map), every route scored by the problem's own cost, and the ``k`` best kept (feasible first)
    that are distinct: a route whose waypoint polyline lies on average within ``DISTINCT`` (5 %)
    of the start-goal distance of a kept one is dropped.  Then the waypoints are placed along
    the ``placed`` (3) best kept routes by :func:`planner.placement.place`, and the
    ``KEEP_PLACED`` (2) cheapest feasible placements of each join the routes (cheapest first;
    they share their route's polyline and surrogate cost), the ``polished`` (2) cheapest of them
    moved by :func:`planner.placement.polish` where that is cheaper and still flyable."""
    k = check_routes(k)
    t0 = time.perf_counter()
    found = [explore(problem, k, cells=c) for c in resolutions]
    cands = [r for e in found for r in e.routes]
    finest = found[-1]
    if not cands:
        return replace(
            finest, elapsed_s=time.perf_counter() - t0, candidates=0, graphs=len(resolutions)
        )
    terms = problem.terms(np.array([r.x for r in cands]))
    ok = problem.repairable(terms)
    scored = [(replace(r, f=float(terms.total[i])), bool(ok[i])) for i, r in enumerate(cands)]
    kept = _distinct(problem, scored, k)
    distinct = len(kept)
    t1 = time.perf_counter()
    placing = placed > 0 and problem.agl_pref is None
    if placing:
        heights = corridor_terrain(problem)
        new: list[Route] = []
        lattice = Lattice(problem, heights)
        for r in kept[:placed]:
            xs = place(problem, r.xy, heights, lattice)
            if not xs:
                continue
            terms = problem.terms(np.array(xs))
            ok = problem.repairable(terms)
            best = sorted((float(terms.total[i]), i) for i in range(len(xs)) if ok[i])
            new += [Route(r.xy, r.cost, xs[i], f, True) for f, i in best[:KEEP_PLACED]]
        new.sort(key=lambda r: r.f)
        for j, r in enumerate(new[:polished]):
            x, f = polish(problem, r.x)
            if f < r.f and _flyable(problem, x):
                new[j] = replace(r, x=x, f=f)
        kept = sorted(kept + new, key=lambda r: (not r.feasible, r.f))
    return Exploration(
        tuple(kept),
        finest.block_m,
        finest.shape,
        sum(e.nodes for e in found),
        sum(e.edges for e in found),
        time.perf_counter() - t0,
        placement_s=time.perf_counter() - t1 if placing else 0.0,
        candidates=len(cands),
        distinct=distinct,
        graphs=len(resolutions),
    )


def _flyable(problem: PlanningProblem, x: FloatArray) -> bool:
    """Whether the flown path of a seed whose cost is feasible also passes what a plan's result
    must (:func:`planner.result.flown_checks`)."""
    return flown_checks(problem, problem.flown(problem.paths(x)))[0]


def _distinct(problem: PlanningProblem, scored: list[tuple[Route, bool]], k: int) -> list[Route]:
    """Up to ``k`` of the scored routes (route, feasible), feasible first and cheapest first,
    none whose waypoint polyline lies on average within ``DISTINCT`` of the start-goal distance
    of one kept before it."""
    order = sorted(range(len(scored)), key=lambda i: (not scored[i][1], scored[i][0].f))
    span = float(np.hypot(*(problem.goal[:2] - problem.start[:2])))
    kept: list[Route] = []
    lines: list[FloatArray] = []
    for i in order:
        route, ok = scored[i]
        line = problem.paths(route.x)[:, :2]
        if any(_polyline_gap(line, other) < DISTINCT * span for other in lines):
            continue
        kept.append(replace(route, feasible=ok))
        lines.append(line)
        if len(kept) == k:
            break
    return kept


def graph_population(
    problem: PlanningProblem,
    n: int,
    rng: np.random.Generator,
    k: int = ROUTES,
    *,
    share: float = SEED_SHARE,
) -> tuple[FloatArray, Exploration]:
    """An initial population of ``n`` (module docstring): the ``k`` routes' waypoint vectors
    and jittered copies of them in the first ``max(k, share n)`` rows (at most ``n - 1``), the
    random corridor population (:meth:`PlanningProblem.corridor_population`) in the rest.
    Copies move each waypoint by a normal step of one block horizontally and raise it by the
    absolute value of a normal of 5 % of the band."""
    found = explore_pool(problem, k)
    x0 = problem.corridor_population(n, rng)
    seeds = [r.x for r in found.routes]
    if not seeds:
        return x0, found
    rows = min(n - 1, max(len(seeds), int(round(share * n))))
    jitter = JITTER * float(np.hypot(*(problem.goal[:2] - problem.start[:2])))
    lo, hi = problem.bounds()
    zlo, zhi = problem.band
    out = []
    for j in range(rows):
        base = seeds[j % len(seeds)].reshape(-1, 3).copy()
        if j >= len(seeds):
            base[:, :2] += rng.normal(0.0, jitter, (len(base), 2))
            base[:, 2] += np.abs(rng.normal(0.0, 0.05 * (zhi - zlo), len(base)))
        out.append(np.clip(base.ravel(), lo, hi))
    x0[:rows] = np.asarray(out)
    return x0, found


__all__ = [
    "CELLS",
    "ROUTES",
    "Exploration",
    "Route",
    "check_routes",
    "corridor_terrain",
    "explore",
    "explore_pool",
    "graph_population",
    "route_waypoints",
]
