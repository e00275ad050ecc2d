"""Regenerate the README's screenshot of the operator console (docs/console.png).

Starts the console on the Panda in the bundled shelf scene, drives the target
into the shelf so that a limit binds, and photographs the page with the same
headless Chromium as the browser tests (tools/console_browser.py)::

    .venv/bin/python tools/console_screenshot.py [--out docs/console.png]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

from console_browser import browser_problem, console_page, dismiss_notifications  # noqa: E402

from lpik.console import console_robot  # noqa: E402
from lpik.console.app import Console  # noqa: E402
from lpik.robots.registry import urdf_path  # noqa: E402, F401


def main() -> int:
    """Take the screenshot; 1 when no browser can be used."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "console.png"))
    args = parser.parse_args()
    problem = browser_problem()
    if problem:
        print(f"console_screenshot: {problem}", file=sys.stderr)
        return 1
    scene = ROOT / "src" / "lpik" / "data" / "scenes" / "panda-shelf.json"
    with Console(console_robot("panda", scene), port=0) as console:
        with console_page(console.url) as page:
            target = console.loop.snapshot().target.copy()
            target[:3, 3] = [0.62, 0.0, 0.52]  # into the shelf, between its boards
            console.loop.set_target(target)
            deadline = time.time() + 20
            while time.time() < deadline and console.loop.snapshot().p > 0.5:
                time.sleep(0.2)
            time.sleep(1.0)
            dismiss_notifications(page)
            time.sleep(0.5)
            page.screenshot(path=args.out)
    print(f"console_screenshot: wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    np.set_printoptions(precision=3)
    sys.exit(main())
