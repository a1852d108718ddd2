"""Perception shared by every avoider: what the sensors' returns mean across scans.

A :class:`Perception` takes each scan of a sensor -- a :class:`~replay.sensors.radar.RadarPicture`, a
:class:`~replay.sensors.cooperative.CooperativePicture`, or a :class:`Scan` built by hand -- in
:meth:`Perception.update` and returns a frozen :class:`PerceptionState`, the one picture avoiders
read: the **obstacles** remembered (:class:`Obstacle`), the **tracks** of the moving ones
(:class:`~replay.avoidance.tracking.Track`), and on demand the **clusters** of stationary obstacles by a link distance
(:class:`Cluster`) with a fitted horizontal circle each.  Map metres (x east, y north, z AMSL),
seconds, m/s.

**Memory.**  Returns are remembered by id.  A return of a solid body (the radar's ``extended``
returns: the nearest point of a cylinder or convex body, which slides over its surface as the
aircraft moves, and the edges of its outline) is remembered per horizontal cell of
``body_cell_m`` (100 m) under its threat's id ``"<source>@<i>/<j>"`` (``i = floor(x / cell)``,
``j = floor(y / cell)``), so the surface seen over time builds up as a set of points.  Each entry keeps the latest position, the scan time it was last
seen (``last_seen``) and the time its position describes (``measured_at``: the same for the radar,
earlier for a cooperative report with latency), when it was first seen, its classification and
since when it has held it, and what the sensor said of its size, top and velocity (NaN: not
reported).  An entry not seen for more than ``memory_s`` (60 s) is forgotten (``t - last_seen >
memory_s``).  ``keep`` (a mask over the scan's returns) lets the caller leave returns out of the
memory altogether -- e.g. terrain the aircraft can climb over; a left-out return neither adds
nor refreshes anything.

**Sizes.**  What the sensor reports: the cooperative sensor's radii and tops; the radar's
measured radius of a sphere it sees whole (a ``solid`` threat) plus two standard errors of the
measurement (:attr:`~replay.sensors.radar.RadarPicture.radii_sigma`: an uncertain size inflates
the distance kept), NaN for everything else.

**Moving or stationary.**  As the sensor classified it (radar: seed 000 Fig. 7 on two scans;
cooperative: the reported speed).  A return the sensor cannot classify (the radar's -1: the id
was not in its previous picture, e.g. after an occlusion) keeps the classification its entry
already had; a new one is *unknown* (``moving is None``) until a sensor classifies it.  With
``moving_speed_mps`` set, the tracker decides instead wherever it has two fixes or more: moving
when the fitted speed exceeds it (a slow target whose displacement per scan stays under the
radar's noise threshold is then still found over a few scans).  Terrain returns are stationary.

**Order.**  Obstacles are listed in the order they took their current classification (an entry
moves to the end when it first gets one or when it changes), returns of one scan in the
sensor's order.  Hence the stationary obstacles are listed in the order they were first seen as
stationary -- the insertion order of PSO-CA's former private memory.

**Tracks.**  Every threat return that is neither terrain nor a body-surface cell keeps its last
``track_scans`` (5) fixes (time = ``measured_at``, position, range).  A :class:`~replay.avoidance.tracking.
Track` is listed for every obstacle currently called moving, in the obstacles' order: the
least-squares fit ``position = p + v (t - t_last)`` over its fixes
(:func:`replay.avoidance.tracking.fit_lines`: velocity, fitted position at the last fix, RMS residual, noise
estimate).  A moving obstacle seen once (possible only for a sensor that classifies at first
sight) has a track when the sensor reported a velocity (``fitted`` False: the velocity as
reported); otherwise none until its second fix.  :meth:`PerceptionState.approaches` gives every
track's closest point of approach to the own aircraft.

**Clusters** (:meth:`PerceptionState.clusters`): the stationary obstacles grouped by single
linkage -- two belong together when their distance is strictly below ``link_m``, and chains of such
steps join (:func:`replay.threats.clusters.cluster_hill_points`) -- horizontally by default.  The link
distance is the caller's (PSO-CA's 1 km of seed 000 §5.3 is PSO-CA's parameter).  Each cluster
has the minimum enclosing circle of its members' (x, y) (:func:`replay.avoidance.circles.min_enclosing_circle`,
seed 001 eqs 1-2 corrected), the highest altitude of its members, and ``outer_radius``, the radius
about the same centre that also encloses each member's reported size.  :attr:`PerceptionState.bodies`
groups the same obstacles by the threat they belong to instead (one circle per hill or solid body,
from the points seen on it), whatever their distances.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from replay.avoidance.circles import Circle, min_enclosing_circle
from replay.avoidance.tracking import Approaches, Track, closest_approaches, fit_lines
from replay.sensors.cooperative import CooperativePicture
from replay.sensors.radar import RadarPicture
from replay.threats.clusters import cluster_hill_points
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]
Int8Array = npt.NDArray[np.int8]

ObstacleKind = Literal["threat", "terrain"]
_MOVING = {-1: None, 0: False, 1: True}
_SCAN_ARRAYS: dict[str, type] = {
    "own_position": np.float64,
    "positions": np.float64,
    "measured_at": np.float64,
    "ranges": np.float64,
    "terrain": np.bool_,
    "extended": np.bool_,
    "moving_code": np.int8,
    "velocities": np.float64,
    "radii": np.float64,
    "tops": np.float64,
}


def _frozen(a: npt.NDArray[Any]) -> npt.NDArray[Any]:
    a.setflags(write=False)
    return a


# -- the sensor-neutral scan -----------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Scan:
    """One scan of any sensor as perception reads it: N returns as parallel arrays.
    ``velocities``, ``radii`` and ``tops`` are NaN where the sensor does not report them;
    ``moving_code`` is -1 (unknown), 0 (stationary) or 1 (moving)."""

    t: float
    own_position: FloatArray  # (3,)
    sensor: str
    ids: tuple[str, ...]
    sources: tuple[str, ...]  # the threat each return belongs to ("terrain" for the ground)
    positions: FloatArray  # (N, 3)
    measured_at: FloatArray  # (N,) the time each position describes
    ranges: FloatArray  # (N,) from own_position
    terrain: BoolArray  # (N,)
    extended: BoolArray  # (N,) a point on a solid body's surface (remembered per cell)
    moving_code: Int8Array  # (N,)
    velocities: FloatArray  # (N, 3)
    radii: FloatArray  # (N,)
    tops: FloatArray  # (N,)

    def __post_init__(self) -> None:
        n = len(self.ids)
        for name, dtype in _SCAN_ARRAYS.items():
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=dtype))
        own = self.own_position
        if own.shape != (3,) or not np.isfinite(own).all():
            raise InputError(
                f"scan own_position must be 3 finite numbers; got {self.own_position!r}"
            )
        if not math.isfinite(self.t):
            raise InputError(f"scan time must be finite; got {self.t!r}")
        shapes = {
            "sources": (len(self.sources),),
            "positions": np.shape(self.positions),
            "measured_at": np.shape(self.measured_at),
            "ranges": np.shape(self.ranges),
            "terrain": np.shape(self.terrain),
            "extended": np.shape(self.extended),
            "moving_code": np.shape(self.moving_code),
            "velocities": np.shape(self.velocities),
            "radii": np.shape(self.radii),
            "tops": np.shape(self.tops),
        }
        for name, shape in shapes.items():
            want = (n, 3) if name in ("positions", "velocities") else (n,)
            if shape != want:
                raise InputError(f"scan {name} must have shape {want} for {n} ids; got {shape}")
        if not np.isfinite(self.positions).all():
            raise InputError("scan positions must be finite")
        if n and not ((self.moving_code >= -1) & (self.moving_code <= 1)).all():
            raise InputError("scan moving_code must be -1 (unknown), 0 (stationary) or 1 (moving)")
        if len(set(self.ids)) != n:
            raise InputError("scan ids must be unique")

    def __len__(self) -> int:
        return len(self.ids)

    @classmethod
    def _of_sensor(cls, **fields: Any) -> Scan:
        """A scan of one of terrapath's own sensors, whose pictures are built to this layout
        (their arrays already of these dtypes and shapes, ids unique): not checked again."""
        scan = object.__new__(cls)
        for name, value in fields.items():
            dtype = _SCAN_ARRAYS.get(name)
            object.__setattr__(scan, name, value if dtype is None else np.asarray(value, dtype))
        return scan

    @classmethod
    def of(cls, picture: RadarPicture | CooperativePicture | Scan) -> Scan:
        """The scan of a radar or cooperative picture (a Scan is returned as it is)."""
        if isinstance(picture, Scan):
            return picture
        n = len(picture)
        nan3 = np.full((n, 3), np.nan)
        nan1 = np.full(n, np.nan)
        if isinstance(picture, RadarPicture):
            radii, tops = nan1, nan1
            if picture.radii is not None:  # spheres the radar measures (solid threats)
                # kept with two standard errors of the measurement (0 for a noise-free radar)
                sigma = picture.radii_sigma
                radii = picture.radii + (0.0 if sigma is None else 2.0 * sigma)
                tops = picture.positions[:, 2] + radii
            return cls._of_sensor(
                t=picture.t,
                own_position=picture.own_position,
                sensor=getattr(picture, "sensor", "radar"),  # a RangefinderPicture's own
                ids=picture.ids,
                sources=picture.sources,
                positions=picture.positions,
                measured_at=np.full(n, picture.t),
                ranges=picture.ranges,
                terrain=picture.is_terrain,
                extended=picture.extended,
                moving_code=picture.moving_code,
                velocities=nan3,
                radii=radii,
                tops=tops,
            )
        if isinstance(picture, CooperativePicture):
            return cls._of_sensor(
                t=picture.t,
                own_position=picture.own_position,
                sensor=picture.sensor,
                ids=picture.ids,
                sources=picture.sources,
                positions=picture.positions,
                measured_at=picture.measured_at,
                ranges=picture.ranges,
                terrain=picture.is_terrain,
                extended=picture.extended,
                moving_code=picture.moving_code,
                velocities=picture.velocities,
                radii=picture.radii,
                tops=picture.tops,
            )
        raise InputError(
            f"perception reads a RadarPicture, a CooperativePicture or a Scan; got "
            f"{type(picture).__name__}"
        )


# -- what avoiders read ----------------------------------------------------------------------------
@dataclass(frozen=True)
class PerceptionConfig:
    """``memory_s``: forget an obstacle not seen for longer; ``body_cell_m``: cell of the surface
    points of solid bodies; ``track_scans``: fixes in a track's fit (>= 2); ``moving_speed_mps``:
    None to keep the sensor's classification, or the fitted speed above which the tracker calls
    an obstacle moving."""

    memory_s: float = 60.0
    body_cell_m: float = 100.0
    track_scans: int = 5
    moving_speed_mps: float | None = None

    def __post_init__(self) -> None:
        for name in ("memory_s", "body_cell_m"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not (0 < v < math.inf):
                raise InputError(f"perception {name} must be a positive number; got {v!r}")
        n = self.track_scans
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 2:
            raise InputError(f"perception track_scans must be an integer >= 2; got {n!r}")
        s = self.moving_speed_mps
        if s is not None and (
            isinstance(s, bool) or not isinstance(s, int | float) or not (0 <= s < math.inf)
        ):
            raise InputError(
                f"perception moving_speed_mps must be None or a number >= 0; got {s!r}"
            )


@dataclass(frozen=True, eq=False)
class Obstacle:
    """One remembered obstacle (see the module docstring)."""

    id: str
    source: str
    position: FloatArray  # (3,)
    kind: ObstacleKind
    moving: bool | None
    last_seen: float
    measured_at: float
    first_seen: float
    since: float  # when it took its current classification
    radius: float  # reported size, NaN if none
    top: float  # reported top, NaN if none
    velocity: FloatArray  # reported velocity (3,), NaN if none
    extended: bool  # a point on a solid body's surface (id "<id>@<i>/<j>")


@dataclass(frozen=True, eq=False)
class Cluster:
    """Stationary obstacles joined by single linkage: ``members`` (ids), ``index`` (their rows in
    the state), the minimum enclosing ``circle`` of their (x, y), the highest ``top`` (reported
    tops, else positions' z) and ``outer_radius`` (about the circle's centre, enclosing each
    member's reported size too; the circle's radius when no size is reported)."""

    members: tuple[str, ...]
    index: IntArray
    circle: Circle
    top: float
    outer_radius: float

    @property
    def center(self) -> FloatArray:
        return self.circle.center

    @property
    def radius(self) -> float:
        return self.circle.radius


@dataclass(frozen=True, eq=False)
class PerceptionState:
    """What the avoiders read after a scan: the remembered obstacles as parallel arrays (K rows,
    in the module docstring's order; as :class:`Obstacle` objects in :attr:`obstacles`), the
    tracks, and on demand the clusters.  Its arrays (and its tracks') are read-only copies:
    nothing an avoider does to them reaches the memory or another reader."""

    t: float
    sensor: str
    own_position: FloatArray
    ids: tuple[str, ...]
    sources: tuple[str, ...]
    positions: FloatArray  # (K, 3)
    terrain: BoolArray
    extended: BoolArray
    moving_code: Int8Array  # -1 unknown, 0 stationary, 1 moving
    last_seen: FloatArray
    measured_at: FloatArray
    first_seen: FloatArray
    since: FloatArray
    radii: FloatArray
    tops: FloatArray
    velocities: FloatArray  # reported, NaN where not
    tracks: tuple[Track, ...]
    _clusters: dict[tuple[float, bool], tuple[Cluster, ...]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def __len__(self) -> int:
        return len(self.ids)

    @cached_property
    def obstacles(self) -> tuple[Obstacle, ...]:
        kinds: tuple[ObstacleKind, ObstacleKind] = ("threat", "terrain")
        return tuple(
            Obstacle(
                ident,
                self.sources[i],
                self.positions[i],
                kinds[int(self.terrain[i])],
                _MOVING[int(self.moving_code[i])],
                float(self.last_seen[i]),
                float(self.measured_at[i]),
                float(self.first_seen[i]),
                float(self.since[i]),
                float(self.radii[i]),
                float(self.tops[i]),
                self.velocities[i],
                bool(self.extended[i]),
            )
            for i, ident in enumerate(self.ids)
        )

    @cached_property
    def index(self) -> dict[str, int]:
        """Row of each id."""
        return {ident: i for i, ident in enumerate(self.ids)}

    def get(self, ident: str) -> Obstacle:
        """The obstacle with this id (KeyError if it is not remembered)."""
        return self.obstacles[self.index[ident]]

    def track(self, ident: str) -> Track:
        """The track with this id (KeyError if there is none)."""
        for tr in self.tracks:
            if tr.id == ident:
                return tr
        raise KeyError(ident)

    @cached_property
    def stationary(self) -> IntArray:
        """Rows of the stationary obstacles, in order."""
        return np.flatnonzero(self.moving_code == 0).astype(np.int64)

    @cached_property
    def moving(self) -> IntArray:
        """Rows of the moving obstacles, in order."""
        return np.flatnonzero(self.moving_code == 1).astype(np.int64)

    @cached_property
    def seen_now(self) -> BoolArray:
        """Obstacles seen in this state's scan."""
        return np.asarray(self.last_seen == self.t)

    def clusters(self, link_m: float, *, horizontal: bool = True) -> tuple[Cluster, ...]:
        """The stationary obstacles grouped by single linkage (distance strictly below ``link_m``;
        horizontal distance unless ``horizontal`` is False), ordered by their first member, each
        with its fitted circle (module docstring).  Computed once per link and kept."""
        link = float(link_m)
        if not (0.0 < link < math.inf):
            raise InputError(f"link distance must be a positive number of metres; got {link_m!r}")
        key = (link, bool(horizontal))
        if key not in self._clusters:
            self._clusters[key] = self._make_clusters(link, horizontal)
        return self._clusters[key]

    def _make_clusters(self, link: float, horizontal: bool) -> tuple[Cluster, ...]:
        rows = self.stationary
        if not len(rows):
            return ()
        pts = self.positions[rows]
        if horizontal:
            pts = np.column_stack([pts[:, :2], np.zeros(len(pts))])
        return tuple(self._cluster(rows[g]) for g in cluster_hill_points(pts, link))

    @cached_property
    def bodies(self) -> tuple[Cluster, ...]:
        """The stationary threat obstacles grouped by the threat they belong to (``sources``:
        a hill's points, a solid body's surface cells, a static point alone), ordered by their
        first member, each with its fitted circle -- seed 001's obstacle circle of one body from
        the points sampled on it.  Terrain returns have no body and are left out."""
        rows = self.stationary[~self.terrain[self.stationary]]
        groups: dict[str, list[int]] = {}
        for i in rows.tolist():
            groups.setdefault(self.sources[i], []).append(i)
        return tuple(self._cluster(np.array(g, dtype=np.int64)) for g in groups.values())

    def _cluster(self, idx: IntArray) -> Cluster:
        circle = min_enclosing_circle(self.positions[idx, :2])
        radii = self.radii[idx]
        size = np.where(np.isnan(radii), 0.0, radii)
        outer = float(np.max(circle.distance(self.positions[idx]) + size))
        tops = np.where(np.isnan(self.tops[idx]), self.positions[idx, 2], self.tops[idx])
        return Cluster(
            tuple(self.ids[i] for i in idx.tolist()),
            idx,
            circle,
            float(np.max(tops)),
            max(outer, circle.radius),
        )

    def approaches(
        self,
        own_position: npt.ArrayLike,
        own_velocity: npt.ArrayLike,
        *,
        horizon: float = math.inf,
        horizontal: bool = False,
    ) -> Approaches:
        """Closest approach of every track (in :attr:`tracks` order), each predicted to this
        state's time, to the aircraft at ``own_position`` / ``own_velocity`` now."""
        pos = np.array([tr.predict(self.t) for tr in self.tracks]).reshape(-1, 3)
        vel = np.array([tr.velocity for tr in self.tracks]).reshape(-1, 3)
        return closest_approaches(
            own_position, own_velocity, pos, vel, t=self.t, horizon=horizon, horizontal=horizontal
        )


# -- the memory --------------------------------------------------------------------------------
# columns of the memory's float table; those before _FIRST are overwritten by every sighting
_X, _VX, _LAST, _MEAS, _RADIUS, _TOP, _FIRST, _SINCE = 0, 3, 6, 7, 8, 9, 10, 11
_NCOL = 12


class Perception:
    """Obstacle memory and tracker across scans; :meth:`update` after every scan.

    Rows are kept in the state's order (module docstring), so a state is a copy of the tables:
    an entry that gets or changes its classification is moved to the end."""

    def __init__(self, config: PerceptionConfig | None = None) -> None:
        self.config = config or PerceptionConfig()
        self.reset()

    def reset(self) -> None:
        """Forget everything."""
        n = self.config.track_scans
        self._keys: list[str] = []
        self._sources: list[str] = []
        self._index: dict[str, int] = {}
        self._f = np.zeros((0, _NCOL))
        self._code = np.zeros(0, dtype=np.int8)
        self._terrain = np.zeros(0, dtype=bool)
        self._extended = np.zeros(0, dtype=bool)
        self._hist_t = np.zeros((0, n))
        self._hist_p = np.zeros((0, n, 3))
        self._hist_r = np.zeros((0, n))
        self._hist_n = np.zeros(0, dtype=np.int64)
        self._t: float | None = None
        self.state: PerceptionState | None = None

    def update(
        self,
        picture: RadarPicture | CooperativePicture | Scan,
        keep: npt.ArrayLike | None = None,
    ) -> PerceptionState:
        """Take one scan (its time must be later than the previous one's) and return the state.
        ``keep``: bool (N,) over the scan's returns, False for returns to leave out."""
        scan = Scan.of(picture)
        if self._t is not None and not scan.t > self._t:
            raise InputError(
                f"perception scans must come in time order; got t = {scan.t} after {self._t}"
            )
        n = len(scan)
        if keep is None:
            rows_in = np.arange(n)
        else:
            mask = np.asarray(keep)
            if mask.dtype != np.bool_ or mask.shape != (n,):
                raise InputError(
                    f"keep must be a bool mask of shape ({n},); got {mask.dtype} {mask.shape}"
                )
            rows_in = mask.nonzero()[0]
        self._t = scan.t
        if len(rows_in):
            self._ingest(scan, rows_in)
        self._forget(scan.t)
        self.state = self._snapshot(scan)
        return self.state

    # -- ingest ------------------------------------------------------------------------------------
    def _keys_of(self, scan: Scan, rows: IntArray) -> tuple[list[str], IntArray]:
        """Memory keys of the returns ``rows`` (body-surface returns per cell); when several
        returns of one scan fall in one cell, the last one stands."""
        ids = scan.ids
        keys = [ids[i] for i in rows.tolist()]
        ext = scan.extended[rows].nonzero()[0]
        if not ext.size:
            return keys, rows
        cells = np.floor(scan.positions[rows[ext], :2] / self.config.body_cell_m).astype(np.int64)
        # a solid's nearest point and outline edges are one surface: keyed by the threat's id
        for k, (ci, cj) in zip(ext.tolist(), cells.tolist(), strict=True):
            keys[k] = f"{scan.sources[int(rows[k])]}@{ci}/{cj}"
        last = {key: k for k, key in enumerate(keys)}
        if len(last) == len(keys):
            return keys, rows
        pick = sorted(last.values())
        return [keys[k] for k in pick], rows[pick]

    def _grow(self, scan: Scan, keys: list[str], rows_in: IntArray) -> None:
        """Append new entries (unknown class, NaN fields) for ``keys`` / returns ``rows_in``."""
        m, base = len(keys), len(self._keys)
        self._index.update(zip(keys, range(base, base + m), strict=True))
        self._keys.extend(keys)
        self._sources.extend(scan.sources[i] for i in rows_in.tolist())
        n = self.config.track_scans
        fresh = np.full((m, _NCOL), np.nan)
        fresh[:, _FIRST] = scan.t
        self._f = np.vstack([self._f, fresh])
        self._code = np.concatenate([self._code, np.full(m, -1, dtype=np.int8)])
        self._terrain = np.concatenate([self._terrain, scan.terrain[rows_in]])
        self._extended = np.concatenate([self._extended, scan.extended[rows_in]])
        self._hist_t = np.vstack([self._hist_t, np.full((m, n), np.nan)])
        self._hist_p = np.concatenate([self._hist_p, np.full((m, n, 3), np.nan)])
        self._hist_r = np.vstack([self._hist_r, np.full((m, n), np.nan)])
        self._hist_n = np.concatenate([self._hist_n, np.zeros(m, dtype=np.int64)])

    def _ingest(self, scan: Scan, rows_in: IntArray) -> None:
        keys, rows_in = self._keys_of(scan, rows_in)
        get = self._index.get
        rows = np.fromiter((get(key, -1) for key in keys), dtype=np.int64, count=len(keys))
        new = (rows < 0).nonzero()[0]
        if new.size:
            base = len(self._keys)
            self._grow(scan, [keys[k] for k in new.tolist()], rows_in[new])
            rows[new] = base + np.arange(new.size)
        t = scan.t
        block = self._f[rows]
        block[:, _X : _X + 3] = scan.positions[rows_in]
        block[:, _VX : _VX + 3] = scan.velocities[rows_in]
        block[:, _LAST] = t
        block[:, _MEAS] = scan.measured_at[rows_in]
        block[:, _RADIUS] = scan.radii[rows_in]
        block[:, _TOP] = scan.tops[rows_in]
        # fixes of trackable returns (neither terrain nor body-surface cells)
        terrain = self._terrain[rows]
        trackable = (~(terrain | self._extended[rows])).nonzero()[0]
        tr = rows[trackable]
        if tr.size:
            src = rows_in[trackable]
            for arr in (self._hist_t, self._hist_p, self._hist_r):
                arr[tr, :-1] = arr[tr, 1:]
            self._hist_t[tr, -1] = scan.measured_at[src]
            self._hist_p[tr, -1] = scan.positions[src]
            self._hist_r[tr, -1] = scan.ranges[src]
            self._hist_n[tr] = np.minimum(self._hist_n[tr] + 1, self.config.track_scans)
        code = np.where(terrain, np.int8(0), scan.moving_code[rows_in]).astype(np.int8)
        if self.config.moving_speed_mps is not None and tr.size:
            fit = fit_lines(self._hist_t[tr], self._hist_p[tr], self._hist_n[tr])
            decided = self._hist_n[tr] >= 2
            speed = np.linalg.norm(fit.velocity[decided], axis=1)
            code[trackable[decided]] = speed > self.config.moving_speed_mps
        old = self._code[rows]
        code = np.where(code >= 0, code, old).astype(np.int8)
        changed = (code != old) | (rows >= len(self._keys) - new.size)
        block[changed, _SINCE] = t
        self._f[rows] = block
        self._code[rows] = code
        if changed.any():
            self._move_to_end(rows[changed])

    def _move_to_end(self, rows: IntArray) -> None:
        """Reorder the tables: the other rows as they are, then ``rows`` in the order given."""
        stay = np.ones(len(self._keys), dtype=bool)
        stay[rows] = False
        order = np.concatenate([stay.nonzero()[0], rows])
        if np.array_equal(order, np.arange(len(order))):
            return
        self._apply(order)

    def _apply(self, order: IntArray) -> None:
        """Keep the rows ``order`` (a permutation or a subset), in that order."""
        idx = order.tolist()
        self._keys = [self._keys[i] for i in idx]
        self._sources = [self._sources[i] for i in idx]
        self._index = {key: i for i, key in enumerate(self._keys)}
        self._f, self._code = self._f[order], self._code[order]
        self._terrain, self._extended = self._terrain[order], self._extended[order]
        self._hist_t, self._hist_p = self._hist_t[order], self._hist_p[order]
        self._hist_r, self._hist_n = self._hist_r[order], self._hist_n[order]

    def _forget(self, t: float) -> None:
        stale = t - self._f[:, _LAST] > self.config.memory_s
        if stale.any():
            self._apply((~stale).nonzero()[0])

    # -- tracks and the state ----------------------------------------------------------------------
    def _tracks(self) -> tuple[Track, ...]:
        moving = ((self._code == 1) & (self._hist_n > 0)).nonzero()[0]
        if not moving.size:
            return ()
        fit = fit_lines(self._hist_t[moving], self._hist_p[moving], self._hist_n[moving])
        out = []
        for k, row in enumerate(moving.tolist()):
            n = int(self._hist_n[row])
            fitted = n >= 2
            vel = fit.velocity[k] if fitted else self._f[row, _VX : _VX + 3]
            if not np.isfinite(vel).all():
                continue  # one fix and no reported velocity: no track yet
            times = self._hist_t[row, -n:].copy()
            out.append(
                Track(
                    id=self._keys[row],
                    source=self._sources[row],
                    t=float(times[-1]),
                    position=_frozen((fit.position[k] if fitted else self._hist_p[row, -1]).copy()),
                    velocity=_frozen(np.array(vel, dtype=np.float64)),
                    residual=float(fit.residual[k]) if fitted else 0.0,
                    sigma=float(fit.sigma[k]),
                    n=n,
                    since=float(self._f[row, _SINCE]),
                    fitted=fitted,
                    times=_frozen(times),
                    positions=_frozen(self._hist_p[row, -n:].copy()),
                    ranges=_frozen(self._hist_r[row, -n:].copy()),
                )
            )
        return tuple(out)

    def _snapshot(self, scan: Scan) -> PerceptionState:
        f = self._f
        return PerceptionState(
            t=scan.t,
            sensor=scan.sensor,
            own_position=_frozen(scan.own_position.copy()),
            ids=tuple(self._keys),
            sources=tuple(self._sources),
            positions=_frozen(f[:, _X : _X + 3].copy()),
            terrain=_frozen(self._terrain.copy()),
            extended=_frozen(self._extended.copy()),
            moving_code=_frozen(self._code.copy()),
            last_seen=_frozen(f[:, _LAST].copy()),
            measured_at=_frozen(f[:, _MEAS].copy()),
            first_seen=_frozen(f[:, _FIRST].copy()),
            since=_frozen(f[:, _SINCE].copy()),
            radii=_frozen(f[:, _RADIUS].copy()),
            tops=_frozen(f[:, _TOP].copy()),
            velocities=_frozen(f[:, _VX : _VX + 3].copy()),
            tracks=self._tracks(),
        )
