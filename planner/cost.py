"""The path cost of seed 002 (after Roberge et al. 2013), vectorised over a whole population.

For a polyline S, W_1 .. W_N, G (all points map metres, z AMSL):

    F             = F_length + F_altitude + F_collision + F_dangerzones
    F_length      = 1 - L_SG / L_traj                 L_SG the straight 3D start-goal distance
    F_altitude    = (A_traj - Zmin) / (Zmax - Zmin)   A_traj the length-weighted mean altitude
    F_collision   = 0 if L_under == 0 else P + L_under / L_traj,  P = 3
    F_dangerzones = (1/n) sum_i min(1, L_inside_i / d_i)   (d_i: a cylinder's diameter, a polygon
                                                          zone's equal-area diameter 2 sqrt(A/pi))

``L_under`` is the length below terrain (+ clearance) from the Bresenham walk of
:mod:`terrain.segments`; ``L_inside_i`` the length inside zone i (a cylinder or a polygon prism, each
with an optional floor and top) from :class:`terrain.zoneset.ZoneSet`. With no danger zones F_dangerzones is 0. Because F_length and
F_altitude lie in [0, 1], F_dangerzones in [0, 1] and F_collision >= 3 whenever the path touches
the ground, a path with F > 3.5 certainly hits the ground — seed 002's infeasibility threshold
(of its four terms; the terms below add to it) —
and any colliding path costs more than any collision-free one of the same map when the
altitude band is honoured.

With ``hard_zones`` (the planner's ``avoid_zones``), a path entering any zone also pays the
penalty P in F_dangerzones, so zones become constraints as hard as the ground.

Three more terms make a path flyable and honest (not in seed 002; zero for a path that keeps the
limits, so the paper's cost is unchanged there), each shaped like F_collision:

    F_climb   = 0 if E_climb == 0 else P + E_climb / L_traj    E_climb: metres climbed or descended
                                                               beyond the aircraft's gradients
    F_turn    = 0 if E_turn == 0 else P + E_turn / L_traj      E_turn: metres by which turn fillets
                                                               overlap on their legs (planner.flown)
    F_unknown = 0 if L_unknown == 0 else P + L_unknown / L_traj  L_unknown: length over terrain the
                                                               DEM did not measure (Bresenham walk
                                                               over the grid's unknown cells)

The caller passes E_climb and E_turn (computed on the flown path, see :mod:`planner.flown`) and the
unknown-cell mask as a grid; the polyline given is the one evaluated (the flown path).

**Spirals (issue 33).**  Where the plan may climb in spirals (``spiral_gradient`` given: the
gradient the aircraft climbs at in its banked turn, :attr:`planner.performance.Performance.
turn_climb_gradient`), a climb or descent a leg cannot make is not a fault but a helix to fly:
the path is priced as if ``E_climb / spiral_gradient`` metres longer (the helix's horizontal
length; at a few per cent of gradient its 3-D length to 0.1 %) in F_length, and F_climb is
``SPIRAL_SURCHARGE`` (1) instead of P + E_climb / L_traj.  So a path that spirals costs more than
any flyable one without a spiral (F_length + F_altitude < 2, and the planner should not spiral
where a straight climb fits) and less than any with a fault (>= P = 3): among the spiralling
ones the swarm weighs a helix against the detour that would make the climb.  A descent is priced
at the same gradient (the climb in a turn is the smaller; the kernel gives one excess for both,
so a descent spiral is priced up to ``climb / turn climb`` times its length -- the repair,
:func:`planner.spiral.spiral_repair`, places and prices it exactly).  The swarm's result keeps
its excess (``climb_excess_m``) and is repaired into spirals after the search.

Three optional terms users ask for (issue 20; zero unless asked for, so seed 002's cost is
unchanged by default), each reported like the others:

    F_above  = 0 if L_above == 0 else P + L_above / L_traj    L_above: length more than agl_max
                                                             above the ground (an above-ground
                                                             band's top; its floor is the
                                                             clearance the collision term keeps)
    F_pref   = mean |h - h_pref| / (Zmax - Zmin)             h: the height above the ground along
                                                             the path (SPSO's altitude term J3);
                                                             it replaces F_altitude when given
    F_smooth = w (1 / (N)) sum_i (theta_i + |gamma_i - gamma_{i-1}|) / pi
                                                             theta_i: the turn at waypoint i,
                                                             gamma: the legs' climb angles (SPSO's
                                                             J4, without its 45 deg dead band)

The height above the ground is sampled along the (flown) path every cell (at most 128 samples a
segment; a sparser estimate let the swarm settle between samples, over valleys the result's check
-- every half cell -- then refused: measured on jacksboro with a 400 m band), on the DEM's cells;
the smoothness is taken on the waypoint
polyline (the N interior vertices), not on the fillets that round it.

A_traj is the mean altitude *along the path* (each segment weighted by its 3D length, its altitude
the mean of its ends), so a short climb costs less than a long high cruise; a degenerate path of
length 0 takes the mean of its points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from planner import kernels
from terrain.grid import HeightGrid
from terrain.segments import path_below_lengths
from terrain.zoneset import ZoneSet

FloatArray = npt.NDArray[np.float64]
COLLISION_PENALTY = 3.0
SPIRAL_SURCHARGE = 1.0  # F_climb of a path that climbs in spirals (module docstring)


@dataclass(frozen=True)
class CostTerms:
    """Every term of the cost for P paths (arrays of shape (P,), ``inside`` (P, K))."""

    total: FloatArray
    length: FloatArray
    altitude: FloatArray
    collision: FloatArray
    dangerzones: FloatArray
    path_length: FloatArray
    below_length: FloatArray
    inside: FloatArray
    mean_altitude: FloatArray
    climb: FloatArray
    turn: FloatArray
    unknown: FloatArray
    climb_excess: FloatArray
    turn_excess: FloatArray
    unknown_length: FloatArray
    above: FloatArray  # F_above
    above_length: FloatArray  # L_above, m
    preferred: FloatArray  # F_pref (0 when no preferred height)
    smoothness: FloatArray  # F_smooth (0 when its weight is 0)

    def row(self, i: int) -> dict[str, float]:
        """Plain-data terms of path i (what the mission file records)."""
        return {
            "total": float(self.total[i]),
            "length": float(self.length[i]),
            "altitude": float(self.altitude[i]),
            "collision": float(self.collision[i]),
            "dangerzones": float(self.dangerzones[i]),
            "path_length_m": float(self.path_length[i]),
            "below_terrain_m": float(self.below_length[i]),
            "inside_zones_m": float(self.inside[i].sum()) if self.inside.shape[1] else 0.0,
            "mean_altitude_m": float(self.mean_altitude[i]),
            "climb": float(self.climb[i]),
            "turn": float(self.turn[i]),
            "unknown": float(self.unknown[i]),
            "climb_excess_m": float(self.climb_excess[i]),
            "turn_excess_m": float(self.turn_excess[i]),
            "unknown_terrain_m": float(self.unknown_length[i]),
            "above_band": float(self.above[i]),
            "above_band_m": float(self.above_length[i]),
            "preferred_height": float(self.preferred[i]),
            "smoothness": float(self.smoothness[i]),
        }


def path_costs(
    grid: HeightGrid,
    paths: npt.ArrayLike,
    *,
    zmin: float,
    zmax: float,
    zones: ZoneSet | None = None,
    clearance: float = 0.0,
    penalty: float = COLLISION_PENALTY,
    hard_zones: bool = False,
    climb_excess: FloatArray | None = None,
    turn_excess: FloatArray | None = None,
    unknown: HeightGrid | None = None,
    ground: HeightGrid | None = None,
    agl_max: float | None = None,
    agl_pref: float | None = None,
    smoothness: FloatArray | None = None,
    spiral_gradient: float | None = None,
) -> CostTerms:
    """Cost terms of a (P, W, 3) stack of polylines (one call for a whole swarm).

    ``climb_excess`` and ``turn_excess`` (P,) are the metres beyond the aircraft's limits (None:
    no limits); ``unknown`` is a grid of the same lattice whose cells are > 0 where the terrain is
    unknown and < 0 where it was measured (None: all measured).  ``ground`` (the DEM) with
    ``agl_max`` or ``agl_pref`` adds the above-ground terms; ``smoothness`` (P,) is F_smooth,
    computed by the caller on the waypoint polylines (:func:`smoothness_of`).
    ``spiral_gradient``: the climb excess is priced as a spiral's length (module docstring)."""
    p = np.ascontiguousarray(paths, dtype=np.float64)
    if p.ndim == 3 and p.shape[1] >= 2 and p.shape[2] == 3:
        seg_len, length, straight, weighted = kernels.path_lengths(p)
    else:
        seg_len, length, straight, weighted = _lengths_numpy(p)
    safe_len = np.where(length > 0, length, 1.0)
    f_length = np.where(length > 0, 1.0 - straight / safe_len, 0.0)

    mean_alt = weighted / safe_len
    if not (length > 0).all():  # a path of length 0: the mean of its points
        mean_alt = np.where(length > 0, mean_alt, p[:, :, 2].mean(axis=1))
    f_alt = (mean_alt - zmin) / (zmax - zmin)

    below = path_below_lengths(grid, p, clearance)
    f_col = np.where(below > 0, penalty + below / safe_len, 0.0)

    k = 0 if zones is None else len(zones)
    if zones is not None and k:
        inside = zones.path_lengths(p)
        f_dz = np.minimum(1.0, inside / zones.sizes[None, :]).sum(axis=1) / k
        if hard_zones:
            # zones as hard constraints: entering any costs the collision penalty, like the ground
            f_dz = f_dz + np.where(inside.sum(axis=1) > 0, penalty, 0.0)
    else:
        inside = np.zeros((p.shape[0], 0))
        f_dz = np.zeros(p.shape[0])
    n = p.shape[0]
    ce = np.zeros(n) if climb_excess is None else np.asarray(climb_excess, dtype=np.float64)
    te = np.zeros(n) if turn_excess is None else np.asarray(turn_excess, dtype=np.float64)
    if unknown is not None:
        flat = p.copy()
        flat[..., 2] = 0.0
        over = path_below_lengths(unknown, flat, 0.0)
    else:
        over = np.zeros(n)
    if spiral_gradient is not None:
        # the climb the legs cannot make, flown in a helix: the path is that much longer
        helix = ce / spiral_gradient
        longer = length + helix
        f_length = np.where(longer > 0, 1.0 - straight / np.where(longer > 0, longer, 1.0), 0.0)
        f_climb = np.where(ce > 0, SPIRAL_SURCHARGE, 0.0)
    else:
        f_climb = np.where(ce > 0, penalty + ce / safe_len, 0.0)
    f_turn = np.where(te > 0, penalty + te / safe_len, 0.0)
    f_unknown = np.where(over > 0, penalty + over / safe_len, 0.0)
    f_above = np.zeros(n)
    above = np.zeros(n)
    f_pref = np.zeros(n)
    if ground is not None and (agl_max is not None or agl_pref is not None):
        agl, w = _heights_above(ground, p, seg_len)
        if agl_max is not None:
            above = ((agl > agl_max) * w).sum(axis=1)
            f_above = np.where(above > 0, penalty + above / safe_len, 0.0)
        if agl_pref is not None:
            f_pref = (np.abs(agl - agl_pref) * w).sum(axis=1) / safe_len / (zmax - zmin)
            f_alt = np.zeros(n)  # the preferred height replaces the lowest-altitude term
    f_smooth = np.zeros(n) if smoothness is None else np.asarray(smoothness, dtype=np.float64)
    total = f_length + f_alt + f_col + f_dz + f_climb + f_turn + f_unknown
    total = total + f_above + f_pref + f_smooth
    return CostTerms(
        total,
        f_length,
        f_alt,
        f_col,
        f_dz,
        length,
        below,
        inside,
        mean_alt,
        f_climb,
        f_turn,
        f_unknown,
        ce,
        te,
        over,
        f_above,
        above,
        f_pref,
        f_smooth,
    )


def _lengths_numpy(p: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """(segment lengths (P, S), path lengths, straight end-to-end distances, sums of segment
    length x mean altitude) of (P, W, 3) polylines: the numpy twin of
    ``planner.kernels.path_lengths`` (which path_costs runs: one pass instead of a dozen numpy
    calls, issue 38).  np.linalg.norm's arithmetic without its checks, the three squares added
    in order as ``(seg * seg).sum(axis=2)`` adds them."""
    seg = np.diff(p, axis=1)
    sq = seg * seg
    seg_len = np.sqrt(sq[..., 0] + sq[..., 1] + sq[..., 2])
    ends = p[:, -1, :] - p[:, 0, :]
    straight = np.sqrt((ends * ends).sum(axis=1))
    mid_z = 0.5 * (p[:, :-1, 2] + p[:, 1:, 2])
    return seg_len, seg_len.sum(axis=1), straight, (seg_len * mid_z).sum(axis=1)


AGL_SAMPLES_MAX = 128  # height-above-ground samples per segment at most


def _heights_above(
    ground: HeightGrid, p: FloatArray, seg_len: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """(P, S m) heights above the DEM's cells at ``m`` samples in each of the S
    segments of every path (midpoints of m equal pieces, m from the longest segment and the
    cell, at most AGL_SAMPLES_MAX), and each sample's share of its segment's length."""
    cell = min(ground.cell_size)
    m = int(min(AGL_SAMPLES_MAX, max(1, math.ceil(float(seg_len.max(initial=0.0)) / cell))))
    t = (np.arange(m) + 0.5) / m
    a, b = p[:, :-1, None, :], p[:, 1:, None, :]
    pts = a + t[None, None, :, None] * (b - a)  # (P, S, m, 3)
    rows, cols = ground.cell_of(pts[..., 0].ravel(), pts[..., 1].ravel())
    h = ground.heights[rows, cols].astype(np.float64).reshape(pts.shape[:3])
    agl = (pts[..., 2] - h).reshape(p.shape[0], -1)
    w = np.repeat(seg_len / m, m, axis=1)
    return agl, w


def smoothness_of(paths: FloatArray, weight: float) -> FloatArray:
    """F_smooth of (P, W, 3) waypoint polylines (module docstring): ``weight`` times the mean,
    over the W - 2 interior vertices, of the horizontal turn plus the change of climb angle,
    in units of pi.  A leg without horizontal extent keeps the previous direction."""
    p = np.asarray(paths, dtype=np.float64)
    if weight == 0.0 or p.shape[1] < 3:
        return np.zeros(p.shape[0])
    d = np.diff(p, axis=1)
    flat = np.hypot(d[..., 0], d[..., 1])
    heading = np.arctan2(d[..., 0], d[..., 1])
    climb = np.arctan2(d[..., 2], flat)
    turn = np.abs((heading[:, 1:] - heading[:, :-1] + np.pi) % (2 * np.pi) - np.pi)
    turn = np.where((flat[:, 1:] > 0) & (flat[:, :-1] > 0), turn, 0.0)
    change = np.abs(climb[:, 1:] - climb[:, :-1])
    return np.asarray(weight * (turn + change).mean(axis=1) / np.pi, dtype=np.float64)
