"""The three figures of ``terrapath view``: the 3D scene, the 2-D map and the time plots.

**3D scene** (:func:`scene_figure`): the terrain as a shaded surface (decimated to at most
:data:`MAX_SURFACE` cells; holes where the DEM has no measurement), drawn with a stated vertical
exaggeration (the aspect ratio is exaggerated, the coordinates and hover values stay true);
danger zones as translucent solids; each source's planned waypoints (a mission: its flown path
with the turn fillets too); each run's flown trajectory coloured by time, by height above the
terrain or by run (at most :data:`MAX_LINE` points a run); every threat as its shape (sphere, hill
cluster, convex body, cylinder, prism; an intruder's sphere moves along its dotted track); the
avoiders' decisions (:mod:`terrapath.view.decisions`); a run's rangefinder beams at sampled
scans, red where they hit (:mod:`terrapath.view.beams`).  A slider and a play button step through
:data:`FRAMES` times: each run's aircraft moves along its flight and each threat is shown from its
appearance time (to its disappearance).  Hovering the trajectory gives time, altitude, height
above the terrain and the separation to the nearest active threat.

**2-D map** (:func:`map_figure`): the same seen from above, over the tinted hillshade.

**Time plots** (:func:`time_figure`): altitude and the terrain below it, airspeed, bank, the
wind where a run flew in one (its horizontal speed and its vertical part, gusts included), and the
separation from each threat's surface against the run's margin (violations in red): per run the
``replay.record.picture.NEAREST_DRAWN`` threats that came closest, as in the run's picture.
"""

from __future__ import annotations

import base64
import io
import math
from dataclasses import replace
from typing import Any

import numpy as np
import numpy.typing as npt

from replay.record.picture import NEAREST_DRAWN, nearest_threats, violation_lows
from terrapath.view.decisions import Mark, decision_marks
from terrapath.view.shapes import (
    Mesh,
    cylinder_mesh,
    merge,
    prism_mesh,
    sphere_mesh,
    superellipsoid_mesh,
)
from terrapath.view.sources import Source
from terrapath.view.style import (
    RUN_COLOURS,
    THREAT_COLOUR,
    label,
    legend_below,
    legend_button,
    run_style,
    threat_dash,
)
from terrapath.view.unknown import map_hatch, scene_hatch

FloatArray = npt.NDArray[np.float64]
MAX_SURFACE = 90_000  # terrain cells of the 3D surface (300 x 300)
MAX_IMAGE = 1600  # pixels along the longer side of the 2-D map's hillshade
MAX_LINE = 4_000  # points of a run's 3D line and map track
PLOT_POINTS = 6_000  # points of a run's altitude, airspeed and bank plots
FRAMES = 200  # slider positions
MIN_Z_ASPECT = 0.12  # the 3D box is at least this high for its width (a long flight is flat)
ZONE_COLOUR = "#d62728"
RED = "#d62728"
COLOR_BY = ("time", "clearance", "run")


def _style(sources: list[Source], s: Source) -> tuple[str, str]:
    """Each source's colour and marker symbol, the same in every tab (by its place among the
    sources)."""
    return run_style(sources.index(s))


def _stride(n: int, most: int) -> int:
    return max(1, math.ceil(n / most))


def _threats(sources: list[Source]) -> list[Any]:
    """The threats of every run, each once (runs of one scenario share them)."""
    out: dict[tuple[str, str], Any] = {}
    for s in sources:
        for th in s.run.threats if s.run is not None else ():
            out.setdefault((th.id, repr(th.to_record())), th)
    return list(out.values())


def _floor(sources: list[Source]) -> float:
    g = sources[0].grid
    if g is not None:
        return float(g.zmin)
    return 0.0


def _zone_mesh(zone: Any, floor: float, top: float) -> Mesh:
    lo = zone.floor if zone.floor is not None else floor
    hi = zone.top if zone.top is not None else top
    if zone.kind == "cylinder":
        return cylinder_mesh((zone.x, zone.y), zone.diameter / 2.0, lo, hi)
    return prism_mesh(zone.geometry, lo, hi)


def _threat_mesh(shape: dict[str, Any], floor: float) -> Mesh:
    """The mesh of one recorded shape (``Threat.shapes``)."""
    kind = shape.get("kind")
    c = shape["center"]
    if kind == "sphere":
        return sphere_mesh(c, float(shape["radius"]))
    if kind == "ellipsoid":
        return superellipsoid_mesh(c, shape["axes"], shape.get("exponents", (1.0, 1.0, 1.0)))
    if kind == "cylinder":
        bottom = shape.get("bottom")
        return cylinder_mesh(
            c[:2], float(shape["radius"]), floor if bottom is None else float(bottom), shape["top"]
        )
    if kind == "prism":
        import shapely

        bottom = shape.get("bottom")
        poly = shapely.Polygon(shape["footprint"])
        return prism_mesh(poly, floor if bottom is None else float(bottom), float(shape["top"]))
    raise ValueError(f"no drawing for a {kind!r} shape")


def _mesh_trace(mesh: Mesh, name: str, colour: str, opacity: float, **kw: Any) -> Any:
    import plotly.graph_objects as go

    v, f = mesh
    return go.Mesh3d(
        x=v[:, 0],
        y=v[:, 1],
        z=v[:, 2],
        i=f[:, 0],
        j=f[:, 1],
        k=f[:, 2],
        name=name,
        color=colour,
        opacity=opacity,
        flatshading=False,
        hoverinfo="name",
        **kw,
    )


def _active(th: Any, t: float) -> bool:
    return bool(th.appears_at <= t and (th.disappears_at is None or t < th.disappears_at))


def _terrain_colourscale() -> list[list[Any]]:
    from matplotlib import colormaps

    cmap = colormaps["gist_earth"]
    return [
        [
            k / 10.0,
            "rgb({:.0f},{:.0f},{:.0f})".format(*(255 * np.asarray(cmap(0.1 + 0.8 * k / 10.0)[:3]))),
        ]
        for k in range(11)
    ]


def _surface(grid: Any) -> tuple[list[Any], int]:
    import plotly.graph_objects as go

    step = _stride(grid.rows * grid.cols, MAX_SURFACE)
    step = max(1, math.ceil(math.sqrt(step)))
    filled = np.asarray(grid.heights[::step, ::step], dtype=np.float64)
    h = filled
    if grid.known is not None:
        h = np.where(np.asarray(grid.known)[::step, ::step], h, np.nan)
    xmin, _, _, ymax = grid.bounds
    dx, dy = grid.cell_size
    xs = xmin + dx * (0.5 + step * np.arange(h.shape[1]))
    ys = ymax - dy * (0.5 + step * np.arange(h.shape[0]))
    relief = float(grid.zmax - grid.zmin)
    hatch = scene_hatch(xs, ys, filled, np.isnan(h), relief)
    surface = go.Surface(
        x=xs,
        y=ys,
        z=h,
        colorscale=_terrain_colourscale(),
        cmin=grid.zmin,
        cmax=grid.zmax,
        showscale=False,
        name="terrain",
        hovertemplate="x %{x:.0f} m, y %{y:.0f} m<br>terrain %{z:.0f} m AMSL<extra></extra>",
        lighting={"ambient": 0.75, "diffuse": 0.7, "specular": 0.05, "roughness": 0.9},
        lightposition={"x": -5e4, "y": 5e4, "z": 1e5},
        showlegend=True,
    )
    return [surface, *hatch], step


def _aircraft_at(s: Source, t: float) -> list[float]:
    run = s.run
    tt = min(max(t, float(run.times[0])), float(run.times[-1]))
    return [float(np.interp(tt, run.times, run.positions[:, k])) for k in range(3)]


def scene_figure(
    sources: list[Source], exaggeration: float = 2.0, color_by: str | None = None
) -> tuple[Any, list[str]]:
    """The 3D scene (module docstring) and the notes the page states (decimation, exaggeration)."""
    import plotly.graph_objects as go

    notes: list[str] = []
    fig = go.Figure()
    grid = sources[0].grid
    runs = [s for s in sources if s.run is not None]
    color_by = color_by or ("time" if len(runs) == 1 else "run")
    floor = _floor(sources)
    if grid is not None:
        _add_terrain(fig, grid, notes)
    top = _scene_top(sources, grid, floor)
    _add_zones(fig, sources[0].mission.danger_zones, floor, top)
    for mark, line3d in _layers(sources, color_by):
        fig.add_trace(_trace(mark, line3d))
    aircraft = _add_aircraft(fig, sources, notes)
    threats = _threats(sources)
    t_end = max((float(s.run.times[-1]) for s in runs), default=0.0)
    threat_traces = _add_threats(fig, threats, floor, t_end)
    # the slider: each run's aircraft, each threat's visibility, each intruder's sphere
    times = np.linspace(0.0, t_end, FRAMES) if runs else np.zeros(1)
    frames, steps = _frames(times, runs, aircraft, threats, threat_traces)
    if runs:
        _add_player(fig, frames, steps)
    else:
        for pair in threat_traces:
            for i in pair:
                fig.data[i].visible = True
    shown = _scene_layout(fig, sources, grid, floor, top, exaggeration)
    if shown > exaggeration * 1.01:
        notes.append(
            f"3D: vertical exaggeration x{shown:.3g} (x{exaggeration:g} asked: raised so that "
            f"the height is at least {MIN_Z_ASPECT:g} of the width; hover values are true)"
        )
    else:
        notes.append(f"3D: vertical exaggeration x{exaggeration:g} (hover values are true)")
    return fig, notes


def _add_terrain(fig: Any, grid: Any, notes: list[str]) -> None:
    """The terrain's surface, and a note when it is decimated."""
    traces, step = _surface(grid)
    for trace in traces:
        fig.add_trace(trace)
    if step > 1:
        notes.append(
            f"3D terrain: 1 in {step} rows and columns of the {grid.rows} x {grid.cols} "
            f"grid ({grid.cell_size[0] * step:.0f} m spacing)"
        )


def _scene_top(sources: list[Source], grid: Any, floor: float) -> float:
    """The top of the scene: 200 m over the highest of the terrain, the waypoints and the
    flights."""
    zs: list[float] = [floor]
    if grid is not None:
        zs.append(float(grid.zmax))
    # what is flown and planned, first: it sets the height of the open-topped zones
    for s in sources:
        zs.extend(np.asarray(s.mission.waypoints)[:, 2].tolist())
        if s.track is not None:
            zs.extend([float(s.track.xyz[:, 2].min()), float(s.track.xyz[:, 2].max())])
    return max(zs) + 200.0


def _add_zones(fig: Any, zones: Any, floor: float, top: float) -> None:
    """The danger zones as translucent solids (one legend entry for them all)."""
    for k, zone in enumerate(zones):
        fig.add_trace(
            _mesh_trace(
                _zone_mesh(zone, floor, top),
                f"danger zone {zone.id or k}",
                ZONE_COLOUR,
                0.3,
                legendgroup="zones",
                showlegend=k == 0,
            )
        )
        fig.data[-1].name = "danger zones" if k == 0 else f"danger zone {zone.id or k}"


def _add_aircraft(fig: Any, sources: list[Source], notes: list[str]) -> list[int]:
    """Each run's aircraft marker in its colour and symbol (the slider moves it), and a note
    of how its flight is sampled; returns the markers' trace indices."""
    import plotly.graph_objects as go

    aircraft: list[int] = []
    for n, s in enumerate(sources):
        if s.run is None:
            continue
        colour, symbol = run_style(n)
        tr = s.track
        assert tr is not None
        k = _stride(len(tr.t), MAX_LINE)
        plot_step = tr.step * _stride(len(tr.t), PLOT_POINTS)
        notes.append(
            f"{s.path.name}: of its {tr.n_states} recorded states, the 3D line and the map "
            f"track draw 1 in {tr.step * k}, the altitude, airspeed and bank plots 1 in "
            f"{plot_step}, the separations and the hover values 1 in {tr.step}"
        )
        fig.add_trace(
            go.Scatter3d(
                x=[0.0],
                y=[0.0],
                z=[0.0],
                mode="markers",
                marker={
                    "size": 8,
                    "color": colour,
                    "symbol": symbol,
                    "line": {"color": "white", "width": 2},
                },
                name=f"aircraft: {s.path.name}",
                hoverinfo="name",
            )
        )
        aircraft.append(len(fig.data) - 1)
    return aircraft


def _add_threats(fig: Any, threats: list[Any], floor: float, t_end: float) -> list[tuple[int, ...]]:
    """Every threat as its shape, with its outline at mid-height in its line style (an
    intruder: its sphere at the start, and its track in its line style) listed in the legend
    under its id, and a label over it; returns per threat the shape's trace index, then its
    outline's (the slider shows both while the threat is active)."""
    threat_traces: list[tuple[int, ...]] = []
    labels: list[dict[str, Any]] = []
    for n, th in enumerate(threats):
        group = f"threat:{th.id}"
        text = f"{th.id} ({th.kind}), from {th.appears_at / 60.0:.1f} min"
        if th.kind == "intruder":
            track = _intruder_track(th, t_end)
            track = replace(track, dash=threat_dash(n), name=f"threat {th.id}", legend=True)
            fig.add_trace(_trace(replace(track, group=group), {}))
            mesh = sphere_mesh(np.asarray(th.position(0.0)).reshape(3), th.radius, 8, 12)
            top = np.asarray(th.position(th.appears_at), dtype=np.float64).reshape(3)
            top[2] += th.radius
            outline: tuple[int, ...] = ()
        else:
            mesh = merge([_threat_mesh(sh, floor) for sh in th.shapes(th.appears_at)])
            mid = float(mesh[0][:, 2].min() + mesh[0][:, 2].max()) / 2.0
            x, y = _joined(_footprints(th, floor))
            ring = Mark(
                f"threat {th.id}",
                np.column_stack([x, y, np.full(len(x), mid)]),
                "lines",
                THREAT_COLOUR,
                (),
                threat_dash(n),
                width=1.5,
                template="",
                group=group,
            )
            fig.add_trace(_trace(ring, {}))
            outline = (len(fig.data) - 1,)
            top = mesh[0][np.argmax(mesh[0][:, 2])].copy()
        fig.add_trace(
            _mesh_trace(
                mesh,
                th.id,
                THREAT_COLOUR,
                0.45,
                legendgroup=group,
                showlegend=False,
                hovertemplate=f"{text}<extra></extra>",
            )
        )
        threat_traces.append((len(fig.data) - 1, *outline))
        labels.append(
            label(
                x=float(top[0]),
                y=float(top[1]),
                z=float(top[2]),
                text=th.id,
                showarrow=False,
                yshift=14,
            )
        )
    fig.update_layout(scene={"annotations": labels})
    return threat_traces


def _frames(
    times: FloatArray,
    runs: list[Source],
    aircraft: list[int],
    threats: list[Any],
    threat_traces: list[tuple[int, ...]],
) -> tuple[list[Any], list[dict[str, Any]]]:
    """The slider's frames and steps: at each time each run's aircraft, each threat's
    visibility, each intruder's sphere."""
    import plotly.graph_objects as go

    frames, steps = [], []
    unit = _unit_sphere(8, 12)
    for t in times:
        name = _clock(float(t))
        data: list[dict[str, Any]] = []
        idx: list[int] = []
        for s, i in zip(runs, aircraft, strict=True):
            x, y, z = _aircraft_at(s, float(t))
            data.append({"type": "scatter3d", "x": [x], "y": [y], "z": [z]})
            idx.append(i)
        for th, (i, *outline) in zip(threats, threat_traces, strict=True):
            active = _active(th, float(t))
            upd: dict[str, Any] = {"type": "mesh3d", "visible": active}
            if th.kind == "intruder":
                c = np.asarray(th.position(float(t)), dtype=np.float64).reshape(3)
                v = c + th.radius * unit
                upd.update(x=v[:, 0].round(1), y=v[:, 1].round(1), z=v[:, 2].round(1))
            data.append(upd)
            idx.append(i)
            for j in outline:  # listed in the legend while hidden
                data.append({"type": "scatter3d", "visible": True if active else "legendonly"})
                idx.append(j)
        frames.append(go.Frame(name=name, data=data, traces=idx))
        steps.append(
            {
                "method": "animate",
                "label": name,
                "args": [
                    [name],
                    {
                        "mode": "immediate",
                        "frame": {"duration": 0, "redraw": True},
                        "transition": {"duration": 0},
                    },
                ],
            }
        )
    return frames, steps


def _add_player(fig: Any, frames: list[Any], steps: list[dict[str, Any]]) -> None:
    """The frames, the scene as the last one shows it, the slider and the play and pause
    buttons."""
    last = frames[-1]
    for upd, i in zip(last.data, last.traces, strict=True):
        for prop in ("x", "y", "z", "visible"):
            if upd[prop] is not None:
                fig.data[i][prop] = upd[prop]
    fig.frames = frames
    fig.update_layout(
        sliders=[
            {
                "active": len(steps) - 1,
                "steps": steps,
                # the steps' labels would overlap: the current one is shown above the slider
                "font": {"color": "rgba(0,0,0,0)"},
                "ticklen": 3,
                "minorticklen": 0,
                "currentvalue": {"prefix": "t = ", "font": {"color": "#222", "size": 14}},
                "pad": {"t": 10},
                "len": 0.85,
                "x": 0.16,
                "y": 0.1,
                "yanchor": "top",
            }
        ],
        updatemenus=[
            {
                "type": "buttons",
                "showactive": False,
                "x": 0.0,
                "y": 0.1,
                "xanchor": "left",
                "yanchor": "top",
                "direction": "left",
                "pad": {"t": 30, "l": 6},
                "bgcolor": "white",
                "font": {"color": "#1a1a1a", "size": 12},
                "buttons": [
                    {
                        "label": "play",
                        "method": "animate",
                        "args": [
                            None,
                            {
                                "mode": "immediate",
                                "fromcurrent": True,
                                "frame": {"duration": 60, "redraw": True},
                                "transition": {"duration": 0},
                            },
                        ],
                    },
                    {
                        "label": "pause",
                        "method": "animate",
                        "args": [
                            [None],
                            {"mode": "immediate", "frame": {"duration": 0, "redraw": False}},
                        ],
                    },
                ],
            }
        ],
    )


def _clock(t: float) -> str:
    """Seconds as h:mm:ss."""
    s = int(round(t))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}"


def _unit_sphere(n_lat: int, n_lon: int) -> FloatArray:
    v, _ = sphere_mesh((0.0, 0.0, 0.0), 1.0, n_lat, n_lon)
    return v


def _layers(
    sources: list[Source], color_by: str | None = None
) -> list[tuple[Mark, dict[str, Any]]]:
    """What the 3D scene and the 2-D map both draw, in drawing order: the planned waypoints
    (each distinct list once), a mission's path with its turn fillets, each run's flown track
    (hover: time, altitude, height above the terrain, the nearest threat), its samples inside a
    threat or below the terrain, its avoider's decisions and its rangefinder beams.  With each, the 3D line's colouring
    (``color_by`` time or clearance; empty: the mark's colour)."""
    grid = sources[0].grid
    runs = [s for s in sources if s.run is not None]
    color_by = color_by or ("time" if len(runs) == 1 else "run")
    out: list[tuple[Mark, dict[str, Any]]] = []
    planned_seen: set[bytes] = set()
    for s in sources:
        wps = np.asarray(s.run.initial_waypoints if s.run is not None else s.mission.waypoints)
        key = np.round(wps).tobytes()
        if key not in planned_seen:
            planned_seen.add(key)
            name = f"planned: {s.path.name}" if len(sources) > 1 else "planned waypoints"
            hover = "waypoint %{pointNumber}: %{customdata:.0f} m AMSL<extra></extra>"
            mark = Mark(name, wps, "lines+markers", "#1f3f77", (), "dash", width=1.5)
            out.append((replace(mark, customdata=wps[:, 2], template=hover), {}))
        if s.run is None and s.mission.turn_radius:
            from planner.flown import flown_paths

            path, _ = flown_paths(wps, float(s.mission.turn_radius))
            name = f"{s.path.name}: path with turn fillets (r {s.mission.turn_radius:.0f} m)"
            out.append((Mark(name, path, "lines", _style(sources, s)[0], (), width=2.5), {}))
    above = "above the terrain" if grid is not None else "(flat ground)"
    template = (
        "t %{customdata[0]:.2f} min<br>alt %{customdata[3]:.0f} m AMSL, %{customdata[1]:.0f} m "
        + above
        + "<br>nearest threat %{text}: %{customdata[2]:.0f} m<extra>%{fullData.name}</extra>"
    )
    for n, s in enumerate(runs):
        tr = s.track
        assert tr is not None
        k = _stride(len(tr.t), MAX_LINE)
        custom = np.column_stack([tr.t / 60.0, tr.agl, tr.nearest, tr.xyz[:, 2]])[::k]
        flown = Mark(
            f"flown: {s.label}",
            tr.xyz[::k],
            "lines",
            _style(sources, s)[0],
            tr.nearest_id[::k],
            width=2.5,
            customdata=custom,
            template=template,
        )
        out.append((flown, _colouring(tr, k, color_by, n == 0)))
        bad = tr.agl < 0.0 if grid is not None else np.zeros(len(tr.t), dtype=bool)
        for v in tr.separations.values():
            bad |= np.nan_to_num(v, nan=np.inf) < 0.0
        if bad.any():
            name = f"inside a threat / below ground: {s.path.name}"
            out.append((Mark(name, tr.xyz[bad], "markers", RED, (), size=4.0, template=""), {}))
        for mark in [*decision_marks(s.run), *s.beams]:
            if len(runs) > 1:
                mark = replace(mark, name=f"{mark.name}: {s.path.name}")
            out.append((mark, {}))
    return out


def _intruder_track(th: Any, t_end: float) -> Mark:
    """An intruder's path from its appearance to its disappearance (or the end of the flights;
    an hour when there is none)."""
    end = th.disappears_at or (t_end if t_end > th.appears_at else th.appears_at + 3600.0)
    track = np.asarray(th.position(np.linspace(th.appears_at, end, 200)), dtype=np.float64)
    mark = Mark(f"{th.id} track", track.reshape(-1, 3), "lines", THREAT_COLOUR, (), "dot")
    return replace(mark, width=1.0, template="", group="threats", legend=False)


def _colouring(tr: Any, k: int, color_by: str, scale: bool) -> dict[str, Any]:
    """The 3D flown line's colours: by time, by height above the terrain, or none (by run)."""
    if color_by == "time":
        return {
            "color": tr.t[::k] / 60.0,
            "colorscale": "Viridis",
            "showscale": scale,
            "colorbar": {"title": {"text": "time (min)"}, "len": 0.6, "x": 1.0},
        }
    if color_by == "clearance":
        return {
            "color": tr.agl[::k],
            "colorscale": "RdYlGn",
            "cmin": 0.0,
            "cmax": max(float(np.nanpercentile(tr.agl, 95)), 1.0),
            "showscale": scale,
            "colorbar": {"title": {"text": "above terrain (m)"}, "len": 0.6, "x": 1.0},
        }
    return {}


def _trace(mark: Mark, line3d: dict[str, Any] | None = None) -> Any:
    """A mark as a 3D trace (``line3d`` given: its line's colouring, maybe empty; lines 2.5
    times wider and markers 0.6 times the size, as a 3D scene shows them) or a 2-D one."""
    import plotly.graph_objects as go

    three = line3d is not None
    kw: dict[str, Any] = {
        "x": mark.xyz[:, 0],
        "y": mark.xyz[:, 1],
        "mode": mark.mode,
        "name": mark.name,
    }
    if mark.template:
        kw["hovertemplate"] = mark.template
    else:
        kw["hoverinfo"] = "name"
    if mark.text:
        kw["text"] = list(mark.text)
    if mark.customdata is not None:
        kw["customdata"] = mark.customdata
    if mark.group:
        kw["legendgroup"] = mark.group
    if not mark.legend:
        kw["showlegend"] = False
    if "lines" in mark.mode:
        line = {"color": mark.color, "width": mark.width * (3.0 if three else 1.0)}
        if mark.dash != "solid":
            line["dash"] = mark.dash
        kw["line"] = {**line, **(line3d or {})}
    if "markers" in mark.mode:
        size = mark.size * (0.6 if three else 1.0)
        kw["marker"] = {"color": mark.color, "size": size, "symbol": mark.symbol}
    if three:
        return go.Scatter3d(z=mark.xyz[:, 2], **kw)
    return go.Scatter(**kw)


def _extent(sources: list[Source], grid: Any) -> tuple[float, float, float, float]:
    if grid is not None:
        xmin, ymin, xmax, ymax = grid.bounds
        return float(xmin), float(ymin), float(xmax), float(ymax)
    pts = [np.asarray(s.mission.waypoints)[:, :2] for s in sources]
    pts += [s.track.xyz[:, :2] for s in sources if s.track is not None]
    allp = np.vstack(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = 0.08 * float(max(hi - lo)) + 200.0
    return float(lo[0] - pad), float(lo[1] - pad), float(hi[0] + pad), float(hi[1] + pad)


def _scene_layout(
    fig: Any, sources: list[Source], grid: Any, floor: float, top: float, exaggeration: float
) -> float:
    """The scene's axes and aspect; returns the vertical exaggeration drawn (``exaggeration``,
    or more when the scene would be flatter than :data:`MIN_Z_ASPECT`)."""
    import plotly.graph_objects as go

    xmin, ymin, xmax, ymax = _extent(sources, grid)
    if grid is None:  # flat ground: a plane at 0 m, said in the legend
        fig.add_trace(
            go.Surface(
                x=[xmin, xmax],
                y=[ymin, ymax],
                z=[[0.0, 0.0], [0.0, 0.0]],
                colorscale=[[0, "#d9d2c3"], [1, "#d9d2c3"]],
                showscale=False,
                name="flat ground (the mission names no DEM)",
                showlegend=True,
                hoverinfo="name",
            )
        )
    span = max(xmax - xmin, ymax - ymin)
    zr = max((top - floor) * exaggeration / span, MIN_Z_ASPECT)
    aspect = ((xmax - xmin) / span, (ymax - ymin) / span, zr)
    fig.update_layout(
        scene={
            "xaxis": {"title": {"text": "x east (m)"}, "range": [xmin, xmax]},
            "yaxis": {"title": {"text": "y north (m)"}, "range": [ymin, ymax]},
            "zaxis": {"title": {"text": "altitude (m AMSL)"}, "range": [floor, top]},
            "aspectmode": "manual",
            "aspectratio": dict(zip("xyz", aspect, strict=True)),
            "camera": {"eye": dict(zip("xyz", fitted_eye(aspect), strict=True))},
            "domain": {"x": [0.0, 1.0], "y": [0.1, 1.0]},
        },
        legend=legend_below(-0.04),
        margin={"l": 0, "r": 0, "t": 34, "b": 10},
        height=760,
    )
    fig.update_layout(updatemenus=[*fig.layout.updatemenus, legend_button()])
    return zr * span / max(top - floor, 1e-9)


def fitted_eye(
    aspect: tuple[float, float, float],
    direction: tuple[float, float, float] = (-0.55, -1.0, 0.75),
    fovy: float = math.pi / 4.0,
    screen: float = 1.2,
) -> tuple[float, float, float]:
    """The camera's eye (plotly's scene units: the box spans half its aspect ratio either side
    of the centre) seen from ``direction``, as near as it can be with every corner of the box
    inside plotly's perspective view (``fovy`` high, ``screen`` times as wide: the scene at
    800 px wide, and anything wider), with a 5 % margin."""
    d = np.asarray(direction, dtype=np.float64)
    d /= np.linalg.norm(d)
    half = 0.5 * np.asarray(aspect, dtype=np.float64)
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    forward = -d
    right = np.cross(forward, (0.0, 0.0, 1.0))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    ty, tx = math.tan(fovy / 2.0), math.tan(fovy / 2.0) * screen

    def fits(dist: float) -> bool:
        rel = corners - dist * d
        depth = rel @ forward
        return bool(
            (depth > 0).all()
            and (np.abs(rel @ right) <= tx * depth).all()
            and (np.abs(rel @ up) <= ty * depth).all()
        )

    lo, hi = 0.0, 100.0
    for _ in range(60):
        mid = (lo + hi) / 2.0
        lo, hi = (lo, mid) if fits(mid) else (mid, hi)
    eye = 1.05 * hi * d
    return float(eye[0]), float(eye[1]), float(eye[2])


# -- the 2-D map ----------------------------------------------------------------------------------


def _image_uri(grid: Any) -> tuple[str, int]:
    from matplotlib.image import imsave

    from terrain.plot import tinted_hillshade

    step = _stride(max(grid.rows, grid.cols), MAX_IMAGE)
    # a large map is shaded from its block means (one pixel a block), never in full
    rgb, _, _ = tinted_hillshade(grid.decimated(step))
    buf = io.BytesIO()
    imsave(buf, rgb, format="png")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii"), step


def _circle(cx: float, cy: float, r: float, n: int = 73) -> tuple[FloatArray, FloatArray]:
    a = np.linspace(0.0, 2.0 * math.pi, n)
    return cx + r * np.cos(a), cy + r * np.sin(a)


def _footprints(th: Any, floor: float) -> list[tuple[FloatArray, FloatArray]]:
    """A threat's outline(s) seen from above: circles of its spheres and cylinders, a body's
    widest section, a prism's footprint."""
    out = []
    for sh in th.shapes(th.appears_at):
        kind = sh.get("kind")
        c = sh["center"]
        if kind == "ellipsoid":
            v, _ = _threat_mesh(sh, floor)
            from scipy.spatial import ConvexHull

            hull = ConvexHull(v[:, :2])
            ring = v[hull.vertices, :2]
            ring = np.vstack([ring, ring[:1]])
            out.append((ring[:, 0], ring[:, 1]))
        elif kind == "prism":
            ring = np.asarray(sh["footprint"], dtype=np.float64)
            ring = np.vstack([ring, ring[:1]])
            out.append((ring[:, 0], ring[:, 1]))
        else:
            out.append(_circle(c[0], c[1], float(sh["radius"])))
    return out


def _joined(parts: list[tuple[FloatArray, FloatArray]]) -> tuple[FloatArray, FloatArray]:
    gap = np.full(1, np.nan)
    xs: list[FloatArray] = []
    ys: list[FloatArray] = []
    for x, y in parts:
        xs += [x, gap]
        ys += [y, gap]
    return np.concatenate(xs[:-1]), np.concatenate(ys[:-1])


def map_figure(sources: list[Source]) -> Any:
    """The 2-D map (module docstring)."""
    import plotly.graph_objects as go

    fig = go.Figure()
    grid = sources[0].grid
    xmin, ymin, xmax, ymax = _extent(sources, grid)
    if grid is not None:
        uri, _ = _image_uri(grid)
        fig.add_layout_image(
            source=uri,
            xref="x",
            yref="y",
            x=xmin,
            y=ymax,
            sizex=xmax - xmin,
            sizey=ymax - ymin,
            sizing="stretch",
            layer="below",
        )
        hatch = map_hatch(grid)
        if hatch is not None:
            fig.add_trace(hatch)
    floor = _floor(sources)
    for k, zone in enumerate(sources[0].mission.danger_zones):
        if zone.kind == "cylinder":
            x, y = _circle(zone.x, zone.y, zone.diameter / 2.0)
        else:
            x, y = _joined([(np.r_[r[:, 0], r[0, 0]], np.r_[r[:, 1], r[0, 1]]) for r in zone.rings])
        fig.add_trace(
            go.Scatter(
                x=x,
                y=y,
                mode="lines",
                fill="toself",
                fillcolor="rgba(214,39,40,0.2)",
                line={"color": ZONE_COLOUR, "width": 1.5},
                name="danger zones" if k == 0 else f"danger zone {zone.id or k}",
                legendgroup="zones",
                showlegend=k == 0,
                hoverinfo="name",
            )
        )
    for n, th in enumerate(_threats(sources)):
        x, y = _joined(_footprints(th, floor))
        group = f"threat:{th.id}"
        fig.add_trace(
            go.Scatter(
                x=x,
                y=y,
                mode="lines",
                line={"color": THREAT_COLOUR, "width": 2, "dash": threat_dash(n)},
                name=f"threat {th.id}",
                legendgroup=group,
                text=[f"{th.id} ({th.kind}), from {th.appears_at / 60.0:.1f} min"] * len(x),
                hovertemplate="%{text}<extra></extra>",
            )
        )
        if th.kind == "intruder":
            t_end = max((float(s.run.times[-1]) for s in sources if s.run is not None), default=0)
            track = _intruder_track(th, t_end)
            fig.add_trace(_trace(replace(track, dash=threat_dash(n), group=group)))
        fig.add_annotation(
            label(  # staggered: the labels of threats side by side do not overlap
                x=float(np.nanmean(x)),
                y=float(np.nanmax(y)),
                text=th.id,
                showarrow=False,
                yanchor="bottom",
                yshift=2 + 26 * (n % 3),
            )
        )
    # each run's flown track (its mark's name, as _layers makes it) with the run's marker symbol
    flown = {f"flown: {s.label}": s for s in sources if s.run is not None}
    for mark, _ in _layers(sources):
        trace = _trace(mark)
        owner = flown.get(mark.name)
        if owner is not None:
            trace.mode = "lines+markers"
            trace.marker = {
                "color": mark.color,
                "size": 9,
                "symbol": _style(sources, owner)[1],
                "maxdisplayed": 12,
                "line": {"color": "white", "width": 1},
            }
        fig.add_trace(trace)
    _add_wind_arrow(fig, sources, (xmin, ymin, xmax, ymax))
    fig.update_layout(
        xaxis={"title": {"text": "x east (m)"}, "range": [xmin, xmax], "constrain": "domain"},
        yaxis={
            "title": {"text": "y north (m)"},
            "range": [ymin, ymax],
            "scaleanchor": "x",
            "scaleratio": 1.0,
            "constrain": "domain",
        },
        plot_bgcolor="#f4f1ea" if grid is None else "white",
        # the hillshade shows through: no grid lines across it
        xaxis_showgrid=grid is None,
        yaxis_showgrid=grid is None,
        margin={"l": 60, "r": 10, "t": 34, "b": 10},
        height=760,
        legend=legend_below(-0.08),
        updatemenus=[legend_button()],
    )
    return fig


def _add_wind_arrow(fig: Any, sources: list[Source], extent: tuple[float, ...]) -> None:
    """The first windy run's mean wind as an arrow the way the air moves, in the map's top-left
    corner, labelled with the wind in words (the picture's arrow, :mod:`replay.record.picture`)."""
    run = next((s.run for s in sources if getattr(s.run, "wind", None) is not None), None)
    if run is None or not len(run.wind):
        return
    wn, we = (float(v) for v in np.mean(run.wind[:, :2], axis=0))
    speed = math.hypot(wn, we)
    if speed < 0.1:
        return
    xmin, ymin, xmax, ymax = extent
    size = (0.04 + 0.06 * min(speed / 20.0, 1.0)) * min(xmax - xmin, ymax - ymin)
    x0, y0 = xmin + 0.08 * (xmax - xmin), ymax - 0.08 * (ymax - ymin)
    fig.add_annotation(
        x=x0 + size * we / speed,
        y=y0 + size * wn / speed,
        ax=x0,
        ay=y0,
        xref="x",
        yref="y",
        axref="x",
        ayref="y",
        showarrow=True,
        arrowhead=2,
        arrowwidth=2.5,
        arrowcolor="#1f3f7f",
        text="",
    )
    fig.add_annotation(
        x=x0,
        y=y0 - 0.04 * (ymax - ymin),
        xref="x",
        yref="y",
        showarrow=False,
        xanchor="left",
        **label(text=f"wind {run.wind_text or f'{speed:.1f} m/s'}"),
    )


# -- the time plots -------------------------------------------------------------------------------


def _below(t: FloatArray, v: FloatArray, top: float) -> tuple[Any, Any]:
    """The samples of ``v`` the plot shows (below 1.2 ``top``, with a neighbour either side:
    the rest is off the plot), NaN between the kept stretches; float32."""
    keep = np.nan_to_num(v, nan=np.inf) <= 1.2 * top
    keep[1:] |= keep[:-1].copy()
    keep[:-1] |= keep[1:].copy()
    idx = np.flatnonzero(keep)
    if not len(idx):
        return np.zeros(0, np.float32), np.zeros(0, np.float32)
    breaks = np.flatnonzero(np.diff(idx) > 1) + 1
    ts = np.insert(t[idx], breaks, np.nan).astype(np.float32)
    vs = np.insert(v[idx], breaks, np.nan).astype(np.float32)
    return ts, vs


def time_figure(sources: list[Source]) -> Any:
    """The time plots (module docstring)."""
    runs = [s for s in sources if s.run is not None]
    windy = any(s.track is not None and s.track.wind is not None for s in runs)
    fig = _time_subplots(runs, windy)
    last = 5 if windy else 4
    grid = sources[0].grid
    threat_ids = [th.id for th in _threats(sources)]
    shown, margin, top, hidden = _separation_scale(runs)
    deepest = 0.0
    above_terrain = len(runs) > 1 and grid is not None  # several runs: their heights above it
    for s in runs:
        style = _style(sources, s)
        _add_flight_plots(fig, style, s, grid, above_terrain)
        if windy:
            _add_wind(fig, style[0], s)
        low = _add_separations(fig, s, style, shown[id(s)], threat_ids, top, last)
        deepest = min(deepest, low)
    drawn = {i for s in runs for i in shown[id(s)]}
    for n, ident in enumerate(threat_ids):  # the threats' line styles, in the legend
        if ident in drawn:
            fig.add_trace(
                _key_trace(f"threat {ident}", threat_dash(n), f"threat:{ident}"), row=last, col=1
            )
    _time_layout(fig, runs, margin, top, hidden, last, deepest, above_terrain)
    return fig


def _key_trace(name: str, dash: str, group: str) -> Any:
    """A legend entry with no data: a line style and what it means."""
    import plotly.graph_objects as go

    return go.Scatter(
        x=[None],
        y=[None],
        mode="lines",
        line={"color": "#444444", "width": 1.5, "dash": dash},
        name=name,
        legendgroup=group,
        hoverinfo="skip",
    )


def _time_subplots(runs: list[Source], windy: bool = False) -> Any:
    """The four rows of plots sharing the time axis, five with the wind's (``windy``: a run
    flew in wind); a note in them when there is no flight."""
    from plotly.subplots import make_subplots

    fig = make_subplots(
        rows=5 if windy else 4,
        cols=1,
        shared_xaxes=True,
        vertical_spacing=0.04,
        row_heights=[0.26, 0.16, 0.16, 0.16, 0.26] if windy else [0.3, 0.2, 0.2, 0.3],
    )
    if not runs:
        fig.add_annotation(
            text="no flight to plot: the sources are missions (replay one to see its flight)",
            xref="paper",
            yref="paper",
            x=0.5,
            y=0.5,
            showarrow=False,
        )
    return fig


def _separation_scale(
    runs: list[Source],
) -> tuple[dict[int, list[str]], float, float, int]:
    """Per run (by ``id``) the threats its separation plot draws, the largest success margin,
    the top of the separation plot and the most threats a run leaves out."""
    # per run the threats that came closest (143 buildings would be a legend, not a plot)
    shown = {
        id(s): nearest_threats(s.track.separations, NEAREST_DRAWN) if s.track is not None else []
        for s in runs
    }
    # the close passes matter: up to four times the largest of the drawn threats' minimum
    closest = max(
        (
            float(np.nanmin(v))
            for s in runs
            if s.track is not None
            for ident, v in s.track.separations.items()
            if ident in shown[id(s)] and np.isfinite(v).any()
        ),
        default=0.0,
    )
    margin = max((float(s.run.margin) for s in runs), default=0.0)
    top = max(4.0 * closest, 2.0 * margin, 10.0)
    hidden = max((len(s.track.separations) - len(shown[id(s)]) for s in runs if s.track), default=0)
    return shown, margin, top, hidden


def _add_flight_plots(
    fig: Any, style: tuple[str, str], s: Source, grid: Any, above_terrain: bool
) -> None:
    """A run's altitude and the terrain below it (``above_terrain``, for several runs: its
    height above the terrain instead, one line a run), airspeed and bank, in its colour with
    its marker."""
    import plotly.graph_objects as go

    tr = s.track
    assert tr is not None
    colour, symbol = style
    k = _stride(len(tr.t), PLOT_POINTS)
    tm = (tr.t[::k] / 60.0).astype(np.float32)
    name = s.path.name
    line = {"color": colour, "width": 1.5}
    marker = {"symbol": symbol, "size": 8, "color": colour, "maxdisplayed": 10}
    top = tr.agl if above_terrain else tr.xyz[:, 2]
    fig.add_trace(
        go.Scatter(
            x=tm,
            y=top[::k].astype(np.float32),
            name=s.label,
            mode="lines+markers",
            line=line,
            marker=marker,
            legendgroup=name,
        ),
        row=1,
        col=1,
    )
    if grid is not None and not above_terrain:
        ground = (tr.xyz[::k, 2] - tr.agl[::k]).astype(np.float32)
        fig.add_trace(
            go.Scatter(
                x=tm,
                y=ground,
                name="terrain below",
                line={"color": "#8c6d46", "width": 1},
                fill="tozeroy",  # the axis starts just below it
                fillcolor="rgba(140,109,70,0.25)",
                legendgroup="terrain",
            ),
            row=1,
            col=1,
        )
    for row, what, values in ((2, "airspeed", tr.airspeed), (3, "bank", np.degrees(tr.bank))):
        fig.add_trace(
            go.Scatter(
                x=tm,
                y=values[::k].astype(np.float32),
                name=f"{name}: {what}",
                mode="lines+markers",
                line=line,
                marker=marker,
                legendgroup=name,
                showlegend=False,
            ),
            row=row,
            col=1,
        )


def _add_wind(fig: Any, colour: str, s: Source) -> None:
    """A windy run's air at each sample (row 4): the horizontal speed (the gusts on the wind)
    and the vertical gust (up positive, dotted)."""
    import plotly.graph_objects as go

    tr = s.track
    if tr is None or tr.wind is None:
        return
    k = _stride(len(tr.t), PLOT_POINTS)
    tm = (tr.t[::k] / 60.0).astype(np.float32)
    w = tr.wind[::k]
    name = s.path.name
    for what, values, dash in (
        ("wind speed", np.hypot(w[:, 0], w[:, 1]), "solid"),
        ("vertical wind (up)", -w[:, 2], "dot"),
    ):
        fig.add_trace(
            go.Scatter(
                x=tm,
                y=values.astype(np.float32),
                name=f"{name}: {what}",
                line={"color": colour, "width": 1, "dash": dash},
                legendgroup=name,
            ),
            row=4,
            col=1,
        )


def _add_separations(
    fig: Any,
    s: Source,
    style: tuple[str, str],
    shown: list[str],
    threat_ids: list[str],
    top: float,
    row: int,
) -> float:
    """A run's separation from each threat it draws, in the run's colour and the threat's line
    style; the samples inside the margin in red, and each violation's deepest point labelled
    with the threat and the depth.  Returns the lowest separation drawn (0 when none is
    below)."""
    import plotly.graph_objects as go

    tr = s.track
    assert tr is not None
    name = s.path.name
    colour, symbol = style
    lowest = 0.0
    for ident in shown:
        v = tr.separations[ident]
        dash = threat_dash(threat_ids.index(ident))
        ts, vs = _below(tr.t / 60.0, v, top)
        fig.add_trace(
            go.Scatter(
                x=ts,
                y=vs,
                name=f"{name}: {ident}",
                mode="lines+markers",
                line={"width": 1.5, "dash": dash, "color": colour},
                marker={"symbol": symbol, "size": 7, "color": colour, "maxdisplayed": 6},
                legendgroup=name,
                showlegend=False,
                hovertemplate=f"{ident}: %{{y:.0f}} m at %{{x:.2f}} min<extra>{name}</extra>",
            ),
            row=row,
            col=1,
        )
        bad = v < s.run.margin
        if not bad.any():
            continue
        fig.add_trace(
            go.Scatter(
                x=tr.t[bad] / 60.0,
                y=v[bad],
                mode="markers",
                marker={"color": RED, "size": 3},
                name=f"{name}: {ident} inside the margin",
                legendgroup=name,
                showlegend=False,
                hoverinfo="skip",
            ),
            row=row,
            col=1,
        )
        for k in violation_lows(v, s.run.margin):  # how deep each violation went
            depth = float(v[k])
            lowest = min(lowest, depth)
            what = f"{-depth:.0f} m inside" if depth < 0 else f"{depth:.0f} m off"
            fig.add_annotation(
                **label(
                    x=float(tr.t[k] / 60.0),
                    y=depth,
                    text=f"{ident}: {what}",
                    showarrow=True,
                    arrowcolor=colour,
                    arrowwidth=1.5,
                    ax=0,
                    ay=-28 if depth < 0 else 28,
                    bordercolor=colour,
                ),
                row=row,
                col=1,
            )
    return lowest


def _time_layout(
    fig: Any,
    runs: list[Source],
    margin: float,
    top: float,
    hidden: int,
    row: int,
    deepest: float = 0.0,
    above_terrain: bool = False,
) -> None:
    """Zero and the margin on the separation plot (``row``, the last), down to the ``deepest``
    violation (inside a threat shaded); the axes' ranges and titles (the wind's row before it
    when there is one; the first row the height above the terrain with ``above_terrain``); the
    size and the legend below the plots."""
    fig.add_hline(y=0.0, line={"color": "black", "width": 1}, row=row, col=1)
    low = min(-0.05 * top, 1.15 * deepest - 0.05 * top)
    if deepest < 0:
        fig.add_hrect(
            y0=low, y1=0.0, fillcolor="rgba(214,39,40,0.08)", line_width=0, row=row, col=1
        )
    if margin:
        fig.add_hline(
            y=margin,
            line={"color": RED, "width": 1, "dash": "dash"},
            label={
                "text": f"margin {margin:g} m",
                "textposition": "end",
                "font": {"color": "#a01818", "size": 11},
            },
            row=row,
            col=1,
        )
    if above_terrain:
        fig.update_yaxes(title_text="above the terrain (m)", row=1, col=1)
        fig.add_hline(y=0.0, line={"color": "#8c6d46", "width": 1.5}, row=1, col=1)
    else:
        if runs:
            lows = [
                float(np.nanmin(s.track.xyz[:, 2] - s.track.agl))
                for s in runs
                if s.track is not None
            ]
            highs = [float(np.nanmax(s.track.xyz[:, 2])) for s in runs if s.track is not None]
            pad = 0.05 * (max(highs) - min(lows)) + 20.0
            fig.update_yaxes(range=[min(lows) - pad, max(highs) + pad], row=1, col=1)
        fig.update_yaxes(title_text="altitude (m AMSL)", row=1, col=1)
    fig.update_yaxes(title_text="airspeed (m/s)", row=2, col=1)
    fig.update_yaxes(title_text="bank (deg)", row=3, col=1)
    if row == 5:
        fig.update_yaxes(title_text="wind (m/s)", row=4, col=1)
    what = f"separation (m), the {NEAREST_DRAWN} nearest" if hidden else "separation (m)"
    fig.update_yaxes(title_text=what, range=[low, top], row=row, col=1)
    fig.update_xaxes(title_text="time (min)", row=row, col=1)
    fig.update_layout(
        height=900 if row == 4 else 1050,
        margin={"l": 70, "r": 10, "t": 34, "b": 10},
        hovermode="x unified",
        legend=legend_below(-0.06),
        updatemenus=[legend_button()],
    )


__all__ = [
    "COLOR_BY",
    "FRAMES",
    "MAX_LINE",
    "MAX_SURFACE",
    "RUN_COLOURS",
    "map_figure",
    "scene_figure",
    "time_figure",
]
