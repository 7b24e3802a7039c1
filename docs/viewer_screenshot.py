"""Make docs/viewer.png, the README's picture of the plan viewer (``coplan view``).

The default problem solved by the optimal planner beside the course's heuristic plan, in the
viewer's compare mode, captured by headless Chromium (Debian package) through Playwright and
stored as a palette PNG. Run from the repository root: ``python docs/viewer_screenshot.py``.
"""

from __future__ import annotations

import io
import sys
import tempfile
from pathlib import Path

from PIL import Image
from playwright.sync_api import sync_playwright

import coplan
from coplan.viz.viewer import write_html

ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run"]


def main(out: Path = Path(__file__).with_name("viewer.png"), t: float = 7.9) -> Path:
    problem = coplan.load_problem(coplan.default_problem_path())
    best, base = coplan.solve(problem), coplan.solve(problem, planner="heuristic")
    with tempfile.TemporaryDirectory() as tmp:
        page_file = write_html(Path(tmp) / "plan.html", problem, best.plan, base.plan, verification=best.verification,
                               compare_verification=base.verification)
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
            page = browser.new_page(viewport={"width": 1180, "height": 860})
            page.goto(f"{page_file.as_uri()}#t={t}")
            page.wait_for_function("window.coplanViewer !== undefined")
            page.locator("svg.timeline .seg").first.hover()  # a tooltip in the picture
            png = page.screenshot(full_page=True)
            browser.close()
    img = Image.open(io.BytesIO(png)).convert("RGB").quantize(colors=256, dither=Image.Dither.NONE)
    img.save(out, optimize=True)
    print(f"wrote {out} ({out.stat().st_size / 1000:.0f} kB, {img.width}x{img.height})")
    return out


if __name__ == "__main__":
    main(*(Path(a) for a in sys.argv[1:2]))
