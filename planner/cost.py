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
the ground, a path with F > 3.5 certainly hits the ground — seed 002's infeasibility threshold —
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

A_traj is the mean altitude *along the path* (each segment weighted by its 3D length, its altitude
the mean of its ends), so a short climb costs less than a long high cruise; a degenerate path of
length 0 takes the mean of its points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from terrain.grid import HeightGrid
from terrain.segments import path_below_lengths
from terrain.zoneset import ZoneSet

FloatArray = npt.NDArray[np.float64]
COLLISION_PENALTY = 3.0


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
) -> CostTerms:
    """Cost terms of a (P, W, 3) stack of polylines (one call for a whole swarm).

    ``climb_excess`` and ``turn_excess`` (P,) are the metres beyond the aircraft's limits (None:
    no limits); ``unknown`` is a grid of the same lattice whose cells are > 0 where the terrain is
    unknown and < 0 where it was measured (None: all measured)."""
    p = np.asarray(paths, dtype=np.float64)
    seg = np.diff(p, axis=1)
    seg_len = np.linalg.norm(seg, axis=2)
    length = seg_len.sum(axis=1)
    straight = np.linalg.norm(p[:, -1, :] - p[:, 0, :], axis=1)
    safe_len = np.where(length > 0, length, 1.0)
    f_length = np.where(length > 0, 1.0 - straight / safe_len, 0.0)

    mid_z = 0.5 * (p[:, :-1, 2] + p[:, 1:, 2])
    mean_alt = np.where(
        length > 0, (seg_len * mid_z).sum(axis=1) / safe_len, p[:, :, 2].mean(axis=1)
    )
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
    f_climb = np.where(ce > 0, penalty + ce / safe_len, 0.0)
    f_turn = np.where(te > 0, penalty + te / safe_len, 0.0)
    f_unknown = np.where(over > 0, penalty + over / safe_len, 0.0)
    total = f_length + f_alt + f_col + f_dz + f_climb + f_turn + f_unknown
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
    )
