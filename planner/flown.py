"""The path the aircraft flies: waypoint legs joined by turn fillets (Beard & McLain §11.2).

A fixed-wing aircraft cannot turn at a waypoint; it flies the leg into waypoint W_k until the
fillet's first tangent point, a circular arc of radius R, then the next leg from the second
tangent point. For a turn through the angle D_k between the horizontal leg directions q_{k-1} and
q_k (0 = straight on, pi = a reversal)::

    d_k = R tan(D_k / 2)                    tangent distance: T1 = W_k - d_k q_{k-1}, T2 = W_k + d_k q_k
    C_k = W_k + R / cos(D_k / 2) * b_k      centre, b_k the unit bisector (q_k - q_{k-1}) / |q_k - q_{k-1}|

The turn fits when the fillets at both ends of every leg fit inside it: d_k + d_{k+1} <= L_k
(the start and the goal have no fillet). ``turn_excess`` is the sum of the overlaps, the term the
planner penalises. When fillets overlap the path is still defined (for the clearance check of an
infeasible candidate): both tangent distances of the leg are shrunk in proportion, which tightens
the radius of those turns below R.

Altitudes (what ``replay/flight/fixedwing/autopilot.py`` commands in its fillet mode): on a leg the altitude is
linear in the horizontal distance between the leg's waypoints; on an arc it is linear in the
angle turned, from the altitude of the leg at T1 to that of the next leg at T2.

``flown_paths`` returns the flown path as a polyline for the planner's cost: every arc is cut into
``chords`` straight pieces (the vertices lie on the arc; a chord stays within
``R (1 - cos(D / (2 chords)))`` of it: 5 m for a 180 deg turn of R = 143 m with 6 chords; the
conservative, one-cell-dilated terrain of the cost covers that). Vectorised over a whole swarm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from planner import kernels

FloatArray = npt.NDArray[np.float64]
CHORDS = 6
MAX_TURN = np.pi - 1e-3  # tan(D/2) of a full reversal is infinite: cap it (d = 2000 R)
_EPS = 1e-9
TOLERANCE = 1e-6  # m: excess below this is rounding, not a broken limit


@dataclass(frozen=True)
class Fillets:
    """Fillet geometry of P paths with N interior waypoints (arrays (P, N) unless noted).

    ``angle`` turn angle D (rad, >= 0); ``side`` +1 for a left (counter-clockwise) turn, -1 right;
    ``wanted`` the tangent distance R tan(D/2); ``distance`` the one used (shrunk where fillets
    overlap); ``radius`` the arc radius that gives; ``t1``, ``t2``, ``center`` (P, N, 3) with the
    altitude of the tangent points (the centre's z is that of W_k); ``turn_excess`` (P,) the sum
    over legs of max(0, d_start + d_end - L_leg); ``leg_excess`` (P, N + 1) per leg.
    """

    angle: FloatArray
    side: FloatArray
    wanted: FloatArray
    distance: FloatArray
    radius: FloatArray
    t1: FloatArray
    t2: FloatArray
    center: FloatArray
    turn_excess: FloatArray
    leg_excess: FloatArray

    def at(self, k: int) -> Fillets:
        """The fillet at interior waypoint ``k`` (1-based, as in the path) of a single path; the
        per-path excesses are kept as they are."""
        sel = slice(k - 1, k)
        return Fillets(
            angle=self.angle[:1, sel],
            side=self.side[:1, sel],
            wanted=self.wanted[:1, sel],
            distance=self.distance[:1, sel],
            radius=self.radius[:1, sel],
            t1=self.t1[:1, sel],
            t2=self.t2[:1, sel],
            center=self.center[:1, sel],
            turn_excess=self.turn_excess,
            leg_excess=self.leg_excess,
        )


def fillets(paths: npt.ArrayLike, radius: float) -> Fillets:
    """Fillets of radius ``radius`` at the interior points of (P, W, 3) (or one (W, 3)) paths."""
    p = np.asarray(paths, dtype=np.float64)
    if p.ndim == 2:
        p = p[None]
    seg = np.diff(p[..., :2], axis=1)  # (P, W-1, 2)
    length = np.hypot(seg[..., 0], seg[..., 1])
    q = seg / np.where(length > _EPS, length, 1.0)[..., None]
    qa, qb = q[:, :-1], q[:, 1:]  # into and out of each interior point
    cos_d = np.clip((qa * qb).sum(axis=-1), -1.0, 1.0)
    angle = np.arccos(cos_d)
    # a zero-length horizontal leg has no direction: no turn there (the climb limit catches it)
    degenerate = (length[:, :-1] <= _EPS) | (length[:, 1:] <= _EPS)
    angle = np.where(degenerate, 0.0, angle)
    cross = qa[..., 0] * qb[..., 1] - qa[..., 1] * qb[..., 0]
    side = np.where(cross >= 0.0, 1.0, -1.0)
    tan_half = np.tan(0.5 * np.minimum(angle, MAX_TURN))
    wanted = float(radius) * tan_half
    # tangent distance at every point of the path (0 at the start and the goal)
    d_all = np.zeros(p.shape[:2])
    d_all[:, 1:-1] = wanted
    need = d_all[:, :-1] + d_all[:, 1:]  # per leg
    leg_excess = np.maximum(0.0, need - length - TOLERANCE)
    scale = np.where(need > length, length / np.where(need > 0, need, 1.0), 1.0)
    used = wanted * np.minimum(scale[:, :-1], scale[:, 1:])
    arc_r = np.where(tan_half > _EPS, used / np.where(tan_half > _EPS, tan_half, 1.0), radius)
    w = p[:, 1:-1, :]
    t1 = np.empty_like(w)
    t2 = np.empty_like(w)
    t1[..., :2] = w[..., :2] - used[..., None] * qa
    t2[..., :2] = w[..., :2] + used[..., None] * qb
    la = length[:, :-1]
    lb = length[:, 1:]
    fa = np.where(la > _EPS, used / np.where(la > _EPS, la, 1.0), 0.0)
    fb = np.where(lb > _EPS, used / np.where(lb > _EPS, lb, 1.0), 0.0)
    t1[..., 2] = w[..., 2] - fa * (w[..., 2] - p[:, :-2, 2])
    t2[..., 2] = w[..., 2] + fb * (p[:, 2:, 2] - w[..., 2])
    bis = qb - qa
    bn = np.hypot(bis[..., 0], bis[..., 1])
    bis = np.where(bn[..., None] > _EPS, bis / np.where(bn > _EPS, bn, 1.0)[..., None], 0.0)
    center = w.copy()
    cos_half = np.cos(0.5 * np.minimum(angle, MAX_TURN))
    center[..., :2] = w[..., :2] + (arc_r / cos_half)[..., None] * bis
    return Fillets(
        angle=angle,
        side=side,
        wanted=wanted,
        distance=used,
        radius=arc_r,
        t1=t1,
        t2=t2,
        center=center,
        turn_excess=leg_excess.sum(axis=1),
        leg_excess=leg_excess,
    )


def arc_points(f: Fillets, chords: int = CHORDS) -> FloatArray:
    """(P, N, chords + 1, 3) points along every fillet from T1 to T2 (both included): positions
    on the arc, altitude linear in the angle turned."""
    s = np.linspace(0.0, 1.0, chords + 1)  # (K+1,)
    a = f.t1[..., None, :2] - f.center[..., None, :2]  # (P, N, 1, 2)
    theta = (f.side * f.angle)[..., None] * s  # (P, N, K+1), + counter-clockwise
    c, sn = np.cos(theta), np.sin(theta)
    out = np.empty((*f.t1.shape[:2], chords + 1, 3))
    out[..., 0] = f.center[..., None, 0] + a[..., 0] * c - a[..., 1] * sn
    out[..., 1] = f.center[..., None, 1] + a[..., 0] * sn + a[..., 1] * c
    out[..., 2] = f.t1[..., None, 2] + s * (f.t2[..., None, 2] - f.t1[..., None, 2])
    # the tangent points exactly (no rounding drift at the joins with the legs)
    out[..., 0, :] = f.t1
    out[..., -1, :] = f.t2
    return out


def flown_paths(
    paths: npt.ArrayLike, radius: float, chords: int = CHORDS
) -> tuple[FloatArray, Fillets]:
    """The flown polylines (P, 2 + N (chords + 1), 3) of (P, W, 3) waypoint paths and their
    fillets: S, then T1..arc..T2 of every interior waypoint, then G."""
    p = np.asarray(paths, dtype=np.float64)
    single = p.ndim == 2
    if single:
        p = p[None]
    f = fillets(p, radius)
    arcs = arc_points(f, chords).reshape(p.shape[0], -1, 3)
    out = np.concatenate([p[:, :1], arcs, p[:, -1:]], axis=1)
    return (out[0] if single else out), f


def flown_with_excess(
    paths: npt.ArrayLike,
    radius: float,
    climb_gradient: float,
    descent_gradient: float,
    chords: int = CHORDS,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(flown polylines, turn excess, climb excess) of (P, W, 3) waypoint paths: what
    :func:`flown_paths` and :func:`climb_excess` give, in one compiled pass
    (``planner.kernels.flown``, about 4x faster on a swarm; the cost runs it every iteration).
    Equal to the numpy functions to rounding (tests compare them)."""
    p = np.ascontiguousarray(paths, dtype=np.float64)
    if p.ndim != 3 or p.shape[1] < 2 or p.shape[2] != 3:
        raise ValueError(f"paths must have shape (P, W >= 2, 3); got {p.shape}")
    out, turn, climb = kernels.flown(
        p,
        float(radius),
        int(chords),
        float(climb_gradient),
        float(descent_gradient),
        float(MAX_TURN),
        _EPS,
        TOLERANCE,
    )
    return np.asarray(out), np.asarray(turn), np.asarray(climb)


def climb_excess(
    flown: npt.ArrayLike, climb_gradient: float, descent_gradient: float
) -> FloatArray:
    """Metres of altitude change beyond the limits, summed over the pieces of (P, M, 3) flown
    polylines: max(0, dz - G_up h) for climbs, max(0, -dz - G_down h) for descents (less a
    micrometre of rounding tolerance per piece)."""
    p = np.asarray(flown, dtype=np.float64)
    d = np.diff(p, axis=-2)
    h = np.hypot(d[..., 0], d[..., 1])
    dz = d[..., 2]
    over = np.maximum(0.0, dz - climb_gradient * h - TOLERANCE) + np.maximum(
        0.0, -dz - descent_gradient * h - TOLERANCE
    )
    return np.asarray(over.sum(axis=-1), dtype=np.float64)
