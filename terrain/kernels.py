"""Compiled hot loops (numba). Every kernel here has a pure-numpy twin in the module that uses it,
and the tests compare the two; keep the arithmetic of both identical.

Kernels take plain arrays only (no grid objects) so that they compile once and cache on disk
(``NUMBA_CACHE_DIR``).
"""

from __future__ import annotations

import numba as nb
import numpy as np


def read_only(a: np.ndarray, dtype: type = np.float64) -> np.ndarray:
    """``a`` as a C-contiguous array of ``dtype``, read-only -- a read-only view where it is one
    already, so the caller's own array keeps its flags.  numba compiles a kernel once per mix
    of read-only and writable arguments: the callers of a kernel hand it this one kind (issue
    38: a fresh test suite compiled ``segment_rays`` four times, ``cylinder_lengths`` three)."""
    out: np.ndarray = np.ascontiguousarray(a, dtype=dtype)
    if out.flags.writeable:
        out = out.view()
        out.flags.writeable = False
    return out


@nb.njit(cache=True, nogil=True)
def bresenham_cells(r0: int, c0: int, r1: int, c1: int) -> np.ndarray:  # pragma: no cover - jit
    """The cells of the integer Bresenham line from (r0, c0) to (r1, c1), both ends included.

    Classic integer error form: step along the major axis; step the minor axis when the
    accumulated error D becomes positive (ties stay, ``D > 0``).
    """
    dr = abs(r1 - r0)
    dc = abs(c1 - c0)
    sr = 1 if r1 >= r0 else -1
    sc = 1 if c1 >= c0 else -1
    n = max(dr, dc)
    out = np.empty((n + 1, 2), dtype=np.int64)
    if dc >= dr:
        d = 2 * dr - dc
        r = r0
        for k in range(n + 1):
            out[k, 0] = r
            out[k, 1] = c0 + sc * k
            if d > 0:
                r += sr
                d -= 2 * dc
            d += 2 * dr
    else:
        d = 2 * dc - dr
        c = c0
        for k in range(n + 1):
            out[k, 0] = r0 + sr * k
            out[k, 1] = c
            if d > 0:
                c += sc
                d -= 2 * dr
            d += 2 * dc
    return out


@nb.njit(cache=True, nogil=True)
def segment_table(
    a: np.ndarray, b: np.ndarray, left: float, top: float, dx: float, dy: float
) -> np.ndarray:  # pragma: no cover - jit
    """The (M, 7) table :func:`below_lengths` walks: fractional row and col of both ends
    (``HeightGrid.xy_to_index``: ``(top - y) / dy - 0.5``, ``(x - left) / dx - 0.5``), z of both
    ends and the 3D length (``sqrt((dx^2 + dy^2) + dz^2)``, ``np.linalg.norm``'s order), for
    segments ``a[i] -> b[i]`` ((M, 3) map metres).  Its twin is
    :func:`terrain.segments.segment_table_numpy`."""
    m = a.shape[0]
    out = np.empty((m, 7))
    for i in range(m):
        out[i, 0] = (top - a[i, 1]) / dy - 0.5
        out[i, 1] = (a[i, 0] - left) / dx - 0.5
        out[i, 2] = (top - b[i, 1]) / dy - 0.5
        out[i, 3] = (b[i, 0] - left) / dx - 0.5
        out[i, 4] = a[i, 2]
        out[i, 5] = b[i, 2]
        ex = b[i, 0] - a[i, 0]
        ey = b[i, 1] - a[i, 1]
        ez = b[i, 2] - a[i, 2]
        out[i, 6] = np.sqrt(ex * ex + ey * ey + ez * ez)
    return out


@nb.njit(cache=True, nogil=True)
def path_segment_table(
    paths: np.ndarray, left: float, top: float, dx: float, dy: float
) -> np.ndarray:  # pragma: no cover - jit
    """:func:`segment_table` of the segments of (P, W, 3) polylines, path after path (the rows
    ``paths[:, :-1].reshape(-1, 3) -> paths[:, 1:].reshape(-1, 3)`` give), read straight from
    the paths: no copies of the segments' ends (issue 38).  The same arithmetic."""
    n_p, n_w = paths.shape[0], paths.shape[1]
    out = np.empty((n_p * (n_w - 1), 7))
    i = 0
    for q in range(n_p):
        for j in range(n_w - 1):
            ax, ay, az = paths[q, j, 0], paths[q, j, 1], paths[q, j, 2]
            bx, by, bz = paths[q, j + 1, 0], paths[q, j + 1, 1], paths[q, j + 1, 2]
            out[i, 0] = (top - ay) / dy - 0.5
            out[i, 1] = (ax - left) / dx - 0.5
            out[i, 2] = (top - by) / dy - 0.5
            out[i, 3] = (bx - left) / dx - 0.5
            out[i, 4] = az
            out[i, 5] = bz
            ex = bx - ax
            ey = by - ay
            ez = bz - az
            out[i, 6] = np.sqrt(ex * ex + ey * ey + ez * ez)
            i += 1
    return out


BLOCK = 16  # cells per side of the block maxima below_lengths skips terrain with
SKIP_MARGIN = 1e-6  # metres: a chunk is skipped only when clear by more than rounding


@nb.njit(cache=True, nogil=True)
def _t_of(
    k: int, n: int, maj0: int, smaj: int, f0: float, span: float
) -> float:  # pragma: no cover
    """Parameter of the centre of Bresenham cell k along the major axis, clamped to [0, 1]."""
    if n == 0 or span == 0.0:
        return 0.5
    return min(max((maj0 + smaj * k - f0) / span, 0.0), 1.0)


@nb.njit(cache=True, nogil=True, inline="always")
def _cell_below(
    k: int,
    n: int,
    maj0: int,
    smaj: int,
    f0: float,
    span: float,
    kt: int,
    t_kt: float,
    t_kt1: float,
    z0: float,
    z1: float,
    ground: float,
    low: float,
) -> tuple[bool, float, int, float, float]:  # pragma: no cover - jit
    """(whether cell k's part of the segment runs below ``ground``, its width in t, and the kt,
    t_kt, t_kt1 to carry on with).  A cell whose ground lies below the chunk's lowest point
    ``low`` is clear without its t (a part's lowest point is no lower than the chunk's lowest:
    the rounded operations are monotone).  The t values of cells kt and kt + 1 (``t_kt``,
    ``t_kt1``) are reused when kt is the previous cell (the same numbers: :func:`_t_of` is a
    function of k)."""
    if low > ground:
        return False, 0.0, kt, t_kt, t_kt1
    if kt == k - 1:
        t_prev, t_cur = t_kt, t_kt1
    else:
        t_prev = _t_of(k - 1, n, maj0, smaj, f0, span) if k > 0 else 0.0
        t_cur = _t_of(k, n, maj0, smaj, f0, span)
    t_next = _t_of(k + 1, n, maj0, smaj, f0, span) if k < n else 0.0
    hi = 0.5 * (t_cur + t_next) if k < n else 1.0
    lo = 0.0 if k == 0 else 0.5 * (t_prev + t_cur)
    z = z0 + (lo if z1 >= z0 else hi) * (z1 - z0)  # the part's lowest point
    return z < ground, hi - lo, k, t_cur, t_next


@nb.njit(cache=True, nogil=True)
def below_lengths(
    seg: np.ndarray, heights: np.ndarray, clearance: float, blocks: np.ndarray
) -> np.ndarray:  # pragma: no cover - jit
    """Length of each segment that runs below ``terrain + clearance``.

    ``seg`` is (M, 7): fractional row and col of both ends, z of both ends, 3D length. Each
    Bresenham cell k stands for the part of the segment between the midpoints of its parameter
    t_k and its neighbours' (t_k is where the cell centre projects on the major axis); that part is
    below ground when the segment's lowest altitude over it (at one of its ends) is below the
    cell's height plus clearance.

    ``blocks`` (``HeightGrid.block_maxima``: :func:`terrain.grid.block_max` of ``heights``) lets
    the walk skip: the cells are taken in chunks of at most BLOCK steps that end where the major
    axis enters the next block (issue 38: its box is one block long on that axis, not two; the
    kernel ~10 % faster on a swarm's calls); a chunk's cells lie in the box spanned by its first
    and last cell (the line is monotone in both axes), and when the lowest altitude of its
    cells' parts clears the highest block over that box by more than SKIP_MARGIN, no cell of it
    can be below and the walk jumps
    to the next chunk (the Bresenham state there from its closed form, minor_k =
    floor((2 k d_minor + d_major - 1) / (2 d_major))).  Inside a chunk that is walked, a cell
    whose height + clearance lies below the chunk's lowest altitude is passed without its part's
    parameters (issue 38: on a swarm's paths only one walked cell in four is below; the
    parameters a cell needs are carried to the next), and a chunk whose box lies on the grid
    walks the flat index of its cells without clamping them.  Skipped cells add nothing, so the
    result is bit-identical to the full walk; a segment well above the ground costs a sixteenth
    of it.

    Single-threaded on purpose: a swarm's call is a few hundred segments (~0.2 ms), too small to
    gain from numba's threads, and with ``parallel=True`` a plan took 20x longer whenever another
    CPU-bound process shared the machine (issue 12: 0.16 s idle, 3.16 s beside one busy process)
    — campaigns run one process per core. benchmarks/bench_plan.py --under-load measures it.
    """
    m = seg.shape[0]
    rows = heights.shape[0]
    cols = heights.shape[1]
    out = np.zeros(m)
    flat = heights.ravel()  # a view: the caller passes C-contiguous heights
    for i in range(m):
        fr0 = seg[i, 0]
        fc0 = seg[i, 1]
        fr1 = seg[i, 2]
        fc1 = seg[i, 3]
        z0 = seg[i, 4]
        z1 = seg[i, 5]
        length = seg[i, 6]
        # walk from the lexicographically smaller end, so a segment and its reverse visit the
        # same cells (Bresenham's tie-breaks depend on the direction)
        if (fr1, fc1, z1) < (fr0, fc0, z0):
            fr0, fc0, z0, fr1, fc1, z1 = fr1, fc1, z1, fr0, fc0, z0
        r0 = int(np.floor(fr0 + 0.5))
        c0 = int(np.floor(fc0 + 0.5))
        r1 = int(np.floor(fr1 + 0.5))
        c1 = int(np.floor(fc1 + 0.5))
        dr = abs(r1 - r0)
        dc = abs(c1 - c0)
        sr = 1 if r1 >= r0 else -1
        sc = 1 if c1 >= c0 else -1
        n = max(dr, dc)
        col_major = dc >= dr
        if col_major:
            f0 = fc0
            span = fc1 - fc0
            maj0, smaj, min0, smin, dmin = c0, sc, r0, sr, dr
            n_maj, n_min = cols, rows
        else:
            f0 = fr0
            span = fr1 - fr0
            maj0, smaj, min0, smin, dmin = r0, sr, c0, sc, dc
            n_maj, n_min = rows, cols
        total = 0.0
        # the last t values computed: t of cell kt in t_kt, of cell kt + 1 in t_kt1
        kt = -2
        t_kt = 0.0
        t_kt1 = 0.0
        k = 0
        while k <= n:
            # chunk [k, k_end]: up to where the major axis leaves its block (at most BLOCK
            # steps; BLOCK steps off the grid), so that its box spans one block along that
            # axis; the Bresenham state at k in closed form (minor_k =
            # floor((2 k d_minor + d_major - 1) / (2 d_major)), the error term to match)
            maj_k = maj0 + smaj * k
            if 0 <= maj_k < n_maj:
                k_end = min(k + (BLOCK - 1 - maj_k % BLOCK if smaj > 0 else maj_k % BLOCK), n)
            else:
                k_end = min(k + BLOCK - 1, n)
            steps = (2 * k * dmin + n - 1) // (2 * n) if n else 0
            minor = min0 + smin * steps
            d = 2 * dmin - n + 2 * k * dmin - 2 * n * steps
            minor_end = min0 + smin * ((2 * k_end * dmin + n - 1) // (2 * n) if n else 0)
            maj_a = min(max(maj0 + smaj * k, 0), n_maj - 1)
            maj_b = min(max(maj0 + smaj * k_end, 0), n_maj - 1)
            min_a = min(max(minor, 0), n_min - 1)
            min_b = min(max(minor_end, 0), n_min - 1)
            if col_major:
                ra, rb, ca, cb = min_a, min_b, maj_a, maj_b
            else:
                ra, rb, ca, cb = maj_a, maj_b, min_a, min_b
            top = -np.inf
            for br in range(min(ra, rb) // BLOCK, max(ra, rb) // BLOCK + 1):
                for bc in range(min(ca, cb) // BLOCK, max(ca, cb) // BLOCK + 1):
                    if blocks[br, bc] > top:
                        top = blocks[br, bc]
            # the chunk's parts run from t_a to t_b (the first's lower end, the last's upper);
            # its lowest altitude is at one of them
            t_k = _t_of(k, n, maj0, smaj, f0, span)
            t_e = _t_of(k_end, n, maj0, smaj, f0, span)
            t_a = 0.0 if k == 0 else 0.5 * (_t_of(k - 1, n, maj0, smaj, f0, span) + t_k)
            t_b = 1.0 if k_end == n else 0.5 * (t_e + _t_of(k_end + 1, n, maj0, smaj, f0, span))
            low = min(z0 + t_a * (z1 - z0), z0 + t_b * (z1 - z0))
            if low > top + clearance + SKIP_MARGIN:
                k = k_end + 1
                continue
            if (
                min_a == minor
                and min_b == minor_end
                and maj_a == maj0 + smaj * k
                and maj_b == maj0 + smaj * k_end
            ):
                # the chunk's cells all lie on the grid (its box does): walk the flat index
                # of the cells, without clamping
                if col_major:
                    at = minor * cols + maj0 + smaj * k
                    step_maj, step_min = smaj, smin * cols
                else:
                    at = (maj0 + smaj * k) * cols + minor
                    step_maj, step_min = smaj * cols, smin
                while k <= k_end:
                    ground = flat[at] + clearance
                    below, width, kt, t_kt, t_kt1 = _cell_below(
                        k, n, maj0, smaj, f0, span, kt, t_kt, t_kt1, z0, z1, ground, low
                    )
                    if below:
                        total += width * length
                    # Bresenham step to the next cell
                    if d > 0:
                        at += step_min
                        d -= 2 * n
                    d += 2 * dmin
                    at += step_maj
                    k += 1
                continue
            # a chunk reaching off the grid: its cells outside take the nearest edge cell's
            # height
            while k <= k_end:
                if col_major:
                    r, c = minor, maj0 + smaj * k
                else:
                    r, c = maj0 + smaj * k, minor
                rr = min(max(r, 0), rows - 1)
                cc = min(max(c, 0), cols - 1)
                ground = heights[rr, cc] + clearance
                below, width, kt, t_kt, t_kt1 = _cell_below(
                    k, n, maj0, smaj, f0, span, kt, t_kt, t_kt1, z0, z1, ground, low
                )
                if below:
                    total += width * length
                # Bresenham step to the next cell
                if d > 0:
                    minor += smin
                    d -= 2 * n
                d += 2 * dmin
                k += 1
        out[i] = total
    return out


@nb.njit(cache=True, nogil=True)
def run_sums(x: np.ndarray, runs: int) -> np.ndarray:  # pragma: no cover - jit
    """``x.reshape(runs, S, K).sum(axis=1)`` of an (runs * S, K) array (S >= 1) with K >= 2, in
    numpy's order there: each run's rows added one after the other from its first (numpy walks
    the K columns innermost and the S rows in order).  A tenth of the time of numpy's reduction,
    whose inner loop runs over only K numbers (issue 38).  For K == 1 numpy sums each run
    pairwise instead: the caller keeps numpy's sum then."""
    s_n = x.shape[0] // runs
    k_n = x.shape[1]
    out = np.empty((runs, k_n))
    for r in range(runs):
        base = r * s_n
        for k in range(k_n):
            out[r, k] = x[base, k]
        for s in range(1, s_n):
            for k in range(k_n):
                out[r, k] += x[base + s, k]
    return out


@nb.njit(cache=True, nogil=True, error_model="numpy")
def point_in_edges(
    px: float, py: float, edges: np.ndarray, e0: int, e1: int
) -> bool:  # pragma: no cover - jit
    """Whether (px, py) lies in the closed region bounded by ``edges[e0:e1]`` (even-odd rule).

    A point on an edge (zero cross product, inside the edge's box) is inside; otherwise a
    horizontal ray to +x toggles the parity at every edge that straddles ``py`` (half-open in y,
    so a vertex is counted once) with its crossing to the right of the point.
    """
    inside = False
    for j in range(e0, e1):
        x0 = edges[j, 0]
        y0 = edges[j, 1]
        x1 = edges[j, 2]
        y1 = edges[j, 3]
        cr = (x1 - x0) * (py - y0) - (y1 - y0) * (px - x0)
        if (
            cr == 0.0
            and min(x0, x1) <= px
            and px <= max(x0, x1)
            and min(y0, y1) <= py
            and py <= max(y0, y1)
        ):
            return True
        if (y0 > py) != (y1 > py):
            xint = x0 + (py - y0) * (x1 - x0) / (y1 - y0)
            if px < xint:
                inside = not inside
    return inside


@nb.njit(cache=True, nogil=True, error_model="numpy")
def polygon_lengths(
    a: np.ndarray,
    b: np.ndarray,
    edges: np.ndarray,
    offsets: np.ndarray,
    bboxes: np.ndarray,
    floors: np.ndarray,
    tops: np.ndarray,
    eps: float,
) -> np.ndarray:  # pragma: no cover - jit
    """Length of each segment a[m] -> b[m] ((M, 3), oriented by the caller) inside each polygon
    prism k, shape (M, K).  Prism k has the edges ``edges[offsets[k]:offsets[k + 1]]`` ((E, 4):
    x0, y0, x1, y1 of every ring edge, all rings and parts together), the box ``bboxes[k]``
    (xmin, ymin, xmax, ymax) and the altitudes ``floors[k] <= z <= tops[k]`` (-inf / +inf when open).

    With t in [0, 1] along the segment's horizontal projection: the breakpoints are the t where it
    crosses an edge (edge parameter u within [-eps, 1 + eps], so a crossing through a vertex is
    never lost to rounding; a spare breakpoint only splits an interval) and the ends of edges it
    runs along; between two breakpoints the projection is wholly inside or wholly outside, which
    the midpoint decides (:func:`point_in_edges`).  Every inside interval, in metres along the
    segment (s = t * L), is clipped to the vertical interval of s where floor <= z(s) <= top
    (computed as in :mod:`terrain.cylinders`), and the widths are summed in increasing t.
    Single-threaded: one call per swarm evaluation, too small for threads to pay.  Division
    follows numpy (``error_model="numpy"``: x / 0 is inf or NaN, never an exception), as the twin's.
    """
    m = a.shape[0]
    k_count = offsets.shape[0] - 1
    out = np.zeros((m, k_count))
    max_edges = 0
    for k in range(k_count):
        max_edges = max(max_edges, offsets[k + 1] - offsets[k])
    ts = np.empty(2 * max_edges + 1)
    for i in range(m):
        ax = a[i, 0]
        ay = a[i, 1]
        az = a[i, 2]
        dx = b[i, 0] - ax
        dy = b[i, 1] - ay
        dz = b[i, 2] - az
        length = np.hypot(np.hypot(dx, dy), dz)
        static = dx == 0.0 and dy == 0.0
        if dz == 0.0:
            factor = np.inf
        else:
            factor = min(max(length / dz, -1.7e308), 1.7e308)
        sxmin = min(ax, b[i, 0])
        sxmax = max(ax, b[i, 0])
        symin = min(ay, b[i, 1])
        symax = max(ay, b[i, 1])
        for k in range(k_count):
            if (
                sxmax < bboxes[k, 0]
                or sxmin > bboxes[k, 2]
                or symax < bboxes[k, 1]
                or symin > bboxes[k, 3]
            ):
                continue
            # vertical interval [vlo, vhi] of s; NaN bounds (level in the plane) are ignored
            vlo = 0.0
            vhi = length
            s_top = (tops[k] - az) * factor
            s_floor = (floors[k] - az) * factor
            if dz >= 0.0:
                if s_top < vhi:
                    vhi = s_top
                if s_floor > vlo:
                    vlo = s_floor
            else:
                if s_top > vlo:
                    vlo = s_top
                if s_floor < vhi:
                    vhi = s_floor
            if not vhi > vlo:
                continue
            e0 = offsets[k]
            e1 = offsets[k + 1]
            n = 0
            if not static:
                dd = dx * dx + dy * dy
                for j in range(e0, e1):
                    x0 = edges[j, 0]
                    y0 = edges[j, 1]
                    fx = edges[j, 2] - x0
                    fy = edges[j, 3] - y0
                    wx = x0 - ax
                    wy = y0 - ay
                    denom = dx * fy - dy * fx
                    num_u = wx * dy - wy * dx
                    if denom != 0.0:
                        t = (wx * fy - wy * fx) / denom
                        u = num_u / denom
                        if u >= -eps and u <= 1.0 + eps and t > 0.0 and t < 1.0:
                            ts[n] = t
                            n += 1
                    elif num_u == 0.0:  # along the edge's line: its ends are breakpoints
                        t0 = (wx * dx + wy * dy) / dd
                        t1 = ((edges[j, 2] - ax) * dx + (edges[j, 3] - ay) * dy) / dd
                        if t0 > 0.0 and t0 < 1.0:
                            ts[n] = t0
                            n += 1
                        if t1 > 0.0 and t1 < 1.0:
                            ts[n] = t1
                            n += 1
                # insertion sort: n is small (a few crossings)
                for p in range(1, n):
                    v = ts[p]
                    q = p - 1
                    while q >= 0 and ts[q] > v:
                        ts[q + 1] = ts[q]
                        q -= 1
                    ts[q + 1] = v
            total = 0.0
            prev = 0.0
            for p in range(n + 1):
                cur = ts[p] if p < n else 1.0
                if cur > prev:
                    tm = 0.5 * (prev + cur)
                    if point_in_edges(ax + tm * dx, ay + tm * dy, edges, e0, e1):
                        w = min(cur * length, vhi) - max(prev * length, vlo)
                        if w > 0.0:
                            total += w
                prev = cur
            out[i, k] = total
    return out


@nb.njit(cache=True, nogil=True)
def cylinder_lengths(
    a_in: np.ndarray,
    b_in: np.ndarray,
    c: np.ndarray,
    r: np.ndarray,
    top: np.ndarray,
    floor: np.ndarray,
    floors: bool,
) -> np.ndarray:  # pragma: no cover - jit
    """Length of each segment a[m] -> b[m] inside each cylinder k, (M, K): the scalar twin of
    ``terrain.cylinders._lengths`` (same operations in the same order, so bit-identical), with the
    ends ordered here as ``orient_segments`` does.  ``floors`` False skips the floor bound as the
    numpy version does when every floor is -inf."""
    m = a_in.shape[0]
    k_n = c.shape[0]
    out = np.empty((m, k_n))
    tiny = 2.0**-52
    # a cylinder whose footprint's box lies farther than its radius (plus a margin far above
    # rounding) from the segment's horizontal box cannot hold any of it: its length is 0.0, as
    # the full computation gives it (perp >= r there clamps ``half`` to 0, so hi <= lo), and a
    # segment far from every cylinder skips that computation (issue 38: most of a swarm's
    # segments are nowhere near the zones)
    reach = np.empty(k_n)
    for k in range(k_n):
        reach[k] = abs(r[k]) * (1.0 + 1e-9) + 1e-6
    far = np.zeros(k_n, dtype=np.bool_)
    for i in range(m):
        ax, ay, az = a_in[i, 0], a_in[i, 1], a_in[i, 2]
        bx, by, bz = b_in[i, 0], b_in[i, 1], b_in[i, 2]
        plain = True  # finite and far from overflow: the length is finite too
        for v in (ax, ay, az, bx, by, bz):
            if not abs(v) < 1e100:
                plain = False
        n_far = 0
        if plain:
            x_lo, x_hi = min(ax, bx), max(ax, bx)
            y_lo, y_hi = min(ay, by), max(ay, by)
            for k in range(k_n):
                cx, cy, rk = c[k, 0], c[k, 1], reach[k]
                # NaN centres, radii, tops or floors compare False: never "far" (NaN below)
                far[k] = (
                    (x_lo - cx > rk or cx - x_hi > rk or y_lo - cy > rk or cy - y_hi > rk)
                    and not np.isnan(top[k])
                    and not np.isnan(floor[k])
                )
                if far[k]:
                    n_far += 1
            if n_far == k_n:
                for k in range(k_n):
                    out[i, k] = 0.0
                continue
        else:
            far[:] = False
        if (bx < ax) or (bx == ax and ((by < ay) or (by == ay and bz < az))):
            ax, ay, az, bx, by, bz = bx, by, bz, ax, ay, az
        dx, dy, dz = bx - ax, by - ay, bz - az
        length = np.hypot(np.hypot(dx, dy), dz)
        hor = np.hypot(dx, dy)
        moving = hor > length * tiny
        safe_hor = hor if moving else 1.0
        scale = length / safe_hor
        ux = dx / safe_hor
        uy = dy / safe_hor
        if dz == 0.0:
            factor = np.inf
        else:
            factor = min(max(length / dz, -1.7e308), 1.7e308)
        bad_segment = not np.isfinite(length)
        for k in range(k_n):
            if far[k]:
                out[i, k] = 0.0
                continue
            cx, cy, rk = c[k, 0], c[k, 1], r[k]
            if bad_segment or np.isnan(cx) or np.isnan(cy) or np.isnan(rk):
                out[i, k] = np.nan
                continue
            if np.isnan(top[k]) or np.isnan(floor[k]):
                out[i, k] = np.nan
                continue
            wx = ax - cx
            wy = ay - cy
            if moving:
                perp = wx * uy - wy * ux
                mid = wx * ux
                mid += wy * uy
                mid *= -scale
                half = rk * rk - perp * perp
                if half < 0.0:
                    half = 0.0
                half = np.sqrt(half) * scale
                lo = mid - half
                hi = mid + half
            elif wx * wx + wy * wy <= rk * rk:
                lo = -np.inf
                hi = np.inf
            else:
                lo = np.inf
                hi = -np.inf
            if lo < 0.0:
                lo = 0.0
            if hi > length:
                hi = length
            s_top = (top[k] - az) * factor
            if dz >= 0.0:
                if s_top < hi:  # fmin: a NaN s_top leaves hi
                    hi = s_top
            elif s_top > lo:
                lo = s_top
            if floors:
                s_floor = (floor[k] - az) * factor
                if dz >= 0.0:
                    if s_floor > lo:
                        lo = s_floor
                elif s_floor < hi:
                    hi = s_floor
            w = hi - lo
            out[i, k] = w if w > 0.0 else 0.0
    return out


@nb.njit(cache=True, nogil=True, error_model="numpy")
def ray_buffer(
    origins: np.ndarray, directions: np.ndarray, shift: np.ndarray, rays: np.ndarray
) -> int:  # pragma: no cover - jit
    """Fill ``rays`` ((N, 6) float32, open3d's layout) with ``origins - shift`` and the unit
    ``directions`` ((N, 3) float64 each) in one pass: the arithmetic of
    ``terrain.model.rays_numpy`` (``norm = sqrt(x^2 + y^2 + z^2)``, ``d / norm``, both in float64,
    then rounded to float32), so the rays are bit-identical.  Returns a bit mask of what was
    wrong (nothing written is then used): 1 a non-finite origin, 2 a non-finite direction, 4 a
    zero direction."""
    bad = 0
    for i in range(origins.shape[0]):
        ox, oy, oz = origins[i, 0], origins[i, 1], origins[i, 2]
        dx, dy, dz = directions[i, 0], directions[i, 1], directions[i, 2]
        if not (np.isfinite(ox) and np.isfinite(oy) and np.isfinite(oz)):
            bad |= 1
        if not (np.isfinite(dx) and np.isfinite(dy) and np.isfinite(dz)):
            bad |= 2
        norm = np.sqrt(dx * dx + dy * dy + dz * dz)
        if norm == 0.0:
            bad |= 4
        rays[i, 0] = ox - shift[0]
        rays[i, 1] = oy - shift[1]
        rays[i, 2] = oz - shift[2]
        rays[i, 3] = dx / norm
        rays[i, 4] = dy / norm
        rays[i, 5] = dz / norm
    return bad


@nb.njit(cache=True, nogil=True)
def ranges_within(t_hit: np.ndarray, max_range: float) -> np.ndarray:  # pragma: no cover - jit
    """open3d's float32 ``t_hit`` as float64, inf beyond ``max_range`` (and for NaN): the
    arithmetic of ``np.where(t.astype(float64) <= max_range, t, inf)``."""
    out = np.empty(t_hit.shape[0])
    for i in range(t_hit.shape[0]):
        v = np.float64(t_hit[i])
        out[i] = v if v <= max_range else np.inf
    return out


@nb.njit(cache=True, nogil=True, error_model="numpy")
def segment_rays(
    a: np.ndarray, b: np.ndarray, tolerance: float, shift: np.ndarray, rays: np.ndarray
) -> tuple[np.ndarray, bool]:  # pragma: no cover - jit
    """The rays of :meth:`terrain.model.TerrainModel.line_of_sight` for segments a -> b ((N, 3)
    float64 each) in one pass: fill ``rays`` ((N, 6) float32) with the unit directions ``(b -
    a) / |b - a|`` (``/ 1`` for a zero segment) and the origins ``a + tolerance * unit`` less
    ``shift``, the arithmetic of ``terrain.model.segment_rays_numpy`` (``|v| = sqrt(x^2 + y^2
    + z^2)`` in float64, rounded to float32 last).  Returns the segments' lengths (N,) and
    whether every coordinate was finite (if not, nothing written is used)."""
    n = a.shape[0]
    length = np.empty(n)
    finite = True
    for i in range(n):
        ax, ay, az = a[i, 0], a[i, 1], a[i, 2]
        vx, vy, vz = b[i, 0] - ax, b[i, 1] - ay, b[i, 2] - az
        if not (np.isfinite(ax) and np.isfinite(ay) and np.isfinite(az)):
            finite = False
        if not (np.isfinite(b[i, 0]) and np.isfinite(b[i, 1]) and np.isfinite(b[i, 2])):
            finite = False
        norm = np.sqrt(vx * vx + vy * vy + vz * vz)
        d = norm if norm > 0.0 else 1.0
        ux, uy, uz = vx / d, vy / d, vz / d
        rays[i, 0] = (ax + tolerance * ux) - shift[0]
        rays[i, 1] = (ay + tolerance * uy) - shift[1]
        rays[i, 2] = (az + tolerance * uz) - shift[2]
        rays[i, 3] = ux
        rays[i, 4] = uy
        rays[i, 5] = uz
        length[i] = norm
    return length, finite


@nb.njit(cache=True, nogil=True)
def clear_segments(
    t_hit: np.ndarray, length: np.ndarray, tolerance: float
) -> np.ndarray:  # pragma: no cover - jit
    """Whether each segment of :func:`segment_rays` is clear: shorter than twice the tolerance,
    or open3d's float32 ``t_hit`` (as float64) reaches its length less twice the tolerance --
    ``(length <= 2 tol) | (t >= length - 2 tol)``."""
    out = np.empty(length.shape[0], dtype=np.bool_)
    for i in range(length.shape[0]):
        out[i] = length[i] <= 2 * tolerance or np.float64(t_hit[i]) >= length[i] - 2 * tolerance
    return out


@nb.njit(cache=True, nogil=True)
def bilinear(
    heights: np.ndarray, x: np.ndarray, y: np.ndarray, left: float, top: float, dx: float, dy: float
) -> tuple[np.ndarray, bool]:  # pragma: no cover - jit
    """Bilinear heights at map points ``x``, ``y`` (1-D, float64) of a (rows, cols) grid whose
    top-left corner is (``left``, ``top``) with cells ``dx`` by ``dy``, and whether every point
    was finite (the heights of the others are NaN).  Its twin is
    :func:`terrain.grid.bilinear_numpy` (``HeightGrid.height_at``): clamped to the cell-centre
    lines, the same operations in the same order."""
    rows, cols = heights.shape
    n = x.shape[0]
    out = np.empty(n)
    finite = True
    for i in range(n):
        xi, yi = x[i], y[i]
        if not (np.isfinite(xi) and np.isfinite(yi)):
            finite = False
            out[i] = np.nan
            continue
        col = (xi - left) / dx - 0.5
        row = (top - yi) / dy - 0.5
        r = min(max(row, 0.0), rows - 1.0)
        c = min(max(col, 0.0), cols - 1.0)
        r0 = min(np.int64(np.floor(r)), rows - 2)
        c0 = min(np.int64(np.floor(c)), cols - 2)
        fr = r - r0
        fc = c - c0
        h00 = np.float64(heights[r0, c0])
        h01 = np.float64(heights[r0, c0 + 1])
        h10 = np.float64(heights[r0 + 1, c0])
        h11 = np.float64(heights[r0 + 1, c0 + 1])
        upper = h00 + (h01 - h00) * fc
        lower = h10 + (h11 - h10) * fc
        out[i] = upper + (lower - upper) * fr
    return out, finite
