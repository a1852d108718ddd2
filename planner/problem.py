"""The global planning problem: a height grid, danger zones, start, goal and N free waypoints.

A candidate path is S, W_1 .. W_N, G. The optimisers see only the solution vector: the 3N
coordinates ``[x_1, y_1, z_1, x_2, ...]`` of the free waypoints, bounded by the map (the extent of
the cell centres, so every lookup is interpolated, never extrapolated) and the altitude band
[Zmin, Zmax]. The problem is a callable objective ``f(X (P, 3N)) -> (P,)`` for any optimiser.

Defaults and choices:

- the altitude band defaults to seed 002's "just below the lowest / just above the highest terrain
  point": Zmin = lowest terrain - 1 m, Zmax = highest terrain + clearance + max(50 m, 5 % of the
  relief), widened if needed to contain the start and goal altitudes;
- start and goal must lie inside the map and at or above the terrain (+ clearance) — the
  conservative terrain the cost checks (see ``conservative``), or no path could be feasible;
- feasibility: no length below terrain + clearance and, with ``avoid_zones``, no length inside any
  danger zone grown by ``zone_margin`` (the aircraft tracks the flown path within metres, not
  exactly: the margin keeps it out of the real zone);
- with ``conservative`` (the default) the Bresenham check runs on the terrain dilated by one cell
  (:func:`dilated`), so a feasible path clears the bilinear terrain surface too — without it a
  path can slip diagonally between the visited cells of a ridge;
- with a ``performance`` (the aircraft's, :class:`planner.performance.Performance`) every term is
  evaluated on the path the aircraft flies — legs joined by turn fillets (:mod:`planner.flown`) —
  and a feasible path also keeps the climb and descent gradients and fits every fillet inside its
  legs. Without one (the pure seed 002 problem) the polyline is the path;
- terrain the DEM did not measure (``grid.known`` False: filled nodata, cells outside the source
  raster, and the cells next to them) is out of bounds like the map's edge, unless
  ``allow_unknown``; every clearance check uses the grid's conservative safety heights
  (``grid.safety()``: the highest source value in each cell).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from planner.cost import COLLISION_PENALTY, CostTerms, path_costs, smoothness_of
from planner.flown import CHORDS, fillets, flown_paths, flown_with_excess
from planner.performance import Performance
from terrain.errors import InputError
from terrain.grid import HeightGrid
from terrain.validity import ValidityChecker
from terrain.zones import Zone, inflated
from terrain.zoneset import ZoneSet

FloatArray = npt.NDArray[np.float64]


def _point(value: Sequence[float] | FloatArray, name: str) -> FloatArray:
    p = np.asarray(value, dtype=np.float64)
    if p.shape != (3,) or not np.isfinite(p).all():
        raise InputError(f"{name} must be three finite numbers x, y, z; got {value!r}")
    return p


def dilated(grid: HeightGrid) -> HeightGrid:
    """The grid with every cell raised to the highest of its 3 x 3 neighbourhood.

    The Bresenham walk compares the path with one cell value per step, while the terrain between
    cell centres is the bilinear surface of the four surrounding centres; a diagonal crossing of a
    ridge can pass between the cells the walk visits. Every point of the bilinear surface lies
    within one cell of the visited cell at the same major-axis position, so on the dilated grid the
    cell value bounds the true terrain from above and "no length below" means clear of the real
    surface (up to the segment's own climb within one cell).
    """
    from scipy.ndimage import maximum_filter

    h = maximum_filter(np.asarray(grid.heights), size=3, mode="nearest")
    h.flags.writeable = False  # the grid takes it as it is (no copy)
    return replace(grid, heights=h, upper=None)


def unknown_mask_grid(grid: HeightGrid) -> HeightGrid | None:
    """A grid on the same lattice whose cells are +1 where the terrain is unknown or next to an
    unknown cell (the bilinear terrain there depends on a filled value), -1 elsewhere: the
    Bresenham walk of :func:`planner.cost.path_costs` measures the length over it. None when
    every cell is measured."""
    if grid.known is None or not grid.has_unknown:
        return None
    from scipy.ndimage import binary_dilation

    near = binary_dilation(~np.asarray(grid.known), structure=np.ones((3, 3), dtype=bool))
    return HeightGrid(np.where(near, 1.0, -1.0), grid.transform, grid.crs)


def terrain_top(grid: HeightGrid, x: float, y: float) -> float:
    """The planner's conservative terrain height at a map point: the highest of the point's cell
    and the eight around it (what :func:`dilated` puts in that cell)."""
    r, c = grid.cell_of(x, y)
    r0, c0 = int(r), int(c)
    h = grid.heights[max(r0 - 1, 0) : r0 + 2, max(c0 - 1, 0) : c0 + 2]
    return float(h.max())


def with_leads(
    paths: npt.ArrayLike, lead_in: npt.ArrayLike | None, lead_out: npt.ArrayLike | None
) -> FloatArray:
    """(P, W, 3) (or (W, 3)) paths with the point ``lead_in`` (x, y, z) before the start and
    ``lead_out`` after the goal where given."""
    p = np.asarray(paths, dtype=np.float64)
    if p.ndim == 2:
        p = p[None]

    def point(lead: npt.ArrayLike) -> FloatArray:
        return np.broadcast_to(np.asarray(lead, dtype=np.float64), (len(p), 1, 3))

    before = [] if lead_in is None else [point(lead_in)]
    after = [] if lead_out is None else [point(lead_out)]
    return np.concatenate([*before, p, *after], axis=1)


def lead_turn_excess(
    paths: npt.ArrayLike,
    radius: float,
    lead_in: npt.ArrayLike | None = None,
    lead_out: npt.ArrayLike | None = None,
) -> FloatArray:
    """(P,) metres by which the fillets of the turns from ``lead_in`` (a point the aircraft
    comes from) onto the first leg of (P, W, 3) (or (W, 3)) paths, and from the last leg on to
    ``lead_out``, overlap their legs -- the fillets' :attr:`planner.flown.Fillets.leg_excess`
    with the leads added, less the paths' own."""
    p = np.asarray(paths, dtype=np.float64)
    whole = fillets(with_leads(p, lead_in, lead_out), radius).leg_excess.sum(axis=1)
    own = fillets(p, radius).leg_excess.sum(axis=1)
    return np.asarray(np.maximum(0.0, whole - own), dtype=np.float64)


def point_text(given: str | None, x: float, y: float) -> str:
    """A point in a message, in the units the user gave it: ``given`` (e.g. ``lon -105.85000,
    lat 40.20000``) with the map metres after it, else the map metres."""
    metres = f"{x:.1f}, {y:.1f}"
    return f"({given}; map {metres})" if given else f"({metres})"


@dataclass(frozen=True, eq=False)
class PlanningProblem:
    """Start/goal (map metres, z AMSL), N free waypoints, zones, band and clearance."""

    grid: HeightGrid
    start: FloatArray
    goal: FloatArray
    n_waypoints: int = 5
    zones: tuple[Zone, ...] = ()
    zmin: float | None = None
    zmax: float | None = None
    clearance: float = 0.0
    avoid_zones: bool = False
    penalty: float = COLLISION_PENALTY
    conservative: bool = True
    performance: Performance | None = None
    chords: int = CHORDS
    allow_unknown: bool = False
    zone_margin: float = 0.0
    agl_min: float | None = None  # an above-ground band's floor: the clearance is at least this
    agl_max: float | None = None  # its top: no length more than this above the ground
    agl_pref: float | None = None  # a preferred height above the ground (SPSO's J3)
    smoothness: float = 0.0  # weight of the turn / climb-change term (SPSO's J4)
    spirals: bool = True  # a climb a leg cannot make may be flown in a helix (planner.spiral)
    # where the aircraft comes from to the start (a take-off's climb-out: the launch, or where
    # its spiral ends) and goes on to after the goal (a landing's touchdown), (x, y, z): the
    # turns there are flown as fillets in the cost (with_leads, lead_turn_excess)
    lead_in: FloatArray | None = None
    lead_out: FloatArray | None = None
    # how messages name the start and the goal where the user gave them otherwise than in map
    # metres (e.g. "lon -105.85000, lat 40.20000"): None names them by their map metres
    named_ends: tuple[str | None, str | None] = (None, None)
    _zones: ZoneSet = field(init=False, repr=False)
    _check_grid: HeightGrid = field(init=False, repr=False)
    _unknown: HeightGrid | None = field(init=False, repr=False)
    safety_grid: HeightGrid = field(init=False, repr=False)
    validity: ValidityChecker = field(init=False, repr=False)

    def __post_init__(self) -> None:
        g = self.grid
        set_ = object.__setattr__
        set_(self, "start", _point(self.start, "start"))
        set_(self, "goal", _point(self.goal, "goal"))
        for lead in ("lead_in", "lead_out"):
            if getattr(self, lead) is not None:
                set_(self, lead, _point(getattr(self, lead), lead))
        if isinstance(self.n_waypoints, bool) or int(self.n_waypoints) != self.n_waypoints:
            raise InputError(f"number of waypoints must be an integer; got {self.n_waypoints!r}")
        if self.n_waypoints < 1:
            raise InputError(
                f"number of free waypoints N must be at least 1; got {self.n_waypoints}"
            )
        set_(self, "n_waypoints", int(self.n_waypoints))
        if not (math.isfinite(self.clearance) and self.clearance >= 0):
            raise InputError(f"clearance must be a number of metres >= 0; got {self.clearance!r}")
        self._check_above_ground()
        span = float(np.hypot(*(self.goal[:2] - self.start[:2])))
        if span < max(g.cell_size):
            raise InputError(
                f"start and goal are the same place ({span:.1f} m apart, less than a cell); "
                "plan a round trip as two missions, out and back"
            )
        self._check_ends_on_the_map()
        zmin, zmax = self._altitude_band()
        set_(self, "zmin", zmin)
        set_(self, "zmax", zmax)
        set_(self, "zones", tuple(self.zones))
        if not (math.isfinite(self.zone_margin) and self.zone_margin >= 0):
            raise InputError(
                f"zone margin must be a number of metres >= 0; got {self.zone_margin!r}"
            )
        # the cost and the feasibility see every zone grown by the margin (terrain.zones.inflated)
        set_(self, "_zones", ZoneSet.of(tuple(inflated(z, self.zone_margin) for z in self.zones)))
        safety = g.safety()
        set_(self, "safety_grid", safety)
        # made once per grid, shared by every problem on it (a problem is rebuilt with new
        # limits by dataclasses.replace)
        check = safety.derived("planner.dilated", dilated) if self.conservative else safety
        set_(self, "_check_grid", check)
        unknown = None if self.allow_unknown else g.derived("planner.unknown", unknown_mask_grid)
        set_(self, "_unknown", unknown)
        # the hard conditions on a result, on the densely sampled flown path: terrain +
        # clearance on the safety heights, unknown terrain (the same mask as the cost), the zones
        # grown by the margin when they must be avoided (terrain.validity)
        set_(
            self,
            "validity",
            ValidityChecker(
                grid=g,
                ground=safety.height_at,
                terrain_clearance=self.clearance,
                unknown=self._unknown,
                allow_unknown=self.allow_unknown,
                zones=self.zones if self.avoid_zones else (),
                zone_margin=self.zone_margin,
            ),
        )
        self._check_ends_known_and_clear()

    def where(self, name: str, p: FloatArray) -> str:
        """The start or goal ``p`` in a message, in the units the user gave it (its
        :attr:`named_ends` text, :func:`point_text`)."""
        given = self.named_ends[0 if name == "start" else 1] if name in ("start", "goal") else None
        return point_text(given, float(p[0]), float(p[1]))

    def _check_ends_on_the_map(self) -> None:
        """Start and goal inside the map, above the terrain by the clearance, below --agl-max."""
        g = self.grid
        for name, p in (("start", self.start), ("goal", self.goal)):
            if not bool(g.contains(p[0], p[1])):
                xmin, ymin, xmax, ymax = g.bounds
                raise InputError(
                    f"{name} {self.where(name, p)} lies outside the map "
                    f"(x {xmin:.1f} .. {xmax:.1f}, y {ymin:.1f} .. {ymax:.1f})"
                )
            ground = float(g.height_at(p[0], p[1]))
            if p[2] < ground + self.clearance:
                need = f"terrain {ground:.1f} m" + (
                    f" + clearance {self.clearance:g} m" if self.clearance else ""
                )
                raise InputError(
                    f"{name} {self.where(name, p)} at {p[2]:.1f} m AMSL is inside the terrain "
                    f"(needs at least {need})"
                )
            if self.agl_max is not None and p[2] - ground > self.agl_max:
                raise InputError(
                    f"{name} {self.where(name, p)} at {p[2]:.1f} m AMSL is {p[2] - ground:.0f} "
                    f"m above the ground, above --agl-max {self.agl_max:g} m; lower it"
                )

    def _altitude_band(self) -> tuple[float, float]:
        """[Zmin, Zmax]: as given, else the terrain's range, widened by the clearance and a
        margin above and to take the start and goal in."""
        g = self.grid
        relief = g.zmax - g.zmin
        zmin = g.zmin - 1.0 if self.zmin is None else float(self.zmin)
        margin = self.clearance + max(50.0, 0.05 * relief)
        zmax = g.zmax + margin if self.zmax is None else float(self.zmax)
        if self.zmax is None:
            zmax = max(zmax, float(self.start[2]), float(self.goal[2]))
        if self.zmin is None:
            zmin = min(zmin, float(self.start[2]), float(self.goal[2]))
        if not (math.isfinite(zmin) and math.isfinite(zmax)) or zmin >= zmax:
            raise InputError(f"altitude band must have Zmin < Zmax; got [{zmin}, {zmax}]")
        if self.agl_min is not None and zmax <= g.zmin + self.clearance:
            raise InputError(
                f"the above-ground band lies above the altitude band: {self.clearance:g} m over "
                f"the lowest terrain ({g.zmin:.1f} m) is above Zmax {zmax:.1f} m"
            )
        if zmax <= g.zmin + self.clearance:
            raise InputError(
                f"altitude band [{zmin:.1f}, {zmax:.1f}] m lies entirely below the terrain "
                f"(lowest point {g.zmin:.1f} m"
                + (f" + clearance {self.clearance:g} m)" if self.clearance else ")")
            )
        return zmin, zmax

    def _check_ends_known_and_clear(self) -> None:
        """Start and goal over measured terrain (unless allowed) and clear of the planner's
        conservative terrain by the clearance."""
        if self._unknown is not None:
            for name, p in (("start", self.start), ("goal", self.goal)):
                if float(self._unknown.heights[self._unknown.cell_of(p[0], p[1])]) > 0:
                    raise InputError(
                        f"the {name} {self.where(name, p)} lies over terrain the DEM did not "
                        "measure (filled nodata or outside the source raster, or next to it); "
                        "--allow-unknown-terrain accepts that"
                    )
        for name, p in (("start", self.start), ("goal", self.goal)):
            top = float(self._check_grid.heights[self._check_grid.cell_of(p[0], p[1])])
            if p[2] < top + self.clearance:
                raise InputError(
                    f"{name} at {p[2]:.1f} m AMSL is only {p[2] - top:.1f} m above the highest "
                    f"terrain around it ({top:.1f} m, the planner's conservative terrain: the "
                    f"highest of its cell and the eight cells around it), less than the clearance "
                    f"of {self.clearance:g} m; raise it to at least {top + self.clearance:.1f} m"
                )

    @property
    def check_grid(self) -> HeightGrid:
        """The terrain the cost checks: the safety heights, dilated by a cell when conservative."""
        return self._check_grid

    @property
    def cost_zones(self) -> ZoneSet:
        """The zones as the cost sees them: every zone grown by the zone margin."""
        return self._zones

    def _check_above_ground(self) -> None:
        """The above-ground band and preferred height (one line naming the option when wrong);
        the band's floor raises the clearance."""
        set_ = object.__setattr__
        for name in ("agl_min", "agl_max", "agl_pref"):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                flag = "--" + name.replace("_", "-")
                raise InputError(
                    f"{flag} must be a height above the ground in metres >= 0; got {v!r}"
                )
        if not (math.isfinite(self.smoothness) and self.smoothness >= 0):
            raise InputError(f"--smoothness must be a weight >= 0; got {self.smoothness!r}")
        if self.agl_min is not None:
            set_(self, "clearance", max(float(self.clearance), float(self.agl_min)))
        low = float(self.clearance)
        if self.agl_max is not None and self.agl_max <= low:
            raise InputError(
                f"the above-ground band is empty: --agl-max {self.agl_max:g} m is not above its "
                f"floor, {low:g} m (the larger of --agl-min and --clearance)"
            )
        if self.agl_pref is not None:
            high = math.inf if self.agl_max is None else float(self.agl_max)
            if not low <= self.agl_pref <= high:
                band = f"[{low:g}, {high:g}] m" if high < math.inf else f"at least {low:g} m"
                raise InputError(
                    f"--agl-pref {self.agl_pref:g} m lies outside the above-ground band ({band})"
                )

    # -- the search space ---------------------------------------------------------------------------
    @property
    def dimension(self) -> int:
        return 3 * self.n_waypoints

    @property
    def band(self) -> tuple[float, float]:
        assert self.zmin is not None and self.zmax is not None
        return (self.zmin, self.zmax)

    def bounds(self) -> tuple[FloatArray, FloatArray]:
        """(lower, upper) of the 3N-vector: cell-centre extent of the map, altitude band."""
        xmin, ymin, xmax, ymax = self.grid.bounds
        dx, dy = self.grid.cell_size
        lo3 = np.array([xmin + dx / 2, ymin + dy / 2, self.band[0]])
        hi3 = np.array([xmax - dx / 2, ymax - dy / 2, self.band[1]])
        return np.tile(lo3, self.n_waypoints), np.tile(hi3, self.n_waypoints)

    def paths(self, x: npt.ArrayLike) -> FloatArray:
        """(P, N + 2, 3) polylines S, W_1..W_N, G of a (P, 3N) population (or one (3N,) vector)."""
        arr = np.asarray(x, dtype=np.float64)
        single = arr.ndim == 1
        arr = np.atleast_2d(arr)
        if arr.shape[1] != self.dimension:
            raise InputError(
                f"solution vectors must have {self.dimension} numbers; got {arr.shape[1]}"
            )
        p = arr.shape[0]
        mid = arr.reshape(p, self.n_waypoints, 3)
        out = np.concatenate(
            [np.broadcast_to(self.start, (p, 1, 3)), mid, np.broadcast_to(self.goal, (p, 1, 3))],
            axis=1,
        )
        return out[0] if single else out

    def straight_seeds(self) -> FloatArray:
        """Two seed solutions on the straight start-goal line: altitudes interpolated between the
        ends, and a constant altitude clearing all terrain under the line (clipped to Zmax)."""
        t = np.linspace(0.0, 1.0, self.n_waypoints + 2)[1:-1, None]
        line = self.start[None, :] + t * (self.goal - self.start)[None, :]
        # highest cell under the line (cell values, as the Bresenham check uses), sampled densely
        span = float(np.linalg.norm(self.goal[:2] - self.start[:2]))
        n = max(2, int(np.ceil(4.0 * span / min(self.grid.cell_size))) + 1)
        dense = np.linspace(0.0, 1.0, n)[:, None]
        xy = self.start[None, :2] + dense * (self.goal - self.start)[None, :2]
        top = float(self._check_grid.heights[self.grid.cell_of(xy[:, 0], xy[:, 1])].max())
        high = line.copy()
        high[:, 2] = min(
            top + max(self.clearance, 1.0) + 0.5 * self.grid.cell_size[0], self.band[1]
        )
        lo, hi = self.bounds()
        return np.clip(np.stack([line.ravel(), high.ravel()]), lo, hi)

    def corridor_population(self, n: int, rng: np.random.Generator) -> FloatArray:
        """``n`` random solutions that progress from start to goal: each path's waypoints sit at
        sorted random fractions of the start-goal line, displaced sideways by a smooth excursion
        (normal, sigma 25 % of the start-goal distance, shaped sin(pi t) so it vanishes at both
        ends) plus a per-waypoint jitter (sigma 5 %); clipped to the box. Uniform points in the
        box make zig-zag paths that cross the map many times, which on mountain maps nearly always
        hit the ground.

        Each waypoint's altitude is uniform between the ground under it (the cell the cost checks,
        plus the clearance; never below Zmin) and Zmax: a waypoint below the ground beneath it
        makes its path infeasible whatever the optimiser does next, so drawing it there wastes the
        particle. Measured on jacksboro (ridge and valley, the hardest of the three benchmark
        maps; 10 seeds, P=60, 200 iterations): with altitudes uniform in the whole band no path
        of the initial population was feasible for 9 seeds of 10, and AMPSO ended infeasible in
        2 runs of 10 (GA 1, APSO 4, PSO 7); with these altitudes every algorithm was feasible in
        all 10 runs (30 seeds: 30/30 each)."""
        s, g = self.start, self.goal
        d = g[:2] - s[:2]
        span = float(np.linalg.norm(d))
        u = d / span if span > 0 else np.array([1.0, 0.0])
        side = np.array([-u[1], u[0]])
        k = self.n_waypoints
        t = np.sort(rng.uniform(0.0, 1.0, (n, k)), axis=1)
        off = rng.normal(0.0, 0.25 * span, (n, 1)) * np.sin(np.pi * t)
        off = off + rng.normal(0.0, 0.05 * span, (n, k))
        xy = (
            s[None, None, :2]
            + t[..., None] * d[None, None, :]
            + off[..., None] * side[None, None, :]
        )
        lo, hi = self.bounds()
        xy = np.clip(xy, lo[:2], hi[:2])
        check = self._check_grid
        ground = check.heights[check.cell_of(xy[..., 0].ravel(), xy[..., 1].ravel())].reshape(n, k)
        floor = np.clip(ground + self.clearance, self.band[0], self.band[1])
        z = floor + rng.uniform(0.0, 1.0, (n, k)) * (self.band[1] - floor)
        x = np.concatenate([xy, z[..., None]], axis=2).reshape(n, -1)
        return np.clip(x, lo, hi)

    # -- the objective -------------------------------------------------------------------------------
    def terms(self, x: npt.ArrayLike) -> CostTerms:
        """Every cost term of a (P, 3N) population (on the flown paths, see :meth:`flown`)."""
        return self.polyline_terms(self.paths(np.atleast_2d(np.asarray(x, dtype=np.float64))))

    def polyline_terms(self, path: npt.ArrayLike) -> CostTerms:
        """Every cost term of waypoint polyline(s) (W, 3) or (P, W, 3) with any number W >= 2 of
        vertices, from the start to the goal as given (not checked): what :meth:`terms` computes
        for the N free waypoints, for a path another planner made (an OMPL path of any length).
        With a performance the polyline is turned into the flown path (fillets, climb excess) as
        in :meth:`terms`; the smoothness is taken on the polyline's interior vertices."""
        paths = np.asarray(path, dtype=np.float64)
        if paths.ndim == 2:
            paths = paths[None]
        if paths.ndim != 3 or paths.shape[1] < 2 or paths.shape[2] != 3:
            raise InputError(
                f"polylines must have shape (W, 3) or (P, W, 3) with W >= 2; got {paths.shape}"
            )
        z = self._zones
        smooth = smoothness_of(paths, self.smoothness) if self.smoothness else None
        ce = te = None
        perf = self.performance
        if perf is not None:
            # with the take-off's and the landing's leads: the turns onto and off the plan are
            # flown as fillets, their overlap and their climb on the arc counted; the flown
            # path checked against the ground starts and ends at their tangent points
            first = self.lead_in is not None
            last = self.lead_out is not None
            paths, te, ce = flown_with_excess(
                with_leads(paths, self.lead_in, self.lead_out),
                perf.turn_radius,
                perf.climb_gradient,
                perf.descent_gradient,
                self.chords,
            )
            paths = paths[:, int(first) : paths.shape[1] - int(last)]
        return path_costs(
            self._check_grid,
            paths,
            zmin=self.band[0],
            zmax=self.band[1],
            zones=z,
            clearance=self.clearance,
            penalty=self.penalty,
            hard_zones=self.avoid_zones,
            climb_excess=ce,
            turn_excess=te,
            unknown=self._unknown,
            ground=self.grid,
            agl_max=self.agl_max,
            agl_pref=self.agl_pref,
            smoothness=smooth,
            spiral_gradient=self.spiral_gradient,
        )

    @property
    def spiral_gradient(self) -> float | None:
        """The gradient a climb spiral climbs at (the climb in the banked turn) when the plan may
        spiral -- a fixed wing with a performance and ``spirals`` on -- else None (the cost then
        refuses a leg too steep, :mod:`planner.cost`)."""
        perf = self.performance
        if not self.spirals or perf is None or perf.hover:
            return None
        return float(perf.turn_climb_gradient)

    def repairable(self, terms: CostTerms) -> npt.NDArray[np.bool_]:
        """:meth:`feasible`, but a climb excess the plan may fly in spirals does not count (the
        repair after the search places them and checks every helix): what the search's own
        rankings of seeds use."""
        if self.spiral_gradient is None:
            return self.feasible(terms)
        return self.feasible(replace(terms, climb_excess=np.zeros_like(terms.climb_excess)))

    def __call__(self, x: npt.ArrayLike) -> FloatArray:
        return self.terms(x).total

    @property
    def rowwise(self) -> bool:
        """Whether each path's cost is the same whatever other paths share the call (the
        optimisers then batch their calls, :data:`planner.optim.base.Objective`): so but with
        the above-ground terms, whose samples a segment follow the call's longest segment."""
        return self.agl_max is None and self.agl_pref is None

    @property
    def unknown_grid(self) -> HeightGrid | None:
        """The unknown-terrain mask the cost walks (None: all measured, or allowed)."""
        return self._unknown

    def flown(self, paths: npt.ArrayLike) -> FloatArray:
        """The path(s) the aircraft flies through waypoint path(s) (W, 3) or (P, W, 3): the
        filleted polyline with a performance, else the waypoints themselves."""
        p = np.asarray(paths, dtype=np.float64)
        if self.performance is None:
            return p
        return flown_paths(p, self.performance.turn_radius, self.chords)[0]

    def feasible(self, terms: CostTerms) -> npt.NDArray[np.bool_]:
        ok = terms.below_length <= 0.0
        if self.avoid_zones and terms.inside.shape[1]:
            ok &= terms.inside.sum(axis=1) <= 0.0
        ok &= (terms.climb_excess <= 0.0) & (terms.turn_excess <= 0.0)
        ok &= terms.unknown_length <= 0.0
        ok &= terms.above_length <= 0.0
        return np.asarray(ok)
