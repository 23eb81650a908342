"""The HMI server in a real browser: messages, bad input, dropped-in pages, frame rate, units."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Page

from carlaverse.hmi.config import load_hmi_config
from carlaverse.hmi.server import HmiError, HmiServer
from carlaverse.hmi.wire import Press
from tests.browser import save_screenshot
from tests.hmi.scripted import ScriptedBridge, serving
from tests.support import wait_until

pytestmark = pytest.mark.browser

DASHBOARD = """
hmi: {rate_hz: 60, units: mph, pages_dir: pages}
layouts:
  dashboard:
    columns: 2
    widgets:
      - {widget: speedometer}
      - {widget: gear, column: 2}
"""
SPEED_MPS = 20.0  # 72 km/h, 44.7 mph


@pytest.fixture
def bridge() -> ScriptedBridge:
    return ScriptedBridge(speed_mps=SPEED_MPS, gear=3)


@pytest.fixture
def server(bridge: ScriptedBridge, tmp_path: Path) -> Iterator[HmiServer]:
    (tmp_path / "pages").mkdir()
    with serving(bridge, tmp_path, DASHBOARD) as running:
        yield running


def _open(page: Page, url: str) -> None:
    page.goto(url)
    page.wait_for_function("window.hmi && hmi.frames > 0")


def test_the_dashboard_shows_telemetry_in_the_configured_units_at_30_hz_or_more(
    page: Page, server: HmiServer, screenshot_dir: Path
) -> None:
    _open(page, server.url + "dashboard")
    readout = page.locator('[data-readout="speed"]')
    wait_until(lambda: readout.text_content() == "45", 5, "44.7 mph shown as 45")
    assert page.locator('[data-readout="gear"]').text_content() == "D3"
    # where the YAML puts them: speedometer in column 1, gear in column 2 of a 2-column grid
    boxes = {name: page.locator(f'[data-widget="{name}"]').bounding_box()
             for name in ("speedometer", "gear")}  # fmt: skip
    assert boxes["speedometer"]["x"] < 640 <= boxes["gear"]["x"]  # the viewport is 1280 px
    assert abs(boxes["speedometer"]["y"] - boxes["gear"]["y"]) < 1  # one row
    frames, started = page.evaluate("[hmi.frames, performance.now()]")
    page.wait_for_timeout(2000)  # a measuring window, not a wait for a condition
    frames_after, ended = page.evaluate("[hmi.frames, performance.now()]")
    rate_hz = (frames_after - frames) / ((ended - started) / 1000)
    assert rate_hz >= 30, f"{rate_hz:.1f} frames/s"
    save_screenshot(page, screenshot_dir, "hmi-scripted-dashboard")
    assert page.errors == []


def test_pushed_text_shows_on_pages_for_its_time(page: Page, server: HmiServer) -> None:
    _open(page, server.url + "dashboard")
    server.show_message("Take the next exit", seconds=60)
    banner = page.locator("#hmi-messages .message")
    banner.wait_for(state="visible", timeout=10000)
    assert banner.text_content() == "Take the next exit"
    late = page.context.new_page()  # a page opened while the message is up sees it too
    _open(late, server.url + "dashboard")
    late.wait_for_function("hmi.messages.includes('Take the next exit')")
    server.show_message("Brake!", seconds=0.5)  # shown, then gone after its time
    for shown in (page, late):
        shown.wait_for_function("hmi.messages.includes('Brake!')")
        shown.locator(".message", has_text="Brake!").wait_for(state="detached", timeout=10000)
    assert banner.text_content() == "Take the next exit"


def test_a_bad_websocket_message_is_counted_and_dropped(
    page: Page, server: HmiServer, bridge: ScriptedBridge
) -> None:
    _open(page, server.url + "dashboard")
    page.evaluate("""() => {
        hmi.socket.send("{not json");
        hmi.send({type: "press", action: "eject_seat"});
        hmi.send({type: "cruise", command: "fly"});
        hmi.socket.send(new Uint8Array([1, 2, 3]));
        hmi.press("low_beam");
    }""")
    wait_until(lambda: bridge.commands, 5, "the good press after the bad ones")
    assert bridge.commands == [Press("low_beam")]
    status = page.evaluate("fetch('/api/status').then(r => r.json())")
    assert status["inputs_rejected"] == {"json": 1, "action": 1, "schema": 1, "binary": 1}
    page.wait_for_function("hmi.rejected.length === 4")
    frames = page.evaluate("hmi.frames")  # the connection lives on: telemetry still flows
    page.wait_for_function(f"hmi.frames > {frames + 10}")


def test_a_page_dropped_into_the_pages_folder_is_served(
    page: Page, server: HmiServer, tmp_path: Path
) -> None:
    page.goto(server.url)
    assert "gauges" not in page.locator("#pages").text_content()
    # written while the server runs: no Python, no restart
    (tmp_path / "pages" / "gauges.html").write_text("""<!doctype html>
<meta charset="utf-8"><link rel="icon" href="data:,"><title>my gauges</title>
<p>speed <b id="mine">?</b></p><main id="layout"></main>
<script type="module">
  import { startPage } from "/hmi.js";
  const hmi = await startPage("gauges");
  const mine = document.getElementById("mine");
  hmi.onTelemetry((v) => { mine.textContent = (v.speed_mps * 3.6).toFixed(1); });
</script>""")
    page.reload()
    page.click("text=gauges")
    page.wait_for_function("document.getElementById('mine').textContent === '72.0'")
    assert page.title() == "my gauges"
    assert page.errors == []


def test_a_port_in_use_is_one_clear_error(server: HmiServer, tmp_path: Path) -> None:
    loaded = load_hmi_config(str(tmp_path / "hmi.yaml"))
    with pytest.raises(HmiError, match=rf"--hmi {server.port}: cannot listen on 127\.0\.0\.1"):
        HmiServer(ScriptedBridge(), loaded, port=server.port).start()
