"""The launcher in a real browser: a demo started and seen, a config refused then saved, the
hardware checks on simulated devices, and nothing left running after stop or close."""

from __future__ import annotations

import signal
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import pytest
import yaml

from carlaverse.config import load_config
from tests.browser import save_screenshot as _save_screenshot
from tests.launcher.served import ServedLauncher
from tests.support import wait_until

if TYPE_CHECKING:
    from playwright.sync_api import Locator, Page

pytestmark = [pytest.mark.browser, pytest.mark.timeout(240)]
playwright_api = pytest.importorskip("playwright.sync_api")
expect = playwright_api.expect

DEMO_NODES = ["scripted-1", "scripted-2"]
SEEN_TIMEOUT_S = 60.0  # [s] router, authority and two nodes start and publish on a loaded host
UI_TIMEOUT_MS = 20_000  # [ms] the page follows the lab every 0.5 s; a loaded host lags


@pytest.fixture(scope="module")
def launcher(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ServedLauncher]:
    served = ServedLauncher(tmp_path_factory.mktemp("launcher"))
    try:
        served.wait_ready()
        yield served
    finally:
        try:
            served.terminate()
        except subprocess.TimeoutExpired:
            served.kill()


def shows(locator: Locator, text: str) -> None:
    """The element shows `text` within the UI timeout (the page follows by timers)."""
    expect(locator).to_contain_text(text, timeout=UI_TIMEOUT_MS)


def save_screenshot(page: Page, directory: Path, name: str) -> Path:
    """From the top: the header is fixed, and a scrolled page draws it mid-picture."""
    page.evaluate("window.scrollTo(0, 0)")
    return _save_screenshot(page, directory, name)


def _table_text(page: Page, testid: str) -> str:
    return page.get_by_test_id(testid).inner_text()


def test_demo_shows_its_nodes_and_stop_leaves_nothing_running(
    launcher: ServedLauncher, page: Page, screenshot_dir: Path
) -> None:
    page.goto(launcher.url)
    page.get_by_test_id("demo-kinds").fill("scripted,scripted")
    page.get_by_test_id("demo-scenario").fill("none")
    page.get_by_test_id("start-demo").click()
    for name in ["router", "authority", *DEMO_NODES]:
        shows(page.get_by_test_id("processes"), name)
    wait_until(lambda: len(launcher.census()) >= 4, 30, "four children of the launcher")
    # the nodes are in the session, with a measured pose rate, as `carlaverse stats` has it
    presence = page.get_by_test_id("presence")
    wait_until(
        lambda: all(_measured(presence.inner_text(), n) for n in DEMO_NODES),
        SEEN_TIMEOUT_S,
        f"{DEMO_NODES} in the presence table with a pose rate",
    )
    shows(page.get_by_test_id("authority-status"), "the authority of session 'lab' is running")
    page.get_by_test_id("processes").get_by_text("authority", exact=True).first.click()
    shows(page.get_by_test_id("log"), "--scenario none")  # the demo's choice
    shows(page.get_by_test_id("log"), "authority of session 'lab' ticking")  # its own output
    page.get_by_test_id("processes").get_by_text("scripted-1", exact=True).click()
    shows(page.get_by_test_id("log"), "carlaverse join scripted")
    save_screenshot(page, screenshot_dir, "launcher-demo")

    page.get_by_test_id("stop-all").click()
    wait_until(lambda: "running" not in _table_text(page, "processes"), 30, "every process stopped")
    wait_until(lambda: not _session_children(launcher), 15, "no session process left")
    wait_until(lambda: not any(n in presence.inner_text() for n in DEMO_NODES), 15, "nobody listed")
    assert _session_children(launcher) == []
    shows(page.get_by_test_id("authority-status"), "does not answer")  # the router went too
    save_screenshot(page, screenshot_dir, "launcher-stopped")


def _measured(table_text: str, node_id: str) -> bool:
    """The presence row of `node_id` shows a number in its rate column."""
    for line in table_text.splitlines():
        cells = line.split("\t")
        if cells and cells[0] == node_id:
            return len(cells) > 3 and cells[3].replace(".", "", 1).isdigit()
    return False


def _session_children(launcher: ServedLauncher) -> list[str]:
    """What still runs of the `carlaverse` commands the launcher started."""
    return [line for line in launcher.left_running() if "-m carlaverse" in line]


def test_config_editor_rejects_then_saves(
    launcher: ServedLauncher, page: Page, screenshot_dir: Path
) -> None:
    from carlaverse_nodes.bike.config import BikeNodeConfig

    target = launcher.config_dir / "edited" / "bike.yaml"  # saved only inside the config dir
    page.goto(launcher.url)
    page.get_by_role("tab", name="Config").click()
    page.get_by_test_id("config-source").fill("bike-sim")
    page.get_by_test_id("config-target").fill(str(target))
    page.get_by_test_id("config-open").click()
    page.get_by_test_id("config-tree").get_by_text("road", exact=True).click()
    grade = page.locator('[data-path="road.grade_percent"]')  # the <input> itself
    field = page.locator('label:has([data-path="road.grade_percent"])')  # with its messages
    grade.fill("99")
    error = "road.grade_percent: Expected `float` <= 40.0"
    shows(page.get_by_test_id("config-errors"), error)
    shows(field, "Expected `float` <= 40.0")  # under the field itself
    shows(page.get_by_test_id("config-tree"), "road ⚠")  # and its section marked in the tree
    page.get_by_test_id("config-save").click()
    shows(page.get_by_test_id("config-status"), "not saved")
    assert not target.exists()
    save_screenshot(page, screenshot_dir, "launcher-config-error")

    grade.fill("5.5")
    shows(page.get_by_test_id("config-errors"), "valid")
    expect(page.get_by_test_id("config-tree")).not_to_contain_text("⚠")
    # The status line follows the edit: the refused save's error no longer holds (issue 43.8).
    shows(page.get_by_test_id("config-status"), "valid, not saved yet")
    expect(page.get_by_test_id("config-status")).not_to_contain_text("grade_percent")
    page.get_by_test_id("config-save").click()
    shows(page.get_by_test_id("config-status"), f"saved {target}")
    assert yaml.safe_load(target.read_text())["road"]["grade_percent"] == 5.5
    assert load_config(target, BikeNodeConfig).road.grade_percent == 5.5  # the node's decoder
    save_screenshot(page, screenshot_dir, "launcher-config-saved")


def test_hardware_checks_on_simulated_devices(
    launcher: ServedLauncher, page: Page, screenshot_dir: Path
) -> None:
    page.goto(launcher.url)
    page.get_by_role("tab", name="Hardware").click()
    page.get_by_test_id("ffb-run").click()
    page.get_by_test_id("motion-run").click()
    page.get_by_test_id("trainer-run").click()
    page.get_by_test_id("joystick-watch").click()
    shows(page.get_by_test_id("ffb-log"), "ending with all forces off")
    shows(page.get_by_test_id("motion-log"), "platform at neutral: True")
    shows(page.get_by_test_id("trainer-log"), "ftms_sim answers")
    steer = page.locator("[data-axis=steer]")
    first = steer.inner_text()
    wait_until(lambda: steer.inner_text() != first, 5, "the steering axis to move")
    save_screenshot(page, screenshot_dir, "launcher-hardware")


def test_closing_the_launcher_stops_everything_it_started(
    launcher: ServedLauncher, page: Page
) -> None:
    """Last in the module: it closes the module's launcher, as a user closing it would."""
    page.goto(launcher.url)
    page.get_by_test_id("demo-kinds").fill("scripted")
    page.get_by_test_id("demo-scenario").fill("none")
    page.get_by_test_id("start-demo").click()
    expect(page.get_by_test_id("presence")).to_contain_text("scripted-1", timeout=60_000)
    launcher.census()
    started = " ".join(_session_children(launcher))
    for command in ("carlaverse router", "carlaverse authority", "--id scripted-1"):
        assert command in started
    # uvicorn shuts down (the launcher stops its children then), and re-raises the signal
    assert launcher.terminate() == -signal.SIGTERM, launcher.output()
    assert launcher.left_running() == [], launcher.output()
