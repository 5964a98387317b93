"""Benchmark: the offline HTML viewer (``doodle view``) — its size, the time to write it, and, in headless
Chromium when Playwright is installed, the time to open it and to draw a new view while dragging.

Target (issue 40): a Lego fit's page ≤ 3 MB, opening without network or console errors.
Run: ``python benchmarks/bench_viewer.py STROKES [STROKES ...]`` (default: a synthetic stroke set).
"""

from __future__ import annotations

import shutil
import sys
import tempfile
import time
from pathlib import Path

from doodle.exporters.viewer import ViewerOptions, write_viewer
from doodle.strokes import read_strokes


def browser_figures(page: Path) -> str:
    """Seconds to open the page and milliseconds per new view while dragging, in headless Chromium."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        return "browser: playwright not installed"
    exe = next((p for p in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if p), None)
    if exe is None:
        return "browser: no chromium on the PATH"
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        tab = browser.new_page(viewport={"width": 900, "height": 800})
        errors: list[str] = []
        tab.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        t0 = time.perf_counter()
        tab.goto(page.as_uri())
        tab.wait_for_selector('body[data-ready="1"]', timeout=60_000)
        opened = time.perf_counter() - t0
        # 36 steps of one view each (5° at the default grid), each drawn before the next
        t0 = time.perf_counter()
        for _ in range(36):
            tab.keyboard.press("ArrowRight")
        tab.evaluate("document.body.dataset.view")
        per_view = (time.perf_counter() - t0) / 36 * 1000
        tab.select_option("#style", "pencil")
        t0 = time.perf_counter()
        for _ in range(12):
            tab.keyboard.press("ArrowRight")
        tab.evaluate("document.body.dataset.view")
        pencil = (time.perf_counter() - t0) / 12 * 1000
        browser.close()
    return (f"browser: opens in {opened:.2f} s, {per_view:.0f} ms a view (ink), {pencil:.0f} ms (pencil), "
            f"console errors {len(errors)}")


def main() -> None:
    files = sys.argv[1:]
    if not files:
        sys.path.insert(0, str(Path(__file__).parent))
        from bench_export import synthetic

        from doodle.strokes import write_strokes

        tmp = Path(tempfile.mkdtemp()) / "synthetic.doodle"
        write_strokes(tmp, synthetic())
        files = [str(tmp)]
    for name in files:
        strokes = read_strokes(name)
        opt = ViewerOptions()
        with tempfile.TemporaryDirectory() as tmp:
            page = Path(tmp) / "sketch.html"
            t0 = time.perf_counter()
            write_viewer(strokes, page, opt, source=name)
            seconds = time.perf_counter() - t0
            views = opt.azimuths * len(opt.elevations)
            print(f"{Path(name).name}: {views} views in {seconds:.1f} s, {page.stat().st_size / 1e6:.2f} MB; "
                  + browser_figures(page))


if __name__ == "__main__":
    main()
