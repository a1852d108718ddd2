"""A set of danger zones of both kinds, packed once for the vectorised length and point queries.

``ZoneSet.of(zones)`` keeps the zones in the order given: column k of every (M, K) / (P, K) /
(N, K) result is zone k.  Cylinders go through :mod:`terrain.cylinders` (analytic), polygon prisms
through :mod:`terrain.prisms` (the numba kernel); both honour ``floor`` and ``top``. A zone with
a limit above the ground (``floor_agl`` / ``top_agl``, :mod:`terrain.zones`) is measured on its
segments sampled every :data:`terrain.zones.AGL_STEP_M` (each piece inside when its middle is).

```python
zs = ZoneSet.of(zones)                       # zones: DangerZone / PolygonZone, any mix
inside = zs.path_lengths(paths)              # (P, W, 3) swarm -> (P, K) metres inside each zone
f_dz = np.minimum(1.0, inside / zs.sizes).sum(axis=1) / len(zs)   # seed 002's F_dangerzones
```
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt

from terrain import kernels
from terrain.cylinders import (
    ZoneArrays,
    points_in_cylinders,
    zones_arrays,
)
from terrain.errors import InputError
from terrain.prisms import (
    PolygonArrays,
    points_in_polygons,
    polygon_arrays,
    segment_polygon_lengths,
)
from terrain.zones import AGL_STEP_M, DangerZone, PolygonZone, Zone

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def _frozen(a: npt.NDArray[np.generic]) -> npt.NDArray[np.generic]:
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class ZoneSet:
    """Zones of both kinds packed as arrays; build it with :meth:`of`.

    ``cylinder_columns`` / ``polygon_columns``: the columns (zone indices) of each kind, in order;
    ``cylinders`` / ``polygons``: their packed arrays; ``sizes`` (K,): each zone's ``size`` (the
    normaliser of F_dangerzones).
    """

    zones: tuple[Zone, ...]
    cylinder_columns: IntArray
    cylinders: ZoneArrays
    polygon_columns: IntArray
    polygons: PolygonArrays
    sizes: FloatArray
    agl_columns: IntArray  # zones with a limit above the ground: sampled, not packed

    @classmethod
    def of(cls, zones: Iterable[Zone]) -> ZoneSet:
        zs = tuple(zones)
        for i, z in enumerate(zs):
            if not isinstance(z, DangerZone | PolygonZone):
                raise InputError(
                    f"zone {i} must be a DangerZone or a PolygonZone; got {type(z).__name__}"
                )
        agl = [i for i, z in enumerate(zs) if z.floor_agl is not None or z.top_agl is not None]
        cyl = [i for i, z in enumerate(zs) if isinstance(z, DangerZone) and i not in agl]
        poly = [i for i, z in enumerate(zs) if isinstance(z, PolygonZone) and i not in agl]
        cylinders = zones_arrays([zs[i] for i in cyl])  # type: ignore[misc]
        polygons = polygon_arrays([zs[i] for i in poly])  # type: ignore[misc]
        for arrays in (cylinders, polygons):
            for a in arrays:
                _frozen(a)
        return cls(
            zones=zs,
            cylinder_columns=_frozen(np.array(cyl, dtype=np.int64)),  # type: ignore[arg-type]
            cylinders=cylinders,
            polygon_columns=_frozen(np.array(poly, dtype=np.int64)),  # type: ignore[arg-type]
            polygons=polygons,
            sizes=_frozen(np.array([z.size for z in zs], dtype=np.float64)),  # type: ignore[arg-type]
            agl_columns=_frozen(np.array(agl, dtype=np.int64)),  # type: ignore[arg-type]
        )

    def __len__(self) -> int:
        return len(self.zones)

    @cached_property
    def _floored(self) -> bool:
        """Whether a cylinder has a floor (segment_cylinder_lengths' ``floors`` flag)."""
        return bool(np.any(self.cylinders.floors != -np.inf))

    def segment_lengths(self, p0: npt.ArrayLike, p1: npt.ArrayLike) -> FloatArray:
        """Length (m) of each segment p0[m] -> p1[m] ((M, 3) map metres, z AMSL) inside each zone,
        shape (M, K).  Bit-identical when p0 and p1 are swapped."""
        a = np.asarray(p0, dtype=np.float64)
        b = np.asarray(p1, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] != 3 or b.shape != a.shape:
            raise InputError(
                f"segment ends must both have shape (M, 3); got {a.shape} and {b.shape}"
            )
        out = np.zeros((a.shape[0], len(self)))
        if self.cylinder_columns.size:
            # segment_cylinder_lengths' kernel on the packed arrays, checked when packed
            # (issue 38: its per-call checks were a sixth of a swarm's zone lengths)
            c = self.cylinders
            out[:, self.cylinder_columns] = kernels.cylinder_lengths(
                kernels.read_only(a),  # as the packed arrays (frozen): one compiled variant
                kernels.read_only(b),
                c.centers,
                c.radii,
                c.tops,
                c.floors,
                self._floored,
            )
        if self.polygon_columns.size:
            out[:, self.polygon_columns] = segment_polygon_lengths(a, b, self.polygons)
        for k in self.agl_columns.tolist():
            out[:, k] = _sampled_lengths(a, b, self.zones[k])
        return out

    def path_lengths(self, paths: npt.ArrayLike) -> FloatArray:
        """Total length of each path inside each zone, shape (P, K): ``paths`` is (P, W, 3), a
        whole swarm in one call; the W - 1 segments of a path are summed in order."""
        p = np.asarray(paths, dtype=np.float64)
        if p.ndim != 3 or p.shape[2] != 3 or p.shape[1] < 1:
            raise InputError(f"paths must have shape (P, W, 3) with W >= 1; got {p.shape}")
        n_paths, n_points = p.shape[0], p.shape[1]
        per_segment = self.segment_lengths(p[:, :-1, :].reshape(-1, 3), p[:, 1:, :].reshape(-1, 3))
        if n_points > 1 and n_paths and len(self) > 1:
            # numpy's sum over the segments, in its order, compiled (terrain.kernels.run_sums)
            return np.asarray(kernels.run_sums(per_segment, n_paths), dtype=np.float64)
        total = per_segment.reshape(n_paths, n_points - 1, len(self)).sum(axis=1)
        return np.asarray(total, dtype=np.float64)

    def contains(self, points: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """True where point n of (N, 3) lies inside zone k (closed sets), shape (N, K)."""
        q = np.asarray(points, dtype=np.float64)
        if q.ndim != 2 or q.shape[1] != 3:
            raise InputError(f"points must have shape (N, 3); got {q.shape}")
        out = np.zeros((q.shape[0], len(self)), dtype=np.bool_)
        if self.cylinder_columns.size:
            c = self.cylinders
            out[:, self.cylinder_columns] = points_in_cylinders(
                q, c.centers, c.radii, c.tops, c.floors
            )
        if self.polygon_columns.size:
            out[:, self.polygon_columns] = points_in_polygons(q, self.polygons)
        for k in self.agl_columns.tolist():
            out[:, k] = self.zones[k].contains(q[:, 0], q[:, 1], q[:, 2])
        return out


def _sampled_lengths(a: FloatArray, b: FloatArray, zone: Zone) -> FloatArray:
    """Length (m) of each segment a[m] -> b[m] inside ``zone`` (one limited above the ground):
    the segment cut into pieces of at most :data:`AGL_STEP_M` horizontally, a piece inside when
    its middle is."""
    m = a.shape[0]
    out = np.zeros(m)
    if m == 0:
        return out
    # only the segments whose box meets the zone's outline box are sampled
    if isinstance(zone, DangerZone):
        box = (
            zone.x - zone.radius,
            zone.y - zone.radius,
            zone.x + zone.radius,
            zone.y + zone.radius,
        )
    else:
        e = zone.edges
        box = (e[:, 0].min(), e[:, 1].min(), e[:, 0].max(), e[:, 1].max())
    near = (
        (np.minimum(a[:, 0], b[:, 0]) <= box[2])
        & (np.maximum(a[:, 0], b[:, 0]) >= box[0])
        & (np.minimum(a[:, 1], b[:, 1]) <= box[3])
        & (np.maximum(a[:, 1], b[:, 1]) >= box[1])
    )
    if not near.any():
        return out
    out[near] = _sampled_near(a[near], b[near], zone)
    return out


def _sampled_near(a: FloatArray, b: FloatArray, zone: Zone) -> FloatArray:
    m = a.shape[0]
    d = b - a
    length = np.linalg.norm(d, axis=1)
    n = np.maximum(1, np.ceil(np.hypot(d[:, 0], d[:, 1]) / AGL_STEP_M)).astype(np.int64)
    seg = np.repeat(np.arange(m), n)
    first = np.cumsum(n) - n
    t = (np.arange(seg.size) - first[seg] + 0.5) / n[seg]
    mid = a[seg] + t[:, None] * d[seg]
    inside = zone.contains(mid[:, 0], mid[:, 1], mid[:, 2])
    out = np.bincount(seg, weights=inside * (length / n)[seg], minlength=m)
    return np.asarray(out, dtype=np.float64)
