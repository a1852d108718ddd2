"""Pop-up threats of a replay: the threat file (DESIGN §5), validated at the edge, and their geometry.

A threat file is YAML (``yaml.safe_load`` only) with ``terrapath: 1``, an optional ``name`` and a
``threats:`` list.  Every entry has a unique ``id`` (text, or an integer kept as text), a ``kind``,
``appears_at`` (seconds after the start, default 0, >= 0) and an optional ``disappears_at``
(> ``appears_at``); a threat is *active* for ``appears_at <= t < disappears_at``.  Positions are map
metres (x east, y north, z metres AMSL, :mod:`replay.frames`).  The kinds:

``static`` (seed 000 §2.1.2) -- ``position: [x, y, z]`` and a safety ``radius`` R > 0: the safety
    sphere.  ``separation(p) = |p - c| - R`` (exact).
``hill`` (seed 000 §2.1.2, §5.3) -- ``points: [[x, y, z], ...]`` and ``radius`` (one number for all
    points, or one per point): a mountain modelled as a group of point obstacles, each with its
    safety sphere.  ``separation(p) = min_k (|p - c_k| - R_k)`` (exact for the union of spheres).
    Points closer than 1 km form one continuous obstacle (:func:`cluster_hill_points`, single
    linkage: a chain of < 1 km steps joins its ends); one entry may hold several such clusters, and
    the boundary ("terminal") points of a cluster seen from the aircraft are the ones an avoider
    goes round (:func:`cluster_terminals`).
``body`` (seed 001 eq 3) -- ``center: [x0, y0, z0]``, ``axes: [a, b, c]``, ``exponents: [p, q, r]``::

        Gamma(x, y, z) = |(x - x0)/a|^(2p) + |(y - y0)/b|^(2q) + |(z - z0)/c|^(2r)

    Gamma < 1 inside, = 1 on the surface, > 1 outside; the no-fly set is Gamma <= 1
    (:meth:`BodyThreat.contains`).  Absolute values make odd powers well defined; exponents must be
    >= 0.5 so that every term is convex and so is the body (that is what "convex body" means in seed
    001), and <= 100.  ``center`` z0 is the body's centre: with z0 at the ground (``z_base``) the
    buried lower half does not matter and the body rises to ``z0 + c``.
    The horizontal section at altitude z is the superellipse
    ``|X/A|^(2p) + |Y/B|^(2q) = 1`` with ``A = a s^(1/(2p))``, ``B = b s^(1/(2q))`` and
    ``s = 1 - |(z - z0)/c|^(2r)`` (no section when s <= 0).  :meth:`BodyThreat.body_radius_at` returns
    its circumscribed radius ``max sqrt(X^2 + Y^2)`` over that curve: with ``u = X/A`` in [0, 1],
    ``f(u) = A^2 u^2 + B^2 (1 - u^(2p))^(1/q)`` is maximised on 257 samples (both ends included)
    refined by golden-section search around the best sample.  For p = q = 1 (an ellipse) the answer
    is ``max(A, B)`` exactly (f is linear in u^2: a sample end is the maximum); for a = b and
    p = q it is ``A 2^(1/2 - 1/(2p))`` when p >= 1, which the search finds to ~1e-12 relative.
    It is 0 at the top ``z0 + c`` and the bottom ``z0 - c``.
    *Separation* has no closed form; it is computed as a *conservative* value (never more than
    the true signed distance) which is, outside the body, also exact to ~1e-9 relative:

    - outside (Gamma > 1): for any surface point q and any (sub)gradient g of Gamma at q, the
      convex body lies in the half-space ``g.(x - q) <= 0``, so ``dist(p, body) >= g^.(p - q)``
      (``g^ = g / |g|``): a lower bound whatever q is.  Two surface points are tried.  q0 is the
      radial projection of p, ``c + s (p - c)`` with Gamma = 1 (Newton's method on log Gamma as a
      function of log s, convex and increasing, from the largest coordinate ratio: monotone).  q1
      solves the nearest-point conditions ``x - d = -(lam/2) grad Gamma(x)`` (centred coordinates,
      d = p - c): for a fixed multiplier each axis is the scalar equation
      ``X + mu X^(2p-1) = |d|``, ``mu = lam p / a^(2p)`` (Newton in log X: convex and increasing),
      and Gamma(x(lam)) = 1 is solved for log lam by bracketed Newton.  q1 is projected radially
      onto the surface and the larger bound is the separation; the closer point is
      :meth:`BodyThreat.nearest_point`.  At the nearest point the half-space bound *equals* the
      distance, so the result is exact when the solver converged and a safe lower bound when it
      did not.  Where an exponent is 0.5 the body has edges (|x/a| is not differentiable at 0);
      there the subgradient closest to the direction p - q is used.  Cost: ~1 ms for one point,
      ~10 us per point in batches;
    - inside: minus the smallest distance from p to a surface point found along the three axis
      directions and along the radial direction (each an upper bound of the depth);
    - on the surface (Gamma = 1): 0.
``cylinder`` -- ``center: [x, y]``, ``radius``, ``top`` and optional ``bottom`` (default -inf):
    a solid vertical cylinder.  Separation is the exact signed distance to the solid: with
    ``dr = rho - R`` (rho the horizontal distance to the axis) and ``dz = max(bottom - z, z - top)``,
    ``hypot(dr, dz)`` when both are > 0, else ``max(dr, dz)`` (negative inside: minus the depth).
``intruder`` -- a moving object with a safety ``radius``, either

    - ``position: [x, y, z]`` and ``velocity: [east, north, up]`` (m/s), optional ``stops_at`` (s,
      >= ``appears_at``): ``p(t) = position + velocity (clip(t, appears_at, stops_at) -
      appears_at)`` -- it is at ``position`` when it appears and stands still after ``stops_at``;
    - ``waypoints: [[x, y, z], ...]`` (>= 2) flown at ``speed`` (m/s, > 0) from the first one at
      ``appears_at``, piecewise-linear at constant speed, holding at the last one; with
      ``loop: true`` it flies back to the first and repeats.  ``p(t)`` is vectorised over t.

    Separation is ``|p - p(t)| - R``.  (Flying an intruder with its own 6-DOF model is left to the
    simulation; here its path is kinematic.)

``static``, ``body`` and ``intruder`` may give ``lon``, ``lat`` (WGS84 degrees) and ``alt`` (metres
AMSL) instead of ``position`` / ``center``, and ``cylinder`` ``lon``, ``lat`` instead of ``center``;
they are converted with the map grid (``HeightGrid.from_lonlat``), so lon/lat needs a georeferenced
grid.  Hill points and intruder waypoints are map metres only.

Validation (:func:`load_threats`): unknown keys are refused listing the keys allowed for the kind;
missing fields, wrong types, NaN or infinite numbers, radii/axes/speeds <= 0, duplicate ids, an
intruder with neither or both of ``velocity`` and ``waypoints``, and (with a grid) positions outside
the map each raise a one-line error naming the file and the field (``threats[2].radius``).  A
missing, unreadable or structurally wrong file raises :class:`DataFileError`, a bad field
:class:`InputError`.  :meth:`ThreatSet.warn_after` lists threats that appear after the mission ends.

Every threat has ``active(t)``, ``position(t)`` (centre or reference point: a static centre, the
hill's first point, the body centre, the centre of the cylinder's top face, the intruder), ``velocity(t)``,
``separation(p, t)`` (map metres, negative inside; vectorised over points (..., 3) and, for
intruders, over times broadcast with them), ``violates(p, t)`` (separation < 0), ``radar_points``
(what the radar sees, see :mod:`replay.radar`) and ``shape(t)``, a plain dict for the recorder:
``{"id", "kind": "sphere"|"cylinder"|"ellipsoid", "center", "radius"|"axes", "top", "bottom"}``
(a hill's ``center`` and ``radius`` are lists, one per point, and ``shapes(t)`` splits it into
spheres ``"<id>/<k>"``; a cylinder's ``center`` is its mid-height point, or the top-face centre when
it has no bottom, which is then ``None``; an ellipsoid also carries its ``exponents``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from terrain.docfile import check_header, read_document
from terrain.docfile import finite_number as _finite
from terrain.docfile import found as _found
from terrain.errors import InputError, where
from terrain.grid import HeightGrid

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]
Vec3 = tuple[float, float, float]

HILL_LINK_M = 1000.0  # seed 000 §5.3: points closer than 1 km form one continuous obstacle
DOCUMENT_KEYS = ("terrapath", "name", "threats")
KINDS = ("static", "hill", "body", "cylinder", "intruder")
COMMON_KEYS = ("id", "kind", "appears_at", "disappears_at")
KIND_KEYS: dict[str, tuple[str, ...]] = {
    "static": ("position", "lon", "lat", "alt", "radius"),
    "hill": ("points", "radius"),
    "body": ("center", "lon", "lat", "alt", "axes", "exponents"),
    "cylinder": ("center", "lon", "lat", "radius", "top", "bottom"),
    "intruder": (
        *("position", "lon", "lat", "alt", "velocity", "stops_at"),
        *("waypoints", "speed", "loop", "radius"),
    ),
}
EXPONENT_RANGE = (0.5, 100.0)
_RADIUS_SAMPLES = 257

Source = str | PathLike[str] | None


# -- small helpers ------------------------------------------------------------------------------
def _as_points(p: npt.ArrayLike, name: str = "p") -> FloatArray:
    a = np.asarray(p, dtype=np.float64)
    if a.ndim < 1 or a.shape[-1] != 3:
        raise InputError(f"{name} must be a point (3,) or points (..., 3); got shape {a.shape}")
    return a


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


def _vec3(value: Any, what: str) -> Vec3:
    x, y, z = _vec(value, 3, what)
    return (x, y, z)


# -- hills: clusters of points ------------------------------------------------------------------
def cluster_hill_points(points: npt.ArrayLike, link: float = HILL_LINK_M) -> tuple[IntArray, ...]:
    """Group points (N, 3) into continuous obstacles: single linkage, two points belong together
    when their 3D distance is strictly below ``link`` (seed 000: "less than 1 km"), and a chain of
    such steps joins its ends.  Returns index arrays (ascending), ordered by their first index."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    p = _as_points(points, "points").reshape(-1, 3)
    if not (math.isfinite(link) and link > 0):
        raise InputError(f"link distance must be a positive number of metres; got {link!r}")
    n = len(p)
    if n == 0:
        return ()
    pairs = cKDTree(p).query_pairs(np.nextafter(link, 0.0), output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    first: dict[int, int] = {}
    for i, lab in enumerate(labels.tolist()):
        first.setdefault(lab, i)
    order = sorted(first, key=first.__getitem__)
    return tuple(np.flatnonzero(labels == lab).astype(np.int64) for lab in order)


def cluster_terminals(points: npt.ArrayLike, observer: npt.ArrayLike) -> tuple[int, int]:
    """The terminal points of one cluster seen from ``observer``: indices of the points with the
    most counter-clockwise (left) and most clockwise (right) horizontal bearing, measured from the
    bearing of the cluster's centroid -- the edges an avoider goes round (seed 000 §5.3)."""
    p = _as_points(points, "points").reshape(-1, 3)
    o = _as_points(observer, "observer").reshape(3)
    if len(p) == 0:
        raise InputError("a cluster needs at least one point")
    d = p[:, :2] - o[:2]
    centre = d.mean(axis=0)
    ref = math.atan2(centre[0], centre[1])  # course of the centroid, clockwise from north
    rel = (np.arctan2(d[:, 0], d[:, 1]) - ref + np.pi) % (2 * np.pi) - np.pi
    return int(np.argmin(rel)), int(np.argmax(rel))


# -- threats ------------------------------------------------------------------------------------
@dataclass(frozen=True, kw_only=True)
class Threat:
    """Base of the five threat kinds: id and activity window (seconds after the start)."""

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

    kind: ClassVar[str] = "static"

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "center", _vec3(self.center, f"threat {self.id!r} position"))
        object.__setattr__(self, "radius", _positive(self.radius, f"threat {self.id!r} radius"))

    def position(self, t: npt.ArrayLike = 0.0) -> FloatArray:
        return np.broadcast_to(np.array(self.center), (*np.shape(t), 3)).copy()

    def separation(self, p: npt.ArrayLike, t: npt.ArrayLike = 0.0) -> FloatArray:
        d = _as_points(p) - np.array(self.center)
        return np.asarray(np.linalg.norm(d, axis=-1) - self.radius)

    def shape(self, t: float = 0.0) -> dict[str, Any]:
        return _sphere(self.id, self.center, self.radius)

    def to_record(self) -> dict[str, Any]:
        return {**super().to_record(), "position": list(self.center), "radius": self.radius}


@dataclass(frozen=True, kw_only=True)
class HillThreat(Threat):
    """A hill as a group of point obstacles, each with a safety sphere (seed 000 §5.3)."""

    points: tuple[Vec3, ...]
    radii: tuple[float, ...]

    kind: ClassVar[str] = "hill"

    def __post_init__(self) -> None:
        super().__post_init__()
        what = f"threat {self.id!r}"
        pts = tuple(_vec3(v, f"{what} points") for v in self.points)
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
        q = _as_points(p)
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


@dataclass(frozen=True, kw_only=True)
class BodyThreat(Threat):
    """Seed 001 eq 3 convex body (superellipsoid); see the module docstring for the equations."""

    center: Vec3
    axes: Vec3
    exponents: Vec3

    kind: ClassVar[str] = "body"
    extended: ClassVar[bool] = True

    def __post_init__(self) -> None:
        super().__post_init__()
        what = f"threat {self.id!r}"
        object.__setattr__(self, "center", _vec3(self.center, f"{what} center"))
        axes = _vec3(self.axes, f"{what} axes")
        if min(axes) <= 0:
            raise InputError(f"{what} axes must all be > 0 metres; got {list(axes)}")
        ex = _vec3(self.exponents, f"{what} exponents")
        lo, hi = EXPONENT_RANGE
        if min(ex) < lo or max(ex) > hi:
            raise InputError(f"{what} exponents must lie in [{lo}, {hi}]; got {list(ex)}")
        # An exponent within rounding of 0.5 is 0.5: the body has an edge there, and the
        # separation must use the edge's subgradients (found by Hypothesis: exponents
        # (0.5 + 1 ulp, 0.5, 0.5) were treated as smooth and the bound fell 5 % short)
        ex = (
            lo if abs(ex[0] - lo) <= 1e-9 else ex[0],
            lo if abs(ex[1] - lo) <= 1e-9 else ex[1],
            lo if abs(ex[2] - lo) <= 1e-9 else ex[2],
        )
        object.__setattr__(self, "axes", axes)
        object.__setattr__(self, "exponents", ex)
        object.__setattr__(self, "_c", np.array(self.center))
        object.__setattr__(self, "_ax", np.array(axes))
        object.__setattr__(self, "_k", 2.0 * np.array(ex))  # the powers 2p, 2q, 2r

    _c: FloatArray = dataclasses.field(init=False, repr=False, compare=False)
    _ax: FloatArray = dataclasses.field(init=False, repr=False, compare=False)
    _k: FloatArray = dataclasses.field(init=False, repr=False, compare=False)

    @property
    def top(self) -> float:
        return self.center[2] + self.axes[2]

    @property
    def bottom(self) -> float:
        return self.center[2] - self.axes[2]

    def position(self, t: npt.ArrayLike = 0.0) -> FloatArray:
        return np.broadcast_to(self._c, (*np.shape(t), 3)).copy()

    def gamma(self, p: npt.ArrayLike) -> FloatArray:
        """Seed 001 eq 3: Gamma at map point(s) p (< 1 inside, 1 on the surface, > 1 outside)."""
        u = np.abs(_as_points(p) - self._c) / self._ax
        with np.errstate(over="ignore"):
            return np.asarray(np.sum(u**self._k, axis=-1))

    def contains(self, p: npt.ArrayLike) -> BoolArray:
        """True where Gamma <= 1 (inside or on the surface: the no-fly set of seed 001)."""
        return np.asarray(self.gamma(p) <= 1.0)

    def body_radius_at(self, z: npt.ArrayLike) -> FloatArray:
        """Circumscribed radius (m) of the horizontal section at altitude(s) z; 0 outside it."""
        za = np.asarray(z, dtype=np.float64)
        a, b, c = self.axes
        p, q, r = self.exponents
        h = np.abs(za - self.center[2]) / c
        s = np.where(h < 1.0, 1.0 - np.minimum(h, 1.0) ** (2 * r), 0.0).ravel()
        big_a = a * s ** (1 / (2 * p))
        big_b = b * s ** (1 / (2 * q))
        out = np.zeros_like(s)
        live = s > 0
        if np.any(live):
            out[live] = _superellipse_radius(big_a[live], big_b[live], p, q)
        return out.reshape(za.shape)

    def _radial(self, d: FloatArray) -> FloatArray:
        """Scale s (...) with Gamma(c + s d) = 1 for non-zero offsets d (..., 3)."""
        u = np.abs(d) / self._ax
        m = u.max(axis=-1)
        with np.errstate(divide="ignore"):
            lw = np.log(u / m[..., None])  # <= 0; -inf for zero components
        lam = np.zeros(m.shape)  # log of s * m; h(0) >= 0, h convex increasing: monotone Newton
        for _ in range(60):
            z = self._k * (lam[..., None] + lw)
            zmax = z.max(axis=-1)
            ez = np.exp(z - zmax[..., None])
            total = ez.sum(axis=-1)
            h = zmax + np.log(total)
            dh = (self._k * ez).sum(axis=-1) / total
            step = h / dh
            lam = lam - step
            if np.all(np.abs(step) < 1e-15):
                break
        return np.asarray(np.exp(lam) / m)

    def _plane_bound(self, x: FloatArray, d: FloatArray) -> FloatArray:
        """Lower bound ``g^.(d - x)`` of the distance from d to the body for surface points x
        (centred coordinates), g a subgradient of Gamma at x (the body lies in ``g.(y - x) <= 0``).

        Gamma is smooth except where an exponent is 0.5 (power k = 1) and x is on that axis plane;
        there any g_i in [-1/a_i, 1/a_i] is a subgradient, and the one closest to the direction
        d - x (scaled to the smooth components) is taken, which makes the bound exact at the
        nearest point of an edge or a vertex."""
        v = d - x
        u = x / self._ax
        g = self._k * np.sign(u) * np.abs(u) ** (self._k - 1.0) / self._ax
        kink = (self._k == 1.0) & (x == 0.0)
        plain = np.einsum("ij,ij->i", g, v) / np.linalg.norm(g, axis=-1)
        if not np.any(kink):
            return np.asarray(plain)
        smooth = ~kink
        vv = np.sum(np.where(smooth, v * v, 0.0), axis=-1)
        gv = np.sum(np.where(smooth, g * v, 0.0), axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(vv > 0, gv / vv, np.inf)[:, None]
            want = np.where(np.isfinite(t), t * v, np.sign(v) / self._ax)
        g2 = np.where(kink, np.clip(want, -1.0 / self._ax, 1.0 / self._ax), g)
        norm = np.linalg.norm(g2, axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            fitted = np.where(norm > 0, np.einsum("ij,ij->i", g2, v) / norm, -np.inf)
        with np.errstate(invalid="ignore"):
            return np.asarray(np.fmax(plain, fitted))

    def _inner(
        self, nu: FloatArray, big_d: FloatArray, start: FloatArray | None = None
    ) -> tuple[FloatArray, FloatArray]:
        """For log multipliers nu (N,) and |d| (N, 3): log X (N, 3) solving, per axis,
        ``X + mu X^(k-1) = |d|`` with ``mu = e^nu k / (2 a^k)``, and d(log X)/d(nu).

        Solved as ``psi(l) = log(e^l + mu e^((k-1) l)) - log|d| = 0`` in l = log X: psi is convex
        and increasing with slope >= min(1, k - 1), so Newton's method converges from any start
        (monotonically from the right; a start left of the root jumps right once).  The start is
        ``start`` (the previous outer iterate) where finite, else l = log|d|.  k = 1 has the closed
        form X = max(|d| - mu, 0)."""
        k, km1 = self._k, self._k - 1.0
        m = nu[:, None] + np.log(k / 2.0) - k * np.log(self._ax)  # log mu
        zero = big_d <= 0.0
        with np.errstate(divide="ignore"):
            ld = np.log(np.where(zero, 1.0, big_d))
        lx = ld.copy() if start is None else np.where(np.isfinite(start), start, ld)
        for _ in range(100):
            a2 = m + km1 * lx
            top = np.maximum(lx, a2)
            e1, e2 = np.exp(lx - top), np.exp(a2 - top)
            step = (top + np.log(e1 + e2) - ld) / ((e1 + km1 * e2) / (e1 + e2))
            step = np.where(km1 > 0.0, step, 0.0)
            lx = lx - step
            if np.all(np.abs(step) < 1e-14):
                break
        a2 = m + km1 * lx
        top = np.maximum(lx, a2)
        e1, e2 = np.exp(lx - top), np.exp(a2 - top)
        dlx = -e2 / (e1 + km1 * e2)
        linear = np.broadcast_to(km1 == 0.0, lx.shape)
        if np.any(linear):  # k = 1: X = |d| - mu, dX/dnu = -mu
            mu = np.exp(m)
            x1 = np.clip(np.exp(ld) - mu, 0.0, None)
            with np.errstate(divide="ignore", invalid="ignore"):
                lx = np.where(linear, np.log(x1), lx)
                dlx = np.where(linear, np.where(x1 > 0, -mu / x1, 0.0), dlx)
        lx = np.where(zero, -np.inf, lx)
        dlx = np.where(zero | ~np.isfinite(lx), 0.0, dlx)
        return lx, dlx

    def _outside(self, p: FloatArray) -> tuple[FloatArray, FloatArray]:
        """For points p (N, 3) outside: (lower bound of the distance (N,), closest surface point
        found (N, 3)).

        The nearest point x of the surface (centred coordinates, d = p - c) satisfies
        ``x - d = -(lam / 2) grad Gamma(x)``: per axis ``X + mu X^(k-1) = |d|`` (see
        :meth:`_inner`), and Gamma(x(lam)) decreases with lam.  ``log Gamma = 0`` is solved for
        nu = log lam by Newton's method kept inside a bracket (bisection when a step leaves it),
        started from the radial projection.  The radial projection and the solution each bound
        the distance from below through their supporting plane; the larger bound is returned."""
        d = p - self._c
        big_d = np.abs(d)
        q0 = self._radial(d)[:, None] * d
        lower0 = self._plane_bound(q0, d)
        u0 = np.abs(q0) / self._ax
        grad0 = np.linalg.norm(self._k * u0 ** (self._k - 1.0) / self._ax, axis=-1)
        nu = np.log(np.maximum(2.0 * np.linalg.norm(d - q0, axis=-1) / grad0, 1e-300))
        lo, hi = np.full(len(d), -np.inf), np.full(len(d), np.inf)
        la = np.log(self._ax)
        lx: FloatArray | None = None
        for _ in range(80):
            lx, dlx = self._inner(nu, big_d, lx)
            z = self._k * (lx - la)
            top = np.max(z, axis=-1)
            live = np.isfinite(top)  # else every X is 0 (k = 1 axes clamped): Gamma = 0
            w = np.exp(z - np.where(live, top, 0.0)[:, None])
            total = np.where(live, w.sum(axis=-1), 1.0)
            f = np.where(live, top + np.log(total), -np.inf)  # log Gamma
            df = np.sum(w * self._k * dlx, axis=-1) / total
            lo = np.where(f > 0, nu, lo)
            hi = np.where(f <= 0, nu, hi)
            with np.errstate(divide="ignore", invalid="ignore"):
                step = np.where(live & (df < 0), -f / df, np.where(live, 4.0, -4.0))
                step = np.clip(step, -4.0, 4.0)
            cand = nu + step
            out = (cand <= lo) | (cand >= hi)
            cand = np.where(out & np.isfinite(lo) & np.isfinite(hi), 0.5 * (lo + hi), cand)
            done = (np.abs(f) < 1e-14) | (hi - lo < 1e-13)
            nu = np.where(done, nu, cand)
            if np.all(done):
                break
        assert lx is not None
        x = np.sign(d) * np.exp(lx)
        x = np.where(np.any(x != 0.0, axis=-1)[:, None], x, q0)
        x = self._radial(x)[:, None] * x  # exactly onto the surface
        lower = self._plane_bound(x, d)
        closer = np.linalg.norm(d - x, axis=-1) <= np.linalg.norm(d - q0, axis=-1)
        best = np.where(closer[:, None], x, q0)
        return np.maximum(np.maximum(lower, lower0), 0.0), best + self._c

    def _depth(self, p: FloatArray) -> FloatArray:
        """Upper bound of the depth of points p (N, 3) inside: distance to the surface along the
        axis directions and the radial direction."""
        u = np.abs(p - self._c) / self._ax
        terms = u**self._k
        rest = terms.sum(axis=-1, keepdims=True) - terms
        exits = self._ax * np.clip(1.0 - rest, 0.0, None) ** (1.0 / self._k) - np.abs(p - self._c)
        depth = np.clip(exits, 0.0, None).min(axis=-1)
        d = p - self._c
        off = np.linalg.norm(d, axis=-1) > 0
        if np.any(off):
            s = self._radial(d[off])
            depth[off] = np.minimum(depth[off], (s - 1.0) * np.linalg.norm(d[off], axis=-1))
        return np.asarray(depth)

    def separation(self, p: npt.ArrayLike, t: npt.ArrayLike = 0.0) -> FloatArray:
        q = _as_points(p)
        flat = q.reshape(-1, 3)
        g = self.gamma(flat)
        out = np.zeros(len(flat))
        outside, inside = g > 1.0, g < 1.0
        if np.any(outside):
            out[outside] = self._outside(flat[outside])[0]
        if np.any(inside):
            out[inside] = -self._depth(flat[inside])
        return out.reshape(q.shape[:-1])

    def nearest_point(self, p: npt.ArrayLike) -> FloatArray:
        """The closest surface point found for outside points (see the module docstring); the
        point itself inside (clipped to the body)."""
        q = _as_points(p)
        flat = q.reshape(-1, 3).copy()
        outside = self.gamma(flat) > 1.0
        if np.any(outside):
            flat[outside] = self._outside(flat[outside])[1]
        return flat.reshape(q.shape)

    def radar_points(
        self, t: float, observer: npt.ArrayLike, max_range: float = math.inf
    ) -> tuple[list[str], FloatArray]:
        o = _as_points(observer).reshape(1, 3)
        if np.linalg.norm(o - self._c) - np.linalg.norm(self._ax) > max_range:
            return [], np.zeros((0, 3))  # the body lies inside the sphere of radius |axes|
        return [self.id], self.nearest_point(o)

    def shape(self, t: float = 0.0) -> dict[str, Any]:
        return {
            "id": self.id,
            "kind": "ellipsoid",
            "center": list(self.center),
            "axes": list(self.axes),
            "exponents": list(self.exponents),
            "top": self.top,
            "bottom": self.bottom,
        }

    def to_record(self) -> dict[str, Any]:
        return {
            **super().to_record(),
            "center": list(self.center),
            "axes": list(self.axes),
            "exponents": list(self.exponents),
        }


def _superellipse_radius(big_a: FloatArray, big_b: FloatArray, p: float, q: float) -> FloatArray:
    """max sqrt(X^2 + Y^2) on |X/A|^(2p) + |Y/B|^(2q) = 1, for arrays A, B > 0 (M,)."""

    def f(u: FloatArray) -> FloatArray:
        v = np.clip(1.0 - u ** (2 * p), 0.0, None) ** (1.0 / q)
        return np.asarray(big_a[:, None] ** 2 * u**2 + big_b[:, None] ** 2 * v)

    grid = np.linspace(0.0, 1.0, _RADIUS_SAMPLES)
    vals = f(np.broadcast_to(grid, (len(big_a), len(grid))))
    k = vals.argmax(axis=1)
    best = vals[np.arange(len(k)), k]
    lo = grid[np.clip(k - 1, 0, len(grid) - 1)]
    hi = grid[np.clip(k + 1, 0, len(grid) - 1)]
    g = (math.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = f(x1[:, None])[:, 0], f(x2[:, None])[:, 0]
    for _ in range(80):
        left = f1 > f2  # the maximum lies in [lo, x2]
        hi = np.where(left, x2, hi)
        lo = np.where(left, lo, x1)
        x1n, x2n = hi - g * (hi - lo), lo + g * (hi - lo)
        x1, x2 = x1n, x2n
        f1, f2 = f(x1[:, None])[:, 0], f(x2[:, None])[:, 0]
    best = np.maximum(best, np.maximum(f1, f2))
    return np.asarray(np.sqrt(best))


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
        q = _as_points(p)
        dr = np.hypot(q[..., 0] - self.center[0], q[..., 1] - self.center[1]) - self.radius
        dz = np.maximum(self.bottom - q[..., 2], q[..., 2] - self.top)
        both = (dr > 0) & (dz > 0)
        return np.asarray(
            np.where(both, np.hypot(np.maximum(dr, 0), np.maximum(dz, 0)), np.maximum(dr, dz))
        )

    def nearest_point(self, p: npt.ArrayLike) -> FloatArray:
        """The point of the solid cylinder closest to p (p itself inside)."""
        q = _as_points(p).astype(np.float64, copy=True)
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
        return [self.id], self.nearest_point(_as_points(observer).reshape(1, 3))

    def shape(self, t: float = 0.0) -> dict[str, Any]:
        bottom = None if self.bottom == -math.inf else self.bottom
        zc = self.top if bottom is None else (self.top + self.bottom) / 2
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

    kind: ClassVar[str] = "intruder"

    def __post_init__(self) -> None:
        super().__post_init__()
        what = f"threat {self.id!r}"
        object.__setattr__(self, "radius", _positive(self.radius, f"{what} radius"))
        if (self.velocity_mps is None) == (self.waypoints is None):
            raise InputError(f"{what} needs either a velocity or waypoints (exactly one)")
        if self.velocity_mps is not None:
            if self.start is None:
                raise InputError(f"{what} with a velocity needs a start position")
            if self.speed is not None or self.loop:
                raise InputError(f"{what}: speed and loop go with waypoints, not a velocity")
            object.__setattr__(self, "start", _vec3(self.start, f"{what} position"))
            object.__setattr__(self, "velocity_mps", _vec3(self.velocity_mps, f"{what} velocity"))
            if self.stops_at is not None:
                stop = _finite(self.stops_at, f"{what} stops_at")
                if stop < self.appears_at:
                    raise InputError(f"{what} stops_at ({stop}) is before appears_at")
                object.__setattr__(self, "stops_at", stop)
            return
        if self.start is not None or self.stops_at is not None:
            raise InputError(f"{what}: position and stops_at go with a velocity, not waypoints")
        assert self.waypoints is not None
        wps = tuple(_vec3(w, f"{what} waypoints") for w in self.waypoints)
        if len(wps) < 2:
            raise InputError(f"{what} waypoints: a route needs at least 2 waypoints")
        object.__setattr__(self, "waypoints", wps)
        object.__setattr__(self, "speed", _positive(self.speed, f"{what} speed"))
        if not isinstance(self.loop, bool):
            raise InputError(f"{what} loop must be true or false; got {self.loop!r}")
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
        d = _as_points(p) - self.position(t)
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
        q = _as_points(p)
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


def threats_to_records(threats: Iterable[Threat]) -> list[dict[str, Any]]:
    """Plain mappings (map metres) that :func:`threats_from_records` reads back to equal threats."""
    return [t.to_record() for t in threats]


# -- parsing ------------------------------------------------------------------------------------


class _FieldError(InputError):
    """An error the parser raised itself, already naming the file and the field."""


class _Parser:
    """Field-by-field validation of one file's threat records, with file/field messages."""

    def __init__(self, source: Source, grid: HeightGrid | None):
        self.source = source
        self.grid = grid

    def fail(self, field: str, message: str) -> InputError:
        return _FieldError(f"{where(self.source, field)}{message}")

    def number(self, value: Any, field: str, expected: str = "a number") -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(field, f"expected {expected}, found {_found(value)}")
        try:
            out = float(value)
        except OverflowError:
            out = math.inf
        if not math.isfinite(out):
            raise self.fail(field, f"expected {expected}, found {_found(value)}")
        return out

    def positive(self, value: Any, field: str, expected: str) -> float:
        out = self.number(value, field, expected)
        if out <= 0:
            raise self.fail(field, f"expected {expected}, found {_found(value)}")
        return out

    def vector(self, value: Any, field: str, n: int, expected: str) -> tuple[float, ...]:
        if not isinstance(value, list | tuple) or len(value) != n:
            raise self.fail(field, f"expected {expected}, found {_found(value)}")
        return tuple(self.number(v, f"{field}[{i}]") for i, v in enumerate(value))

    def point3(self, value: Any, field: str) -> Vec3:
        x, y, z = self.vector(value, field, 3, "[x, y, z] in map metres")
        self.inside(x, y, field)
        return (x, y, z)

    def point_list(self, value: Any, field: str, minimum: int) -> tuple[Vec3, ...]:
        if not isinstance(value, list | tuple) or len(value) < minimum:
            raise self.fail(
                field, f"expected a list of at least {minimum} [x, y, z], found {_found(value)}"
            )
        return tuple(self.point3(v, f"{field}[{i}]") for i, v in enumerate(value))

    def inside(self, x: float, y: float, field: str, given: str = "") -> None:
        if self.grid is not None and not bool(self.grid.contains(x, y)):
            bounds = ", ".join(f"{v:.3f}" for v in self.grid.bounds)
            raise self.fail(
                field,
                f"position {given}({x:.3f}, {y:.3f}) lies outside the map bounds "
                f"(xmin, ymin, xmax, ymax) = ({bounds})",
            )

    def located(self, entry: dict[str, Any], field: str, key: str, dims: int) -> tuple[float, ...]:
        """``key: [x, y(, z)]`` or ``lon, lat(, alt)`` converted with the grid."""
        ll_keys = ("lon", "lat", "alt") if dims == 3 else ("lon", "lat")
        ll = [k for k in ll_keys if k in entry]
        if key in entry and ll:
            raise self.fail(field, f"give '{key}' (map metres) or {'/'.join(ll_keys)}, not both")
        if not ll:
            if key not in entry:
                raise self.fail(
                    field, f"missing '{key}' (map metres) or {', '.join(ll_keys)} (degrees)"
                )
            if dims == 3:
                return self.point3(entry[key], f"{field}.{key}")
            xy = self.vector(entry[key], f"{field}.{key}", 2, "[x, y] in map metres")
            self.inside(xy[0], xy[1], f"{field}.{key}")
            return xy
        for k in ll_keys:
            if k not in entry:
                raise self.fail(
                    field, f"missing '{k}'; lon/lat positions need {', '.join(ll_keys)}"
                )
        lon = self.number(entry["lon"], f"{field}.lon", "a longitude in degrees")
        lat = self.number(entry["lat"], f"{field}.lat", "a latitude in degrees")
        if not -180.0 <= lon <= 180.0:
            raise self.fail(f"{field}.lon", f"expected degrees in [-180, 180], found {lon}")
        if not -90.0 <= lat <= 90.0:
            raise self.fail(f"{field}.lat", f"expected degrees in [-90, 90], found {lat}")
        if self.grid is None or self.grid.crs is None:
            found = "no map grid" if self.grid is None else "a local grid without CRS"
            raise self.fail(
                field, f"lon/lat positions need a georeferenced map, found {found}; use map metres"
            )
        mx, my = self.grid.from_lonlat(lon, lat)
        x, y = float(mx), float(my)
        self.inside(x, y, field, f"lon/lat ({lon}, {lat}) = map ")
        if dims == 3:
            return (x, y, self.number(entry["alt"], f"{field}.alt", "an altitude in metres AMSL"))
        return (x, y)

    def entry(self, entry: Any, field: str) -> Threat:
        if not isinstance(entry, dict):
            raise self.fail(
                field, f"expected a mapping like {{id, kind, ...}}, found {_found(entry)}"
            )
        kind = entry.get("kind")
        if "kind" not in entry:
            raise self.fail(field, f"missing 'kind'; expected one of {', '.join(KINDS)}")
        if kind not in KINDS:
            raise self.fail(
                f"{field}.kind", f"expected one of {', '.join(KINDS)}, found {_found(kind)}"
            )
        allowed = COMMON_KEYS + KIND_KEYS[kind]
        unknown = [str(k) for k in entry if k not in allowed]
        if unknown:
            raise self.fail(
                field,
                f"unknown key(s) {', '.join(map(repr, unknown))} for kind {kind!r}; "
                f"allowed: {', '.join(allowed)}",
            )
        if "id" not in entry:
            raise self.fail(field, "missing 'id' (text, unique in the file)")
        ident = entry["id"]
        if isinstance(ident, bool) or not isinstance(ident, str | int) or ident == "":
            raise self.fail(f"{field}.id", f"expected text or an integer, found {_found(ident)}")
        common: dict[str, Any] = {"id": str(ident)}
        if entry.get("appears_at") is not None:
            t0 = self.number(entry["appears_at"], f"{field}.appears_at", "seconds >= 0")
            if t0 < 0:
                raise self.fail(f"{field}.appears_at", f"expected seconds >= 0, found {t0}")
            common["appears_at"] = t0
        if entry.get("disappears_at") is not None:
            t1 = self.number(entry["disappears_at"], f"{field}.disappears_at", "seconds")
            if t1 <= common.get("appears_at", 0.0):
                raise self.fail(
                    f"{field}.disappears_at",
                    f"expected a time after appears_at ({common.get('appears_at', 0.0):g} s), "
                    f"found {t1}",
                )
            common["disappears_at"] = t1
        try:
            return getattr(self, f"_{kind}")(entry, field, common)
        except _FieldError:
            raise
        except InputError as exc:  # a constructor's own check: label it with the entry
            raise self.fail(field, str(exc)) from exc

    def _require(self, entry: dict[str, Any], field: str, key: str, expected: str) -> Any:
        if key not in entry:
            raise self.fail(field, f"missing '{key}' ({expected})")
        return entry[key]

    def _radius(self, entry: dict[str, Any], field: str) -> float:
        r = self._require(entry, field, "radius", "safety radius in metres, > 0")
        return self.positive(r, f"{field}.radius", "a radius in metres > 0")

    def _static(self, entry: dict[str, Any], field: str, common: dict[str, Any]) -> Threat:
        c = self.located(entry, field, "position", 3)
        return StaticThreat(**common, center=(c[0], c[1], c[2]), radius=self._radius(entry, field))

    def _hill(self, entry: dict[str, Any], field: str, common: dict[str, Any]) -> Threat:
        pts = self.point_list(
            self._require(entry, field, "points", "a list of [x, y, z]"), f"{field}.points", 1
        )
        r = self._require(entry, field, "radius", "a radius in metres > 0, or one per point")
        if isinstance(r, list):
            if len(r) != len(pts):
                raise self.fail(
                    f"{field}.radius",
                    f"expected one radius or {len(pts)} (one per point), found {len(r)}",
                )
            radii = tuple(
                self.positive(v, f"{field}.radius[{i}]", "a radius in metres > 0")
                for i, v in enumerate(r)
            )
        else:
            radii = (self.positive(r, f"{field}.radius", "a radius in metres > 0"),)
        return HillThreat(**common, points=pts, radii=radii)

    def _body(self, entry: dict[str, Any], field: str, common: dict[str, Any]) -> Threat:
        c = self.located(entry, field, "center", 3)
        raw = self._require(entry, field, "axes", "[a, b, c] semi-axes in metres")
        ax = self.vector(raw, f"{field}.axes", 3, "[a, b, c] semi-axes in metres > 0")
        for i, v in enumerate(ax):
            if v <= 0:
                raise self.fail(
                    f"{field}.axes[{i}]", f"expected a semi-axis in metres > 0, found {v}"
                )
        raw = self._require(entry, field, "exponents", "[p, q, r] of seed 001 eq 3")
        ex = self.vector(raw, f"{field}.exponents", 3, "[p, q, r] (seed 001 eq 3)")
        lo, hi = EXPONENT_RANGE
        for i, v in enumerate(ex):
            if not lo <= v <= hi:
                raise self.fail(
                    f"{field}.exponents[{i}]",
                    f"expected an exponent in [{lo}, {hi}] (convex body), found {v}",
                )
        return BodyThreat(
            **common,
            center=(c[0], c[1], c[2]),
            axes=(ax[0], ax[1], ax[2]),
            exponents=(ex[0], ex[1], ex[2]),
        )

    def _cylinder(self, entry: dict[str, Any], field: str, common: dict[str, Any]) -> Threat:
        c = self.located(entry, field, "center", 2)
        radius = self._radius(entry, field)
        top = self.number(
            self._require(entry, field, "top", "top altitude in metres AMSL"),
            f"{field}.top",
            "a top altitude in metres AMSL",
        )
        bottom = -math.inf
        if entry.get("bottom") is not None:
            bottom = self.number(entry["bottom"], f"{field}.bottom", "an altitude in metres AMSL")
            if bottom >= top:
                raise self.fail(f"{field}.bottom", f"expected below top ({top}), found {bottom}")
        return CylinderThreat(**common, center=(c[0], c[1]), radius=radius, top=top, bottom=bottom)

    def _intruder(self, entry: dict[str, Any], field: str, common: dict[str, Any]) -> Threat:
        has_v, has_w = "velocity" in entry, "waypoints" in entry
        if has_v == has_w:
            found = "both" if has_v else "neither"
            raise self.fail(
                field,
                f"an intruder needs 'velocity' (with 'position') or 'waypoints' (with 'speed'), "
                f"exactly one; found {found}",
            )
        radius = self._radius(entry, field)
        if has_v:
            for key in ("speed", "loop"):
                if key in entry:
                    raise self.fail(f"{field}.{key}", "goes with 'waypoints', not 'velocity'")
            start = self.located(entry, field, "position", 3)
            v = self.vector(entry["velocity"], f"{field}.velocity", 3, "[east, north, up] m/s")
            stop = None
            if entry.get("stops_at") is not None:
                stop = self.number(entry["stops_at"], f"{field}.stops_at", "seconds")
                if stop < common.get("appears_at", 0.0):
                    raise self.fail(
                        f"{field}.stops_at", f"expected a time >= appears_at, found {stop}"
                    )
            return IntruderThreat(
                **common,
                radius=radius,
                start=(start[0], start[1], start[2]),
                velocity_mps=(v[0], v[1], v[2]),
                stops_at=stop,
            )
        for key in ("position", "lon", "lat", "alt", "stops_at"):
            if key in entry:
                raise self.fail(
                    f"{field}.{key}",
                    "goes with 'velocity'; a waypoint intruder starts at its first waypoint",
                )
        wps = self.point_list(entry["waypoints"], f"{field}.waypoints", 2)
        speed = self.positive(
            self._require(entry, field, "speed", "m/s along the waypoints, > 0"),
            f"{field}.speed",
            "a speed in m/s > 0",
        )
        loop = entry.get("loop", False)
        if not isinstance(loop, bool):
            raise self.fail(f"{field}.loop", f"expected true or false, found {_found(loop)}")
        return IntruderThreat(**common, radius=radius, waypoints=wps, speed=speed, loop=loop)


def threats_from_records(
    records: Any,
    grid: HeightGrid | None = None,
    *,
    source: Source = None,
    field: str = "threats",
    name: str | None = None,
) -> ThreatSet:
    """Validate a list of threat mappings (a threat file's ``threats:``).  ``source`` and ``field``
    label error messages; with a ``grid``, lon/lat is converted and positions must lie on the map."""
    if not isinstance(records, list | tuple):
        raise InputError(
            f"{where(source, field)}expected a list of threats (use [] for none), "
            f"found {_found(records)}"
        )
    parser = _Parser(source, grid)
    threats: list[Threat] = []
    seen: dict[str, str] = {}
    for i, rec in enumerate(records):
        at = f"{field}[{i}]"
        th = parser.entry(rec, at)
        if th.id in seen:
            raise parser.fail(f"{at}.id", f"duplicate id {th.id!r} (also {seen[th.id]})")
        seen[th.id] = at
        threats.append(th)
    return ThreatSet(tuple(threats), None if source is None else str(source), name)


def load_threats(path: str | PathLike[str], grid: HeightGrid | None = None) -> ThreatSet:
    """Read and validate a threat file (see the module docstring)."""
    p = Path(path)
    data = check_header(read_document(p, "a threat file"), p, "threats", DOCUMENT_KEYS, "threats")
    name = data.get("name")
    if name is not None and not isinstance(name, str):
        raise InputError(f"{where(p, 'name')}expected text, found {_found(name)}")
    return threats_from_records(data["threats"], grid, source=p, name=name)
