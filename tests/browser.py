"""A real headless browser for tests: Playwright driving Debian's Chromium.

Playwright is only the driver: it never downloads a browser (no `playwright install`). It
launches /usr/bin/chromium (tools/install-test-deps.sh installs it) through
carlaverse.testing.chromium; each launch gets a fresh temporary user-data dir from
Playwright, removed when the browser closes, and each test a fresh context (cookies,
storage) and page.

Use: mark the test (or module) `browser` and ask for the `page` fixture. Tests marked `browser`
skip with the reason when Chromium or Playwright is absent (tests/conftest.py does that).

    pytestmark = pytest.mark.browser

    def test_dashboard(page: Page, screenshot_dir: Path) -> None:
        page.goto(url)
        save_screenshot(page, screenshot_dir, "dashboard")
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from carlaverse.testing.chromium import launch_chromium

if TYPE_CHECKING:
    from playwright.sync_api import Browser, Page

VIEWPORT = {"width": 1280, "height": 800}  # [px]


@pytest.fixture(scope="module")
def chromium() -> Iterator[Browser]:
    """One headless Chromium per test module (launching costs about a second)."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = launch_chromium(playwright)
        try:
            yield browser
        finally:
            browser.close()


@pytest.fixture
def page(chromium: Browser) -> Iterator[Page]:
    """A page in a fresh browser context; its console errors are kept on `page.errors`."""
    context = chromium.new_context(viewport=VIEWPORT)
    tab = context.new_page()
    errors: list[str] = []
    tab.on("console", lambda msg: errors.append(msg.text) if msg.type == "error" else None)
    tab.on("pageerror", lambda exc: errors.append(str(exc)))
    tab.errors = errors  # type: ignore[attr-defined]
    try:
        yield tab
    finally:
        context.close()


@pytest.fixture(scope="session")
def screenshot_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Where browser tests save their screenshots ($CARLAVERSE_SCREENSHOTS to keep them)."""
    chosen = os.environ.get("CARLAVERSE_SCREENSHOTS")
    if chosen:
        Path(chosen).mkdir(parents=True, exist_ok=True)
        return Path(chosen)
    return tmp_path_factory.mktemp("screenshots")


def save_screenshot(page: Page, directory: Path, name: str) -> Path:
    """Save a full-page PNG of `page` as directory/name.png and return its path."""
    path = directory / f"{name}.png"
    page.screenshot(path=str(path), full_page=True)
    return path
