"""`TerrainModel`: the terrain as a triangle mesh, for collision, clearance and ray queries.

Conventions:

- the mesh vertices are the grid's cell centres ``(x, y, height)``, vertex ``r * cols + c`` for
  cell ``(r, c)``; each grid quad is split along its north-west to south-east diagonal into two
  triangles wound counter-clockwise seen from above, so every face normal points up (+z).  The
  mesh is an open surface (a disc), not a watertight solid: "below ground" is decided by comparing
  a point with the surface height, never by inside/outside tests on the mesh;
- every public method takes and returns **map coordinates** (float64 metres: x east, y north,
  z AMSL).  The trimesh mesh is kept in map coordinates too, but fcl and open3d are given vertices
  relative to :attr:`TerrainModel.origin` (grid centre x, y and z = 0): open3d works in float32,
  which at UTM magnitudes (x ~ 4e5, y ~ 4e6) would round to 0.03-0.5 m; relative to the centre of a
  40 km map the rounding is below 2 mm;
- outside the mesh's horizontal extent there is no terrain: rays there hit nothing, and
  :meth:`TerrainModel.surface_height` is NaN;
- decimation (``max_faces``) keeps a subset of the grid's rows and columns, spread evenly and always
  including the first and last, and meshes those cell centres the same way.  Unlike quadric
  decimation this keeps a single connected height field over exactly the same extent, keeps the
  mesh's vertices on the full grid (no vertical bias), and keeps the exact vectorised
  :meth:`surface_height`.  Peaks between kept rows and columns are lowered: the error on a smooth
  surface is at most ``|Hessian| * d**2 / 8`` for a kept-cell diagonal ``d``.  The full grid stays
  available as :attr:`TerrainModel.grid`;
- the fcl BVH (about 8 s for 1.5 M triangles) and the open3d scene are built on first use.
"""

from __future__ import annotations

import math
from functools import cached_property
from typing import Any

import fcl
import numpy as np
import numpy.typing as npt
import open3d as o3d
import trimesh

from terrain import kernels
from terrain.errors import InputError
from terrain.grid import HeightGrid

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]


def airframe_box(length: float, span: float, height: float) -> fcl.Box:
    """An fcl box bounding an airframe: body x forward (length), y to the wing (span), z height."""
    for name, value in (("length", length), ("span", span), ("height", height)):
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"airframe {name} must be a positive number of metres; got {value!r}")
    return fcl.Box(float(length), float(span), float(height))


def airframe_sphere(radius: float) -> fcl.Sphere:
    """An fcl sphere bounding an airframe (orientation-free, the cheapest check)."""
    if not (math.isfinite(radius) and radius > 0):
        raise InputError(f"airframe radius must be a positive number of metres; got {radius!r}")
    return fcl.Sphere(float(radius))


def smallest_extent(shape: fcl.CollisionGeometry) -> float | None:
    """The shape's smallest outer dimension in metres, or None for a shape type not known here."""
    if isinstance(shape, fcl.Sphere | fcl.Capsule):
        return 2.0 * float(shape.radius)
    if isinstance(shape, fcl.Box):
        return float(np.min(shape.side))
    if isinstance(shape, fcl.Cylinder | fcl.Cone):
        return min(2.0 * float(shape.radius), float(shape.lz))
    if isinstance(shape, fcl.Ellipsoid):
        return 2.0 * float(np.min(shape.radii))
    return None


def _points(value: npt.ArrayLike, name: str) -> FloatArray:
    a = np.asarray(value, dtype=np.float64)
    if a.ndim not in (1, 2) or a.shape[-1] != 3:
        raise InputError(
            f"{name} must be one point (3,) or an array of points (N, 3); got {a.shape}"
        )
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name} must be finite numbers; found NaN or infinity")
    return a


def _point(value: npt.ArrayLike, name: str) -> FloatArray:
    a = _points(value, name)
    if a.size != 3:
        raise InputError(f"{name} must be one point (3,); got an array of shape {a.shape}")
    return a.reshape(3)


def _pair(a: npt.ArrayLike, b: npt.ArrayLike, na: str, nb: str) -> tuple[FloatArray, FloatArray]:
    pa, pb = _points(a, na), _points(b, nb)
    try:
        shape = np.broadcast_shapes(pa.shape, pb.shape)
    except ValueError:
        raise InputError(
            f"{na} and {nb} must have the same number of points (or one of them a single point); "
            f"got shapes {pa.shape} and {pb.shape}"
        ) from None
    return np.broadcast_to(pa, shape), np.broadcast_to(pb, shape)


def _flat_pair(
    a: FloatArray, b: FloatArray, na: str, nb: str
) -> tuple[FloatArray, FloatArray, tuple[int, ...]]:
    """``a`` and ``b`` (float64, (3,) or (N, 3)) broadcast together, as C-contiguous (M, 3)
    arrays, and their common shape; else the error :func:`_pair` names.  Both read-only
    (:func:`terrain.kernels.read_only`) whether broadcast (a copy) or not (a view): the
    kernels compiled once."""
    try:
        shape = np.broadcast_shapes(a.shape, b.shape)
    except ValueError:
        shape = None
    if shape is None or any(p.ndim not in (1, 2) or p.shape[-1] != 3 for p in (a, b)):
        _pair(a, b, na, nb)  # raises the error of the one at fault
        raise AssertionError("unreachable")  # pragma: no cover
    flat = (-1, 3)
    fa = kernels.read_only(np.broadcast_to(a, shape).reshape(flat))
    fb = kernels.read_only(np.broadcast_to(b, shape).reshape(flat))
    return fa, fb, shape


def _rotation(value: npt.ArrayLike | None) -> FloatArray:
    if value is None:
        return np.eye(3)
    r = np.asarray(value, dtype=np.float64)
    if r.shape != (3, 3) or not np.all(np.isfinite(r)):
        raise InputError(f"rotation must be a finite 3 x 3 matrix; got shape {r.shape}")
    if not np.allclose(r.T @ r, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0:
        raise InputError("rotation must be a proper rotation matrix (orthonormal, determinant +1)")
    return r


def _kept(n: int, intervals: int) -> IntArray:
    """``intervals + 1`` indices spread evenly over ``0 .. n - 1``, both ends included."""
    return np.unique(np.round(np.linspace(0, n - 1, intervals + 1)).astype(np.int64))


def grid_faces(rows: int, cols: int) -> npt.NDArray[np.int64]:
    """Triangles (2 (rows-1) (cols-1), 3) of a row-major vertex grid, normals up for row 0 north."""
    r, c = np.meshgrid(np.arange(rows - 1), np.arange(cols - 1), indexing="ij")
    v00 = (r * cols + c).ravel()
    v01, v10, v11 = v00 + 1, v00 + cols, v00 + cols + 1
    tri = np.stack([np.stack([v00, v10, v11], -1), np.stack([v00, v11, v01], -1)], axis=1)
    return tri.reshape(-1, 3).astype(np.int64)


def rays_numpy(
    origins: FloatArray, directions: FloatArray, shift: FloatArray
) -> npt.NDArray[np.float32]:
    """The (N, 6) float32 rays open3d casts for origins and directions (N, 3): the origins less
    ``shift``, the directions made unit (in float64, then rounded).  The pure-numpy twin of
    :func:`terrain.kernels.ray_buffer` (which also checks them)."""
    rays = np.empty((*origins.shape[:-1], 6), dtype=np.float32)
    rays[..., :3] = origins - shift
    rays[..., 3:] = directions / np.linalg.norm(directions, axis=-1, keepdims=True)
    return rays


def segment_rays_numpy(
    a: FloatArray, b: FloatArray, tolerance: float, shift: FloatArray
) -> tuple[npt.NDArray[np.float32], FloatArray]:
    """The (N, 6) float32 rays :meth:`TerrainModel.line_of_sight` casts for segments a -> b
    (N, 3), and their lengths: from ``tolerance`` past ``a`` (less ``shift``) along the unit
    direction.  The pure-numpy twin of :func:`terrain.kernels.segment_rays`."""
    v = b - a
    length = np.linalg.norm(v, axis=-1)
    units = v / np.where(length > 0, length, 1.0)[..., None]
    rays = np.empty((*a.shape[:-1], 6), dtype=np.float32)
    rays[..., :3] = a + tolerance * units - shift
    rays[..., 3:] = units
    return rays, length


class TerrainModel:
    """Mesh, fcl BVH and ray-casting scene of a height grid; build with :meth:`from_grid`."""

    def __init__(
        self, grid: HeightGrid, row_idx: IntArray, col_idx: IntArray, max_faces: int | None
    ):
        self.grid = grid
        self.max_faces = max_faces
        self._row_idx, self._col_idx = row_idx, col_idx
        xs, _ = grid.index_to_xy(np.zeros(len(col_idx)), col_idx)
        _, ys = grid.index_to_xy(row_idx, np.zeros(len(row_idx)))
        self._xs, self._ys = xs, ys  # xs increasing, ys decreasing
        self._h = grid.heights[np.ix_(row_idx, col_idx)].astype(np.float64)
        xmin, ymin, xmax, ymax = grid.bounds
        self.origin: FloatArray = np.array([(xmin + xmax) / 2, (ymin + ymax) / 2, 0.0])
        gx, gy = np.meshgrid(xs, ys)
        verts = np.column_stack([gx.ravel(), gy.ravel(), self._h.ravel()])
        faces = grid_faces(len(row_idx), len(col_idx))
        self.mesh = trimesh.Trimesh(verts, faces, process=False, validate=False)
        self._local = verts - self.origin

    @classmethod
    def from_grid(cls, grid: HeightGrid, max_faces: int | None = None) -> TerrainModel:
        """Mesh ``grid``; above ``max_faces`` triangles, mesh a subset of its rows and columns."""
        rows, cols = grid.shape
        if max_faces is not None:
            if isinstance(max_faces, bool) or not isinstance(max_faces, int | np.integer):
                raise InputError(f"max_faces must be an integer or None; got {max_faces!r}")
            if max_faces < 2:
                raise InputError(f"max_faces must be at least 2 (one grid quad); got {max_faces}")
            max_faces = int(max_faces)
        if max_faces is None or 2 * (rows - 1) * (cols - 1) <= max_faces:
            return cls(grid, np.arange(rows), np.arange(cols), max_faces)
        f = math.sqrt(max_faces / (2.0 * (rows - 1) * (cols - 1)))
        nr, nc = max(1, math.floor((rows - 1) * f)), max(1, math.floor((cols - 1) * f))
        if nr >= nc:  # trims the long side only when the short one was clamped to 1 interval
            nr = min(nr, max_faces // (2 * nc))
        else:
            nc = min(nc, max_faces // (2 * nr))
        return cls(grid, _kept(rows, nr), _kept(cols, nc), max_faces)

    def __reduce__(self) -> tuple[Any, ...]:  # fcl and open3d objects do not pickle: rebuild
        return (TerrainModel.from_grid, (self.grid, self.max_faces))

    @property
    def decimated(self) -> bool:
        return self.mesh_shape != self.grid.shape

    @property
    def mesh_shape(self) -> tuple[int, int]:
        """(rows, cols) of cell centres used as mesh vertices."""
        return (len(self._row_idx), len(self._col_idx))

    @property
    def mesh_spacing(self) -> tuple[float, float]:
        """Largest (dx, dy) between neighbouring mesh vertices, metres."""
        return (float(np.max(np.diff(self._xs))), float(np.max(-np.diff(self._ys))))

    # -- surface ----------------------------------------------------------------------------------
    def surface_height(self, x: npt.ArrayLike, y: npt.ArrayLike) -> FloatArray:
        """Height of the mesh surface (exact, float64) at map points; NaN outside the mesh."""
        xa, ya = np.broadcast_arrays(np.asarray(x, np.float64), np.asarray(y, np.float64))
        xs, ys_up = self._xs, self._ys[::-1]
        c0 = np.clip(np.searchsorted(xs, xa, side="right") - 1, 0, len(xs) - 2)
        k = np.clip(np.searchsorted(ys_up, ya, side="right") - 1, 0, len(ys_up) - 2)
        r0 = len(ys_up) - 2 - k  # row index (north) of the quad containing the point
        fc = (xa - xs[c0]) / (xs[c0 + 1] - xs[c0])
        fr = (self._ys[r0] - ya) / (self._ys[r0] - self._ys[r0 + 1])
        h = self._h
        h00, h01, h10, h11 = h[r0, c0], h[r0, c0 + 1], h[r0 + 1, c0], h[r0 + 1, c0 + 1]
        lower = h00 + fr * (h10 - h00) + fc * (h11 - h10)  # triangle (00, 10, 11), fr >= fc
        upper = h00 + fc * (h01 - h00) + fr * (h11 - h01)  # triangle (00, 11, 01), fc >= fr
        z = np.where(fr >= fc, lower, upper)
        inside = (xa >= xs[0]) & (xa <= xs[-1]) & (ya >= ys_up[0]) & (ya <= ys_up[-1])
        return np.asarray(np.where(inside, z, np.nan), dtype=np.float64)

    def _below(self, p: FloatArray) -> BoolArray:
        z = self.surface_height(p[..., 0], p[..., 1])
        return np.asarray(np.isfinite(z) & (p[..., 2] < z))

    # -- fcl: collision and clearance -------------------------------------------------------------
    @cached_property
    def _terrain(self) -> fcl.CollisionObject:
        faces = np.asarray(self.mesh.faces, dtype=np.int32)
        bvh = fcl.BVHModel()
        bvh.beginModel(len(self._local), len(faces))
        bvh.addSubModel(self._local, faces)
        bvh.endModel()
        return fcl.CollisionObject(bvh, fcl.Transform())

    def _place(self, shape: fcl.CollisionGeometry, p: FloatArray, r: FloatArray) -> Any:
        return fcl.CollisionObject(shape, fcl.Transform(r, p - self.origin))

    def _touches(self, obj: fcl.CollisionObject) -> bool:
        return fcl.collide(self._terrain, obj, fcl.CollisionRequest(), fcl.CollisionResult()) > 0

    def collides(
        self,
        shape: fcl.CollisionGeometry,
        position: npt.ArrayLike,
        rotation: npt.ArrayLike | None = None,
    ) -> bool:
        """True if ``shape`` at map ``position`` (rotated by ``rotation``) touches or is below the
        terrain (a shape entirely underground touches no triangle, so its centre is checked too)."""
        p = _point(position, "position")
        if self._below(p):
            return True
        return self._touches(self._place(shape, p, _rotation(rotation)))

    def distance(
        self,
        shape: fcl.CollisionGeometry,
        position: npt.ArrayLike,
        rotation: npt.ArrayLike | None = None,
    ) -> float:
        """Signed clearance in metres: the minimum distance from ``shape`` to the terrain surface if
        it is above ground, 0.0 if it touches the surface, minus that distance if it is buried.

        fcl's own ``distance`` is not used on contact: against a mesh it returns -1 or an
        uninitialised denormal (~1e-320) there, so contact is tested first with ``collide``.
        """
        p = _point(position, "position")
        obj = self._place(shape, p, _rotation(rotation))
        if self._touches(obj):
            return 0.0
        d = float(fcl.distance(self._terrain, obj, fcl.DistanceRequest(), fcl.DistanceResult()))
        return -d if self._below(p) else d

    def sweep_collides(
        self,
        shape: fcl.CollisionGeometry,
        positions: npt.ArrayLike,
        rotations: npt.ArrayLike | None = None,
        step: float | None = None,
    ) -> BoolArray:
        """Per segment of the path ``positions`` (N, 3), whether ``shape`` hits the terrain on it.

        fcl's continuous collision is unreliable against meshes, so each segment is sampled at
        poses no more than ``step`` metres apart (both ends included; default the smaller of half
        the shape's smallest extent and the grid cell size).  ``rotations`` is None, one 3 x 3
        matrix, or one per position (N, 3, 3), interpolated by slerp along each segment.
        Returns a bool array of shape (N - 1,).
        """
        p = _points(positions, "positions")
        if p.ndim != 2 or len(p) < 2:
            raise InputError(f"a sweep needs a path of at least 2 positions (N, 3); got {p.shape}")
        if step is None:
            ext = smallest_extent(shape)
            step = min(self.grid.cell_size) if ext is None else min(ext / 2, *self.grid.cell_size)
        if not (math.isfinite(step) and step > 0):
            raise InputError(f"sweep step must be a positive number of metres; got {step!r}")
        seg_len = np.linalg.norm(np.diff(p, axis=0), axis=1)
        n = np.maximum(1, np.ceil(seg_len / step).astype(np.int64))
        seg = np.repeat(np.arange(len(n)), n + 1)
        t = np.arange(len(seg)) - np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)
        t = t / n[seg]
        samples = p[seg] + t[:, None] * (p[seg + 1] - p[seg])
        rots = self._sweep_rotations(rotations, len(p), seg, t)
        hit = np.zeros(len(n), dtype=bool)
        hit[seg[self._below(samples)]] = True
        for i in np.flatnonzero(~hit[seg]):
            if not hit[seg[i]] and self._touches(self._place(shape, samples[i], rots[i])):
                hit[seg[i]] = True
        return hit

    @staticmethod
    def _sweep_rotations(
        rotations: npt.ArrayLike | None, n: int, seg: IntArray, t: FloatArray
    ) -> FloatArray:
        if rotations is None or np.ndim(rotations) == 2:
            return np.broadcast_to(_rotation(rotations), (len(seg), 3, 3))
        from scipy.spatial.transform import Rotation

        r = np.asarray(rotations, dtype=np.float64)
        if r.shape != (n, 3, 3):
            raise InputError(f"rotations must be None, (3, 3) or ({n}, 3, 3); got {r.shape}")
        for m in r:
            _rotation(m)
        rot = Rotation.from_matrix(r)
        rel = (rot[:-1].inv() * rot[1:]).as_rotvec()
        out = rot[seg] * Rotation.from_rotvec(rel[seg] * t[:, None])
        return np.asarray(out.as_matrix(), dtype=np.float64)

    # -- open3d: rays -----------------------------------------------------------------------------
    @cached_property
    def _scene(self) -> o3d.t.geometry.RaycastingScene:
        scene = o3d.t.geometry.RaycastingScene()
        # keep the buffers alive with the model: from_numpy shares memory rather than copying
        self._scene_buffers = (
            self._local.astype(np.float32),
            np.ascontiguousarray(self.mesh.faces, dtype=np.uint32),
        )
        scene.add_triangles(*(o3d.core.Tensor.from_numpy(a) for a in self._scene_buffers))
        return scene

    def raycast(
        self, origins: npt.ArrayLike, directions: npt.ArrayLike, max_range: float = math.inf
    ) -> FloatArray:
        """Range in metres from each origin along its direction (need not be unit) to the first
        terrain hit; inf where nothing is hit within ``max_range``.  Shape (N,), or () for one ray.

        The rays are checked, made relative to :attr:`origin`, normalised and written in
        open3d's float32 layout in one compiled pass (:func:`terrain.kernels.ray_buffer`, the
        arithmetic of :func:`rays_numpy`), and the ranges read back in another
        (:func:`terrain.kernels.ranges_within`): at a million rays the numpy passes cost a tenth
        of open3d's own time (issue 38).
        """
        o, d, shape = _flat_pair(
            np.asarray(origins, dtype=np.float64),
            np.asarray(directions, dtype=np.float64),
            "origins",
            "directions",
        )
        rays = np.empty((o.shape[0], 6), dtype=np.float32)
        bad = kernels.ray_buffer(o, d, self.origin, rays)
        if bad & 1:
            raise InputError("origins must be finite numbers; found NaN or infinity")
        if bad & 2:
            raise InputError("directions must be finite numbers; found NaN or infinity")
        if bad & 4:
            raise InputError("ray directions must be non-zero vectors; found a zero direction")
        if math.isnan(max_range) or max_range <= 0:
            raise InputError(f"max_range must be positive (inf for unlimited); got {max_range!r}")
        answer = self._scene.cast_rays(o3d.core.Tensor.from_numpy(rays))
        t = kernels.ranges_within(answer["t_hit"].numpy(), float(max_range))
        return np.asarray(t.reshape(shape[:-1]))

    def hit_points(
        self, origins: npt.ArrayLike, directions: npt.ArrayLike, max_range: float = math.inf
    ) -> FloatArray:
        """Map xyz of each ray's first terrain hit (as :meth:`raycast`); NaN rows for misses."""
        o, d = _pair(origins, directions, "origins", "directions")
        t = self.raycast(o, d, max_range)
        units = d / np.linalg.norm(d, axis=-1, keepdims=True)
        with np.errstate(invalid="ignore"):
            return np.asarray(np.where(np.isfinite(t)[..., None], o + t[..., None] * units, np.nan))

    def line_of_sight(
        self, a: npt.ArrayLike, b: npt.ArrayLike, tolerance: float = 0.01
    ) -> BoolArray:
        """True where the straight segment a -> b (map points) meets no terrain between a and b.

        Hits within ``tolerance`` metres of either end do not block, so an observer or a target
        sitting on the surface sees and is seen (float32 ray casting rounds hits by millimetres).
        """
        if not (math.isfinite(tolerance) and tolerance >= 0):
            raise InputError(
                f"tolerance must be a non-negative number of metres; got {tolerance!r}"
            )
        a0 = np.asarray(a, dtype=np.float64)
        b0 = np.asarray(b, dtype=np.float64)
        pa, pb, shape = _flat_pair(a0, b0, "a", "b")
        rays = np.empty((pa.shape[0], 6), dtype=np.float32)
        # from tolerance past a (past a surface at a), in one compiled pass (segment_rays_numpy)
        length, finite = kernels.segment_rays(pa, pb, float(tolerance), self.origin, rays)
        if not finite:
            _pair(a0, b0, "a", "b")  # raises the error of the one at fault
            raise AssertionError("unreachable")  # pragma: no cover
        t = self._scene.cast_rays(o3d.core.Tensor.from_numpy(rays))["t_hit"].numpy()
        return np.asarray(kernels.clear_segments(t, length, float(tolerance)).reshape(shape[:-1]))
