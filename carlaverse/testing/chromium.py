"""Debian's Chromium under Playwright, for the browser tests and the HMI benchmark.

Playwright only drives it: no browser is ever downloaded (no `playwright install`). Each
launch gets a fresh temporary user-data dir from Playwright, removed when the browser closes.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any

CHROMIUM = Path("/usr/bin/chromium")
# Quiet, offline, no sandbox (tests run as root in a container), software rendering.
CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def missing_browser() -> str:
    """Why a browser cannot be launched here, or "" when it can."""
    if not CHROMIUM.exists():
        return f"needs Debian chromium at {CHROMIUM} (run tools/install-test-deps.sh)"
    if importlib.util.find_spec("playwright") is None:
        return "needs the playwright package (pip install -e '.[test]')"
    return ""


def launch_chromium(playwright: Any) -> Any:
    """A headless Chromium Browser from a running `sync_playwright()`."""
    return playwright.chromium.launch(
        executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_FLAGS
    )
