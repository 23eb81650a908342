"""The bike node's HMI page shows the simulated trainer's power and cadence, and the grade.

The test reads the node's own loop state (its shared-memory block, as a viewer would) and
checks what the page shows against it."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml
from carlaverse_nodes.bike.shared_state import STATE
from playwright.sync_api import Browser, Page

from carlaverse.shm import BlockReader, block_name
from tests.browser import save_screenshot
from tests.hmi.live import LoopRecord, assert_within, node_with_hmi
from tests.support import wait_until

pytestmark = pytest.mark.browser

# The sim trainer's rider: 180 W ± 10 W, the page rounds to 1 W and 1 rpm. The frame shown
# carries its loop tick's time `t`; the watcher reads the loop every ~10 ms (more on a loaded
# host), so the value shown must be among those the loop held within ±HALF_WIDTH_S of t.
HALF_WIDTH_S = 0.1  # [s]
SAMPLES = 8


@pytest.fixture
def loop_state(tmp_path: Path, chromium: Browser) -> Iterator[tuple[str, LoopRecord]]:
    """The bike's HMI URL and a thread recording its loop state every 10 ms."""
    with node_with_hmi(tmp_path, "bike", "bike") as (_, _, url):
        readings, stop = LoopRecord(), threading.Event()
        watcher = threading.Thread(target=_watch, args=(readings, stop), daemon=True)
        watcher.start()
        try:
            yield url, readings
        finally:
            stop.set()
            watcher.join(5)


def _watch(readings: LoopRecord, stop: threading.Event) -> None:
    # BlockReader, as a viewer reads: a torn read (the loop writing while we copy, more likely
    # on a loaded host) is counted and skipped. A bare SharedBlock.read raised TornRead here,
    # which ended this thread silently and left the test waiting for a rider who was pedalling.
    reader = BlockReader(block_name("t", "bike", "state"), STATE)
    try:
        while not stop.wait(0.01):
            s = reader.read()
            if s is not None:
                names = ("power_w", "cadence_rpm", "grade_percent", "speed_mps")
                readings.add(float(s["t"]), {name: float(s[name]) for name in names})
    finally:
        reader.close()


def test_the_bike_page_shows_power_and_cadence_from_the_trainer(
    loop_state: tuple[str, LoopRecord], page: Page, screenshot_dir: Path
) -> None:
    url, readings = loop_state
    page.goto(url + "bike")
    wait_until(lambda: (readings.latest() or {}).get("power_w", 0) > 100, 30, "the rider pedalling")
    page.wait_for_function("window.hmi && hmi.drawn && hmi.drawn.power_w > 100", timeout=30000)
    for _ in range(SAMPLES):
        shown, t = page.evaluate("""() => [
            ["power", "cadence", "grade"].map(
                (name) => document.querySelector(`[data-readout="${name}"]`).textContent),
            hmi.drawn.t]""")
        power, cadence, grade = (float(text) for text in shown)
        wait_until(lambda t=t: readings.last_t() > t + HALF_WIDTH_S, 5,
                   "the watcher to read past the frame's time")  # fmt: skip
        near = {name: readings.around(t, HALF_WIDTH_S, name)
                for name in ("power_w", "cadence_rpm", "grade_percent")}  # fmt: skip
        assert_within(power, near["power_w"], 1.0, "power [W]")
        assert_within(cadence, near["cadence_rpm"], 1.0, "cadence [rpm]")
        assert_within(grade, near["grade_percent"], 0.1, "grade [%]")
        page.wait_for_timeout(200)
    save_screenshot(page, screenshot_dir, "hmi-bike")
    assert page.errors == []


def test_the_bike_page_says_when_the_trainer_cannot_render_the_climb(
    tmp_path: Path, page: Page, screenshot_dir: Path
) -> None:
    """A 12 % road: m·g·sin(atan 0.12) = 105 N of slope alone, where the simulated trainer's
    brake gives at most F_0 + F_max·(1 − e^(−v/4)) + k·v² ≈ 64 N at the ~2.8 m/s the 180 W
    rider then rides. The page names the shortfall; the node's summary counts its seconds."""
    config = tmp_path / "steep.yaml"
    config.write_text(yaml.safe_dump({"road": {"grade_percent": 12.0}}))
    with node_with_hmi(tmp_path, "bike", "bike", "--config", str(config)) as (_, node, url):
        page.goto(url + "bike")
        page.wait_for_function(
            """() => (document.querySelector('[data-readout="warnings"]')?.textContent || "")
                .includes("trainer at 100 %")""",
            timeout=30000,
        )
        save_screenshot(page, screenshot_dir, "hmi-bike-steep")
        assert page.errors == []
        assert node.stop() == 0
        limits = node.json()["extra"]["loop"]["trainer_limits"]
    assert limits["too_steep_s"] > 0.0 and limits["too_steep_worst_n"] > 30.0, limits
