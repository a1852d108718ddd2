"""FGA's collision-cone geometry (Lin, Castano & Xu; seed 004 §II-III): obstacles as the aircraft
perceives them (:class:`FgaObstacle`), the cone's half angle, the encounter window of a course
(:func:`encounter`, eqs 6-9's conflict test), conflicts of many courses at once, separations
along a straight path, the side an obstacle is passed on, the tangent courses to a cone's edges,
and the climb kinematics the pitch plan counts on. :mod:`replay.avoidance.fga` decides with them;
PSO-CA reads the encounter test too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from replay.flight.fixedwing.gains import LoopDesign
from replay.frames import wrap

FloatArray = npt.NDArray[np.float64]

DYNAMIC_MPS = 0.5  # an obstacle faster than this is dynamic (§III-A)
CLIMB_SLEW = LoopDesign.climb_slew  # m/s^2: the autopilot's climb-rate command slew


def climbed(rate: float, t: float) -> float:
    """Height gained in ``t`` seconds by a climb-rate command ``rate`` from level flight, slewed
    at the autopilot's ``CLIMB_SLEW`` (m/s^2)."""
    if t <= 0.0:
        return 0.0
    ramp = abs(rate) / CLIMB_SLEW
    if t <= ramp:
        return math.copysign(0.5 * CLIMB_SLEW * t * t, rate)
    return rate * (t - 0.5 * ramp)


def climb_time(rate: float, height: float) -> float:
    """The time :func:`climbed` takes to gain ``height`` (> 0) at ``|rate|``."""
    r = abs(rate)
    if r <= 0.0:
        return math.inf
    if height <= 0.5 * r * r / CLIMB_SLEW:
        return math.sqrt(2.0 * height / CLIMB_SLEW)
    return height / r + 0.5 * r / CLIMB_SLEW


@dataclass(frozen=True)
class FgaObstacle:
    """One obstacle as FGA sees it: ``center`` (x, y, z: a sphere's centre, a cylinder's top
    face), ``velocity`` (3), horizontal size ``radius`` and vertical extent ``bottom``..``top``."""

    key: str
    center: tuple[float, float, float]
    velocity: tuple[float, float, float]
    radius: float
    bottom: float
    top: float

    @property
    def moving(self) -> bool:
        return math.hypot(*self.velocity) > DYNAMIC_MPS

    def at(self, dt: float) -> FgaObstacle:
        """The obstacle ``dt`` seconds later (constant velocity)."""
        if dt == 0.0 or not self.moving:
            return self
        vx, vy, vz = self.velocity
        x, y, z = self.center
        return FgaObstacle(
            self.key,
            (x + vx * dt, y + vy * dt, z + vz * dt),
            self.velocity,
            self.radius,
            self.bottom + vz * dt,
            self.top + vz * dt,
        )


def cone_half_angle(distance: float, keep: float) -> float:
    """Eq 1 with the exact tangent: ``asin(keep / distance)`` (pi/2 inside)."""
    if distance <= keep:
        return 0.5 * math.pi
    return math.asin(keep / distance)


@dataclass(frozen=True)
class Encounter:
    """One obstacle against one own velocity (module docstring): the relative geometry in the
    horizontal plane, the conflict window, and eq 7's critical time."""

    obstacle: FgaObstacle
    distance: float  # horizontal range r
    along: float  # r cos theta: along-track distance to the CPA (> 0: ahead)
    miss: float  # r |sin theta|
    closing: float  # |V_r| horizontal
    range_rate: float  # d|r|/dt (3-D), < 0 closing
    window: tuple[float, float] | None  # times (from now) inside the protected volume
    inside: bool  # inside the protected volume now
    t_c: float  # eq 7 (inf: no conflict)


def _interval_1d(x0: float, rate: float, lo: float, hi: float) -> tuple[float, float] | None:
    """Times at which ``x0 + rate t`` lies in (lo, hi)."""
    if abs(rate) < 1e-9:
        return (-math.inf, math.inf) if lo < x0 < hi else None
    a, b = (lo - x0) / rate, (hi - x0) / rate
    return (min(a, b), max(a, b))


def interval_disk(
    px: float, py: float, wx: float, wy: float, keep: float
) -> tuple[float, float] | None:
    """Times at which the aircraft, at ``-p`` from the obstacle moving at ``w`` relative to it,
    is within ``keep`` horizontally."""
    a = wx * wx + wy * wy
    c = px * px + py * py - keep * keep
    if a < 1e-12:
        return (-math.inf, math.inf) if c < 0.0 else None
    b = -2.0 * (px * wx + py * wy)
    disc = b * b - 4.0 * a * c
    if disc <= 0.0:
        return None
    s = math.sqrt(disc)
    return ((-b - s) / (2.0 * a), (-b + s) / (2.0 * a))


def encounter(
    position: npt.ArrayLike,
    velocity: npt.ArrayLike,
    obs: FgaObstacle,
    *,
    keep_h: float,
    keep_v: float,
    rho: float,
    horizon: float,
    speed: float | None = None,
) -> Encounter:
    """The encounter of an aircraft at ``position`` flying ``velocity`` with ``obs`` (both at
    constant velocity); ``keep_h`` is added to the obstacle's radius, ``keep_v`` above its top
    and below its bottom.  ``t_c`` is eq 7 with ``rho`` taken in the relative frame: eq 7's
    ``rho`` is the distance flown while turning one radian at the limit, which relative to the
    obstacle is ``rho |V_r| / V_u`` (``speed`` = ``V_u``; the same ``rho`` for a static
    obstacle).  Plain floats: this runs for every obstacle and candidate."""
    p = np.asarray(position, dtype=np.float64)
    v = np.asarray(velocity, dtype=np.float64)
    ox, oy, _oz = obs.center
    ux, uy, uz = obs.velocity
    px, py = ox - float(p[0]), oy - float(p[1])  # line of sight aircraft -> obstacle
    wx, wy, wz = float(v[0]) - ux, float(v[1]) - uy, float(v[2]) - uz  # V_r = V_u - V_a
    r = math.hypot(px, py)
    keep = obs.radius + keep_h
    closing = math.hypot(wx, wy)
    if closing > 1e-9:
        along = (px * wx + py * wy) / closing
        miss = abs(px * wy - py * wx) / closing
    else:
        along, miss = 0.0, r
    pz = obs.center[2] - float(p[2])
    r3 = math.sqrt(r * r + pz * pz)
    range_rate = -(px * wx + py * wy + pz * wz) / r3 if r3 > 1e-9 else 0.0
    z = float(p[2])
    lo, hi = obs.bottom - keep_v, obs.top + keep_v
    inside = r < keep and lo < z < hi
    window = None
    h = interval_disk(px, py, wx, wy, keep)
    if h is not None:
        vert = _interval_1d(z, wz, lo, hi)
        if vert is not None:
            start = max(h[0], vert[0], 0.0)
            end = min(h[1], vert[1], horizon)
            if start < end:
                window = (start, end)
    t_c = math.inf
    if window is not None and closing > 1e-9:
        v_u = closing if speed is None else speed
        t_c = (along - rho * closing / max(v_u, 1e-9) - (keep - miss)) / closing  # eq 7
    return Encounter(obs, r, along, miss, closing, range_rate, window, inside, t_c)


def in_conflict(
    x: float,
    y: float,
    z: float,
    vx: float,
    vy: float,
    vz: float,
    obs: FgaObstacle,
    keep: float,
    horizon: float,
) -> bool:
    """Whether :func:`encounter` would find a conflict window (``keep_h = keep_v = keep``):
    the same test in plain floats, for the many course candidates of a decision."""
    ux, uy, uz = obs.velocity
    h = interval_disk(obs.center[0] - x, obs.center[1] - y, vx - ux, vy - uy, obs.radius + keep)
    if h is None:
        return False
    v = _interval_1d(z, vz - uz, obs.bottom - keep, obs.top + keep)
    if v is None:
        return False
    return max(h[0], v[0], 0.0) < min(h[1], v[1], horizon)


def conflict_matrix(
    position: npt.ArrayLike,
    velocities: FloatArray,
    obstacles: list[FgaObstacle],
    keep: float,
    horizon: float,
) -> npt.NDArray[np.bool_]:
    """:func:`in_conflict` for many own velocities (N x 3) against many obstacles at once: an
    (N, M) array, element for element the same arithmetic (a decision tests some 80 course
    candidates against every obstacle within ``R``)."""
    x, y, z = (float(c) for c in np.asarray(position, dtype=np.float64)[:3])
    v = np.asarray(velocities, dtype=np.float64).reshape(-1, 3)
    if not obstacles:
        return np.zeros((len(v), 0), dtype=bool)
    o = np.array(
        [(*ob.center[:2], *ob.velocity, ob.radius, ob.bottom, ob.top) for ob in obstacles],
        dtype=np.float64,
    )
    px, py = o[:, 0] - x, o[:, 1] - y
    wx = v[:, 0:1] - o[None, :, 2]
    wy = v[:, 1:2] - o[None, :, 3]
    k = o[:, 5] + keep
    a = wx * wx + wy * wy
    c = px * px + py * py - k * k
    b = -2.0 * (px * wx + py * wy)
    disc = b * b - 4.0 * a * c
    still = a < 1e-12
    with np.errstate(divide="ignore", invalid="ignore"):
        root = np.sqrt(np.maximum(disc, 0.0))
        h0 = np.where(still, -np.inf, (-b - root) / (2.0 * a))
        h1 = np.where(still, np.inf, (-b + root) / (2.0 * a))
        h_ok = np.where(still, c < 0.0, disc > 0.0)
        rate = v[:, 2:3] - o[None, :, 4]
        lo, hi = o[:, 6] - keep, o[:, 7] + keep
        level = np.abs(rate) < 1e-9
        ta, tb = (lo - z) / rate, (hi - z) / rate
        v0 = np.where(level, -np.inf, np.minimum(ta, tb))
        v1 = np.where(level, np.inf, np.maximum(ta, tb))
    v_ok = np.where(level, (lo < z) & (z < hi), True)
    start = np.maximum(np.maximum(h0, v0), 0.0)
    end = np.minimum(np.minimum(h1, v1), horizon)
    return np.asarray(h_ok & v_ok & (start < end), dtype=bool)


def path_separation(
    t: FloatArray, x: FloatArray, y: FloatArray, z: FloatArray, obstacles: list[FgaObstacle]
) -> tuple[float, str]:
    """The least separation of the path (x, y, z) at times ``t`` from ``obstacles`` (each at
    constant velocity from now) in the protected volume's metric -- the larger of the horizontal
    distance outside its radius and the vertical distance outside [bottom, top] -- and the
    obstacle it is least from ((inf, "") without obstacles)."""
    worst = (math.inf, "")
    for o in obstacles:
        dh = np.hypot(x - (o.center[0] + o.velocity[0] * t), y - (o.center[1] + o.velocity[1] * t))
        climb = o.velocity[2] * t
        dv = np.maximum(z - (o.top + climb), (o.bottom + climb) - z)
        sep = float(np.maximum(dh - o.radius, dv).min())
        if sep < worst[0]:
            worst = (sep, o.key)
    return worst


def pass_side(position: FloatArray, velocity: FloatArray, obs: FgaObstacle) -> int:
    """+1 when the relative velocity points clockwise of the line of sight to ``obs`` (it
    passes on the aircraft's left), -1 otherwise."""
    px, py = obs.center[0] - float(position[0]), obs.center[1] - float(position[1])
    wx, wy = float(velocity[0]) - obs.velocity[0], float(velocity[1]) - obs.velocity[1]
    return 1 if wrap(math.atan2(wx, wy) - math.atan2(px, py)) >= 0.0 else -1


def flips(position: FloatArray, velocity: FloatArray, obs: FgaObstacle, side: int) -> bool:
    """Whether ``velocity`` passes ``obs`` on the other side than ``side`` while still closing
    on it.  A course whose relative velocity opens the range has left the obstacle behind: its
    "side" flips without crossing the cone (an obstacle passed on the left is, once behind,
    "passed on the right" by any turn to the right), so only a closing course can flip."""
    px, py = obs.center[0] - float(position[0]), obs.center[1] - float(position[1])
    wx, wy = float(velocity[0]) - obs.velocity[0], float(velocity[1]) - obs.velocity[1]
    return px * wx + py * wy > 0.0 and pass_side(position, velocity, obs) != side


def tangent_courses(
    position: npt.ArrayLike, obs: FgaObstacle, keep: float, speed: float, side: int
) -> list[float]:
    """Every own course at horizontal ``speed`` that puts the relative velocity on the
    ``side`` edge (:func:`tangent_course`): for an obstacle faster than the aircraft both
    positive roots of the quadratic are courses (the smaller root lets it pass ahead)."""
    p = np.asarray(position, dtype=np.float64)
    px, py = obs.center[0] - float(p[0]), obs.center[1] - float(p[1])
    r = math.hypot(px, py)
    if r <= keep:
        return []
    edge = math.atan2(px, py) + side * math.asin(keep / r)
    ex, ey = math.sin(edge), math.cos(edge)
    ux, uy = obs.velocity[0], obs.velocity[1]
    if ux == 0.0 and uy == 0.0:
        return [wrap(edge)]
    ue = ux * ex + uy * ey
    disc = ue * ue - (ux * ux + uy * uy) + speed * speed
    if disc < 0.0:
        return []
    root = math.sqrt(disc)
    return [
        math.atan2(ux + lam * ex, uy + lam * ey) for lam in (-ue + root, -ue - root) if lam > 1e-9
    ]


def tangent_course(
    position: npt.ArrayLike,
    obs: FgaObstacle,
    keep: float,
    speed: float,
    side: int,
) -> float | None:
    """The own course at horizontal ``speed`` that puts the relative velocity on the ``side``
    edge of the obstacle's horizontal cone (``+1``: the obstacle passes on the aircraft's left,
    i.e. the edge clockwise of the line of sight; ``-1``: on its right), ``keep`` the cone's
    radius about the obstacle's centre (its radius included).  Static: ``LOS + side asin(keep /
    r)``.  Moving at ``u``: the relative velocity is ``lambda e`` along the edge's unit vector
    ``e``, so ``|u + lambda e| = speed``: ``lambda = -u.e + sqrt((u.e)^2 - |u|^2 + speed^2)``
    (the larger root; None when it is not positive: the obstacle outruns the aircraft on that
    edge): the first of :func:`tangent_courses`."""
    roots = tangent_courses(position, obs, keep, speed, side)
    return roots[0] if roots else None


__all__ = [
    "CLIMB_SLEW",
    "DYNAMIC_MPS",
    "Encounter",
    "FgaObstacle",
    "climb_time",
    "climbed",
    "cone_half_angle",
    "conflict_matrix",
    "encounter",
    "flips",
    "in_conflict",
    "interval_disk",
    "pass_side",
    "path_separation",
    "tangent_course",
    "tangent_courses",
]
