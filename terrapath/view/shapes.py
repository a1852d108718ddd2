"""Triangle meshes of what ``terrapath view`` draws in 3D: threats and danger zones.

A mesh is ``(vertices (N, 3), faces (M, 3) int)`` in map metres.  Every shape is closed (a
threat's volume is a solid, and a closed mesh is what a browser shades right):

- :func:`sphere_mesh` -- a UV sphere (a static threat, each point of a hill, an intruder);
- :func:`superellipsoid_mesh` -- seed 001's convex body
  ``|x/a|^(2p) + |y/b|^(2q) + |z/c|^(2r) = 1`` (:mod:`replay.threats.body`): each vertex of a unit
  sphere is pushed along its direction to the surface (the radial distance solves a monotone
  equation, by bisection), so any exponents >= 0.5 mesh the body's true shape;
- :func:`cylinder_mesh` -- a vertical cylinder with both caps (a cylinder threat, a circular
  danger zone);
- :func:`prism_mesh` -- a polygon (with holes, several parts) extruded between two altitudes (a
  polygon danger zone, a building), its caps triangulated by shapely's constrained Delaunay
  triangulation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
Mesh = tuple[FloatArray, IntArray]


def _uv_sphere(n_lat: int, n_lon: int) -> Mesh:
    """Unit sphere: the two poles and ``n_lat - 1`` rings of ``n_lon`` vertices."""
    lat = np.linspace(0.0, math.pi, n_lat + 1)[1:-1]
    lon = np.linspace(0.0, 2.0 * math.pi, n_lon, endpoint=False)
    ring = np.stack(
        [
            np.outer(np.sin(lat), np.cos(lon)),
            np.outer(np.sin(lat), np.sin(lon)),
            np.repeat(np.cos(lat)[:, None], n_lon, axis=1),
        ],
        axis=-1,
    ).reshape(-1, 3)
    verts = np.vstack([[0.0, 0.0, 1.0], ring, [0.0, 0.0, -1.0]])
    faces: list[tuple[int, int, int]] = []
    last = len(verts) - 1
    for j in range(n_lon):
        j1 = (j + 1) % n_lon
        faces.append((0, 1 + j, 1 + j1))
        base = 1 + (n_lat - 2) * n_lon
        faces.append((last, base + j1, base + j))
    for i in range(n_lat - 2):
        a, b = 1 + i * n_lon, 1 + (i + 1) * n_lon
        for j in range(n_lon):
            j1 = (j + 1) % n_lon
            faces.append((a + j, b + j, b + j1))
            faces.append((a + j, b + j1, a + j1))
    return verts, np.array(faces, dtype=np.int64)


def sphere_mesh(
    center: Sequence[float] | FloatArray, radius: float, n_lat: int = 10, n_lon: int = 18
) -> Mesh:
    v, f = _uv_sphere(n_lat, n_lon)
    return np.asarray(center, dtype=np.float64) + radius * v, f


def superellipsoid_mesh(
    center: Sequence[float],
    axes: Sequence[float],
    exponents: Sequence[float],
    n_lat: int = 16,
    n_lon: int = 24,
) -> Mesh:
    """The body ``sum |u_i / axis_i|^(2 e_i) = 1`` about ``center``: vertex = centre + s u for
    each unit direction u, with s solving ``G(s) = sum (s |u_i| / axis_i)^(2 e_i) = 1`` (G is
    increasing in s, so 60 bisection steps between 0 and the largest axis times sqrt(3) give s
    to ~1e-18 relative)."""
    u, f = _uv_sphere(n_lat, n_lon)
    ax = np.asarray(axes, dtype=np.float64)
    ex = 2.0 * np.asarray(exponents, dtype=np.float64)
    ratio = np.abs(u) / ax
    lo = np.zeros(len(u))
    hi = np.full(len(u), float(ax.max()) * math.sqrt(3.0))
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        inside = ((mid[:, None] * ratio) ** ex).sum(axis=1) <= 1.0
        lo = np.where(inside, mid, lo)
        hi = np.where(inside, hi, mid)
    s = 0.5 * (lo + hi)
    return np.asarray(center, dtype=np.float64) + s[:, None] * u, f


def _walls(ring: FloatArray, bottom: float, top: float, offset: int) -> Mesh:
    """Vertical quads (two triangles each) along a closed ring's edges."""
    n = len(ring)
    verts = np.vstack(
        [np.column_stack([ring, np.full(n, bottom)]), np.column_stack([ring, np.full(n, top)])]
    )
    k = np.arange(n)
    k1 = (k + 1) % n
    faces = np.concatenate([np.column_stack([k, k1, n + k1]), np.column_stack([k, n + k1, n + k])])
    return verts, faces + offset


def cylinder_mesh(
    center_xy: Sequence[float], radius: float, bottom: float, top: float, n: int = 36
) -> Mesh:
    a = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    ring = np.column_stack([center_xy[0] + radius * np.cos(a), center_xy[1] + radius * np.sin(a)])
    wv, wf = _walls(ring, bottom, top, 0)
    cx, cy = float(center_xy[0]), float(center_xy[1])
    verts = np.vstack([wv, [[cx, cy, bottom], [cx, cy, top]]])
    cb, ct = 2 * n, 2 * n + 1
    k = np.arange(n)
    k1 = (k + 1) % n
    caps = np.concatenate(
        [np.column_stack([np.full(n, cb), k1, k]), np.column_stack([np.full(n, ct), n + k, n + k1])]
    )
    return verts, np.concatenate([wf, caps])


def prism_mesh(geometry: Any, bottom: float, top: float) -> Mesh:
    """A shapely (Multi)Polygon extruded from ``bottom`` to ``top``: walls along every ring
    (exterior and holes), caps from its constrained Delaunay triangles."""
    import shapely
    from shapely.geometry.polygon import orient

    polys = list(getattr(geometry, "geoms", [geometry]))
    meshes: list[Mesh] = []
    for poly in polys:
        poly = orient(poly, 1.0)  # exterior anticlockwise, holes clockwise: walls face out
        for ring in [poly.exterior, *poly.interiors]:
            xy = np.asarray(ring.coords, dtype=np.float64)[:-1, :2]
            meshes.append(_walls(xy, bottom, top, 0))
        tris = shapely.constrained_delaunay_triangles(poly)
        for tri in getattr(tris, "geoms", []):
            xy = np.asarray(tri.exterior.coords, dtype=np.float64)[:3, :2]
            (x0, y0), (x1, y1), (x2, y2) = xy
            if (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0) < 0.0:
                xy = xy[::-1]  # anticlockwise: the top faces up, the bottom (reversed) down
            meshes.append((np.column_stack([xy, np.full(3, bottom)]), np.array([[0, 2, 1]])))
            meshes.append((np.column_stack([xy, np.full(3, top)]), np.array([[0, 1, 2]])))
    return merge(meshes)


def merge(meshes: Sequence[Mesh]) -> Mesh:
    """One mesh of several (faces re-indexed)."""
    if not meshes:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    verts, faces, n = [], [], 0
    for v, f in meshes:
        verts.append(v)
        faces.append(np.asarray(f, dtype=np.int64) + n)
        n += len(v)
    return np.vstack(verts), np.vstack(faces)


__all__ = [
    "Mesh",
    "cylinder_mesh",
    "merge",
    "prism_mesh",
    "sphere_mesh",
    "superellipsoid_mesh",
]
