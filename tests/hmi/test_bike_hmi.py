"""The bike node's HMI page shows the simulated trainer's power and cadence, and the grade.

The test reads the node's own loop state (its shared-memory block, as a viewer would) and
checks what the page shows against it."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from carlaverse_nodes.bike.shared_state import STATE
from playwright.sync_api import Browser, Page

from carlaverse.shm import SharedBlock, block_name
from tests.browser import save_screenshot
from tests.hmi.live import Recent, assert_within, node_with_hmi
from tests.support import wait_until

pytestmark = pytest.mark.browser

# The sim trainer's rider: 180 W ± 10 W, the page rounds to 1 W and 1 rpm; a value shown
# may be up to WINDOW_S old on a loaded host (the trainer changes its reading a few times a
# second), so it must be among the values the loop held over that window.
WINDOW_S = 0.8  # [s]
SAMPLES = 8


@pytest.fixture
def loop_state(tmp_path: Path, chromium: Browser) -> Iterator[tuple[str, Recent]]:
    """The bike's HMI URL and a thread recording its loop state every 10 ms."""
    with node_with_hmi(tmp_path, "bike", "bike") as (_, _, url):
        readings, stop = Recent(), threading.Event()
        watcher = threading.Thread(target=_watch, args=(readings, stop), daemon=True)
        watcher.start()
        try:
            yield url, readings
        finally:
            stop.set()
            watcher.join(5)


def _watch(readings: Recent, stop: threading.Event) -> None:
    block: SharedBlock | None = None
    try:
        while not stop.wait(0.01):
            try:
                block = block or SharedBlock(block_name("t", "bike", "state"), STATE)
            except FileNotFoundError:
                continue  # the node makes it when its loop starts
            s = block.read()
            if s["running"]:
                names = ("power_w", "cadence_rpm", "grade_percent", "speed_mps")
                readings.add({name: float(s[name]) for name in names})
    finally:
        if block is not None:
            block.close()


def test_the_bike_page_shows_power_and_cadence_from_the_trainer(
    loop_state: tuple[str, Recent], page: Page, screenshot_dir: Path
) -> None:
    url, readings = loop_state
    page.goto(url + "bike")
    wait_until(lambda: (readings.latest() or {}).get("power_w", 0) > 100, 30, "the rider pedalling")
    page.wait_for_function("window.hmi && hmi.last && hmi.last.power_w > 100", timeout=30000)
    for _ in range(SAMPLES):
        window_from = time.monotonic() - WINDOW_S
        power, cadence, grade = (
            float(page.locator(f'[data-readout="{name}"]').text_content() or "nan")
            for name in ("power", "cadence", "grade")
        )
        assert_within(power, readings.since(window_from, "power_w"), 1.0, "power [W]")
        assert_within(cadence, readings.since(window_from, "cadence_rpm"), 1.0, "cadence [rpm]")
        assert_within(grade, readings.since(window_from, "grade_percent"), 0.1, "grade [%]")
        page.wait_for_timeout(200)
    save_screenshot(page, screenshot_dir, "hmi-bike")
    assert page.errors == []
