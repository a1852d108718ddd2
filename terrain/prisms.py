"""Length of 3D segments inside vertical polygon prisms (polygon danger zones), vectorised.

A polygon zone is a vertical prism: a horizontal region bounded by rings (the exterior and holes of
one or several parts, in map metres) between an altitude ``floor`` (``-inf`` when open below) and
an altitude ``top`` (``+inf`` when open above).  As for the cylinders (:mod:`terrain.cylinders`),
the ground is not a floor.

Method, for a segment p(t) = p0 + t (p1 - p0), t in [0, 1], of length L:

1. horizontal: the breakpoints are the t where the segment's projection crosses an edge of any ring
   and the ends of the edges it runs along.  Between two consecutive breakpoints the projection is
   wholly inside or wholly outside the region, which the even-odd rule decides at the interval's
   midpoint.  Every ring of every part takes part in one even-odd count, which is exact for a
   valid (Multi)Polygon (parts do not overlap, holes lie inside their exterior);
2. vertical: the set of s = t L where floor <= z(s) <= top is one interval, computed as for the
   cylinders (a segment lying in the floor or top plane counts as inside);
3. the inside length is the sum of the widths of the inside intervals (in metres) clipped to (2).

The prism is closed: a point on a wall, on the floor or on the top is inside, so a segment running
along a wall counts when the arithmetic finds its midpoints on the wall (always for axis-aligned
walls).  Crossings are found with a tolerance of 1e-9 on the edge parameter, so a crossing through
a vertex is never lost to rounding (a spare breakpoint only splits an interval).  Each segment is
evaluated from its lexicographically smaller end, so swapping p0 and p1 gives a bit-identical
result.  NaN coordinates give NaN.

Two implementations with the same arithmetic: :func:`segment_polygon_lengths` runs the numba
kernel ``terrain.kernels.polygon_lengths`` (single-threaded, a loop over segments, prisms and
edges with a box test first); :func:`segment_polygon_lengths_numpy` is the pure-numpy twin the
tests compare it with (a Python loop over the prisms, numpy over segments and edges).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, Literal, NamedTuple

import numpy as np
import numpy.typing as npt

from terrain import kernels
from terrain.cylinders import orient_segments
from terrain.errors import InputError

if TYPE_CHECKING:
    from terrain.zones import PolygonZone

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]
Backend = Literal["numba", "numpy"]

#: tolerance on the edge parameter u of a crossing (see the module docstring)
EDGE_EPS = 1e-9
#: the numpy twin works on blocks of at most this many (segment, interval, edge) triples
_BLOCK = 2_000_000


class PolygonArrays(NamedTuple):
    """Polygon prisms packed for the kernels.

    ``edges`` (E, 4): x0, y0, x1, y1 of every edge of every ring (map metres), prism after prism;
    ``offsets`` (K + 1,): prism k owns ``edges[offsets[k]:offsets[k + 1]]``; ``bboxes`` (K, 4):
    xmin, ymin, xmax, ymax; ``floors`` (K,) with -inf = open below; ``tops`` (K,) with +inf =
    open above.
    """

    edges: FloatArray
    offsets: IntArray
    bboxes: FloatArray
    floors: FloatArray
    tops: FloatArray

    @property
    def n_prisms(self) -> int:
        """The number of prisms K."""
        return int(self.offsets.shape[0] - 1)


def ring_edges(ring: npt.ArrayLike) -> FloatArray:
    """The (V, 4) edges of an open ring of V vertices (V, 2), the closing edge included."""
    r = np.asarray(ring, dtype=np.float64).reshape(-1, 2)
    return np.concatenate([r, np.roll(r, -1, axis=0)], axis=1)


def pack_polygons(
    rings: Iterable[Iterable[npt.ArrayLike]],
    floors: npt.ArrayLike,
    tops: npt.ArrayLike,
) -> PolygonArrays:
    """Pack K prisms given as lists of open rings ((V, 2) arrays, every ring of every part) with
    their floors and tops (K,) into :class:`PolygonArrays`."""
    blocks: list[FloatArray] = []
    counts: list[int] = []
    for prism in rings:
        per_ring = [ring_edges(r) for r in prism]
        block = np.concatenate(per_ring, axis=0) if per_ring else np.zeros((0, 4))
        blocks.append(block)
        counts.append(block.shape[0])
    k = len(blocks)
    f = np.asarray(floors, dtype=np.float64).reshape(-1)
    t = np.asarray(tops, dtype=np.float64).reshape(-1)
    if f.shape != (k,) or t.shape != (k,):
        raise InputError(
            f"floors and tops must have shape ({k},) to match the polygons; got {f.shape} and {t.shape}"
        )
    if any(c < 3 for c in counts):
        raise InputError("every polygon needs at least one ring of 3 or more vertices")
    edges = np.ascontiguousarray(np.concatenate(blocks, axis=0) if blocks else np.zeros((0, 4)))
    offsets = np.zeros(k + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    bboxes = np.empty((k, 4))
    for i, block in enumerate(blocks):
        xs, ys = block[:, 0], block[:, 1]
        bboxes[i] = (xs.min(), ys.min(), xs.max(), ys.max())
    return PolygonArrays(edges, offsets, bboxes, f, t)


def polygon_arrays(zones: Iterable[PolygonZone]) -> PolygonArrays:
    """Pack polygon zones (in their order) for :func:`segment_polygon_lengths`."""
    zs = list(zones)
    return pack_polygons(
        [z.rings for z in zs],
        [-np.inf if z.floor is None else z.floor for z in zs],
        [np.inf if z.top is None else z.top for z in zs],
    )


def _check(p0: npt.ArrayLike, p1: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    a = np.asarray(p0, dtype=np.float64)
    b = np.asarray(p1, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3 or b.shape != a.shape:
        raise InputError(f"segment ends must both have shape (M, 3); got {a.shape} and {b.shape}")
    return orient_segments(a, b)


def _nan_rows(out: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    bad = ~(np.isfinite(a).all(axis=1) & np.isfinite(b).all(axis=1))
    if bad.any():
        out[bad, :] = np.nan
    return out


def segment_polygon_lengths(
    p0: npt.ArrayLike,
    p1: npt.ArrayLike,
    polygons: PolygonArrays,
    backend: Backend = "numba",
) -> FloatArray:
    """Length (m) of each segment p0[m] -> p1[m] ((M, 3) map metres, z AMSL) inside each polygon
    prism k of ``polygons``, shape (M, K).  ``backend="numpy"`` runs the pure-numpy twin."""
    if backend == "numpy":
        return segment_polygon_lengths_numpy(p0, p1, polygons)
    if backend != "numba":
        raise InputError(f"backend must be 'numba' or 'numpy'; got {backend!r}")
    a, b = _check(p0, p1)
    out = kernels.polygon_lengths(
        kernels.read_only(a),
        kernels.read_only(b),
        kernels.read_only(polygons.edges),
        kernels.read_only(polygons.offsets, np.int64),
        kernels.read_only(polygons.bboxes),
        kernels.read_only(polygons.floors),
        kernels.read_only(polygons.tops),
        EDGE_EPS,
    )
    return _nan_rows(np.asarray(out, dtype=np.float64), a, b)


def _in_edges(px: FloatArray, py: FloatArray, edges: FloatArray) -> BoolArray:
    """Numpy twin of ``kernels.point_in_edges`` for points of any shape S: a bool array S."""
    x0, y0, x1, y1 = (edges[:, c] for c in range(4))
    qx, qy = px[..., None], py[..., None]
    cr = (x1 - x0) * (qy - y0) - (y1 - y0) * (qx - x0)
    on = (
        (cr == 0.0)
        & (np.minimum(x0, x1) <= qx)
        & (qx <= np.maximum(x0, x1))
        & (np.minimum(y0, y1) <= qy)
        & (qy <= np.maximum(y0, y1))
    )
    straddle = (y0 > qy) != (y1 > qy)
    with np.errstate(divide="ignore", invalid="ignore"):
        xint = x0 + (qy - y0) * (x1 - x0) / (y1 - y0)
    crossings = np.count_nonzero(straddle & (qx < xint), axis=-1)
    return np.asarray(on.any(axis=-1) | (crossings % 2 == 1))


def points_in_edges(x: npt.ArrayLike, y: npt.ArrayLike, edges: npt.ArrayLike) -> BoolArray:
    """Whether map points (x, y) (broadcast together) lie in the closed region bounded by
    ``edges`` ((E, 4), see :func:`ring_edges`), by the even-odd rule used by the kernel."""
    xa, ya = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    e = np.asarray(edges, dtype=np.float64).reshape(-1, 4)
    flat_x, flat_y = xa.reshape(-1), ya.reshape(-1)
    out = np.empty(flat_x.shape, dtype=np.bool_)
    step = max(1, _BLOCK // max(1, e.shape[0]))
    for lo in range(0, flat_x.shape[0], step):
        out[lo : lo + step] = _in_edges(flat_x[lo : lo + step], flat_y[lo : lo + step], e)
    return out.reshape(xa.shape)


def points_in_polygons(points: npt.ArrayLike, polygons: PolygonArrays) -> BoolArray:
    """True where point n of (N, 3) lies inside prism k (closed), shape (N, K)."""
    q = np.asarray(points, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != 3:
        raise InputError(f"points must have shape (N, 3); got {q.shape}")
    k = polygons.n_prisms
    out = np.zeros((q.shape[0], k), dtype=np.bool_)
    for j in range(k):
        edges = polygons.edges[polygons.offsets[j] : polygons.offsets[j + 1]]
        vertical = (q[:, 2] >= polygons.floors[j]) & (q[:, 2] <= polygons.tops[j])
        if vertical.any():
            out[vertical, j] = points_in_edges(q[vertical, 0], q[vertical, 1], edges)
    return out


def segment_polygon_lengths_numpy(
    p0: npt.ArrayLike, p1: npt.ArrayLike, polygons: PolygonArrays
) -> FloatArray:
    """Pure-numpy twin of :func:`segment_polygon_lengths` (same arithmetic, same summation order;
    no box test, which changes no result)."""
    a, b = _check(p0, p1)
    m, k = a.shape[0], polygons.n_prisms
    out = np.zeros((m, k))
    if m == 0 or k == 0:
        return _nan_rows(out, a, b)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        d = b - a
        dx, dy, dz = d[:, 0:1], d[:, 1:2], d[:, 2:3]
        length = np.hypot(np.hypot(dx, dy), dz)
        static = (dx == 0.0) & (dy == 0.0)
        factor = np.where(dz == 0.0, np.inf, np.clip(length / dz, -1.7e308, 1.7e308))
        ax, ay, az = a[:, 0:1], a[:, 1:2], a[:, 2:3]
        dd = dx * dx + dy * dy
        for j in range(k):
            edges = polygons.edges[polygons.offsets[j] : polygons.offsets[j + 1]]
            # vertical interval [vlo, vhi] of s (NaN bounds ignored, as fmin / fmax do)
            s_top = (polygons.tops[j] - az) * factor
            s_floor = (polygons.floors[j] - az) * factor
            climbing = dz >= 0.0
            vhi = np.where(climbing, np.fmin(length, s_top), np.fmin(length, s_floor))
            vlo = np.where(climbing, np.fmax(0.0, s_floor), np.fmax(0.0, s_top))
            # breakpoints: a crossing (slot 0) or the ends of an edge the segment runs along
            x0, y0, x1, y1 = (edges[None, :, c] for c in range(4))
            fx, fy = x1 - x0, y1 - y0
            wx, wy = x0 - ax, y0 - ay
            denom = dx * fy - dy * fx
            num_u = wx * dy - wy * dx
            t = (wx * fy - wy * fx) / denom
            u = num_u / denom
            cross = (
                (denom != 0.0) & (u >= -EDGE_EPS) & (u <= 1.0 + EDGE_EPS) & (t > 0.0) & (t < 1.0)
            )
            along = (denom == 0.0) & (num_u == 0.0)
            t0 = (wx * dx + wy * dy) / dd
            t1 = ((x1 - ax) * dx + (y1 - ay) * dy) / dd
            slot0 = np.where(cross, t, np.where(along & (t0 > 0.0) & (t0 < 1.0), t0, np.nan))
            slot1 = np.where(along & (t1 > 0.0) & (t1 < 1.0), t1, np.nan)
            slots = np.concatenate([slot0, slot1], axis=1)
            slots[static[:, 0]] = np.nan
            count = int(np.count_nonzero(~np.isnan(slots), axis=1).max(initial=0))
            ts = np.sort(slots, axis=1)[:, :count]  # NaN sort last
            bounds = np.concatenate([np.zeros((m, 1)), ts, np.ones((m, 1))], axis=1)
            # NaN slots of rows with fewer breakpoints: the row's end (1.0) repeats, width 0
            bounds = np.where(np.isnan(bounds), 1.0, bounds)
            prev, cur = bounds[:, :-1], bounds[:, 1:]
            tm = 0.5 * (prev + cur)
            px = ax + tm * dx
            py = ay + tm * dy
            inside = points_in_edges(px, py, edges) & (cur > prev)
            w = np.minimum(cur * length, vhi) - np.maximum(prev * length, vlo)
            w = np.where(inside & (w > 0.0) & (vhi > vlo), w, 0.0)
            total = np.zeros(m)
            for c in range(w.shape[1]):  # in increasing t, as the kernel adds them
                total += w[:, c]
            out[:, j] = total
    return _nan_rows(out, a, b)
