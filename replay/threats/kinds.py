"""The threat kinds of a replay and their geometry: what a pop-up threat is, once validated.

Threats are read from a threat file (DESIGN §5) by :mod:`replay.threats.file`, which validates every
field at the edge; the classes here check their own fields again when built directly.  Every
threat has an ``id``, ``appears_at`` (seconds after the start, >= 0) and an optional
``disappears_at`` (> ``appears_at``); it is *active* for ``appears_at <= t < disappears_at``.
Positions are map metres (x east, y north, z metres AMSL, :mod:`replay.frames`).  The kinds:

``static`` (:class:`StaticThreat`, seed 000 §2.1.2) -- a centre and a safety radius R > 0: the
    safety sphere.  ``separation(p) = |p - c| - R`` (exact).  By default (seed 000) the sphere
    is a safety distance round a point: the radar sees the point, never the radius.  With
    ``solid`` (true) the sphere is a body the radar sees whole -- a balloon, a cloud, a declared
    volume -- and it measures the centre and the radius (:mod:`replay.sensors.radar`).
``hill`` (:class:`HillThreat`, seed 000 §2.1.2, §5.3) -- points and one radius for all points or
    one per point: a mountain modelled as a group of point obstacles, each with its safety sphere.
    ``separation(p) = min_k (|p - c_k| - R_k)`` (exact for the union of spheres).  Points closer
    than 1 km form one continuous obstacle (:func:`replay.threats.clusters.cluster_hill_points`); one
    entry may hold several such clusters, and the boundary ("terminal") points of a cluster seen
    from the aircraft are the ones an avoider goes round
    (:func:`replay.threats.clusters.cluster_terminals`).
``body`` (seed 001 eq 3) -- a convex superellipsoid: :class:`replay.threats.body.BodyThreat`, in a
    module of its own (its separation has no closed form).
``cylinder`` (:class:`CylinderThreat`) -- a centre (x, y), ``radius``, ``top`` and optional
    ``bottom`` (default -inf): a solid vertical cylinder.  Separation is the exact signed distance
    to the solid: with ``dr = rho - R`` (rho the horizontal distance to the axis) and
    ``dz = max(bottom - z, z - top)``, ``hypot(dr, dz)`` when both are > 0, else ``max(dr, dz)``
    (negative inside: minus the depth).
``prism`` (:class:`PrismThreat`) -- a building: a polygon ``footprint`` (x, y), ``top`` and
    optional ``bottom`` (default -inf; the threat file defaults it to the ground under the
    footprint when it has a map grid): a solid vertical prism.  The footprint is one simple
    polygon (at least 3 distinct vertices, no self-intersection, no holes), stored as an open
    counter-clockwise ring.  Separation is the exact signed distance to the solid, combined as
    for the cylinder with ``dr`` the signed horizontal distance to the polygon's boundary
    (negative inside: minus the distance to the nearest edge), vectorised over points and edges.
``intruder`` (:class:`IntruderThreat`) -- a moving object with a safety ``radius``, either

    - a start position and ``velocity`` (east, north, up, m/s), optional ``stops_at`` (s,
      >= ``appears_at``): ``p(t) = position + velocity (clip(t, appears_at, stops_at) -
      appears_at)`` -- it is at ``position`` when it appears and stands still after ``stops_at``;
    - ``waypoints`` (>= 2) flown at ``speed`` (m/s, > 0) from the first one at ``appears_at``,
      piecewise-linear at constant speed, holding at the last one; with ``loop`` it flies back to
      the first and repeats.  ``p(t)`` is vectorised over t.

    Separation is ``|p - p(t)| - R``.  ``solid`` as for ``static``: by default the radar sees
    the intruder's position only (seed 000); with ``solid`` it measures its sphere.  (Flying an intruder with its own 6-DOF model is left to the
    simulation; here its path is kinematic.)

Every threat has ``active(t)``, ``position(t)`` (centre or reference point: a static centre, the
hill's first point, the body centre, the centre of the cylinder's top face, the footprint's
centroid at a prism's top, the intruder), ``velocity(t)``,
``separation(p, t)`` (map metres, negative inside; vectorised over points (..., 3) and, for
intruders, over times broadcast with them), ``violates(p, t)`` (separation < 0), ``radar_points``
(what the radar sees, see :mod:`replay.sensors.radar`), ``shape(t)``, a plain dict for the recorder:
``{"id", "kind": "sphere"|"cylinder"|"ellipsoid"|"prism", "center", "radius"|"axes"|"footprint",
"top", "bottom"}`` (a hill's ``center`` and ``radius`` are lists, one per point, and ``shapes(t)``
splits it into spheres ``"<id>/<k>"``; a cylinder's ``center`` is its mid-height point, or the
top-face centre when it has no bottom, which is then ``None``, and a prism's likewise over its
centroid, its ``footprint`` the open ring ``[[x, y], ...]``; an ellipsoid also carries its
``exponents``), and
``to_record()``, its entry of a threat file.

:class:`ThreatSet` holds the threats of one file in file order; :meth:`ThreatSet.warn_after` lists
threats that appear after the mission ends.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from replay.frames import as_points
from replay.threats.clusters import cluster_hill_points
from terrain.docfile import finite_number as _finite
from terrain.errors import InputError, where

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]
Vec3 = tuple[float, float, float]


# -- field checks of the constructors -------------------------------------------------------------
def _positive(value: Any, what: str) -> float:
    out = _finite(value, what)
    if out <= 0:
        raise InputError(f"{what} must be > 0; got {value!r}")
    return out


def _vec(value: Any, n: int, what: str) -> tuple[float, ...]:
    try:
        items = list(value)
    except TypeError:
        raise InputError(f"{what} must be {n} numbers; got {value!r}") from None
    if len(items) != n:
        raise InputError(f"{what} must be {n} numbers; got {len(items)}")
    return tuple(_finite(v, what) for v in items)


def finite_vec3(value: Any, what: str) -> Vec3:
    """``value`` as three finite floats (``what`` names it in the error)."""
    x, y, z = _vec(value, 3, what)
    return (x, y, z)


# -- threats ------------------------------------------------------------------------------------
@dataclass(frozen=True, kw_only=True)
class Threat:
    """Base of the six threat kinds: id and activity window (seconds after the start)."""

    id: str
    appears_at: float = 0.0
    disappears_at: float | None = None

    kind: ClassVar[str] = "threat"
    extended: ClassVar[bool] = False  # True: the radar sees the nearest point of a solid body

    def __post_init__(self) -> None:
        if not isinstance(self.id, str) or not self.id:
            raise InputError(f"threat id must be non-empty text; got {self.id!r}")
        t0 = _finite(self.appears_at, f"threat {self.id!r} appears_at")
        if t0 < 0:
            raise InputError(f"threat {self.id!r} appears_at must be >= 0 s; got {t0}")
        object.__setattr__(self, "appears_at", t0)
        if self.disappears_at is not None:
            t1 = _finite(self.disappears_at, f"threat {self.id!r} disappears_at")
            if t1 <= t0:
                raise InputError(
                    f"threat {self.id!r} disappears_at ({t1}) must be after appears_at ({t0})"
                )
            object.__setattr__(self, "disappears_at", t1)

    def active(self, t: float) -> bool:
        """True for ``appears_at <= t < disappears_at``."""
        return bool(t >= self.appears_at and (self.disappears_at is None or t < self.disappears_at))

    def position(self, t: npt.ArrayLike = 0.0) -> FloatArray:
        """Reference point (map xyz) at time(s) t: shape (3,) or t.shape + (3,)."""
        raise NotImplementedError

    def velocity(self, t: npt.ArrayLike = 0.0) -> FloatArray:
        """Velocity (m/s, east, north, up) at time(s) t; zero for everything but intruders."""
        return np.zeros((*np.shape(t), 3))

    def separation(self, p: npt.ArrayLike, t: npt.ArrayLike = 0.0) -> FloatArray:
        """Distance (m) from map point(s) p (..., 3) to the threat's surface; negative inside."""
        raise NotImplementedError

    def violates(self, p: npt.ArrayLike, t: npt.ArrayLike = 0.0) -> BoolArray:
        return np.asarray(self.separation(p, t) < 0.0)

    def radar_points(
        self, t: float, observer: npt.ArrayLike, max_range: float = math.inf
    ) -> tuple[list[str], FloatArray]:
        """(ids, points (K, 3)) the radar can see at time t from ``observer``; points certainly
        farther than ``max_range`` may be left out (the caller still tests the range)."""
        return [self.id], self.position(t).reshape(1, 3)

    def shape(self, t: float = 0.0) -> dict[str, Any]:
        raise NotImplementedError

    def shapes(self, t: float = 0.0) -> list[dict[str, Any]]:
        """The threat as single primitives (one per hill point)."""
        return [self.shape(t)]

    def to_record(self) -> dict[str, Any]:
        rec: dict[str, Any] = {"id": self.id, "kind": self.kind}
        if self.appears_at:
            rec["appears_at"] = self.appears_at
        if self.disappears_at is not None:
            rec["disappears_at"] = self.disappears_at
        return rec


def _check_flag(threat: Threat, name: str) -> None:
    """A true/false field of ``threat`` (``solid``, ``loop``), refused otherwise."""
    value = getattr(threat, name)
    if not isinstance(value, bool):
        raise InputError(f"threat {threat.id!r} {name} must be true or false; got {value!r}")


def sized_radius(threat: Threat) -> float | None:
    """The radius the radar measures of a threat it sees as a sphere (``solid``), else None."""
    if isinstance(threat, StaticThreat | IntruderThreat) and threat.solid:
        return threat.radius
    return None


def _sphere(ident: str, c: Sequence[float], r: float) -> dict[str, Any]:
    cz = float(c[2])
    return {
        "id": ident,
        "kind": "sphere",
        "center": [float(v) for v in c],
        "radius": float(r),
        "top": cz + r,
        "bottom": cz - r,
    }


@dataclass(frozen=True, kw_only=True)
class StaticThreat(Threat):
    """A point obstacle with a safety sphere (seed 000): centre (x, y, z) and radius R."""

    center: Vec3
    radius: float
    solid: bool = False  # True: the radar sees the sphere (centre and radius), not a point

    kind: ClassVar[str] = "static"

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "center", finite_vec3(self.center, f"threat {self.id!r} position"))
        object.__setattr__(self, "radius", _positive(self.radius, f"threat {self.id!r} radius"))
        _check_flag(self, "solid")

    def position(self, t: npt.ArrayLike = 0.0) -> FloatArray:
        return np.broadcast_to(np.array(self.center), (*np.shape(t), 3)).copy()

    def separation(self, p: npt.ArrayLike, t: npt.ArrayLike = 0.0) -> FloatArray:
        d = as_points(p) - np.array(self.center)
        return np.asarray(np.linalg.norm(d, axis=-1) - self.radius)

    def shape(self, t: float = 0.0) -> dict[str, Any]:
        return _sphere(self.id, self.center, self.radius)

    def to_record(self) -> dict[str, Any]:
        rec = {**super().to_record(), "position": list(self.center), "radius": self.radius}
        return {**rec, "solid": True} if self.solid else rec


@dataclass(frozen=True, kw_only=True)
class HillThreat(Threat):
    """A hill as a group of point obstacles, each with a safety sphere (seed 000 §5.3)."""

    points: tuple[Vec3, ...]
    radii: tuple[float, ...]

    kind: ClassVar[str] = "hill"

    def __post_init__(self) -> None:
        super().__post_init__()
        what = f"threat {self.id!r}"
        pts = tuple(finite_vec3(v, f"{what} points") for v in self.points)
        if not pts:
            raise InputError(f"{what} points: a hill needs at least one point")
        radii = tuple(_positive(r, f"{what} radius") for r in self.radii)
        if len(radii) == 1 and len(pts) > 1:
            radii = radii * len(pts)
        if len(radii) != len(pts):
            raise InputError(f"{what} needs one radius or one per point ({len(pts)})")
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "radii", radii)
        object.__setattr__(self, "_p", np.array(pts, dtype=np.float64))
        object.__setattr__(self, "_r", np.array(radii, dtype=np.float64))
        object.__setattr__(self, "_clusters", cluster_hill_points(self._p))

    _p: FloatArray = dataclasses.field(init=False, repr=False, compare=False)
    _r: FloatArray = dataclasses.field(init=False, repr=False, compare=False)
    _clusters: tuple[IntArray, ...] = dataclasses.field(init=False, repr=False, compare=False)

    @property
    def clusters(self) -> tuple[IntArray, ...]:
        """Index arrays of the continuous obstacles (points closer than 1 km, single linkage)."""
        return self._clusters

    @property
    def points_array(self) -> FloatArray:
        return self._p.copy()

    def position(self, t: npt.ArrayLike = 0.0) -> FloatArray:
        return np.broadcast_to(self._p[0], (*np.shape(t), 3)).copy()

    def separation(self, p: npt.ArrayLike, t: npt.ArrayLike = 0.0) -> FloatArray:
        q = as_points(p)
        d = np.linalg.norm(q[..., None, :] - self._p, axis=-1) - self._r
        return np.asarray(d.min(axis=-1))

    def radar_points(
        self, t: float, observer: npt.ArrayLike, max_range: float = math.inf
    ) -> tuple[list[str], FloatArray]:
        return [f"{self.id}/{k}" for k in range(len(self._p))], self._p.copy()

    def shape(self, t: float = 0.0) -> dict[str, Any]:
        return {
            "id": self.id,
            "kind": "sphere",
            "center": self._p.tolist(),
            "radius": self._r.tolist(),
            "top": float(np.max(self._p[:, 2] + self._r)),
            "bottom": float(np.min(self._p[:, 2] - self._r)),
        }

    def shapes(self, t: float = 0.0) -> list[dict[str, Any]]:
        return [
            _sphere(f"{self.id}/{k}", c, r)
            for k, (c, r) in enumerate(zip(self._p, self._r, strict=True))
        ]

    def to_record(self) -> dict[str, Any]:
        radius: Any = self.radii[0] if len(set(self.radii)) == 1 else list(self.radii)
        return {**super().to_record(), "points": [list(p) for p in self.points], "radius": radius}


EDGE_SUFFIXES = ("#left", "#right")  # the outline returns of a solid (radar_points)


def solid_separation(dr: npt.ArrayLike, dz: npt.ArrayLike) -> FloatArray:
    """The signed distance to a vertical solid (a cylinder, a prism) from the horizontal signed
    distance ``dr`` to its outline and the vertical one ``dz`` outside [bottom, top] (both
    negative inside): ``hypot(dr, dz)`` beyond an edge (both > 0), else the larger of the two."""
    r = np.asarray(dr, dtype=np.float64)
    z = np.asarray(dz, dtype=np.float64)
    both = (r > 0) & (z > 0)
    return np.asarray(
        np.where(both, np.hypot(np.maximum(r, 0), np.maximum(z, 0)), np.maximum(r, z))
    )


def outline_edges(observer: npt.ArrayLike, boundary: npt.ArrayLike, z: float) -> FloatArray | None:
    """The left and right edges (2, 3) of a solid's horizontal section as seen from
    ``observer``: of the section's ``boundary`` points (K, 2), the two at the extreme bearings
    about the bearing of their centroid (left: counter-clockwise), at altitude ``z``; None when
    the observer is inside the section (the outline then surrounds it)."""
    o = np.asarray(observer, dtype=np.float64).reshape(-1)
    b = np.asarray(boundary, dtype=np.float64).reshape(-1, 2)
    rel = b - o[:2]
    c = rel.mean(axis=0)
    ang = np.arctan2(rel[:, 0], rel[:, 1]) - math.atan2(float(c[0]), float(c[1]))
    ang = (ang + np.pi) % (2.0 * np.pi) - np.pi
    if float(ang.max() - ang.min()) >= math.pi - 1e-9 or float(np.hypot(*c)) < 1e-9:
        return None
    out = np.empty((2, 3))
    out[0, :2] = b[int(np.argmin(ang))]
    out[1, :2] = b[int(np.argmax(ang))]
    out[:, 2] = z
    return out


def circle_edges(
    observer: npt.ArrayLike, center: Sequence[float], radius: float, z: float
) -> FloatArray | None:
    """:func:`outline_edges` of a circle, in closed form: the two tangent points from the
    observer (None inside it)."""
    o = np.asarray(observer, dtype=np.float64).reshape(-1)
    dx, dy = center[0] - o[0], center[1] - o[1]
    d = math.hypot(dx, dy)
    if d <= radius:
        return None
    beta = math.atan2(dx, dy)
    alpha = math.asin(radius / d)
    length = math.sqrt(d * d - radius * radius)
    out = np.empty((2, 3))
    for k, bearing in enumerate((beta - alpha, beta + alpha)):
        out[k] = (o[0] + length * math.sin(bearing), o[1] + length * math.cos(bearing), z)
    return out


def _near_and_edges(
    ident: str, near: FloatArray, edges: FloatArray | None
) -> tuple[list[str], FloatArray]:
    """``radar_points`` of an extended threat: the nearest point (``ident``), then the outline's
    edges when there are any (``ident`` + each of ``EDGE_SUFFIXES``)."""
    if edges is None:
        return [ident], near
    return [ident, *(ident + s for s in EDGE_SUFFIXES)], np.vstack([near, edges])


def _bottom_and_middle(top: float, bottom: float) -> tuple[float | None, float]:
    """For ``shape``: the bottom (None when unbounded below) and the height the shape's centre is
    drawn at (the top then, else half-way)."""
    if bottom == -math.inf:
        return None, top
    return bottom, (top + bottom) / 2


@dataclass(frozen=True, kw_only=True)
class CylinderThreat(Threat):
    """A solid vertical cylinder: centre (x, y), radius, top and bottom (default -inf) AMSL."""

    center: tuple[float, float]
    radius: float
    top: float
    bottom: float = -math.inf

    kind: ClassVar[str] = "cylinder"
    extended: ClassVar[bool] = True

    def __post_init__(self) -> None:
        super().__post_init__()
        what = f"threat {self.id!r}"
        x, y = _vec(self.center, 2, f"{what} center")
        object.__setattr__(self, "center", (x, y))
        object.__setattr__(self, "radius", _positive(self.radius, f"{what} radius"))
        top = _finite(self.top, f"{what} top")
        bottom = -math.inf if self.bottom == -math.inf else _finite(self.bottom, f"{what} bottom")
        if bottom >= top:
            raise InputError(f"{what} bottom ({bottom}) must be below top ({top})")
        object.__setattr__(self, "top", top)
        object.__setattr__(self, "bottom", bottom)

    def position(self, t: npt.ArrayLike = 0.0) -> FloatArray:
        return np.broadcast_to(np.array([*self.center, self.top]), (*np.shape(t), 3)).copy()

    def separation(self, p: npt.ArrayLike, t: npt.ArrayLike = 0.0) -> FloatArray:
        q = as_points(p)
        dr = np.hypot(q[..., 0] - self.center[0], q[..., 1] - self.center[1]) - self.radius
        dz = np.maximum(self.bottom - q[..., 2], q[..., 2] - self.top)
        return solid_separation(dr, dz)

    def nearest_point(self, p: npt.ArrayLike) -> FloatArray:
        """The point of the solid cylinder closest to p (p itself inside)."""
        q = as_points(p).astype(np.float64, copy=True)
        dx, dy = q[..., 0] - self.center[0], q[..., 1] - self.center[1]
        rho = np.hypot(dx, dy)
        scale = np.where(rho > self.radius, self.radius / np.where(rho > 0, rho, 1.0), 1.0)
        q[..., 0] = self.center[0] + dx * scale
        q[..., 1] = self.center[1] + dy * scale
        q[..., 2] = np.clip(q[..., 2], self.bottom, self.top)
        return q

    def radar_points(
        self, t: float, observer: npt.ArrayLike, max_range: float = math.inf
    ) -> tuple[list[str], FloatArray]:
        """The nearest point, then the outline's left and right edges at the observer's
        altitude (clipped to the cylinder), as a scanning radar sees its extent."""
        o = as_points(observer).reshape(1, 3)
        near = self.nearest_point(o)
        edges = circle_edges(o[0], self.center, self.radius, float(near[0, 2]))
        return _near_and_edges(self.id, near, edges)

    def shape(self, t: float = 0.0) -> dict[str, Any]:
        bottom, zc = _bottom_and_middle(self.top, self.bottom)
        return {
            "id": self.id,
            "kind": "cylinder",
            "center": [*self.center, zc],
            "radius": self.radius,
            "top": self.top,
            "bottom": bottom,
        }

    def to_record(self) -> dict[str, Any]:
        rec = {**super().to_record(), "center": list(self.center), "radius": self.radius}
        rec["top"] = self.top
        if self.bottom != -math.inf:
            rec["bottom"] = self.bottom
        return rec


def footprint_ring(value: Any, what: str) -> FloatArray:
    """A prism's footprint (``value``: (x, y) vertices, the ring given open or closed) as an
    open ring (V, 2), V >= 3: repeated consecutive vertices and a repeated closing vertex
    dropped, counter-clockwise, starting at its first vertex as given.  Raises InputError
    (``what: ...``) for fewer than 3 distinct vertices or an invalid polygon (shapely's
    reason, e.g. ``Self-intersection[1 2]``, in the ring's coordinates)."""
    from terrain.zones import polygon_problem

    try:
        ring = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        ring = np.zeros((0,))
    if ring.ndim != 2 or ring.shape[1] != 2 or not np.isfinite(ring).all():
        raise InputError(f"{what}: expected a list of finite [x, y] vertices, found {value!r:.60}")
    keep = np.ones(len(ring), dtype=bool)
    keep[1:] = np.any(ring[1:] != ring[:-1], axis=1)
    ring = ring[keep]
    while len(ring) > 1 and np.array_equal(ring[0], ring[-1]):
        ring = ring[:-1]
    if len(ring) < 3:
        raise InputError(f"{what}: expected at least 3 distinct vertices, found {len(ring)}")
    problem = polygon_problem([[ring]])
    if problem is not None:
        raise InputError(f"{what}: expected a simple polygon, found {problem}")
    r = ring - ring[0]
    area2 = float(np.sum(r[:, 0] * np.roll(r[:, 1], -1) - np.roll(r[:, 0], -1) * r[:, 1]))
    if area2 < 0:  # clockwise: reverse, keeping the first vertex
        ring = np.concatenate([ring[:1], ring[:0:-1]])
    return np.asarray(ring)


_PRISM_BLOCK = 16384  # numbers per (points x edges) temporary of PrismThreat


@dataclass(frozen=True, kw_only=True)
class PrismThreat(Threat):
    """A solid vertical prism (a building): a polygon ``footprint`` (x, y) in map metres, ``top``
    and ``bottom`` (default -inf) AMSL.  The footprint is kept as an open ring (V, 2),
    counter-clockwise (:func:`footprint_ring`; it may be given closed or open here, the threat
    file asks for a closed ring)."""

    footprint: tuple[tuple[float, float], ...]
    top: float
    bottom: float = -math.inf

    kind: ClassVar[str] = "prism"
    extended: ClassVar[bool] = True

    _ring: FloatArray = dataclasses.field(init=False, repr=False, compare=False)
    _rel: FloatArray = dataclasses.field(init=False, repr=False, compare=False)
    _centroid: tuple[float, float] = dataclasses.field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        super().__post_init__()
        what = f"threat {self.id!r}"
        ring = footprint_ring(self.footprint, f"{what} footprint")
        top = _finite(self.top, f"{what} top")
        bottom = -math.inf if self.bottom == -math.inf else _finite(self.bottom, f"{what} bottom")
        if bottom >= top:
            raise InputError(f"{what} bottom ({bottom}) must be below top ({top})")
        object.__setattr__(self, "footprint", tuple((float(x), float(y)) for x, y in ring))
        object.__setattr__(self, "top", top)
        object.__setattr__(self, "bottom", bottom)
        object.__setattr__(self, "_ring", ring)
        object.__setattr__(self, "_rel", ring - ring[0])  # small numbers for the arithmetic
        import shapely

        c = shapely.Polygon(self._rel).centroid
        object.__setattr__(self, "_centroid", (float(c.x + ring[0, 0]), float(c.y + ring[0, 1])))

    @property
    def ring(self) -> FloatArray:
        """The footprint as an open ring (V, 2), counter-clockwise."""
        return self._ring.copy()

    @property
    def centroid(self) -> tuple[float, float]:
        """The footprint's centroid (x, y) (of its area; it may lie outside a concave one)."""
        return self._centroid

    @property
    def enclosing_radius(self) -> float:
        """Radius of the circle about :attr:`centroid` that holds the footprint (its farthest
        vertex): a cylinder with it contains the prism."""
        c = np.array(self._centroid) - self._ring[0]
        return float(np.max(np.hypot(*(self._rel - c).T)))

    def position(self, t: npt.ArrayLike = 0.0) -> FloatArray:
        return np.broadcast_to(np.array([*self._centroid, self.top]), (*np.shape(t), 3)).copy()

    def _horizontal(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Signed horizontal distance (...) from points q (..., >= 2) to the footprint's
        boundary (negative inside) and the nearest boundary point (..., 2), both exact."""
        from terrain.prisms import points_in_edges, ring_edges

        origin = self._ring[0]
        flat = q[..., :2].reshape(-1, 2) - origin
        a = self._rel
        ab = np.roll(a, -1, axis=0) - a
        ab2 = np.einsum("ij,ij->i", ab, ab)
        dist = np.empty(len(flat))
        near = np.empty((len(flat), 2))
        step = max(1, _PRISM_BLOCK // len(a))
        for lo in range(0, len(flat), step):
            p = flat[lo : lo + step, None, :]  # (n, 1, 2) against the edges (V, 2)
            u = np.clip(np.einsum("nvj,vj->nv", p - a, ab) / ab2, 0.0, 1.0)
            foot = a + u[..., None] * ab
            d = np.hypot(p[..., 0] - foot[..., 0], p[..., 1] - foot[..., 1])
            k = np.argmin(d, axis=1)
            rows = np.arange(len(k))
            dist[lo : lo + step] = d[rows, k]
            near[lo : lo + step] = foot[rows, k]
        inside = points_in_edges(flat[:, 0], flat[:, 1], ring_edges(a))
        signed = np.where(inside, -dist, dist).reshape(q.shape[:-1])
        return signed, (near + origin).reshape((*q.shape[:-1], 2))

    def separation(self, p: npt.ArrayLike, t: npt.ArrayLike = 0.0) -> FloatArray:
        q = as_points(p)
        dr, _ = self._horizontal(q)
        dz = np.maximum(self.bottom - q[..., 2], q[..., 2] - self.top)
        return solid_separation(dr, dz)

    def nearest_point(self, p: npt.ArrayLike) -> FloatArray:
        """The point of the solid prism closest to p (p itself inside)."""
        q = as_points(p).astype(np.float64, copy=True)
        dr, near = self._horizontal(q)
        outside = dr > 0
        q[..., 0] = np.where(outside, near[..., 0], q[..., 0])
        q[..., 1] = np.where(outside, near[..., 1], q[..., 1])
        q[..., 2] = np.clip(q[..., 2], self.bottom, self.top)
        return q

    def radar_points(
        self, t: float, observer: npt.ArrayLike, max_range: float = math.inf
    ) -> tuple[list[str], FloatArray]:
        """The nearest point, then the outline's left and right edges (the extreme vertices
        seen from the observer, :func:`outline_edges`) at the observer's altitude clipped to
        the prism; only the nearest point when the observer is over the footprint (or in a
        notch of it that spans half the horizon)."""
        o = as_points(observer).reshape(1, 3)
        near = self.nearest_point(o)
        edges = outline_edges(o[0], self._ring, float(near[0, 2]))
        return _near_and_edges(self.id, near, edges)

    def shape(self, t: float = 0.0) -> dict[str, Any]:
        bottom, zc = _bottom_and_middle(self.top, self.bottom)
        return {
            "id": self.id,
            "kind": "prism",
            "center": [*self._centroid, zc],
            "footprint": [list(v) for v in self.footprint],
            "top": self.top,
            "bottom": bottom,
        }

    def to_record(self) -> dict[str, Any]:
        ring = [list(v) for v in self.footprint]
        rec = {**super().to_record(), "footprint": [*ring, ring[0]], "top": self.top}
        if self.bottom != -math.inf:
            rec["bottom"] = self.bottom
        return rec


@dataclass(frozen=True, kw_only=True)
class IntruderThreat(Threat):
    """A moving object with a safety sphere: constant velocity from ``start`` (until ``stops_at``)
    or a piecewise-linear route through ``waypoints`` at ``speed`` (optionally looping)."""

    radius: float
    start: Vec3 | None = None
    velocity_mps: Vec3 | None = None
    stops_at: float | None = None
    waypoints: tuple[Vec3, ...] | None = None
    speed: float | None = None
    loop: bool = False
    solid: bool = False  # True: the radar sees the sphere (centre and radius), not a point

    kind: ClassVar[str] = "intruder"

    def __post_init__(self) -> None:
        super().__post_init__()
        what = f"threat {self.id!r}"
        object.__setattr__(self, "radius", _positive(self.radius, f"{what} radius"))
        _check_flag(self, "solid")
        if (self.velocity_mps is None) == (self.waypoints is None):
            raise InputError(f"{what} needs either a velocity or waypoints (exactly one)")
        if self.velocity_mps is not None:
            if self.start is None:
                raise InputError(f"{what} with a velocity needs a start position")
            if self.speed is not None or self.loop:
                raise InputError(f"{what}: speed and loop go with waypoints, not a velocity")
            object.__setattr__(self, "start", finite_vec3(self.start, f"{what} position"))
            object.__setattr__(
                self, "velocity_mps", finite_vec3(self.velocity_mps, f"{what} velocity")
            )
            if self.stops_at is not None:
                stop = _finite(self.stops_at, f"{what} stops_at")
                if stop < self.appears_at:
                    raise InputError(f"{what} stops_at ({stop}) is before appears_at")
                object.__setattr__(self, "stops_at", stop)
            return
        if self.start is not None or self.stops_at is not None:
            raise InputError(f"{what}: position and stops_at go with a velocity, not waypoints")
        assert self.waypoints is not None
        wps = tuple(finite_vec3(w, f"{what} waypoints") for w in self.waypoints)
        if len(wps) < 2:
            raise InputError(f"{what} waypoints: a route needs at least 2 waypoints")
        object.__setattr__(self, "waypoints", wps)
        object.__setattr__(self, "speed", _positive(self.speed, f"{what} speed"))
        _check_flag(self, "loop")
        w = np.array(wps + ((wps[0],) if self.loop else ()), dtype=np.float64)
        seg = np.linalg.norm(np.diff(w, axis=0), axis=1)
        object.__setattr__(self, "_w", w)
        object.__setattr__(self, "_seg", seg)
        object.__setattr__(self, "_cum", np.concatenate([[0.0], np.cumsum(seg)]))

    _w: FloatArray = dataclasses.field(init=False, repr=False, compare=False)
    _seg: FloatArray = dataclasses.field(init=False, repr=False, compare=False)
    _cum: FloatArray = dataclasses.field(init=False, repr=False, compare=False)

    @property
    def moving(self) -> bool:
        return True

    def _route(self, t: npt.ArrayLike) -> tuple[FloatArray, IntArray, FloatArray]:
        """Arc length flown, leg index and fraction along the leg at times t."""
        assert self.speed is not None
        ta = np.asarray(t, dtype=np.float64)
        total = float(self._cum[-1])
        s = np.clip(ta - self.appears_at, 0.0, None) * self.speed
        if self.loop and total > 0:
            s = np.mod(s, total)
        else:
            s = np.minimum(s, total)
        leg = np.clip(np.searchsorted(self._cum, s, side="right") - 1, 0, len(self._seg) - 1)
        length = self._seg[leg]
        frac = np.where(length > 0, (s - self._cum[leg]) / np.where(length > 0, length, 1.0), 0.0)
        return s, leg, np.clip(frac, 0.0, 1.0)

    def position(self, t: npt.ArrayLike = 0.0) -> FloatArray:
        if self.velocity_mps is not None:
            assert self.start is not None
            ta = np.asarray(t, dtype=np.float64)
            stop = math.inf if self.stops_at is None else self.stops_at
            dt = np.clip(ta, self.appears_at, stop) - self.appears_at
            return np.asarray(np.array(self.start) + dt[..., None] * np.array(self.velocity_mps))
        _, leg, frac = self._route(t)
        return np.asarray(self._w[leg] + frac[..., None] * (self._w[leg + 1] - self._w[leg]))

    def velocity(self, t: npt.ArrayLike = 0.0) -> FloatArray:
        ta = np.asarray(t, dtype=np.float64)
        if self.velocity_mps is not None:
            stop = math.inf if self.stops_at is None else self.stops_at
            going = (ta >= self.appears_at) & (ta < stop)
            return np.asarray(np.where(going[..., None], np.array(self.velocity_mps), 0.0))
        assert self.speed is not None
        s, leg, _ = self._route(t)
        d = self._w[leg + 1] - self._w[leg]
        length = self._seg[leg]
        unit = d / np.where(length > 0, length, 1.0)[..., None]
        done = (~np.asarray(self.loop)) & (s >= self._cum[-1])
        going = (ta >= self.appears_at) & ~done & (length > 0)
        return np.asarray(np.where(going[..., None], unit * self.speed, 0.0))

    def separation(self, p: npt.ArrayLike, t: npt.ArrayLike = 0.0) -> FloatArray:
        d = as_points(p) - self.position(t)
        return np.asarray(np.linalg.norm(d, axis=-1) - self.radius)

    def shape(self, t: float = 0.0) -> dict[str, Any]:
        return _sphere(self.id, self.position(t).tolist(), self.radius)

    def to_record(self) -> dict[str, Any]:
        rec = super().to_record()
        if self.velocity_mps is not None:
            assert self.start is not None
            rec["position"] = list(self.start)
            rec["velocity"] = list(self.velocity_mps)
            if self.stops_at is not None:
                rec["stops_at"] = self.stops_at
        else:
            assert self.waypoints is not None
            rec["waypoints"] = [list(w) for w in self.waypoints]
            rec["speed"] = self.speed
            if self.loop:
                rec["loop"] = True
        rec["radius"] = self.radius
        if self.solid:
            rec["solid"] = True
        return rec


# -- the set --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ThreatSet:
    """The validated threats of one file, in file order; ``source`` names the file."""

    threats: tuple[Threat, ...] = ()
    source: str | None = None
    name: str | None = None

    def __post_init__(self) -> None:
        threats = tuple(self.threats)
        ids = [t.id for t in threats]
        if len(set(ids)) != len(ids):
            dup = next(i for i in ids if ids.count(i) > 1)
            raise InputError(f"{where(self.source)}duplicate threat id {dup!r}")
        object.__setattr__(self, "threats", threats)

    def __len__(self) -> int:
        return len(self.threats)

    def __iter__(self) -> Iterator[Threat]:
        return iter(self.threats)

    @property
    def ids(self) -> tuple[str, ...]:
        return tuple(t.id for t in self.threats)

    def get(self, ident: str) -> Threat:
        for t in self.threats:
            if t.id == ident:
                return t
        raise KeyError(ident)

    def active(self, t: float) -> tuple[Threat, ...]:
        return tuple(th for th in self.threats if th.active(t))

    def separations(self, p: npt.ArrayLike, t: float) -> dict[str, FloatArray]:
        """Separation of point(s) p from every threat active at time t, by id."""
        return {th.id: th.separation(p, t) for th in self.active(t)}

    def min_separation(self, p: npt.ArrayLike, t: float) -> FloatArray:
        """Smallest separation over the active threats (inf when none is active)."""
        q = as_points(p)
        out = np.full(q.shape[:-1], math.inf)
        for th in self.active(t):
            out = np.minimum(out, th.separation(q, t))
        return out

    def shapes(self, t: float) -> list[dict[str, Any]]:
        """``shape(t)`` of every active threat (for the recorder)."""
        return [th.shape(t) for th in self.active(t)]

    def warn_after(self, duration: float) -> list[str]:
        """One message per threat that appears at or after ``duration`` s (never seen)."""
        out = []
        for i, th in enumerate(self.threats):
            if th.appears_at >= duration:
                out.append(
                    f"{where(self.source, f'threats[{i}].appears_at')}threat {th.id!r} appears "
                    f"at {th.appears_at:g} s, at or after the end of the mission ({duration:g} s); "
                    "it will never be seen"
                )
        return out
