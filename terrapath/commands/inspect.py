"""`terrapath inspect`: what a recorded run contains, and its metrics."""

from __future__ import annotations

import json
from datetime import UTC, datetime
from typing import Any

import click

from terrain.docfile import parse_yaml
from terrain.errors import DataFileError
from terrapath.runtext import duration, metrics_rows, plural, report_lines, table


@click.command("inspect")
@click.argument("run", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Machine-readable JSON output.")
@click.option(
    "--png",
    "png",
    type=click.Path(dir_okay=False),
    default=None,
    help="Also draw the run's picture to this PNG (as terrapath replay writes beside the MCAP).",
)
@click.option(
    "--at",
    "at",
    type=float,
    multiple=True,
    metavar="SECONDS",
    help="Where the aircraft was at this time of the flight (repeatable): map metres, lon/lat, "
    "altitude and height above the terrain, as a threat file's entry -- to place a threat on "
    "its path.",
)
def inspect_cmd(run: str, as_json: bool, png: str | None, at: tuple[float, ...]) -> None:
    """Summarise a replay MCAP: what was flown (mission, terrain, vehicle, seed, avoidance), the
    metrics (success, PLR, terrain clearance, minimum separation to each threat), topics and
    attachments; --json adds the final waypoint list; --png draws the run; --at T says where the
    aircraft was at T seconds."""
    from replay.record.reader import load_run, summary

    if at:
        _where(run, at)
        return

    if png is not None:
        if not png.lower().endswith(".png"):
            raise click.BadParameter(
                f"the picture must end in .png; got {png!r}", param_hint="--png"
            )
        from replay.record.picture import run_picture

        run_picture(run, png)
        click.echo(f"wrote {png}", err=True)

    record = load_run(run, with_states=False)
    s = summary(record)
    final = record.waypoints[-1].waypoints.tolist() if record.waypoints else []
    s["final_waypoints"] = final
    s["min_separation"] = s.get("metrics", {}).get("min_separation", {})
    if as_json:
        click.echo(json.dumps(s, indent=2, default=str))
        return
    mission = _mission(record.attachments.get("mission.yaml"))
    rate = s.get("log_rate_hz")
    rows = [
        ("run", s["path"]),
        ("recorded", f"{_utc(s['started_utc'])} by terrapath {s['software_version'] or '?'}"),
        ("command", s["command"] or "n/a"),
        ("mission", _describe_mission(mission, s, "mission.yaml" in record.attachments)),
        ("terrain", _describe_terrain(mission, s)),
        ("vehicle", s["vehicle"] or (mission or {}).get("vehicle") or "n/a"),
        ("seed", "n/a" if s["seed"] is None else str(s["seed"])),
        ("avoidance", s["avoid"] or "n/a"),
        (
            "simulated",
            f"{duration(s['duration_s'])}, {plural(s['samples'], 'state sample')}"
            + (f" at {rate:g} Hz" if rate else ""),
        ),
    ]
    m = s.get("metrics") or {}
    rows += metrics_rows(m) if m else [("metrics", "none recorded (the run did not finish)")]
    changes = s["waypoint_changes"]
    rows.append(
        (
            "waypoints",
            f"{len(final)} in the final list, {plural(changes, 'change')} during the flight",
        )
    )
    rows.append(("radar", plural(s["radar_scans"], "scan")))
    n_log = s["topics"].get("/log", 0)
    rows.append(
        (
            "log",
            f"{plural(n_log, 'entry', 'entries')}"
            + (f", {s['warnings']} of them warnings or errors" if n_log else ""),
        )
    )
    for line in report_lines(rows, m):
        click.echo(line)
    click.echo("")
    for line in table(
        [
            ("topics", ", ".join(f"{k} ({n})" for k, n in sorted(s["topics"].items()))),
            (
                "attachments",
                ", ".join(f"{a['name']} ({_size(a['bytes'])})" for a in s["attachments"]) or "none",
            ),
        ]
    ):
        click.echo(line)


def _where(run: str, times: tuple[float, ...]) -> None:
    """One line per time: the aircraft's position then (interpolated between the recorded
    states), and the same as a threat entry (``{kind: static, ...}``: give it a radius)."""
    import numpy as np

    from replay.record.picture import recorded_view
    from terrain.errors import InputError

    view = recorded_view(run, max_states=None)
    t0, t1 = float(view.times[0]), float(view.times[-1])
    for t in times:
        if not t0 <= t <= t1:
            raise InputError(f"{run}: --at {t:g}: the flight lasts from t = {t0:.1f} to {t1:.1f} s")
    for t in times:
        x, y, z = (float(np.interp(t, view.times, view.positions[:, i])) for i in range(3))
        text = f"t = {t:.1f} s: x {x:.1f}, y {y:.1f} m"
        entry = f"position: [{x:.1f}, {y:.1f}, {z:.0f}]"
        grid = view.grid
        if grid is not None and grid.crs is not None:
            lon, lat = grid.to_lonlat([x], [y])
            text += f" (lon {float(lon[0]):.5f}, lat {float(lat[0]):.5f})"
            entry = f"lon: {float(lon[0]):.5f}, lat: {float(lat[0]):.5f}, alt: {z:.0f}"
        text += f", {z:,.0f} m AMSL"
        if grid is not None:
            ground = float(grid.height_at([x], [y])[0])
            text += f", {z - ground:,.0f} m above the terrain"
        click.echo(text)
        click.echo(f"  as a threat: {{id: at-{t:g}s, kind: static, {entry}, radius: ...}}")


def _mission(text: bytes | None) -> dict[str, Any] | None:
    """The run's mission attachment, for display only (None when absent or unreadable)."""
    if text is None:
        return None
    try:
        doc = parse_yaml(text.decode("utf-8"), "mission.yaml")
    except (DataFileError, UnicodeDecodeError):
        return None
    return doc if isinstance(doc, dict) else None


def _describe_mission(mission: dict[str, Any] | None, s: dict[str, Any], attached: bool) -> str:
    if mission is None:
        return (
            "n/a (its mission.yaml attachment is not a mission)"
            if attached
            else ("n/a (no mission.yaml attachment)")
        )
    wps = mission.get("waypoints")
    text = str(mission.get("name", "?"))
    if isinstance(wps, list):
        text += f", {plural(len(wps), 'waypoint')}"
    if s.get("source"):
        text += f", from {s['source']}"
    return text


def _describe_terrain(mission: dict[str, Any] | None, s: dict[str, Any]) -> str:
    if s.get("dem"):
        return ", ".join(s["dem"])
    terrain = (mission or {}).get("terrain")
    if isinstance(terrain, dict) and terrain.get("dem"):
        return ", ".join(map(str, terrain["dem"]))
    return "none (flat ground at 0 m)" if mission is not None else "n/a"


def _size(n: int) -> str:
    return (
        f"{n} B" if n < 1024 else f"{n / 1024:.1f} kB" if n < 1024**2 else f"{n / 1024**2:.1f} MB"
    )


def _utc(text: str) -> str:
    """``2026-11-23 20:18:13 UTC`` from the recorder's ISO time stamp."""
    try:
        t = datetime.fromisoformat(text).astimezone(UTC)
    except (TypeError, ValueError):
        return text or "n/a"
    return t.strftime("%Y-%m-%d %H:%M:%S UTC")
