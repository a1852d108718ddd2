"""A picture of a recorded run (``RUN.png``): what ``terrapath replay`` writes beside the MCAP and
``terrapath inspect RUN.mcap --png OUT.png`` makes from any recorded run.

``inspect`` draws from the MCAP itself (its states, waypoint changes, decisions and attachments:
the mission, the threat file) and the DEM tiles it names (:func:`recorded_view`); ``replay`` draws
the same from the flight it has in memory (:func:`replay_view`: nothing read back). A run over
flat ground (no DEM, or tiles no longer where they were recorded) is drawn without a map, and the
title says so.

- **Plan view** (top): the hillshade of the DEM, the mission's danger zones, the planned waypoints
  (the list the run started with, dashed), the flown track, the final waypoint list when the
  avoider changed it, every threat's footprint (a circle of its safety radius about each point --
  a static threat, a hill's points, an intruder at its closest approach, whose track is drawn too
  -- a cylinder's circle, a convex body's widest section) in its colour with its id on a white
  halo, the orbits an avoider commanded (CTGA's arcs, dotted), the priority loop's set-points
  (crosses) and the points of the track inside a threat's volume or a zone, in red.
  When the flight covers a small part of a large map (under a third of it each way: a priority
  loop's block of a city district, 65 km of a 640 km map) the view is zoomed onto the flight
  (:func:`terrain.plot.map_window`), its colours and colour bar spanning the heights shown.
- **Separation** (middle): the distance from each threat's and each danger zone's surface
  against time (NaN while a threat is not active), each its own colour (zones dashed, the same
  colour as the threat on the map) and labelled at its least separation, how deep it went inside
  shaded red, zero (the surface: the safety radius) and the margin; the :data:`NEAREST_DRAWN`
  that came closest (:func:`nearest_threats`: 143 buildings would be a legend, not a plot), the
  scale from below the deepest violation up to four times the largest of their least
  separations (and at least 30 % of the deepest, to see its approach). "no pop-up threats; N
  danger zones" for a run with zones only, "no threats" only with neither.
- **Above the ground** (bottom): the altitude above the terrain under the aircraft against time
  (with a DEM), or the altitude (flat ground).

At most :data:`MAX_POINTS` samples of the trajectory are drawn (a regular stride: the 8-hour seed
000 flight has 290,000 states); the separations are computed on those samples.
"""

from __future__ import annotations

import functools
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from replay.frames import PD, PE, PHI, PN, U, V, W, velocities_ned
from replay.record import topics as T
from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
MAX_POINTS = 20_000
RED = "#d62728"
OTHER = "#555555"  # threats beyond the separation panel's
NEAREST_DRAWN = 8  # threats drawn in the separation panel: those that came closest


@dataclass(frozen=True, eq=False)
class RunView:
    """What the picture draws of one run: from its MCAP (:func:`recorded_view`) or from the
    replay just flown (:func:`replay_view`, nothing read back)."""

    title: str
    mission: Any
    grid: Any  # HeightGrid or None (flat ground, or a DEM no longer where it was)
    note: str  # said in the title when there is no map
    threats: tuple[Any, ...]
    times: FloatArray  # (K,)
    positions: FloatArray  # (K, 3) map
    initial_waypoints: FloatArray
    final_waypoints: FloatArray
    decisions: tuple[dict[str, Any], ...]
    margin: float
    airspeed: FloatArray  # (K,) m/s
    bank: FloatArray  # (K,) rad
    # the waypoint lists an avoider commanded, (t, (W, 3), reason) (recorded runs only: a
    # replay's result keeps its final list)
    changes: tuple[tuple[float, FloatArray, str], ...] = ()
    success: bool = True
    avoid: str | None = None
    stride: int = 1  # times/positions hold every stride-th recorded state
    n_states: int = 0  # states recorded (0: len(times))
    wind: FloatArray | None = None  # (K, 3) the air's velocity NED at each sample (None: still)
    wind_text: str = ""  # the run's wind in words ("10 m/s from 270 deg"), "" in still air


def _title(name: str, avoid: str | None, success: bool) -> str:
    return f"{name}: {avoid or 'no avoidance'}, {'success' if success else 'FAILED'}"


def recorded_view(run: str | Path, max_states: int | None = MAX_POINTS) -> RunView:
    """The view of a recorded run (one read of the MCAP, decoding at most about ``max_states``
    states, a regular stride); a one-line error when it has no trajectory."""
    from replay.record.reader import load_run
    from replay.source import mission_of_run, recorded_threats

    src = Path(run)
    record = load_run(src, max_states=max_states)
    if len(record.times) < 2:
        raise InputError(f"{src}: the run has no trajectory to draw (fewer than 2 states)")
    mission = mission_of_run(record, str(src))
    grid, note = load_grid(mission)
    threat_text = record.attachments.get("threats.yaml")
    threats = (
        tuple(recorded_threats(threat_text.decode("utf-8"), str(src), grid))
        if threat_text is not None
        else ()
    )
    s = record.states
    start = record.waypoints[0].waypoints if record.waypoints else mission.waypoints
    m = record.metrics
    wind = None
    if "wind_n" in record.extras:
        wind = np.column_stack([record.extras[k] for k in ("wind_n", "wind_e", "wind_d")])
        wind = np.nan_to_num(wind)
    wind_text = ""
    if "wind" in record.metadata:
        wind_text = str(json.loads(record.metadata["wind"]).get("text", ""))
    return RunView(
        _title(src.name, record.metadata.get("avoid"), bool(m.get("success"))),
        mission,
        grid,
        note,
        threats,
        record.times,
        np.column_stack([s[:, PE], s[:, PN], -s[:, PD]]),
        start,
        record.waypoints[-1].waypoints if record.waypoints else start,
        tuple(d.decision for d in record.decisions),
        float(m.get("margin_m") or 0.0),
        _airspeed(s, wind),
        s[:, PHI].copy(),
        tuple((c.t, c.waypoints, c.reason) for c in record.waypoints[1:]),
        bool(m.get("success")),
        record.metadata.get("avoid"),
        record.state_stride,
        record.topic_counts.get(T.VEHICLE_STATE, 0),
        wind,
        wind_text,
    )


def _airspeed(states: FloatArray, wind: FloatArray | None) -> FloatArray:
    """The speed through the air of each state (its ground velocity less the air's)."""
    if wind is None:
        return np.asarray(np.linalg.norm(states[:, [U, V, W]], axis=1))
    return np.asarray(np.linalg.norm(velocities_ned(states) - wind, axis=1))


def replay_view(prepared: Any, result: Any, name: str) -> RunView:
    """The view of the replay just flown (``replay.run.PreparedReplay`` and its result)."""
    grid = prepared.grid
    return RunView(
        _title(name, prepared.request.avoid, result.metrics.success),
        prepared.mission,
        grid,
        "" if grid is not None else " (flat ground)",
        tuple(prepared.threats),
        result.times,
        result.positions,
        result.initial_waypoints,
        result.waypoints,
        tuple(result.decisions),
        float(result.metrics.margin_m),
        _airspeed(result.states, result.extra.get("wind")),
        result.states[:, PHI].copy(),
        success=bool(result.metrics.success),
        avoid=prepared.request.avoid,
        wind=result.extra.get("wind"),
        wind_text=prepared.config.wind.describe() if prepared.config.wind else "",
    )


def run_picture(run: str | Path, out: str | Path) -> Path:
    """Write the picture of the recorded run ``run`` (an MCAP) to ``out``."""
    return draw_run(recorded_view(run), out)


def draw_run(view: RunView, out: str | Path) -> Path:
    """Write the picture of ``view`` to ``out`` (PNG, through a temporary name)."""
    from terrain.plot import save_figure

    return save_figure(run_figure(view), out)


def run_figure(view: RunView) -> Any:
    """The picture of ``view``: the plan view over the map (zoomed onto a small flight on a large
    map, its colours spanning the heights shown), the separation panel and the height panel."""
    from terrain.plot import legend_below, map_window, new_figure

    grid = view.grid
    n = view.n_states or len(view.times)
    step = max(1, math.ceil(len(view.times) / MAX_POINTS))
    t = view.times[::step]
    xyz = view.positions[::step]

    width = 9.0
    window = None
    if grid is not None:
        window = map_window(grid, np.vstack([xyz[:, :2], view.initial_waypoints[:, :2]]))
        xmin, ymin, xmax, ymax = window
        map_h = max(3.5, min(width * (ymax - ymin) / (xmax - xmin), 10.0))
    else:
        map_h = 6.0
    fig = new_figure(width, map_h + 5.8)
    gs = fig.add_gridspec(3, 1, height_ratios=[map_h, 2.6, 2.2])
    ax = fig.add_subplot(gs[0])
    _draw_map(fig, ax, view, window)
    sep = {th.id: separation_of(th, xyz, t) for th in view.threats}
    zone_sep = zone_separations(view.mission, grid, xyz)
    every = {**sep, **zone_sep}
    shown = nearest_threats(every, NEAREST_DRAWN)  # the separation panel's
    styles = series_styles(list(every), shown)
    for th in view.threats:
        _draw_threat(ax, th, xyz, t, sep[th.id], styles[th.id][0])
    _draw_flight(ax, view, xyz, t, every)
    _draw_decisions(ax, view.decisions)
    if grid is None:
        _frame(ax, xyz, view.initial_waypoints)
    _draw_wind(ax, view)
    legend_below(ax)

    ax2 = fig.add_subplot(gs[1])
    _draw_separations(ax2, sep, zone_sep, shown, t, view.margin, styles)

    ax3 = fig.add_subplot(gs[2], sharex=ax2)
    _draw_height(ax3, grid, t, xyz)
    every_n = step * view.stride
    ax3.set_xlabel("time (min)" + (f"; 1 in {every_n} of {n} states drawn" if every_n > 1 else ""))
    return fig


def zone_separations(mission: Any, grid: Any, xyz: FloatArray) -> dict[str, FloatArray]:
    """The distance from each of the mission's danger zones at each sample (negative inside),
    by the ids the replay's metrics give them (``zone:<id>``, ``zone:<k>`` without an id); a zone
    limited above the ground needs the map (left out over flat ground)."""
    from planner.mission import on_terrain

    zones = on_terrain(mission, grid).danger_zones if mission.danger_zones else ()
    out: dict[str, FloatArray] = {}
    for k, z in enumerate(zones):
        try:
            out[f"zone:{z.id or k}"] = np.asarray(z.separation(xyz), dtype=np.float64).reshape(-1)
        except InputError:  # above the ground, with no ground to measure it on
            continue
    return out


def series_styles(ids: list[str], shown: list[str]) -> dict[str, tuple[str, str]]:
    """(colour, line style) of each threat or zone: the ``shown`` ones (the separation panel's)
    each its own colour of :data:`terrain.plot.SERIES_COLOURS` (zones dashed), the others grey,
    so a threat has the same colour on the map and in the panel."""
    from terrain.plot import SERIES_COLOURS

    styles = {i: (OTHER, "-") for i in ids}
    for k, ident in enumerate(shown):
        dash = "--" if ident.startswith("zone:") else "-"
        if k >= len(SERIES_COLOURS):
            dash = ":" if dash == "-" else "-."
        styles[ident] = (SERIES_COLOURS[k % len(SERIES_COLOURS)], dash)
    return styles


def _draw_wind(ax: Any, view: RunView) -> None:
    """An arrow in the plan view's top-left corner the way the air moves (the run's mean wind,
    its length growing with the speed), labelled with the wind in words."""
    if view.wind is None or not len(view.wind):
        return
    wn, we = (float(v) for v in np.mean(view.wind[:, :2], axis=0))
    speed = math.hypot(wn, we)
    if speed < 0.1:
        return
    x0, y0 = 0.08, 0.90  # axes fraction
    size = 0.04 + 0.06 * min(speed / 20.0, 1.0)
    ax.annotate(
        "",
        xy=(x0 + size * we / speed, y0 + size * wn / speed),
        xytext=(x0, y0),
        xycoords="axes fraction",
        arrowprops={"arrowstyle": "-|>", "color": "#1f3f7f", "lw": 2.0},
        zorder=20,
    )
    text = view.wind_text or f"{speed:.1f} m/s"
    ax.text(
        x0,
        y0 - 0.05,
        f"wind {text}",
        transform=ax.transAxes,
        fontsize=8,
        color="#1f3f7f",
        bbox={"facecolor": "white", "alpha": 0.75, "edgecolor": "none", "pad": 1.5},
        zorder=20,
    )


def _draw_map(fig: Any, ax: Any, view: RunView, window: Any) -> None:
    """The plan view's background: the hillshade of ``window`` (or bare axes over flat ground),
    the title and the mission's danger zones."""
    from terrain.plot import draw_hillshade, draw_zones

    grid, mission, note = view.grid, view.mission, view.note
    if grid is not None:
        draw_hillshade(fig, ax, grid, view.title + note, window)
    else:
        ax.set_title(view.title + note)
        ax.set_aspect("equal")
        ax.set_xlabel("x east (m)")
        ax.set_ylabel("y north (m)")
    if mission.danger_zones:
        draw_zones(ax, mission.danger_zones)


def _draw_flight(
    ax: Any, view: RunView, xyz: FloatArray, t: FloatArray, sep: dict[str, FloatArray]
) -> None:
    """The planned waypoints, the final list when the avoider changed it, the flown track and
    its points inside a threat."""
    from matplotlib.patheffects import Normal, Stroke

    start, final = view.initial_waypoints, view.final_waypoints
    ax.plot(start[:, 0], start[:, 1], "--o", color="#1f77b4", ms=4, lw=1.2, label="planned")
    if len(final) != len(start) or not np.allclose(final, start):
        ax.plot(
            final[:, 0],
            final[:, 1],
            "o",
            color="#ff7f0e",
            mec="black",
            ms=5,
            ls="",
            label="waypoints after avoidance",
        )
    ax.plot(
        xyz[:, 0],
        xyz[:, 1],
        "-",
        color="white",
        lw=1.4,
        label="flown",
        path_effects=[Stroke(linewidth=2.8, foreground="black"), Normal()],
    )
    inside = np.zeros(len(t), dtype=bool)
    for v in sep.values():
        inside |= np.nan_to_num(v, nan=np.inf) < 0.0
    if inside.any():
        ax.plot(
            xyz[inside, 0], xyz[inside, 1], ".", color=RED, ms=3, label="inside a threat or zone"
        )


def _draw_decisions(ax: Any, decisions: tuple[dict[str, Any], ...]) -> None:
    """The orbits the avoider commanded (dotted) and the priority loop's last set-points."""
    drawn: set[tuple[int, int, int]] = set()
    for d in decisions:  # each distinct orbit once (an arc's updates move it little)
        cmd = d.get("command")
        if isinstance(cmd, dict) and cmd.get("command") == "Orbit":
            cx, cy = cmd["center"]
            r = cmd["radius"]
            key = (round(cx / 50.0), round(cy / 50.0), round(r / 50.0))
            if key in drawn:
                continue
            drawn.add(key)
            a = np.linspace(0.0, 2.0 * math.pi, 73)
            label = "avoider's orbits" if len(drawn) == 1 else None
            ax.plot(
                cx + r * np.sin(a), cy + r * np.cos(a), ":", color="#e377c2", lw=1.0, label=label
            )
    setpoints = next((d["setpoints"] for d in reversed(decisions) if d.get("setpoints")), None)
    if setpoints:  # the priority loop's path S, as its last decision had it
        s = np.asarray(setpoints, dtype=np.float64)
        ax.plot(s[:, 0], s[:, 1], "x", color="#ff7f0e", ms=5, mew=1.5, ls="", label="set-points S")


def _draw_separations(
    ax2: Any,
    sep: dict[str, FloatArray],
    zone_sep: dict[str, FloatArray],
    shown: list[str],
    t: FloatArray,
    margin: float,
    styles: dict[str, tuple[str, str]],
) -> None:
    """The separation panel: the threats and zones that came closest (``shown``, of
    :func:`nearest_threats`) against time, each in its colour (zones dashed) and labelled at its
    least separation and at the deepest point of each violation, how deep each went inside
    shaded red, the threat's surface (its safety radius: zero) and the margin. Says "no pop-up
    threats" when a run had only zones, "no threats" when it had neither."""
    from terrain.plot import halo, legend_below

    every = {**sep, **zone_sep}
    notes = []
    if not sep and zone_sep:
        n = len(zone_sep)
        notes.append(f"no pop-up threats; {n} danger zone{'s' if n != 1 else ''}")
    if len(shown) < len(every):
        notes.append(f"the {len(shown)} that came closest, of {len(every)}")
    if notes:
        ax2.set_title("; ".join(notes), fontsize=8)
    ax2.set_ylabel("separation from\nthe surface (m)")
    ax2.set_xlim(t[0] / 60.0, t[-1] / 60.0)
    if not every:
        ax2.text(0.5, 0.5, "no threats", transform=ax2.transAxes, ha="center")
        return
    minutes = t / 60.0
    lows = []
    for ident in shown:
        v = every[ident]
        colour, dash = styles[ident]
        ax2.plot(minutes, v, dash, color=colour, lw=1.3, label=ident)
        bad = np.nan_to_num(v, nan=np.inf) < margin
        if bad.any():  # how deep it went, in the violation's red
            ax2.fill_between(minutes, v, margin, where=bad, color=RED, alpha=0.18, lw=0)
        if not np.isfinite(v).any():
            continue
        k = int(np.nanargmin(v))
        lows.append(float(v[k]))
        # its least separation, and the deepest point of each other violation of it
        for j in [k, *(i for i in violation_lows(v, margin) if i != k)]:
            marker = "v" if v[j] < margin else "o"
            ax2.plot(minutes[j], v[j], marker, color=colour, mec="black", ms=6 if j == k else 5)
            ax2.annotate(
                f"{ident} {float(v[j]):.0f} m",
                (minutes[j], float(v[j])),
                xytext=(5, -11 if v[j] < margin else 4),
                textcoords="offset points",
                fontsize=7,
                color=colour,
                path_effects=halo(),
                annotation_clip=True,
                zorder=5,
            )
    ax2.axhline(0.0, color="black", lw=0.9, label="surface (safety radius)")
    if margin:
        ax2.axhline(margin, color=RED, lw=0.8, ls="--", label=f"margin {margin:g} m")
    deepest = min([0.0, *lows])
    closest = max(lows, default=0.0)
    # the close passes matter: up to four times the largest of the drawn minima, and room above
    # zero to see a deep violation's approach
    top = max(4.0 * closest, 2.0 * margin, 0.3 * -deepest, 10.0)
    ax2.set_ylim(deepest - 0.1 * (top - deepest), top)
    legend_below(ax2, ncol=min(len(shown) + 1 + bool(margin), 5))


def _draw_height(ax3: Any, grid: Any, t: FloatArray, xyz: FloatArray) -> None:
    """The bottom panel: the height above the terrain (below it in red), or the altitude over
    flat ground."""
    if grid is not None:
        agl = xyz[:, 2] - np.asarray(grid.height_at(xyz[:, 0], xyz[:, 1]), dtype=np.float64)
        ax3.plot(t / 60.0, agl, color="#2ca02c", lw=1.0)
        low = agl < 0.0
        if low.any():
            ax3.plot(t[low] / 60.0, agl[low], ".", color=RED, ms=2)
        ax3.axhline(0.0, color="#8c6d46", lw=1.2)
        ax3.set_ylabel("above the\nterrain (m)")
    else:
        ax3.plot(t / 60.0, xyz[:, 2], color="#2ca02c", lw=1.0)
        ax3.set_ylabel("altitude (m)")


def load_grid(mission: Any) -> tuple[Any, str]:
    """The run's DEM, or None with a note for the title (flat ground, or tiles not found).
    (Several runs of one map, as ``terrapath view`` compares, load it once.)"""
    if mission.terrain is None:
        return None, " (flat ground)"
    try:
        t = mission.terrain
        return _load_tiles(t.paths(), t.cell_size, t.local_cell_size), ""
    except InputError:
        return None, " (its DEM is not where it was recorded: drawn without the map)"


@functools.lru_cache(maxsize=2)
def _load_tiles(paths: tuple[str, ...], cell_size: Any, local_cell_size: Any = None) -> Any:
    from terrain.load import load_dem

    return load_dem(list(paths), cell_size=cell_size, local_cell_size=local_cell_size)


def separation_of(th: Any, xyz: FloatArray, t: FloatArray) -> FloatArray:
    """Distance from the threat's surface at each sample, NaN while it is not active."""
    sep = np.asarray(th.separation(xyz, t), dtype=np.float64).reshape(-1)
    return np.where(active_at(th, t), sep, np.nan)


def active_at(th: Any, t: FloatArray) -> npt.NDArray[np.bool_]:
    """``appears_at <= t < disappears_at`` at each time."""
    end = math.inf if th.disappears_at is None else th.disappears_at
    return np.asarray((t >= th.appears_at) & (t < end))


def _draw_threat(
    ax: Any,
    th: Any,
    xyz: FloatArray,
    t: FloatArray,
    sep: FloatArray,
    colour: str = OTHER,
) -> None:
    """A threat's footprint in its colour: circles of its shapes (a body's widest section), a
    prism's polygon, an intruder's track and its circle where it came closest; its id on a white
    halo."""
    from matplotlib.patches import Circle, Polygon

    from terrain.plot import halo

    edge = {"fill": False, "ec": colour, "lw": 1.3, "path_effects": halo(2.6)}
    # out of the layout: a label sits on its threat inside the map (clipped with it), and
    # measuring a hundred of them for the layout cost a third of a 100-obstacle picture
    label = {
        "color": colour,
        "fontsize": 7,
        "path_effects": halo(),
        "annotation_clip": True,
        "in_layout": False,
    }
    if th.kind == "intruder":
        active = active_at(th, t)
        if active.any():
            track = np.asarray(th.position(t[active]), dtype=np.float64).reshape(-1, 3)
            ax.plot(track[:, 0], track[:, 1], "-", color=colour, lw=1.0, path_effects=halo(2.4))
            k = int(np.nanargmin(np.where(active, sep, np.inf)))
            p = np.asarray(th.position(t[k]), dtype=np.float64).reshape(3)
            ax.add_patch(Circle((p[0], p[1]), th.radius, **edge))
            ax.annotate(th.id, (p[0], p[1]), **label)
        return
    shapes = th.shapes(float(t[0]))
    for sh in shapes:
        if sh.get("kind") == "prism":
            ring = np.asarray(sh["footprint"], dtype=np.float64)
            ax.add_patch(Polygon(ring, closed=True, **edge))
            continue
        c = np.asarray(sh["center"], dtype=np.float64).reshape(-1, 3)
        r = np.atleast_1d(np.asarray(sh.get("radius", 0.0), dtype=np.float64))
        if sh.get("kind") == "body" or "axes" in sh:
            axes = sh.get("axes") or (r[0], r[0])
            r = np.array([max(float(axes[0]), float(axes[1]))])
        for k in range(len(c)):
            rk = float(r[min(k, len(r) - 1)])
            ax.add_patch(Circle((c[k, 0], c[k, 1]), rk, **edge))
    c0 = np.asarray(shapes[0]["center"], dtype=np.float64).reshape(-1, 3)[0]
    ax.annotate(th.id, (c0[0], c0[1]), **label)


def violation_lows(v: FloatArray, margin: float, limit: int = 5) -> list[int]:
    """The index of the deepest sample of each separate violation of ``v`` (each run of
    consecutive samples below ``margin``; NaN is no violation), deepest first, at most ``limit``:
    where a picture labels how deep each one went."""
    bad = np.nan_to_num(v, nan=np.inf) < margin
    if not bad.any():
        return []
    edges = np.flatnonzero(np.diff(np.concatenate(([0], bad.astype(np.int8), [0]))))
    lows = [int(a + np.argmin(v[a:b])) for a, b in zip(edges[::2], edges[1::2], strict=True)]
    return sorted(lows, key=lambda k: float(v[k]))[:limit]


def nearest_threats(sep: dict[str, FloatArray], k: int) -> list[str]:
    """The ids of the ``k`` threats whose least separation is smallest, in their given order
    (a threat never active -- all NaN -- counts as infinitely far)."""
    least = {
        ident: float(np.nanmin(v)) if np.isfinite(v).any() else math.inf for ident, v in sep.items()
    }
    keep = set(sorted(least, key=lambda i: least[i])[:k])
    return [ident for ident in sep if ident in keep]


def _frame(ax: Any, xyz: FloatArray, wps: FloatArray) -> None:
    """Limits round the track and the waypoints (flat ground: no map to set them)."""
    pts = np.vstack([xyz[:, :2], np.asarray(wps, dtype=np.float64)[:, :2]])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.08 * float(max(hi - lo)) + 100.0
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)


__all__ = [
    "MAX_POINTS",
    "RunView",
    "active_at",
    "draw_run",
    "load_grid",
    "nearest_threats",
    "recorded_view",
    "replay_view",
    "run_figure",
    "run_picture",
    "separation_of",
    "series_styles",
    "zone_separations",
]
