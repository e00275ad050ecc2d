"""The operator console in a real browser: headless Chromium driven by Playwright.

Skipped, with the reason, where Playwright or Chromium is missing (``.ci/run``
installs Chromium first). The page must load without console errors, render
the scene, follow a target moved through the server, show the controller's
``p`` and binding limit, and connect only with the access token when it has one.
"""

from __future__ import annotations

import io
import sys
import time
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

from console_browser import browser_problem, chromium, open_console  # noqa: E402

PROBLEM = browser_problem()
pytestmark = pytest.mark.skipif(PROBLEM is not None, reason=f"no browser test: {PROBLEM}")


@pytest.fixture(scope="module")
def console():
    from lpik.console import console_robot
    from lpik.console.app import Console

    with Console(console_robot("planar"), port=0) as running:
        yield running


def _shown(page) -> tuple[str, str]:
    return page.inner_text("#lpik-p"), page.inner_text("#lpik-binding")


def test_the_page_renders_follows_the_target_and_shows_the_controllers_p(console) -> None:
    from PIL import Image

    with chromium() as browser:
        page = open_console(browser, console.url)
        picture = np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("L"), float)
        assert picture.std() > 10, "the page looks blank"
        q_before = console.loop.snapshot().q.copy()
        console.loop.change(v_max=2.0)
        console.loop.set_target([3.232e3, 0.866e3, 0.0])  # far outside the 4 m reach
        deadline = time.time() + 30
        while time.time() < deadline and console.loop.snapshot().p > 0.5:
            time.sleep(0.1)
        page.get_by_role("button", name="Pause / resume").click()  # a control of the page
        deadline = time.time() + 10
        while time.time() < deadline and not console.loop.snapshot().paused:
            time.sleep(0.1)
        snap = console.loop.snapshot()
        assert snap.paused
        assert np.abs(snap.q - q_before).max() > 0.05, "the robot did not move"
        assert snap.p < 0.5 and snap.binding is not None
        want = (f"{snap.p:.3f}", str(snap.binding))
        deadline = time.time() + 10
        while time.time() < deadline and _shown(page) != want:
            time.sleep(0.1)
        assert _shown(page) == want
        assert page.errors == []
        assert console.view.frame_rate > 20  # 30 Hz, less what a loaded machine takes
        console.loop.reset()


def test_a_page_without_the_token_gets_nothing() -> None:
    from playwright.sync_api import TimeoutError as PageTimeout

    from lpik.console import console_robot
    from lpik.console.app import Console

    with Console(console_robot("planar"), port=0, token="s3cret") as console, chromium() as browser:
        assert open_console(browser, console.url).inner_text("#lpik-p")  # the printed URL
        with pytest.raises(PageTimeout):
            open_console(browser, f"http://127.0.0.1:{console.port}/", timeout=3.0)
