"""``terrapath view`` on the 8-hour seed 000 flight (issue 16: a file <= 25 MB that opens in
under 5 s): the Table 4 mission and threats flown with PSO-CA (and, with ``--compare``, also
without avoidance, both in one view), recorded; then the view written, its size, and the time
headless Chromium takes to draw the page's first tab (the 3D scene) and each other tab.

Headless Chromium draws WebGL on the CPU (SwiftShader): a desktop browser with a GPU draws the
3D scene faster, so the figure here is an upper bound.

Run: ``.venv/bin/python benchmarks/bench_view.py [--compare] [--keep DIR]``
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks._record import record  # noqa: E402

MISSION = ROOT / "data" / "missions" / "seed000-table4.yaml"
THREATS = ROOT / "data" / "threats" / "seed000-table4.yaml"


def _cli(args: list[str], ok: Sequence[int] = (0,)) -> float:
    from terrapath.cli import main

    t = time.perf_counter()
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(args)
    if rc not in ok:
        raise SystemExit(f"terrapath {args[0]} failed ({rc}): {err.getvalue()}")
    return time.perf_counter() - t


def _draw_times(page: Path, shots: Path) -> tuple[float, dict[str, float], list[str]]:
    """Seconds to the first tab drawn, then to each other tab; JavaScript errors."""
    from playwright.sync_api import sync_playwright

    from tests.browser import ARGS, chromium

    exe = chromium()
    if exe is None:
        raise SystemExit("no chromium on PATH (Debian: apt-get install chromium)")
    errors: list[str] = []
    tabs: dict[str, float] = {}
    drawn = "(key) => document.getElementById('plot-' + key)._fullLayout !== undefined"
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=ARGS)
        page_ = browser.new_page(viewport={"width": 1400, "height": 1000})
        page_.on("pageerror", lambda e: errors.append(str(e)))
        t = time.perf_counter()
        page_.goto(page.resolve().as_uri())
        page_.wait_for_function(drawn, arg="scene", timeout=120_000)
        first = time.perf_counter() - t
        page_.screenshot(path=str(shots / "scene.png"))
        for tab in ("map", "plots"):
            t = time.perf_counter()
            page_.click(f"nav button[data-tab='{tab}']")
            page_.wait_for_function(drawn, arg=tab, timeout=120_000)
            tabs[tab] = time.perf_counter() - t
            page_.wait_for_timeout(500)
            page_.screenshot(path=str(shots / f"{tab}.png"))
        again = browser.new_page(viewport={"width": 1400, "height": 1000})
        t = time.perf_counter()
        again.goto(page.resolve().as_uri())
        again.wait_for_function(drawn, arg="scene", timeout=120_000)
        tabs["again"] = time.perf_counter() - t
        plan = browser.new_page(viewport={"width": 1400, "height": 1000})
        t = time.perf_counter()
        plan.goto(page.resolve().as_uri() + "#map")
        plan.wait_for_function(drawn, arg="map", timeout=120_000)
        tabs["open on #map"] = time.perf_counter() - t
        bare = browser.new_page(viewport={"width": 1400, "height": 1000})
        base = shots / "plotly-only.html"
        import plotly.offline

        base.write_text(
            "<html><head><meta charset='utf-8'><script>"
            + plotly.offline.get_plotlyjs()
            + "</script></head><body><div id='plot-scene' style='height:760px'></div><script>"
            "Plotly.newPlot('plot-scene', [{type: 'scatter3d', x: [0, 1], y: [0, 1], z: [0, 1]}])"
            "</script></body></html>"
        )
        t = time.perf_counter()
        bare.goto(base.resolve().as_uri())
        bare.wait_for_function(drawn, arg="scene", timeout=120_000)
        tabs["plotly-only"] = time.perf_counter() - t
        browser.close()
    return first, tabs, errors


def main(argv: Sequence[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--compare", action="store_true", help="also fly it without avoidance")
    ap.add_argument("--keep", type=Path, default=None, help="keep the runs, view and screenshots")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        work = args.keep or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        base = [str(MISSION), "--threats", str(THREATS), "--seed", "0", "--no-picture"]
        runs = [work / "pso-ca.mcap"]
        fly = _cli(["replay", *base, "--avoid", "pso-ca", "-o", str(runs[0])])
        if args.compare:
            runs.append(work / "none.mcap")
            _cli(["replay", *base, "--avoid", "none", "-o", str(runs[1])], ok=(0, 3))
        page = work / "view.html"
        t_write = _cli(["view", *map(str, runs), "-o", str(page)])
        size = page.stat().st_size / 1e6
        first, tabs, errors = _draw_times(page, work)
        label = "PSO-CA and no avoidance" if args.compare else "PSO-CA"
        record(
            f"view: the seed 000 Table 4 flight (8 h), {label}",
            [
                ("replay with PSO-CA (s)", f"{fly:.1f}", ""),
                ("terrapath view, write (s)", f"{t_write:.1f}", ""),
                ("HTML size (MB)", f"{size:.1f}", "<= 25"),
                (
                    "headless Chromium just started: open to 3D scene drawn (s)",
                    f"{first:.1f}",
                    "< 5",
                ),
                ("the browser running: open to 3D scene drawn (s)", f"{tabs['again']:.1f}", "< 5"),
                ("then the 2-D map tab drawn (s)", f"{tabs['map']:.1f}", ""),
                ("then the time plots tab drawn (s)", f"{tabs['plots']:.1f}", ""),
                ("open view.html#map to the map drawn (s)", f"{tabs['open on #map']:.1f}", "< 5"),
                (
                    "reference: a plotly.js-only page with a 2-point 3D plot (s)",
                    f"{tabs['plotly-only']:.1f}",
                    "",
                ),
                ("JavaScript errors", str(len(errors)), "0"),
            ],
            notes="Chromium draws WebGL on the CPU (SwiftShader); "
            + ("" if args.keep is None else f"screenshots in {work}"),
        )


if __name__ == "__main__":
    main()
