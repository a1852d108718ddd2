"""How a run looks in Foxglove: the drawing pieces of :mod:`replay.record.recorder`.

The vehicle attitude as a map-frame quaternion (:func:`quaternion_map`), poses, colours, the head
of a track line strip (:func:`line_head`), terrain colours by height (:func:`height_colors`),
terrain mesh decimation (:func:`decimate_mesh`) and the triangle meshes of a superellipsoid threat
(:func:`superellipsoid_mesh`) and of a prism threat, a building (:func:`prism_mesh`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
from foxglove_schemas_protobuf.Vector3_pb2 import Vector3

FloatArray = npt.NDArray[np.float64]

# ---------------------------------------------------------------------------------------------
# geometry helpers

_S = math.sqrt(0.5)


def quaternion_map(phi: float, theta: float, psi: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) attitude of the FLU body in the ENU map frame from 3-2-1 Euler angles: the same
    rotation as :func:`replay.frames.quaternion_map_from_euler`, in plain floats (about 10x faster,
    it runs for every state sample).  q = q(NED->ENU) * q(FRD body->NED) * q(FLU->FRD)."""
    cr, sr = math.cos(0.5 * phi), math.sin(0.5 * phi)
    cp, sp = math.cos(0.5 * theta), math.sin(0.5 * theta)
    cy, sy = math.cos(0.5 * psi), math.sin(0.5 * psi)
    w0 = cr * cp * cy + sr * sp * sy
    x0 = sr * cp * cy - cr * sp * sy
    y0 = cr * sp * cy + sr * cp * sy
    z0 = cr * cp * sy - sr * sp * cy
    return (_S * (x0 + y0), _S * (x0 - y0), _S * (w0 - z0), _S * (w0 + z0))


@functools.cache
def line_head(rgba: tuple[float, float, float, float], *, segments: bool = False) -> bytes:
    """A track line strip (or, with ``segments``, a line list: point pairs) without its points
    (they are appended as wire bytes)."""
    return bytes(
        LinePrimitive(
            type=LinePrimitive.LINE_LIST if segments else LinePrimitive.LINE_STRIP,
            pose=pose(),
            thickness=3.0,
            scale_invariant=True,
            color=color(*rgba),
        ).SerializeToString()
    )


def pose(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> Pose:
    """A pose at (x, y, z) with the identity orientation (never the all-zero quaternion)."""
    return Pose(position=Vector3(x=x, y=y, z=z), orientation=Quaternion(w=1.0))


def color(r: float, g: float, b: float, a: float = 1.0) -> Color:
    """An RGBA colour (0..1)."""
    return Color(r=r, g=g, b=b, a=a)


def height_colors(z: FloatArray) -> FloatArray:
    """(n, 4) RGBA: green lowlands, brown hills, grey-white tops (min..max of z)."""
    span = float(np.ptp(z)) if z.size else 0.0
    h = (z - float(np.min(z))) / span if span > 0 else np.zeros_like(z)
    stops = [0.0, 0.35, 0.7, 1.0]
    rgb = [
        (0.22, 0.45, 0.20),
        (0.55, 0.55, 0.30),
        (0.50, 0.38, 0.25),
        (0.92, 0.92, 0.92),
    ]
    out = np.ones((z.size, 4))
    for c in range(3):
        out[:, c] = np.interp(h, stops, [s[c] for s in rgb])
    return out


def decimate_mesh(
    vertices: FloatArray, faces: npt.NDArray[np.int64], max_triangles: int
) -> tuple[FloatArray, npt.NDArray[np.int64]]:
    """Vertex clustering on a horizontal grid until at most ``max_triangles`` remain (for terrain
    meshes, which are height fields): each cell's vertices merge at their mean, degenerate and
    repeated triangles go.  Returns the mesh unchanged when it is small enough."""
    if len(faces) <= max_triangles:
        return vertices, faces
    lo = vertices[:, :2].min(axis=0)
    span = np.maximum(np.ptp(vertices[:, :2], axis=0), 1e-9)
    cell = math.sqrt(float(span[0] * span[1]) / (max_triangles / 2.0))
    while True:
        ij = np.floor((vertices[:, :2] - lo) / cell).astype(np.int64)
        key = ij[:, 0] * (int(ij[:, 1].max()) + 1) + ij[:, 1]
        _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
        inverse = inverse.reshape(-1)
        merged = np.stack(
            [np.bincount(inverse, weights=vertices[:, k]) / counts for k in range(3)], axis=1
        )
        f = inverse[faces]
        keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
        f = f[keep]
        _, first = np.unique(np.sort(f, axis=1), axis=0, return_index=True)
        f = f[np.sort(first)]
        if len(f) <= max_triangles:
            used, remap = np.unique(f, return_inverse=True)
            return merged[used], remap.reshape(f.shape).astype(np.int64)
        cell *= 1.25


def superellipsoid_mesh(
    axes: Sequence[float], exponents: Sequence[float], n_lon: int = 32, n_lat: int = 16
) -> tuple[FloatArray, npt.NDArray[np.int64]]:
    """Surface of ``|x/a|^(2p) + |y/b|^(2q) + |z/c|^(2r) = 1`` (centred at 0) as a triangle mesh:
    each direction of a UV sphere scaled to the surface (bisection on the radius, vectorised)."""
    lon = np.linspace(0.0, 2 * np.pi, n_lon, endpoint=False)
    lat = np.linspace(-np.pi / 2, np.pi / 2, n_lat + 1)[1:-1]
    la, lo = np.meshgrid(lat, lon, indexing="ij")
    dirs = np.stack([np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)], -1)
    dirs = np.concatenate([dirs.reshape(-1, 3), [[0, 0, -1.0], [0, 0, 1.0]]])
    a = np.asarray(axes, dtype=np.float64)
    e = 2.0 * np.asarray(exponents, dtype=np.float64)
    lo_r = np.zeros(len(dirs))
    hi_r = np.full(len(dirs), float(np.linalg.norm(a)))  # the box corner bounds the body
    for _ in range(50):
        mid = 0.5 * (lo_r + hi_r)
        gamma = np.sum(np.abs(mid[:, None] * dirs / a) ** e, axis=1)
        inside = gamma <= 1.0
        lo_r = np.where(inside, mid, lo_r)
        hi_r = np.where(inside, hi_r, mid)
    points = dirs * lo_r[:, None]
    rows, cols = len(lat), n_lon
    faces: list[tuple[int, int, int]] = []
    for i in range(rows - 1):
        for j in range(cols):
            a0, a1 = i * cols + j, i * cols + (j + 1) % cols
            b0, b1 = a0 + cols, a1 + cols
            faces += [(a0, a1, b1), (a0, b1, b0)]
    south, north = rows * cols, rows * cols + 1
    for j in range(cols):
        faces.append((south, (j + 1) % cols, j))
        top = (rows - 1) * cols
        faces.append((north, top + j, top + (j + 1) % cols))
    return points, np.asarray(faces, dtype=np.int64)


def prism_mesh(
    footprint: npt.ArrayLike, bottom: float, top: float
) -> tuple[FloatArray, npt.NDArray[np.int64]]:
    """A vertical prism over a simple polygon (``footprint``: open ring (V, 2), either
    orientation) from ``bottom`` to ``top`` as a closed triangle mesh, faces counter-clockwise
    seen from outside: two triangles per wall, the caps from shapely's constrained Delaunay
    triangulation (a concave footprint's caps stay inside it)."""
    import shapely

    ring = np.asarray(footprint, dtype=np.float64).reshape(-1, 2)
    r = ring - ring[0]
    if np.sum(r[:, 0] * np.roll(r[:, 1], -1) - np.roll(r[:, 0], -1) * r[:, 1]) < 0:
        ring = ring[::-1]  # counter-clockwise: the walls face out
    n = len(ring)
    points = np.vstack(
        [np.column_stack([ring, np.full(n, bottom)]), np.column_stack([ring, np.full(n, top)])]
    )
    k = np.arange(n)
    k1 = (k + 1) % n
    faces = [np.column_stack([k, k1, n + k1]), np.column_stack([k, n + k1, n + k])]
    tris = shapely.constrained_delaunay_triangles(shapely.Polygon(ring))
    corners = np.array([np.asarray(t.exterior.coords)[:3] for t in tris.geoms]).reshape(-1, 2)
    # each triangle corner is a footprint vertex: its index (the nearest, against rounding)
    d = np.hypot(*(corners[:, None, :] - ring[None, :, :]).transpose(2, 0, 1))
    cap = np.argmin(d, axis=1).astype(np.int64).reshape(-1, 3)
    a, b, c = ring[cap[:, 0]], ring[cap[:, 1]], ring[cap[:, 2]]
    cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]) < 0
    cap[cw] = cap[cw, ::-1]  # counter-clockwise seen from above
    faces += [cap[:, ::-1], cap + n]  # the bottom faces down, the top up
    return points, np.concatenate(faces).astype(np.int64)
