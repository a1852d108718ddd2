"""Open a page in headless Chromium (the system's ``chromium``, driven by playwright): collect its
JavaScript errors and take screenshots.  Used by the tests of ``terrapath view``."""

from __future__ import annotations

import shutil
from pathlib import Path

CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome")
# root in a container has no user namespace for Chromium's sandbox; WebGL runs on SwiftShader
ARGS = ["--no-sandbox", "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"]


def chromium() -> str | None:
    for name in CHROMIUM_NAMES:
        found = shutil.which(name)
        if found:
            return found
    return None


def render(
    page_path: Path, tabs: dict[str, Path], width: int = 1400, height: int = 1000
) -> tuple[list[str], float]:
    """Open ``page_path``; for each tab key -> screenshot path, click the tab and screenshot it.
    Returns the page's JavaScript errors and requests beyond the file itself, and the seconds
    until the first tab's plot was drawn."""
    import time

    from playwright.sync_api import sync_playwright

    exe = chromium()
    assert exe is not None, "no chromium on PATH"
    errors: list[str] = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=ARGS)
        try:
            page = browser.new_page(viewport={"width": width, "height": height})
            page.on("pageerror", lambda e: errors.append(f"page error: {e}"))
            page.on(  # a self-contained page asks for nothing beyond itself
                "request",
                lambda r: (
                    None
                    if r.url.startswith(("file:", "data:", "blob:"))
                    else errors.append(f"request to {r.url}")
                ),
            )
            page.on(
                "console",
                lambda m: (
                    errors.append(f"console {m.type}: {m.text}") if m.type == "error" else None
                ),
            )
            t0 = time.perf_counter()
            page.goto(page_path.resolve().as_uri())
            drawn = "(key) => document.getElementById('plot-' + key)._fullLayout !== undefined"
            page.wait_for_function(drawn, arg="scene", timeout=60_000)
            loaded = time.perf_counter() - t0
            for tab, shot in tabs.items():
                page.click(f"nav button[data-tab='{tab}']")
                page.wait_for_function(drawn, arg=tab, timeout=60_000)
                page.wait_for_timeout(1000)
                page.screenshot(path=str(shot))
        finally:
            browser.close()
    return errors, loaded
