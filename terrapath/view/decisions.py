"""How ``terrapath view`` draws an avoider's decisions: one small function per kind of command.

A drawing takes one recorded decision (the dict the flight loop records: ``t``, ``algorithm``,
``reason``, ``command`` ...) and the run it belongs to, and returns :class:`Mark` s -- polylines
or points in map metres -- that the 3D scene and the 2-D map both draw.  Register one with
``@drawing("CommandName")``; the command's name is ``decision["command"]["command"]``.  Marks of
the same name in one run are joined into one trace (NaN rows split them), and marks with equal
keys (an orbit re-commanded with nearly the same centre and radius) are drawn once.

Drawn today: CTGA's orbits (``Orbit``: the circle it flies round), PSO-CA's new waypoints
(``FollowWaypoints``: the points of the commanded list that were not in the planned one), FGA's
collision cones and commanded course (``HoldCourse`` decisions that carry ``cones``), the
priority loop's set-points (``GoTo`` and ``YawTo`` decisions that carry ``appended``: the point
they added to its path S).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from replay.avoidance.circles import cone_outline

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Mark:
    """A polyline (``mode="lines"``), points (``"markers"``) or both, (N, 3) map metres, that
    the 3D scene and the 2-D map draw alike; NaN rows split a polyline; ``text`` is each
    point's hover text."""

    name: str
    xyz: FloatArray
    mode: str
    color: str
    text: tuple[str, ...]
    dash: str = "solid"
    symbol: str = "circle"
    # marks with equal keys are drawn once (default: the points in plan, to 10 m)
    key: tuple[Any, ...] | None = None
    width: float = 1.5  # line width on the 2-D map (the 3D scene draws it wider)
    size: float = 8.0  # marker size on the 2-D map
    customdata: Any = None  # per-point hover values for ``template``
    template: str = "%{text}<extra></extra>"  # plotly hover template ("": the name only)
    group: str = ""  # legend group (toggled together)
    legend: bool = True  # listed in the legend


Drawing = Callable[[dict[str, Any], Any], list[Mark]]
DRAWINGS: dict[str, Drawing] = {}


def drawing(command: str) -> Callable[[Drawing], Drawing]:
    """Register the drawing of the decisions whose command is ``command``."""

    def register(fn: Drawing) -> Drawing:
        DRAWINGS[command] = fn
        return fn

    return register


def _altitude(run: Any, t: float) -> float:
    """The aircraft's altitude at time ``t`` (the run's samples, interpolated)."""
    return float(np.interp(t, run.times, run.positions[:, 2]))


def _hover(decision: dict[str, Any]) -> str:
    t = float(decision.get("t", 0.0))
    return f"{decision.get('algorithm', '')} at {t / 60.0:.2f} min: {decision.get('reason', '')}"


@drawing("Orbit")
def orbit(decision: dict[str, Any], run: Any) -> list[Mark]:
    """The circle CTGA commanded, at its altitude (or the aircraft's, when it holds altitude)."""
    cmd = decision["command"]
    cx, cy = (float(v) for v in cmd["center"])
    r = float(cmd["radius"])
    alt = cmd.get("altitude")
    z = float(alt) if alt is not None else _altitude(run, float(decision["t"]))
    a = np.linspace(0.0, 2.0 * math.pi, 73)
    xyz = np.column_stack([cx + r * np.sin(a), cy + r * np.cos(a), np.full(len(a), z)])
    # the same circle to 50 m (its centre moves a little as CTGA updates the arc): drawn once
    key = (round(cx / 50.0), round(cy / 50.0), round(r / 50.0))
    hover = (_hover(decision),) * len(a)
    return [Mark("avoider's orbits", xyz, "lines", "#e377c2", hover, "dot", key=key)]


@drawing("FollowWaypoints")
def new_waypoints(decision: dict[str, Any], run: Any) -> list[Mark]:
    """The waypoints of the list commanded at that time that were not in the planned list."""
    t = float(decision["t"])
    for tc, wps, _reason in run.changes:
        if abs(tc - t) < 1e-6:
            planned = np.asarray(run.initial_waypoints, dtype=np.float64)
            new = [
                w for w in np.asarray(wps) if not np.any(np.all(np.abs(planned - w) < 1e-3, axis=1))
            ]
            if not new:
                return []
            xyz = np.array(new, dtype=np.float64)
            return [
                Mark(
                    "avoider's new waypoints",
                    xyz,
                    "markers",
                    "#ff7f0e",
                    (_hover(decision),) * len(xyz),
                    symbol="diamond",
                )
            ]
    return []


@drawing("HoldCourse")
def cones(decision: dict[str, Any], run: Any) -> list[Mark]:
    """FGA's start of a manoeuvre: each collision cone (its two edges from the aircraft to the
    tangent points, and the protected circle round the obstacle) and the course commanded (a
    150 m line from the aircraft), at the aircraft's altitude."""
    info = decision.get("cones")
    if not info:
        return []
    t = float(decision["t"])
    here = np.array([float(np.interp(t, run.times, run.positions[:, k])) for k in range(3)])
    hover = _hover(decision)
    gap = np.full((1, 3), np.nan)
    parts: list[FloatArray] = []
    for c in info:
        a_end, b_end, ring = cone_outline(c, here, 48)
        parts += [np.vstack([a_end, here, b_end]), gap, ring, gap]
    xyz = np.vstack(parts[:-1])
    course = float(decision["command"]["course"])
    heading = np.vstack([here, here + 150.0 * np.array([math.sin(course), math.cos(course), 0.0])])
    key = (round(t, 1),)
    return [
        Mark("FGA's collision cones", xyz, "lines", "#ff7f0e", (hover,) * len(xyz), key=key),
        Mark("FGA's course", heading, "lines", "#d62728", (hover,) * 2, "dash", key=key),
    ]


def setpoint(decision: dict[str, Any], run: Any) -> list[Mark]:
    """The point a priority-loop decision appended to its path S (the start, a stop, a chosen
    I point), with the step that chose it."""
    point = decision.get("appended")
    if not point:
        return []
    xyz = np.asarray([point], dtype=np.float64)
    n = len(decision.get("setpoints") or ()) - 1
    hover = f"S_{n}: " + _hover(decision)
    key = (round(float(decision["t"]), 2),)  # every one (they may lie a few metres apart)
    return [Mark("priority set-points", xyz, "markers", "#ff7f0e", (hover,), key=key, symbol="x")]


drawing("GoTo")(setpoint)
drawing("YawTo")(setpoint)


def decision_marks(run: Any) -> list[Mark]:
    """Every decision of ``run`` drawn, marks of one name joined, duplicates dropped."""
    joined: dict[str, list[Mark]] = {}
    seen: set[tuple[str, Any]] = set()
    for d in run.decisions:
        cmd = d.get("command")
        if not isinstance(cmd, dict) or cmd.get("command") not in DRAWINGS:
            continue
        for mark in DRAWINGS[cmd["command"]](d, run):
            key = (
                mark.name,
                mark.key or np.round(mark.xyz[:, :2] / 10.0).astype(np.int64).tobytes(),
            )
            if key in seen:
                continue
            seen.add(key)
            joined.setdefault(mark.name, []).append(mark)
    out = []
    for name, marks in joined.items():
        gap = np.full((1, 3), np.nan)
        xyz = np.vstack([part for m in marks for part in (m.xyz, gap)][:-1])
        text = tuple(s for m in marks for s in (*m.text, ""))[:-1]
        m0 = marks[0]
        out.append(Mark(name, xyz, m0.mode, m0.color, text, m0.dash, m0.symbol))
    return out


__all__ = ["DRAWINGS", "Mark", "decision_marks", "drawing"]
