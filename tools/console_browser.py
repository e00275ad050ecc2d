"""Headless Chromium for the operator console: the browser tests and the README screenshot.

Uses Debian's ``chromium`` package driven by Playwright (``executable_path``):
Playwright's own browser downloads are not needed. :func:`browser_problem`
says why no browser can be used here (the tests skip with that reason).
"""

from __future__ import annotations

import contextlib
import shutil
from collections.abc import Iterator
from typing import Any

#: Chromium's names on the PATH, in the order they are tried.
CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome")
#: Software WebGL: no GPU is needed.
CHROMIUM_ARGS = ("--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader")
#: Seconds the page may take to load and connect.
LOAD_TIMEOUT = 60.0


def chromium_path() -> str | None:
    """The Chromium executable on the PATH, or None."""
    for name in CHROMIUM_NAMES:
        path = shutil.which(name)
        if path:
            return path
    return None


def browser_problem() -> str | None:
    """Why no browser test can run here, or None when one can."""
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "playwright is not installed (pip install -e '.[test]')"
    if chromium_path() is None:
        return "no Chromium on the PATH (apt-get install -y chromium)"
    return None


@contextlib.contextmanager
def chromium() -> Iterator[Any]:
    """A headless Chromium (a Playwright ``Browser``), closed on exit."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium_path(), args=list(CHROMIUM_ARGS))
        try:
            yield browser
        finally:
            browser.close()


def open_console(
    browser: Any, url: str, width: int = 1280, height: int = 800, timeout: float = LOAD_TIMEOUT
) -> Any:
    """A new page of ``browser`` that has opened ``url`` and shows the console's instruments.

    The page's ``errors`` attribute lists its console errors and uncaught exceptions.

    Raises:
        playwright.sync_api.TimeoutError: When the instruments do not show within ``timeout`` s.
    """
    page = browser.new_page(viewport={"width": width, "height": height})
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.errors = errors
    page.goto(url)
    page.wait_for_selector("#lpik-p", timeout=timeout * 1000)
    return page


@contextlib.contextmanager
def console_page(url: str, width: int = 1280, height: int = 800) -> Iterator[Any]:
    """A page of a fresh headless Chromium showing the console at ``url``."""
    with chromium() as browser:
        yield open_console(browser, url, width, height)


def dismiss_notifications(page: Any) -> None:
    """Close the viewer's notifications (e.g. that WebGL runs in software)."""
    page.evaluate(
        """() => {
        for (const el of document.querySelectorAll('[role="alert"], .mantine-Notification-root')) {
            const close = el.querySelector('button');
            if (close) close.click();
        }
    }"""
    )
