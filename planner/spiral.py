"""Climb and descent spirals: where a leg needs more climb (or descent) than the aircraft makes over
its length, it circles -- at the launch, before a ridge, after a pass into a valley -- as a pilot
does, and the plan says so (issue 33).

A :class:`Spiral` belongs to a waypoint ``at``: the aircraft arrives there at ``entry`` metres,
flies ``turns`` full circles of ``radius`` climbing (or descending) at a constant gradient, and
leaves at the waypoint's own altitude -- MAVLink's ``LOITER_TO_ALT`` with the turns counted.
The helix is tangent to the path where it is flown, so it is entered and left tangentially on
the heading the aircraft already has, and the turn fillets of the path stay as they are:

- at the start (``at`` 0): tangent to the first leg at the start;
- at an interior waypoint: tangent to the leg into it at the fillet's first tangent point ``T1``
  (the end of the straight leg, before the turn);
- at the goal: tangent to the last leg at the goal.

Altitudes (what :func:`flown_path` builds and the replay flies): leg ``k`` runs from the altitude
the aircraft leaves waypoint ``k`` at (its ``z``) to the altitude it arrives at ``k + 1`` with (the
next spiral's ``entry``, else that waypoint's ``z``), linear in the horizontal distance along the
leg; a helix changes the altitude linearly in the angle turned; at an interior waypoint the helix
runs from the incoming leg's altitude at ``T1`` to the outgoing leg's at the fillet's end ``T2``,
and the fillet after it is flown level (:func:`spiral_ends`).

:func:`add_spirals` is the repair the planner runs on a path whose only fault is a leg too steep
for the aircraft: each such leg keeps its gradient limit and the rest of its climb (descent) goes
into a spiral at its start (its end), with the fewest turns that fit the climb the aircraft makes
in the banked turn (:attr:`planner.performance.Performance.turn_climb_gradient`); a waypoint
between a descent and a climb gets one spiral for both.  Every helix is checked like a leg --
terrain clearance over the conservative heights, unknown terrain, zones, the map edge (the
problem's validity layer) -- on both sides of the path, the side with more clearance kept; a
spiral that fits on neither side is the reason the plan stays infeasible.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from planner.flown import CHORDS, TOLERANCE, arc_points, fillets
from planner.performance import Performance
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
PER_TURN = 24  # chords per full turn of a helix (each within R (1 - cos 7.5 deg) = 1 % of R)
GRADIENT_MARGIN = 0.98  # a repaired leg or spiral keeps this share of the limit, for rounding
MAX_TURNS = 200  # more turns than this is not a spiral but a mistake


@dataclass(frozen=True)
class Spiral:
    """``turns`` circles of ``radius`` m at waypoint ``at``, entered at ``entry`` m AMSL and left
    at the waypoint's altitude; ``clockwise`` seen from above."""

    at: int
    entry: float
    turns: int
    radius: float
    clockwise: bool

    def __post_init__(self) -> None:
        if isinstance(self.at, bool) or int(self.at) != self.at or self.at < 0:
            raise InputError(f"spiral waypoint must be an index >= 0; got {self.at!r}")
        if isinstance(self.turns, bool) or int(self.turns) != self.turns:
            raise InputError(f"spiral turns must be a whole number; got {self.turns!r}")
        if not 1 <= self.turns <= MAX_TURNS:
            raise InputError(f"spiral turns must lie in 1..{MAX_TURNS}; got {self.turns}")
        for name in ("entry", "radius"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise InputError(f"spiral {name} must be a number of metres; got {v!r}")
        if self.radius <= 0:
            raise InputError(f"spiral radius must be > 0 m; got {self.radius!r}")
        object.__setattr__(self, "at", int(self.at))
        object.__setattr__(self, "turns", int(self.turns))
        object.__setattr__(self, "entry", float(self.entry))
        object.__setattr__(self, "radius", float(self.radius))

    def as_dict(self) -> dict[str, Any]:
        return {
            "waypoint": self.at,
            "entry_altitude": round(self.entry, 2),
            "turns": self.turns,
            "radius": round(self.radius, 2),
            "direction": "clockwise" if self.clockwise else "counter-clockwise",
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], where: str = "spiral") -> Spiral:
        """A spiral from its mission record (:meth:`as_dict`); one-line errors naming ``where``."""
        if not isinstance(d, Mapping):
            raise InputError(
                f"{where}: expected a mapping with waypoint, entry_altitude, turns, "
                f"radius, direction; got {type(d).__name__}"
            )
        keys = {"waypoint", "entry_altitude", "turns", "radius", "direction"}
        unknown = set(d) - keys
        missing = keys - set(d)
        if unknown or missing:
            what = (
                f"unknown key(s) {', '.join(sorted(map(str, unknown)))}"
                if unknown
                else (f"missing {', '.join(sorted(missing))}")
            )
            raise InputError(f"{where}: {what}; a spiral has {', '.join(sorted(keys))}")
        direction = d["direction"]
        if direction not in ("clockwise", "counter-clockwise"):
            raise InputError(
                f"{where}.direction must be clockwise or counter-clockwise; got {direction!r}"
            )
        try:
            return cls(
                d["waypoint"],
                d["entry_altitude"],
                d["turns"],
                d["radius"],
                direction == "clockwise",
            )
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None


def anchor(waypoints: FloatArray, k: int, radius: float) -> tuple[FloatArray, FloatArray]:
    """(map x, y, heading unit vector) where the helix at waypoint ``k`` touches the path (module
    docstring): the start, an interior waypoint's fillet tangent point T1, or the goal."""
    w = np.asarray(waypoints, dtype=np.float64)
    if k == 0:
        d = w[1, :2] - w[0, :2]
        return w[0, :2].copy(), d / max(float(np.hypot(*d)), 1e-12)
    d = w[k, :2] - w[k - 1, :2]
    q = d / max(float(np.hypot(*d)), 1e-12)
    if k == len(w) - 1:
        return w[k, :2].copy(), q
    f = fillets(w, radius).at(k)
    return np.asarray(f.t1[0, 0, :2], dtype=np.float64), q


def helix(
    point: FloatArray,
    heading: FloatArray,
    spiral: Spiral,
    z0: float,
    z1: float,
    per_turn: int = PER_TURN,
) -> FloatArray:
    """(turns * per_turn + 1, 3) points of a helix tangent to ``heading`` at ``point`` (map x,
    y), from altitude ``z0`` to ``z1`` (linear in the angle), starting and ending at ``point``."""
    q = np.asarray(heading, dtype=np.float64)
    left = np.array([-q[1], q[0]])
    side = -1.0 if spiral.clockwise else 1.0  # + counter-clockwise
    centre = np.asarray(point, dtype=np.float64) + side * spiral.radius * left
    a0 = math.atan2(point[1] - centre[1], point[0] - centre[0])
    n = spiral.turns * per_turn
    s = np.linspace(0.0, 1.0, n + 1)
    theta = a0 + side * 2.0 * math.pi * spiral.turns * s
    out = np.empty((n + 1, 3))
    out[:, 0] = centre[0] + spiral.radius * np.cos(theta)
    out[:, 1] = centre[1] + spiral.radius * np.sin(theta)
    out[:, 2] = z0 + s * (z1 - z0)
    out[0, :2] = out[-1, :2] = point  # exactly tangent where it joins the path
    return out


def centre(waypoints: FloatArray, spiral: Spiral, radius: float) -> FloatArray:
    """Map (x, y) of the centre of ``spiral``'s circle on ``waypoints`` (fillets of ``radius``)."""
    p, q = anchor(waypoints, spiral.at, radius)
    side = -1.0 if spiral.clockwise else 1.0
    return np.asarray(p + side * spiral.radius * np.array([-q[1], q[0]]), dtype=np.float64)


@dataclass(frozen=True)
class FlownPath:
    """The path flown through waypoints with spirals: ``points`` (M, 3), and for each of the
    M - 1 pieces the waypoint-list ``leg`` it belongs to, whether it is part of a ``spiral``
    (its waypoint index, else -1), whether it is a ``straight`` piece of its leg (not a turn's
    arc nor a helix) and a ``label`` for messages."""

    points: FloatArray
    leg: npt.NDArray[np.int64]
    spiral: npt.NDArray[np.int64]
    labels: tuple[str, ...]
    straight: npt.NDArray[np.bool_]


def flown_path(
    waypoints: npt.ArrayLike,
    spirals: Sequence[Spiral],
    radius: float,
    chords: int = CHORDS,
    per_turn: int = PER_TURN,
) -> FlownPath:
    """The path the aircraft flies (module docstring): legs, turn fillets of ``radius`` and the
    helices of ``spirals``."""
    w = np.asarray(waypoints, dtype=np.float64)
    n = len(w)
    by_at = {s.at: s for s in spirals}
    if len(by_at) != len(spirals) or any(s.at >= n for s in spirals):
        raise InputError(f"spirals must be at distinct waypoints 0..{n - 1}")
    z_out = w[:, 2].copy()
    z_in = z_out.copy()
    for s in spirals:
        z_in[s.at] = s.entry
    seg = np.diff(w[:, :2], axis=0)
    length = np.hypot(seg[:, 0], seg[:, 1])

    def profile(k: int, u: float) -> float:
        """Leg k's altitude ``u`` m (horizontally) from waypoint k."""
        f = 0.0 if length[k] <= 1e-9 else min(max(u / length[k], 0.0), 1.0)
        return float(z_out[k] + f * (z_in[k + 1] - z_out[k]))

    pts: list[FloatArray] = []
    legs: list[int] = []
    spiral_of: list[int] = []
    labels: list[str] = []
    straight: list[bool] = []

    def add(block: FloatArray, leg: int, spiral: int, label: str, line: bool = False) -> None:
        """Append ``block``'s points; the pieces they end are of ``leg`` / ``spiral`` (``line``:
        straight pieces of the leg)."""
        for p in block:
            if pts:
                legs.append(leg)
                spiral_of.append(spiral)
                labels.append(label)
                straight.append(line)
            pts.append(p)

    def loop(
        k: int, p: FloatArray, q: FloatArray, z0: float, leg: int, z1: float | None = None
    ) -> float:
        s = by_at[k]
        end = z0 + z_out[k] - z_in[k] if z1 is None else z1
        way = "climb" if end >= z0 else "descent"
        h = helix(p, q, s, z0, end, per_turn)
        add(h[1:], leg, k, f"the {way} spiral at waypoint {k}")
        return end

    add(np.array([[w[0, 0], w[0, 1], z_in[0]]]), 0, -1, "")
    if 0 in by_at:
        p, q = anchor(w, 0, radius)
        loop(0, p, q, float(z_in[0]), 0)
    if n > 2:
        f = fillets(w[None], radius)
        arcs = arc_points(f, chords)[0]  # (N, chords + 1, 3): x, y on the arcs
        for k in range(1, n - 1):
            d = float(f.distance[0, k - 1])
            z1 = profile(k - 1, length[k - 1] - d)
            t1 = np.array([f.t1[0, k - 1, 0], f.t1[0, k - 1, 1], z1])
            add(t1[None], k - 1, -1, f"leg {k - 1} (waypoint {k - 1} -> {k})", True)
            z2 = profile(k, d)
            if k in by_at:
                # the helix climbs (descends) to where the next leg is at the turn's end: the
                # turn is flown level (a fillet keeps no gradient of its own to spare here)
                q = seg[k - 1] / max(float(length[k - 1]), 1e-12)
                z1 = loop(k, t1[:2], q, z1, k - 1, z2)
            arc = arcs[k - 1].copy()
            arc[:, 2] = z1 + np.linspace(0.0, 1.0, chords + 1) * (z2 - z1)
            add(arc[1:], k - 1, -1, f"the turn at waypoint {k}")
    g = n - 1
    add(
        np.array([[w[g, 0], w[g, 1], z_in[g]]]),
        g - 1,
        -1,
        f"leg {g - 1} (waypoint {g - 1} -> {g})",
        True,
    )
    if g in by_at:
        p, q = anchor(w, g, radius)
        loop(g, p, q, float(z_in[g]), g - 1)
    return FlownPath(
        np.asarray(pts, dtype=np.float64),
        np.asarray(legs, dtype=np.int64),
        np.asarray(spiral_of, dtype=np.int64),
        tuple(labels),
        np.asarray(straight, dtype=np.bool_),
    )


def spiral_ends(
    waypoints: npt.ArrayLike, spirals: Sequence[Spiral], k: int, radius: float
) -> tuple[float, float]:
    """The altitudes the helix at waypoint ``k`` starts and ends at on the flown path (module
    docstring): at the start or the goal its entry and the waypoint's altitude; at an interior
    waypoint the incoming leg's altitude at the fillet's first tangent point and the outgoing
    leg's at its second."""
    w = np.asarray(waypoints, dtype=np.float64)
    z_out = w[:, 2].copy()
    z_in = z_out.copy()
    for s in spirals:
        z_in[s.at] = s.entry
    if k == 0 or k == len(w) - 1:
        return float(z_in[k]), float(z_out[k])
    d = float(fillets(w[None], radius).distance[0, k - 1])
    l1 = float(np.hypot(*(w[k, :2] - w[k - 1, :2])))
    l2 = float(np.hypot(*(w[k + 1, :2] - w[k, :2])))
    z0 = z_out[k - 1] + (z_in[k] - z_out[k - 1]) * (max(l1 - d, 0.0) / l1 if l1 > 0 else 1.0)
    z1 = z_out[k] + (z_in[k + 1] - z_out[k]) * (min(d / l2, 1.0) if l2 > 0 else 0.0)
    return float(z0), float(z1)


def respiral(
    waypoints: npt.ArrayLike, spirals: Sequence[Spiral], perf: Performance
) -> tuple[Spiral, ...]:
    """``spirals`` with the fewest turns their helices need on ``waypoints`` as flown (after the
    path around them changed: a take-off joined before the plan's start)."""
    out = []
    for s in spirals:
        z0, z1 = spiral_ends(waypoints, spirals, s.at, perf.turn_radius)
        rate = GRADIENT_MARGIN * (perf.turn_climb_gradient if z1 > z0 else perf.descent_gradient)
        turns = max(1, math.ceil(abs(z1 - z0) / (2.0 * math.pi * s.radius * rate)))
        out.append(Spiral(s.at, s.entry, min(turns, MAX_TURNS), s.radius, s.clockwise))
    return tuple(out)


def gradient_excess(path: FlownPath, perf: Performance) -> FloatArray:
    """(M - 1,) metres each piece climbs or descends beyond the aircraft's gradient: the straight
    climb gradient on legs and turns, the climb in the banked turn on a spiral's helix."""
    d = np.diff(path.points, axis=0)
    h = np.hypot(d[:, 0], d[:, 1])
    up = np.where(path.spiral >= 0, perf.turn_climb_gradient, perf.climb_gradient)
    over = np.maximum(0.0, d[:, 2] - up * h - TOLERANCE)
    return np.asarray(
        over + np.maximum(0.0, -d[:, 2] - perf.descent_gradient * h - TOLERANCE), dtype=np.float64
    )


@dataclass(frozen=True)
class Repair:
    """What :func:`add_spirals` made of a path: the waypoints (each at the altitude it is left
    at), the spirals, and why it could not (None: every leg fits now)."""

    waypoints: FloatArray
    spirals: tuple[Spiral, ...]
    reason: str | None


SPLITS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)  # along a leg, from its start


def _spiral(
    k: int, p: FloatArray, q: FloatArray, z0: float, z1: float, perf: Performance, fits: Any
) -> tuple[Spiral | None, int]:
    """The spiral at waypoint ``k`` (touching the path at ``p`` on heading ``q``) from ``z0`` to
    ``z1`` with the fewest turns the gradient allows, on the side with more clearance (None
    when neither side fits), and its number of turns."""
    dz = z1 - z0
    rate = GRADIENT_MARGIN * (perf.turn_climb_gradient if dz > 0 else perf.descent_gradient)
    turns = max(1, math.ceil(abs(dz) / (2.0 * math.pi * perf.turn_radius * rate)))
    if turns > MAX_TURNS:
        return None, turns
    best: tuple[float, Spiral] | None = None
    for clockwise in (False, True):
        s = Spiral(k, z0, turns, perf.turn_radius, clockwise)
        ok, clearance = fits(helix(p, q, s, z0, z1))
        if ok and (best is None or clearance > best[0]):
            best = (clearance, s)
    return (None if best is None else best[1]), turns


def _arc_share(angle: npt.ArrayLike) -> FloatArray:
    """The share of a leg's gradient a turn fillet of ``angle`` (rad) keeps: its arc (R D) is
    shorter than the two tangent pieces (2 R tan(D / 2)) whose altitude change it flies,
    ``D / (2 tan(D / 2))`` (1 for no turn)."""
    ang = np.maximum(np.asarray(angle, dtype=np.float64), 1e-9)
    return np.asarray(np.minimum(1.0, ang / (2.0 * np.tan(0.5 * np.minimum(ang, 3.1)))))


def add_spirals(
    waypoints: npt.ArrayLike,
    perf: Performance,
    fits: Any,
    chords: int = CHORDS,
    lead_in: npt.ArrayLike | None = None,
    lead_out: npt.ArrayLike | None = None,
) -> Repair:
    """Move the climb (descent) a leg cannot make into a spiral (module docstring).

    A leg too steep to climb keeps its gradient limit and climbs the rest in a spiral as early
    as one fits: at its start waypoint, else at a new waypoint on the leg (at a tenth of it, a
    fifth, ...; on the straight part between the turn fillets) reached at the gradient limit; a
    leg too steep to descend mirrors it, the spiral as late as one fits.  The straight piece
    the aircraft now flies lower than the leg did (before a climb spiral, after a descent
    spiral) is checked too.  ``fits(points (K, 3)) -> (ok, clearance)`` checks points against the
    terrain, zones and map (the problem's validity layer) and says how far above the terrain they
    stay; each spiral is tried on both sides and the one with more clearance kept.

    ``lead_in`` / ``lead_out``: where the aircraft comes from to the start (the take-off) and
    goes on to after the goal (the landing's touchdown).  The turn there is a fillet whose arc
    changes altitude by ``R tan(D / 2) (g_lead + g_leg)`` over ``R D``: the first (last) leg
    keeps ``g_leg <= 2 s G - g_lead`` (``s = D / (2 tan(D / 2))``, ``G`` the limit, with the
    margin), so the arc stays within the gradient too."""
    w = np.array(waypoints, dtype=np.float64)
    n = len(w)
    radius = perf.turn_radius
    seg = np.diff(w[:, :2], axis=0)
    length = np.hypot(seg[:, 0], seg[:, 1])
    f = fillets(w[None], radius)
    d_at = np.zeros(n)  # each waypoint's fillet tangent distance (0 at the ends)
    arc_share = np.ones(n)
    if n > 2:
        d_at[1:-1] = f.distance[0]
        # on a fillet the leg's altitude change is flown over the arc (R D), shorter than the
        # two tangent pieces (2 R tan(D / 2)) it replaces: a leg keeps a gradient its arcs keep
        arc_share[1:-1] = _arc_share(f.angle[0])
    share = GRADIENT_MARGIN * np.minimum(arc_share[:-1], arc_share[1:])
    up_cap = np.full(n - 1, np.inf)  # the first and last legs' gradients, turning onto a lead
    down_cap = np.full(n - 1, np.inf)
    for lead, k in ((lead_in, 0), (lead_out, n - 2)):
        if lead is None:
            continue
        p_lead = np.asarray(lead, dtype=np.float64)
        # the turn at the start (goal) with the lead before (after) it, in the order flown
        turn = np.array([p_lead, w[0], w[1]] if k == 0 else [w[-2], w[-1], p_lead])
        span = float(np.hypot(*(p_lead[:2] - w[0 if k == 0 else -1, :2])))
        if span < 1e-9:
            continue
        s_arc = float(_arc_share(fillets(turn[None], radius).angle[0])[0])
        # the lead's gradient in the direction of flight (up positive)
        g_lead = (turn[1, 2] - turn[0, 2] if k == 0 else turn[2, 2] - turn[1, 2]) / span
        up_cap[k] = GRADIENT_MARGIN * 2.0 * s_arc * perf.climb_gradient - max(g_lead, 0.0)
        down_cap[k] = GRADIENT_MARGIN * 2.0 * s_arc * perf.descent_gradient - max(-g_lead, 0.0)
    out: list[FloatArray] = [w[0].copy()]  # z: the altitude each waypoint is left at
    entry: list[float] = [float(w[0, 2])]  # the altitude each is arrived at

    def push(point: npt.ArrayLike, arrive: float) -> None:
        out.append(np.array(point, dtype=np.float64))
        entry.append(float(arrive))

    a = float(w[0, 2])
    for k in range(n - 1):
        b = w[k + 1]
        big_l = float(length[k])
        q = seg[k] / max(big_l, 1e-12)
        up = max(0.0, min(float(share[k] * perf.climb_gradient), float(up_cap[k])))
        down = max(0.0, min(float(share[k] * perf.descent_gradient), float(down_cap[k])))
        margin = 0.1 * radius
        if b[2] - a > up * big_l + TOLERANCE:  # a climb it cannot make
            placed = False
            for t in SPLITS:
                if t == 0.0:
                    p, qa = anchor(w, k, radius)
                    z0, z1 = entry[-1], float(b[2] - up * big_l)
                    if _spiral(k, p, qa, z0, z1, perf, fits)[0] is not None:
                        out[-1] = np.array([out[-1][0], out[-1][1], z1])
                        a, placed = z1, True
                        break
                    continue
                if t * big_l < d_at[k] + margin or (1 - t) * big_l < d_at[k + 1] + margin:
                    continue
                x = w[k, :2] + t * big_l * q
                z0, z1 = a + up * t * big_l, float(b[2] - up * (1 - t) * big_l)
                before = np.array([[w[k, 0], w[k, 1], a], [x[0], x[1], z0]])
                if not fits(before)[0]:
                    continue
                if _spiral(k, x, q, z0, z1, perf, fits)[0] is not None:
                    push([x[0], x[1], z1], z0)
                    a, placed = z1, True
                    break
            if not placed:
                return Repair(
                    np.asarray(out),
                    (),
                    f"no room for a climb spiral on leg {k} (waypoint {k} "
                    f"-> {k + 1}, {b[2] - a:,.0f} m up over {big_l / 1000:.2f} km): every "
                    f"helix of radius {radius:.0f} m tried along it meets the terrain (with the "
                    "clearance), a zone, unknown terrain or the map's edge -- the valley is "
                    "narrower than the turn's diameter",
                )
            push(b, b[2])
            a = float(b[2])
        elif a - b[2] > down * big_l + TOLERANCE:  # a descent it cannot make
            placed = False
            for t in (1.0 - s for s in SPLITS):
                if t == 1.0:
                    p, qa = anchor(w, k + 1, radius)
                    z0 = a - down * big_l
                    if _spiral(k + 1, p, qa, z0, float(b[2]), perf, fits)[0] is not None:
                        push(b, z0)
                        placed = True
                        break
                    continue
                if t * big_l < d_at[k] + margin or (1 - t) * big_l < d_at[k + 1] + margin:
                    continue
                x = w[k, :2] + t * big_l * q
                z0, z1 = a - down * t * big_l, float(b[2] + down * (1 - t) * big_l)
                after = np.array([[x[0], x[1], z1], [b[0], b[1], b[2]]])
                if not fits(after)[0]:
                    continue
                if _spiral(k, x, q, z0, z1, perf, fits)[0] is not None:
                    push([x[0], x[1], z1], z0)
                    push(b, b[2])
                    placed = True
                    break
            if not placed:
                return Repair(
                    np.asarray(out),
                    (),
                    f"no room for a descent spiral on leg {k} (waypoint "
                    f"{k} -> {k + 1}, {a - b[2]:,.0f} m down over {big_l / 1000:.2f} km): every "
                    f"helix of radius {radius:.0f} m tried along it meets the terrain, a zone, "
                    "unknown terrain or the map's edge",
                )
            a = float(b[2])
        else:
            push(b, b[2])
            a = float(b[2])
    path = np.asarray(out, dtype=np.float64)
    spirals: list[Spiral] = []
    marks = [Spiral(i, entry[i], 1, radius, False) for i in range(len(path))
             if abs(float(path[i, 2]) - entry[i]) > TOLERANCE]  # fmt: skip
    for mark in marks:
        i = mark.at
        z0, z1 = spiral_ends(path, marks, i, radius)
        p, q = anchor(path, i, radius)
        sp, turns = _spiral(i, p, q, z0, z1, perf, fits)
        if sp is None:
            way = "climb" if z1 > z0 else "descent"
            return Repair(
                path,
                (),
                f"no room for the {way} spiral at waypoint {i} ({turns} turns of radius "
                f"{radius:.0f} m from {z0:,.0f} to {z1:,.0f} m at ({p[0]:.0f}, {p[1]:.0f}))",
            )
        spirals.append(Spiral(i, mark.entry, sp.turns, sp.radius, sp.clockwise))
    return Repair(path, tuple(spirals), None)


@dataclass(frozen=True)
class Repaired:
    """A plan with spirals (:func:`spiral_repair`): its waypoints, flown path (points), cost
    terms (a ``CostTerms.row``), spirals, whether every hard term holds, and why there are
    none when the repair failed (then the rest is the input's)."""

    path: FloatArray
    flown: FloatArray
    terms: dict[str, float]
    spirals: tuple[Spiral, ...]
    feasible: bool
    reason: str | None


def spiral_repair(problem: Any, path: npt.ArrayLike) -> Repaired:
    """:func:`add_spirals` on a :class:`planner.problem.PlanningProblem`'s waypoint ``path``:
    each helix checked by the problem's validity layer (terrain + clearance on the safety
    heights, unknown terrain, zones, the map), and the repaired path's cost terms on its flown
    path -- the spirals' length counted, their gradient the climb in the banked turn."""
    from dataclasses import replace

    from planner.cost import path_costs, smoothness_of
    from terrain.segments import path_below_lengths

    perf = problem.performance
    w = np.asarray(path, dtype=np.float64)

    def fits(points: FloatArray) -> tuple[bool, float]:
        """Clear for the validity layer: on the map, over measured terrain, out of the zones and
        above the terrain + clearance on the safety heights (the highest source value in each
        cell, bilinear between them), sampled every half cell -- what the plan's result check
        and the replay judge a flown path by. Not the cost's Bresenham walk over the terrain
        dilated by a cell: that bounds a straight leg crossing cells diagonally, and round a
        helix a cell or two across it would raise the ground by up to the slope of two cells
        (on RMNP's 233 m cells, hundreds of metres over a valley floor)."""
        check = problem.validity.path(points)
        return bool(check.valid.all()), float(np.min(check.clearance))

    rep = add_spirals(w, perf, fits, problem.chords, problem.lead_in, problem.lead_out)
    if rep.reason is not None:
        return Repaired(w, problem.flown(w), {}, (), False, rep.reason)
    flown = flown_path(rep.waypoints, rep.spirals, perf.turn_radius, problem.chords)
    ce = float(gradient_excess(flown, perf).sum())
    te = float(fillets(rep.waypoints[None], perf.turn_radius).turn_excess[0])
    terms = path_costs(
        problem.check_grid,
        flown.points[None],
        zmin=problem.band[0],
        zmax=problem.band[1],
        zones=problem.cost_zones,
        clearance=problem.clearance,
        penalty=problem.penalty,
        hard_zones=problem.avoid_zones,
        climb_excess=np.array([ce]),
        turn_excess=np.array([te]),
        unknown=problem.unknown_grid,
        ground=problem.grid,
        agl_max=problem.agl_max,
        agl_pref=problem.agl_pref,
        smoothness=smoothness_of(rep.waypoints[None], problem.smoothness)
        if problem.smoothness
        else None,
    )
    # the Bresenham walk of the cost on the legs and turns; the helices are checked above
    on_helix = np.concatenate([[False], flown.spiral >= 0]) & np.concatenate(
        [flown.spiral >= 0, [False]]
    )
    below = path_below_lengths(problem.check_grid, flown.points[~on_helix][None], problem.clearance)
    length = np.maximum(terms.path_length, 1e-9)
    collision = np.where(below > 0, problem.penalty + below / length, 0.0)
    terms = replace(
        terms,
        below_length=below,
        collision=collision,
        total=terms.total - terms.collision + collision,
    )
    ok = bool(problem.feasible(terms)[0])
    row = terms.row(0)
    if not ok:
        faults = [
            f"{k.replace('_m', '').replace('_', ' ')} {row[k]:.0f} m"
            for k in ("below_terrain_m", "climb_excess_m", "turn_excess_m", "unknown_terrain_m")
            if row[k] > 0
        ]
        return Repaired(
            w,
            problem.flown(w),
            {},
            (),
            False,
            "with its spirals the path still fails: " + ", ".join(faults or ["a zone"]),
        )
    row["spirals"] = float(len(rep.spirals))
    row["spiral_turns"] = float(sum(s.turns for s in rep.spirals))
    return Repaired(rep.waypoints, flown.points, row, rep.spirals, ok, None)


def climb_bound(waypoints: npt.ArrayLike, perf: Performance) -> float:
    """A lower bound (m) on the horizontal length of any flyable path through ``waypoints``'
    altitudes: up from the start to the highest at the climb gradient, and down from there to
    the goal at the descent gradient (the two cannot overlap)."""
    w = np.asarray(waypoints, dtype=np.float64)
    top = float(w[:, 2].max())
    return (top - float(w[0, 2])) / perf.climb_gradient + (top - float(w[-1, 2])) / (
        perf.descent_gradient
    )


def only_too_steep(terms: Mapping[str, float]) -> bool:
    """Whether a plan's cost terms (a :meth:`planner.cost.CostTerms.row`) say its one fault is a
    leg too steep: a climb excess, and no terrain, zone, turn, unknown-terrain or band fault."""
    return (
        terms.get("climb_excess_m", 0.0) > 0.0
        and terms.get("below_terrain_m", 0.0) <= 0.0
        and terms.get("turn_excess_m", 0.0) <= 0.0
        and terms.get("unknown_terrain_m", 0.0) <= 0.0
        and terms.get("above_band_m", 0.0) <= 0.0
        and terms.get("dangerzones", 0.0) < 3.0  # hard zones pay the collision penalty
    )


__all__ = [
    "FlownPath",
    "Repair",
    "Repaired",
    "Spiral",
    "add_spirals",
    "anchor",
    "centre",
    "climb_bound",
    "flown_path",
    "gradient_excess",
    "helix",
    "only_too_steep",
    "respiral",
    "spiral_ends",
    "spiral_repair",
]
