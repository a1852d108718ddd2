"""Open a page in headless Chromium (the system's ``chromium``, driven by playwright): collect its
JavaScript errors and take screenshots.  Used by the tests of ``terrapath view``."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome")
# root in a container has no user namespace for Chromium's sandbox; WebGL runs on SwiftShader
ARGS = ["--no-sandbox", "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"]


# a tab's plot drawn with its frames (the page sets data-ready), then two animation frames: what
# the drawing queued (the 3D scene's WebGL frame) is on the screen
DRAWN = "(key) => document.getElementById('plot-' + key).dataset.ready === '1'"
FRAMES = "() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)))"


def chromium() -> str | None:
    for name in CHROMIUM_NAMES:
        found = shutil.which(name)
        if found:
            return found
    return None


def listen(page: Any, errors: list[str]) -> None:
    """Collect the page's JavaScript errors, console errors and requests beyond the file itself
    (a self-contained page asks for nothing more) into ``errors``."""
    page.on("pageerror", lambda e: errors.append(f"page error: {e}"))
    page.on(
        "request",
        lambda r: (
            None
            if r.url.startswith(("file:", "data:", "blob:"))
            else errors.append(f"request to {r.url}")
        ),
    )
    page.on(
        "console",
        lambda m: errors.append(f"console {m.type}: {m.text}") if m.type == "error" else None,
    )


# what the page shows, read from its DOM: per tab the plot area(s), the legend's box, plotly's
# toolbar and every text label with its colour (boxes in CSS pixels of the viewport)
_MEASURE = """(key) => {
  const div = document.getElementById('plot-' + key);
  const box = (el) => { const r = el.getBoundingClientRect();
    return [r.left, r.top, r.right, r.bottom]; };
  const full = div._fullLayout;
  const areas = [...div.querySelectorAll('.nsewdrag')].map(box);
  const top = div.getBoundingClientRect();
  for (const name of Object.keys(full).filter((k) => /^scene\\d*$/.test(k))) {
    const d = full[name].domain, s = full._size;
    areas.push([top.left + s.l + d.x[0] * s.w, top.top + s.t + (1 - d.y[1]) * s.h,
                top.left + s.l + d.x[1] * s.w, top.top + s.t + (1 - d.y[0]) * s.h]);
  }
  const legends = [...div.querySelectorAll('.legend > .bg')].map(box);
  const modebar = [...div.querySelectorAll('.modebar')].map(box);
  const labels = [];
  const selector = '.annotation-text, .legendtext, .legendtitletext, .textpoint text, '
    + '.updatemenu-item-text, .slider-current-value';
  for (const el of div.querySelectorAll(selector)) {
    const b = box(el);
    if (b[2] - b[0] < 1 || b[3] - b[1] < 1 || !el.textContent.trim()) continue;
    labels.push({text: el.textContent, box: b, color: getComputedStyle(el).fill});
  }
  const ranges = {x: full.xaxis && full.xaxis.range, y: full.yaxis && full.yaxis.range};
  return {areas, legends, modebar, labels, ranges};
}"""


class Browser:
    """One headless Chromium for several pages and viewport sizes (a context manager):
    :meth:`show` opens a page at a size, and for each tab clicks it, screenshots it and measures
    it (:data:`_MEASURE`); the page's JavaScript errors and outside requests are collected."""

    def __enter__(self) -> Browser:
        from playwright.sync_api import sync_playwright

        exe = chromium()
        assert exe is not None, "no chromium on PATH"
        self._pw = sync_playwright().start()
        self._browser = self._pw.chromium.launch(executable_path=exe, args=ARGS)
        return self

    def __exit__(self, *exc: object) -> None:
        self._browser.close()
        self._pw.stop()

    def show(
        self, page_path: Path, shots: dict[str, Path], width: int, height: int
    ) -> tuple[list[str], dict[str, dict[str, Any]], float]:
        """Open ``page_path`` at ``width`` x ``height``; per tab key its screenshot (the whole
        page) and measures; returns the errors, the measures by tab and the seconds until the
        3D scene (the tab the page opens on) was drawn."""
        import time

        errors: list[str] = []
        page = self._browser.new_page(viewport={"width": width, "height": height})
        try:
            listen(page, errors)
            t0 = time.perf_counter()
            page.goto(page_path.resolve().as_uri())
            page.wait_for_function(DRAWN, arg="scene", timeout=60_000)
            seconds = time.perf_counter() - t0
            measures: dict[str, dict[str, Any]] = {}
            for tab, shot in shots.items():
                page.click(f"nav button[data-tab='{tab}']")
                page.wait_for_function(DRAWN, arg=tab, timeout=60_000)
                page.evaluate(FRAMES)
                page.screenshot(path=str(shot), full_page=True)
                measures[tab] = page.evaluate(_MEASURE, tab)
        finally:
            page.close()
        return errors, measures, seconds


def luminance(rgb: Any) -> Any:
    """WCAG 2 relative luminance of sRGB colours in [0, 1] (..., 3)."""
    import numpy as np

    c = np.asarray(rgb, dtype=np.float64)
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return lin @ np.array([0.2126, 0.7152, 0.0722])


def contrast(a: Any, b: Any) -> Any:
    """WCAG 2 contrast ratio of colours ``a`` and ``b`` (broadcast), from 1 to 21."""
    import numpy as np

    la, lb = luminance(a), luminance(b)
    return (np.maximum(la, lb) + 0.05) / (np.minimum(la, lb) + 0.05)


def css_rgb(colour: str) -> tuple[float, float, float]:
    """``rgb(r, g, b)`` / ``rgba(...)`` as computed by the browser, in [0, 1]."""
    import re

    r, g, b = (float(v) / 255.0 for v in re.findall(r"[\d.]+", colour)[:3])
    return r, g, b
