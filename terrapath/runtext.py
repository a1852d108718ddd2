"""A run's metrics as `terrapath replay` and `terrapath inspect` print them for people: one layout,
numbers rounded to what they mean (metres to 0.1 m, times to 0.1 s, lengths in km to 10 m), counts
with the right plural, and what separation and PLR measure (see :mod:`replay.metrics`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

SEPARATION_NOTE = (
    "separation: distance from the threat's surface (the sphere of its radius around a point, "
    "its cylinder, building (prism) or body; a zone:<id> is a danger zone of the mission); "
    "negative = inside its safety volume"
)
PLR_MEANING = "flown length / straight-line distance from the first to the last waypoint"


def plural(n: int, word: str, many: str | None = None) -> str:
    """``1 change``, ``2 changes``, ``0 changes``."""
    return f"{n} {word if n == 1 else (many or word + 's')}"


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None


def metres(value: Any) -> str:
    v = _number(value)
    return "n/a" if v is None else f"{v:.1f} m"


def kilometres(value: Any) -> str:
    v = _number(value)
    return "n/a" if v is None else f"{v / 1000:.2f} km"


def seconds(value: Any) -> str:
    v = _number(value)
    return "n/a" if v is None else f"{v:.1f} s"


def duration(value: Any) -> str:
    """Seconds under two minutes, else minutes (and hours from two hours on)."""
    v = _number(value)
    if v is None:
        return "n/a"
    if v < 120:
        return f"{v:.1f} s"
    if v < 7200:
        return f"{v / 60:.1f} min"
    return f"{v / 3600:.2f} h"


def milliseconds(value: Any) -> str:
    v = _number(value)
    return "n/a" if v is None else f"{v * 1000:.1f} ms"


def table(rows: list[tuple[str, str]]) -> list[str]:
    """``label  value`` lines, the values aligned."""
    width = max((len(k) for k, _ in rows), default=0)
    return [f"{k:<{width}}  {v}" for k, v in rows]


# how the failures of a kind are summed up on the success line (the run's end is said apart)
_SUMMARY = {
    "violation": ("safety violation", None),
    "stall": ("stall", None),
    "lateral_excursion": ("lateral excursion", None),
    "vertical_excursion": ("vertical excursion", None),
    "not_back_on_plan": ("time not back on the plan in time", "times not back on the plan in time"),
    "off_command": ("time off the avoider's command", "times off the avoider's command"),
}


def failure_summary(m: Mapping[str, Any]) -> list[str]:
    """Why a run failed, in a few words each: how it ended, then each kind of failure
    (``ended by time limit``, ``1 safety violation``, ``35.2 s over unknown terrain``...); a
    run recorded before failures were named gives what its metrics say."""
    why = []
    end = m.get("end_reason")
    if end not in (None, "goal"):
        why.append(f"ended by {end}")
    failures = [f for f in m.get("failures") or [] if isinstance(f, dict)]
    names = [str(f.get("name")) for f in failures]
    if "failures" not in m:  # an older run: its violations and time off the map
        names = ["violation"] * len(m.get("violations") or [])
        names += ["off_map"] if _number(m.get("off_map_s")) else []
        names += ["terrain_contact"] if m.get("terrain_contact") else []
    for name in dict.fromkeys(names):
        n = names.count(name)
        if name == "terrain_contact" and end != "terrain contact":
            why.append("terrain contact")
        elif name == "off_map":
            why.append(f"{seconds(m.get('off_map_s'))} off the map")
        elif name == "unknown_terrain":
            why.append(f"{seconds(m.get('unknown_terrain_s'))} over unknown terrain")
        elif name in _SUMMARY:
            why.append(plural(n, *_SUMMARY[name]))
    return why


def energy_text(e: Mapping[str, Any]) -> str:
    """A run's energy (``RunMetrics.energy``): what the battery or the fuel gave, and what is
    left of the capacity where the vehicle gives one."""
    unit = str(e.get("unit", ""))
    used = float(e["used"])
    what = str(e.get("kind", ""))  # battery or fuel
    amount = f"{used:,.2f}" if unit == "kg" else f"{used:,.1f}"
    left = _number(e.get("left"))
    if left is None:
        return f"{amount} {unit} of {what} used (the vehicle gives no capacity)"
    return f"{amount} {unit} of {what} used of {e.get('capacity')} {unit} ({100 * max(left, 0.0):.0f} % left)"


def metrics_rows(m: Mapping[str, Any]) -> list[tuple[str, str]]:
    """The run-level metrics (a ``RunMetrics.as_dict()``); keys a run did not record are left out."""
    rows: list[tuple[str, str]] = []
    if "success" in m:
        why = failure_summary(m)
        if m["success"]:
            verdict = "yes (the goal reached and the mission flown: no failure)"
        else:
            verdict = "NO" + (f" ({', '.join(why)})" if why else "")
        rows.append(("success", verdict))
    if "flight_time_s" in m:
        rows.append(("flight time", duration(m["flight_time_s"])))
    if "flown_length_m" in m:
        rows.append(("flown length", kilometres(m["flown_length_m"])))
    if "plr" in m:
        plr = _number(m["plr"])
        text = "n/a" if plr is None else f"{plr:.3f}"
        straight = m.get("straight_distance_m")
        rows.append(
            (
                "PLR",
                f"{text} ({PLR_MEANING}"
                + (f", {kilometres(straight)}" if straight is not None else "")
                + ("; the goal was not reached)" if m.get("reached_goal") is False else ")"),
            )
        )
    energy = m.get("energy")
    if isinstance(energy, dict) and _number(energy.get("used")) is not None:
        rows.append(("energy", energy_text(energy)))
    if "min_terrain_clearance_m" in m:
        t = m.get("min_terrain_clearance_t")
        at = f" at t = {seconds(t)}" if _number(t) is not None else ""
        rows.append(("min terrain clearance", metres(m["min_terrain_clearance_m"]) + at))
    spirals = [sp for sp in m.get("spirals") or [] if isinstance(sp, dict)]
    if spirals:
        rows.append(
            (
                "spirals",
                "; ".join(
                    f"waypoint {sp.get('waypoint')} left at {metres(sp.get('altitude'))} "
                    f"(plan {metres(sp.get('planned'))})"
                    for sp in spirals
                ),
            )
        )
    if _number(m.get("off_map_s")):
        rows.append(("off the map", seconds(m["off_map_s"]) + " (terrain unknown there)"))
    if _number(m.get("unknown_terrain_s")):
        rows.append(
            ("over unknown terrain", seconds(m["unknown_terrain_s"]) + " (the DEM filled it)")
        )
    if _number(m.get("off_plan_s")):
        judged = m.get("judged_by") or {}
        tol = (
            f" (beyond {metres(judged.get('lateral_tolerance_m'))} laterally or "
            f"{metres(judged.get('vertical_tolerance_m'))} vertically, or on an avoider's commands)"
            if judged
            else ""
        )
        rows.append(("off the plan", seconds(m["off_plan_s"]) + tol))
    if "waypoints_added" in m:
        rows.append(("waypoints added", str(m["waypoints_added"])))
    if "decisions" in m:
        n = int(m["decisions"])
        rows.append(
            (
                "avoidance decisions",
                "none"
                if n == 0
                else f"{n} (computation mean {milliseconds(m.get('decision_time_mean_s'))}, "
                f"max {milliseconds(m.get('decision_time_max_s'))})",
            )
        )
    return rows


def threat_lines(m: Mapping[str, Any]) -> list[str]:
    """Minimum separation to each threat, when, and the intervals spent inside its safety volume;
    then what separation means.  [] when the run had no threats."""
    seps = m.get("min_separation")
    if not isinstance(seps, dict) or not seps:
        return []
    violations = [v for v in m.get("violations") or [] if isinstance(v, dict)]
    margin = _number(m.get("margin_m")) or 0.0
    head = (
        "threat",
        "min separation",
        "at t",
        f"closer than {metres(margin)}" if margin else "inside its safety volume",
    )
    rows = []
    for tid, sep in seps.items():
        sep = sep if isinstance(sep, dict) else {}
        spans = [
            f"t = {seconds(v.get('t_enter'))} to "
            f"{'the end' if v.get('t_exit') is None else seconds(v['t_exit'])} "
            f"(deepest {metres(v.get('min_separation'))})"
            for v in violations
            if v.get("threat") == tid
        ]
        never = _number(sep.get("value")) is None
        rows.append(
            (
                str(tid),
                "never active" if never else metres(sep.get("value")),
                "" if never else seconds(sep.get("t")),
                ", ".join(spans) or "-",
            )
        )
    w = [max(len(r[i]) for r in (head, *rows)) for i in range(3)]
    lines = [f"{head[0]:<{w[0]}}  {head[1]:>{w[1]}}  {head[2]:>{w[2]}}  {head[3]}"]
    lines += [f"{a:<{w[0]}}  {b:>{w[1]}}  {c:>{w[2]}}  {d}" for a, b, c, d in rows]
    return [*lines, SEPARATION_NOTE]


MAX_FAILURE_LINES = 12  # more of them are counted per name on one line


def failure_lines(m: Mapping[str, Any]) -> list[str]:
    """One line per failure of metrics ``m`` (``name: why``), the first ``MAX_FAILURE_LINES``,
    then the rest counted per name; [] for a success."""
    failures = [f for f in m.get("failures") or [] if isinstance(f, dict)]
    if not failures:
        return []
    lines = ["why it failed:"]
    lines += [f"  {f.get('name')}: {f.get('text')}" for f in failures[:MAX_FAILURE_LINES]]
    rest = failures[MAX_FAILURE_LINES:]
    if rest:
        counts: dict[str, int] = {}
        for f in rest:
            counts[str(f.get("name"))] = counts.get(str(f.get("name")), 0) + 1
        lines.append("  and " + ", ".join(f"{n} more {k}" for k, n in counts.items()))
    return lines


def gave_up_lines(m: Mapping[str, Any]) -> list[str]:
    """The avoider's decisions that gave up, per reason: how many and the first time; []
    when none did."""
    entries = [g for g in m.get("gave_up") or [] if isinstance(g, dict)]
    if not entries:
        return []
    total = sum(int(g.get("count", 0)) for g in entries)
    lines = [f"the avoider gave up {plural(total, 'time')}:"]
    for g in entries:
        first = str(g.get("first", ""))
        lines.append(
            f"  {g.get('count')} x {g.get('reason')} (first at t = {seconds(g.get('t_first'))}"
            + (f": {first})" if first and first != g.get("reason") else ")")
        )
    return lines


def report_lines(rows: list[tuple[str, str]], m: Mapping[str, Any]) -> list[str]:
    """The aligned ``rows``; after a blank line each, why the run failed, the avoider's
    decisions that gave up and the threat table of metrics ``m`` (those it has): what
    ``replay`` and ``inspect`` print."""
    out = table(rows)
    for block in (failure_lines(m), gave_up_lines(m), threat_lines(m)):
        if block:
            out += ["", *block]
    return out
