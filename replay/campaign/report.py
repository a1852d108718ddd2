"""``terrapath report STORE -o DIR``: a campaign store as Markdown tables in the papers' layout and
PNG plots, linked from ``DIR/index.md``.

For each campaign (spec name) in the store, and each of its missions:

- a table with one line per row of the study (a threat count, or a threat file) and avoider:
  runs, success rate with its Wilson 95 % interval (ten runs do not make a precise rate: 10/10
  is 72-100 %), path-length ratio (mean +- sd over the successful runs), flight time, time per
  decision, decisions and waypoints added per run, and the runs that raised;
- plots against the row (the number of obstacles, or the file): success rate with the Wilson
  interval as error bars, PLR, time per decision and flight time, one line per avoider.

Every file is written through a temporary name; ``index.md`` last.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from replay.campaign.runner import wilson

PLOTS = (
    ("success", "success rate (Wilson 95 %)"),
    ("plr", "path-length ratio"),
    ("decision_ms", "time per decision (ms)"),
    ("flight_min", "flight time (min)"),
)


def mean_sd(values: Sequence[float | None]) -> tuple[float, float] | None:
    """Mean and sample standard deviation of the finite values (None when there are none)."""
    vals = [v for v in values if v is not None and math.isfinite(v)]
    if not vals:
        return None
    m = sum(vals) / len(vals)
    sd = math.sqrt(sum((v - m) ** 2 for v in vals) / (len(vals) - 1)) if len(vals) > 1 else 0.0
    return m, sd


def line_of(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The figures of one (row, avoider) group of runs."""
    ok = [r for r in rows if r["status"] == "ok"]
    wins = [r for r in ok if r["success"]]
    lo, hi = wilson(len(wins), len(ok))
    met = [r["metrics"] for r in ok]
    return {
        "runs": len(rows),
        "errors": len(rows) - len(ok),
        "successes": len(wins),
        "finished": len(ok),
        "rate": len(wins) / len(ok) if ok else math.nan,
        "ci": (lo, hi),
        "plr": mean_sd([r["metrics"]["plr"] for r in wins]),
        "flight_min": mean_sd(
            [m["flight_time_s"] / 60.0 for m in met if m.get("flight_time_s") is not None]
        ),
        "decision_ms": mean_sd(
            [
                1000.0 * m["decision_time_mean_s"]
                for m in met
                if m.get("decisions") and m.get("decision_time_mean_s") is not None
            ]
        ),
        "decisions": mean_sd([float(m.get("decisions") or 0) for m in met]),
        "added": mean_sd([float(m.get("waypoints_added") or 0) for m in met]),
    }


def _fmt(v: tuple[float, float] | None, digits: int = 2) -> str:
    if v is None:
        return "-"
    return f"{v[0]:.{digits}f} ± {v[1]:.{digits}f}"


def row_order(label: str) -> tuple[int, str]:
    """Rows of a study in order: by their leading count ("40", "40 + 1 hill"), then the rest
    (threat files) by name."""
    head = label.split(" ", 1)[0]
    return (int(head) if head.isdigit() else 10**9, label)


def groups(
    rows: list[dict[str, Any]],
) -> dict[str, dict[str, dict[tuple[str, str], list[dict[str, Any]]]]]:
    """spec name -> mission -> (row, avoider) -> runs."""
    out: dict[str, dict[str, dict[tuple[str, str], list[dict[str, Any]]]]] = {}
    for r in rows:
        out.setdefault(r["spec_name"], {}).setdefault(r["mission"], {}).setdefault(
            (r["row"], r["avoider"]), []
        ).append(r)
    return out


def table_lines(by_line: dict[tuple[str, str], list[dict[str, Any]]]) -> list[str]:
    head = "| row | avoider | runs | success | 95 % CI | PLR | flight (min) | decision (ms) | decisions | waypoints added | errors |"
    out = [head, "|---|---|---:|---:|---|---|---|---|---|---|---:|"]
    for (row, avoider), runs in sorted(
        by_line.items(), key=lambda kv: (row_order(kv[0][0]), kv[0][1])
    ):
        f = line_of(runs)
        lo, hi = f["ci"]
        rate = f"{f['successes']}/{f['finished']}" if f["finished"] else "-"
        out.append(
            f"| {row} | {avoider} | {f['runs']} | {rate} | {100 * lo:.0f}–{100 * hi:.0f} % | "
            f"{_fmt(f['plr'], 3)} | {_fmt(f['flight_min'], 1)} | {_fmt(f['decision_ms'], 2)} | "
            f"{_fmt(f['decisions'], 1)} | {_fmt(f['added'], 1)} | {f['errors']} |"
        )
    return out


def _plot(by_line: dict[tuple[str, str], list[dict[str, Any]]], out: Path, title: str) -> Path:
    """Four panels against the row, one line per avoider."""
    from terrain.plot import new_figure, save_figure

    rows = sorted({row for row, _ in by_line}, key=row_order)
    avoiders = sorted({av for _, av in by_line})
    numeric = all(r.isdigit() for r in rows)
    xs = {r: (int(r) if numeric else i) for i, r in enumerate(rows)}
    fig = new_figure(10.0, 7.5)
    axes = fig.subplots(2, 2).ravel()
    for ax, (key, label) in zip(axes, PLOTS, strict=True):
        for k, av in enumerate(avoiders):
            colour = f"C{k % 10}"  # one colour per avoider in every panel
            pts = [(xs[r], line_of(by_line[(r, av)])) for r in rows if (r, av) in by_line]
            if not pts:
                continue
            x = [p[0] + (0.0 if numeric else 0.08 * (k - (len(avoiders) - 1) / 2)) for p in pts]
            if key == "success":
                y = [100 * p[1]["rate"] for p in pts]
                lo = [100 * (p[1]["rate"] - p[1]["ci"][0]) for p in pts]
                hi = [100 * (p[1]["ci"][1] - p[1]["rate"]) for p in pts]
                ax.errorbar(x, y, yerr=[lo, hi], marker="o", capsize=3, label=av, color=colour)
                ax.set_ylim(-5, 105)
            else:
                vals = [p[1][key] for p in pts]
                xy = [(xi, v) for xi, v in zip(x, vals, strict=True) if v is not None]
                if xy:
                    ax.errorbar(
                        [a for a, _ in xy],
                        [v[0] for _, v in xy],
                        yerr=[v[1] for _, v in xy],
                        marker="o",
                        capsize=3,
                        label=av,
                        color=colour,
                    )
        ax.set_title(label, fontsize=10)
        ax.set_xlabel("obstacles" if numeric else "scenario")
        if not numeric:
            ax.set_xticks(range(len(rows)), rows, rotation=20, fontsize=8)
        elif len(rows) <= 12:
            ax.set_xticks([xs[r] for r in rows])
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(title)
    return save_figure(fig, out)


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "-" for c in text).strip("-") or "campaign"


def write_report(rows: list[dict[str, Any]], folder: str | Path, store_name: str) -> Path:
    """Write the tables, plots and ``index.md`` for ``rows``; returns the index's path."""
    from terrain.atomic import atomic_output, make_folder

    out = make_folder(folder)
    index = [f"# Campaign report: {store_name}", ""]
    total = len(rows)
    index.append(
        f"{total} runs. Success: the flight reached the goal without entering a threat's safety volume or a danger zone, touching the terrain or leaving the map. The 95 % interval is Wilson's. PLR, flight time and decision time: mean ± sd (PLR over the successful runs)."
    )
    index.append("")
    for name, missions in sorted(groups(rows).items()):
        index.append(f"## {name}")
        index.append("")
        versions = sorted(
            {r["version"] for ms in missions.values() for rs in ms.values() for r in rs}
        )
        hashes = sorted(
            {r["spec_hash"][:12] for ms in missions.values() for rs in ms.values() for r in rs}
        )
        index.append(f"spec hash {', '.join(hashes)}; flown by terrapath {', '.join(versions)}")
        index.append("")
        for mission, by_line in sorted(missions.items()):
            stem = f"{_slug(name)}--{_slug(mission)}"
            table = table_lines(by_line)
            with atomic_output(out / f"{stem}.md") as tmp:
                tmp.write_text(
                    f"# {name}: {mission}\n\n" + "\n".join(table) + "\n", encoding="utf-8"
                )
            png = _plot(by_line, out / f"{stem}.png", f"{name}: {mission}")
            index += [
                f"### {mission}",
                "",
                *table,
                "",
                f"![{name}: {mission}]({png.name})",
                "",
                f"[table alone]({stem}.md)",
                "",
            ]
    path = out / "index.md"
    with atomic_output(path) as tmp:
        tmp.write_text("\n".join(index) + "\n", encoding="utf-8")
    return path


__all__ = ["line_of", "mean_sd", "row_order", "table_lines", "write_report"]
