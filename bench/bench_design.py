"""How long drag-to-design takes to follow an edit, in headless Chromium, per shipped mechanism.

Each mechanism's ``design.html`` is opened with Playwright on Debian's Chromium; one dimension
(the first length of its blocks) is set ``--edits`` times to values alternating about its
nominal, each a full update (every point at 360 angles per input turn, the metrics, the
drawing and the thread curve), and the page's own measure of each update (``data-update-ms``,
``performance.now()`` around it) is collected. Printed: the median and the largest, ms. The goal
is under 50 ms per update. The machine is shared: run it again before trusting one number.

Run: ``python bench/bench_design.py [--edits N]`` (default 30).
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from playwright.sync_api import sync_playwright  # noqa: E402

from mjlink.analysis import summary  # noqa: E402
from mjlink.model import catalogue, mechanism  # noqa: E402
from mjlink.pages import design as design_page  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--edits", type=int, default=30)
    args = ap.parse_args()
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        raise SystemExit("needs Debian's Chromium: apt-get install chromium")
    with tempfile.TemporaryDirectory() as tmp, sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=exe, args=["--no-sandbox", "--disable-gpu"])
        print(f"{'mechanism':<18} {'parameter':<24} {'median ms':>10} {'largest ms':>11}")
        for name in catalogue.names():
            path = catalogue.path_of(name)
            mech = mechanism.load(path)
            page_file = Path(tmp) / f"{name}.html"
            page_file.write_text(design_page.design_html(mech, path.read_text()))
            page = browser.new_page(viewport={"width": 1280, "height": 800})
            page.goto(page_file.as_uri())
            page.wait_for_selector("body[data-ready=true]")
            param, nominal, _ = next(d for d in summary.dimensions(mech) if d[0].endswith(".length"))
            times = []
            for i in range(args.edits):
                before = int(page.get_attribute("body", "data-updates") or 0)
                value = nominal * (1.0 + (0.002 if i % 2 else -0.002))
                page.fill(f"input[data-param='{param}']", f"{value:.6f}")
                page.wait_for_function(f"Number(document.body.dataset.updates) > {before}")
                times.append(float(page.get_attribute("body", "data-update-ms") or "nan"))
            print(f"{name:<18} {param:<24} {statistics.median(times):>10.1f} {max(times):>11.1f}")
            page.close()
        browser.close()


if __name__ == "__main__":
    main()
