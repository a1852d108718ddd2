"""`terrapath inspect`: what a recorded run contains, and its metrics."""

from __future__ import annotations

import json

import click


@click.command("inspect")
@click.argument("run", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Machine-readable JSON output.")
def inspect_cmd(run: str, as_json: bool) -> None:
    """Summarise a replay MCAP: duration, seed, topics, metrics, the final waypoint list."""
    from replay.reader import load_run, summary

    record = load_run(run, with_states=False)
    s = summary(record)
    final = record.waypoints[-1].waypoints.tolist() if record.waypoints else []
    s["final_waypoints"] = final
    s["min_separation"] = s.get("metrics", {}).get("min_separation", {})
    if as_json:
        click.echo(json.dumps(s, indent=2, default=str))
        return
    m = s.get("metrics", {})
    click.echo(f"run            {s['path']}")
    click.echo(f"duration       {s['duration_s']:.1f} s simulated, {s['samples']} state samples")
    click.echo(
        f"seed           {s['seed']}   avoid {s['avoid']}   terrapath {s['software_version']}"
    )
    click.echo(f"success        {m.get('success')}   ({m.get('end_reason')})")
    if m:
        click.echo(
            f"flight time    {m['flight_time_s'] / 60:.1f} min, flown {m['flown_length_m'] / 1000:.2f} km, PLR {m['plr']:.4f}"
        )
    for tid, sep in s["min_separation"].items():
        click.echo(f"  {tid:<12} min separation {sep['value']:.1f} m at t={sep['t']:.0f} s")
    for v in m.get("violations", []):
        click.echo(
            f"  violation: {v['threat']} from t={v['t_enter']:.0f} s to {v['t_exit'] if v['t_exit'] is not None else 'end'} (min {v['min_separation']:.0f} m)"
        )
    click.echo(f"waypoints      {len(final)} in the final list, {s['waypoint_changes']} changes")
    click.echo("topics         " + ", ".join(f"{k} ({n})" for k, n in sorted(s["topics"].items())))
    click.echo("attachments    " + (", ".join(a["name"] for a in s["attachments"]) or "none"))
