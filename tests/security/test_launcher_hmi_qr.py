"""A cabin tablet pairs with a node's HMI by the QR code on the launcher (issue 39 item 3).

A real `carlaverse launcher` starts a router and a real drive node (`--backend sim`) serving its
HMI on every address; headless Chromium, holding the launcher's token, reads the node's QR code
off the page as pixels, and OpenCV decodes them. What the code must hold follows from the node's
rule (join_hmi: beyond loopback a pairing token, shown only in the pairing URL): a browser that
has never seen the HMI gets the dashboard with it (200, the token kept as a cookie) and 401
without it. The token goes only where it is meant to: the QR panel, never the live log (whoever
holds the launcher's token reads that log) nor the launcher's own output.

The node needs no authority for this: it serves its HMI before it joins (it waits to be
admitted meanwhile), and a router is all its fabric needs to open.
"""

from __future__ import annotations

import ipaddress
import re
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING
from urllib.parse import urlsplit

import pytest

from tests.browser import save_screenshot
from tests.launcher.served import ServedLauncher
from tests.support import free_port

if TYPE_CHECKING:
    from playwright.sync_api import Browser, Locator, Page

pytestmark = [pytest.mark.browser, pytest.mark.timeout(180)]
playwright_api = pytest.importorskip("playwright.sync_api")
cv2 = pytest.importorskip("cv2")
np = pytest.importorskip("numpy")
expect = playwright_api.expect

UI_TIMEOUT_MS = 30_000  # [ms] router and node start, and the page follows every 0.5 s
# The node's token: 256 bit in base64url (web_guard.new_token) is 43 characters.
PAIRING_URL = re.compile(r"http://(?P<host>[^/:]+):(?P<port>\d+)/dashboard\?token=(?P<token>"
                         r"[A-Za-z0-9_-]{43})")  # fmt: skip


@pytest.fixture
def launcher(tmp_path: Path) -> Iterator[ServedLauncher]:
    config_dir = tmp_path / "configs"
    config_dir.mkdir()
    served = ServedLauncher(config_dir)
    try:
        served.wait_ready()
        yield served
    finally:
        try:
            served.terminate()
        except subprocess.TimeoutExpired:
            served.kill()


def choose(page: Page, testid: str, option: str) -> None:
    """Pick `option` in a (Quasar) select: open its menu, click the option."""
    page.get_by_test_id(testid).click()
    page.get_by_role("option", name=option, exact=True).click()


def open_log(page: Page, process: str, text: str) -> Locator:
    """Show `process`'s live log and wait until it shows `text`."""
    page.get_by_test_id("processes").get_by_text(process, exact=True).first.click()  # its name
    log = page.get_by_test_id("log")
    expect(log).to_contain_text(text, timeout=UI_TIMEOUT_MS)
    return log


def decode_qr(png: bytes) -> str:
    """The text a QR code in a screenshot carries, as OpenCV reads it ('' when it cannot)."""
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_GRAYSCALE)
    text, _corners, _code = cv2.QRCodeDetector().detectAndDecode(image)
    return str(text)


def test_a_tablet_pairs_by_the_qr_code_and_the_log_keeps_no_token(
    launcher: ServedLauncher, page: Page, chromium: Browser, screenshot_dir: Path
) -> None:
    hmi_port = free_port()
    page.goto(launcher.url)
    page.get_by_role("button", name="Start router").click()
    open_log(page, "router", "listening on")  # the node's fabric opens on it
    choose(page, "node-kind", "drive")
    page.get_by_test_id("node-id").fill("cab")
    page.get_by_test_id("node-hmi-port").fill(str(hmi_port))
    choose(page, "node-hmi-bind", "this machine's network address")
    expect(page.get_by_text("Anyone on the network can reach this HMI")).to_be_visible()
    page.get_by_test_id("start-node").click()

    code = page.get_by_test_id("hmi-qr-cab")
    expect(code).to_be_visible(timeout=UI_TIMEOUT_MS)
    # An <img> with alt text is "visible" before its picture is decoded (a CI run screenshot the
    # empty box and read ''); decode() settles once the pixels are there. Centred, so the fixed
    # header never lies over the code in the element's screenshot.
    code.evaluate("img => img.decode()")
    code.evaluate("img => img.scrollIntoView({block: 'center'})")
    png = code.screenshot()
    scanned = decode_qr(png)
    if not scanned:
        (screenshot_dir / "launcher-hmi-qr-unread.png").write_bytes(png)
    page.evaluate("window.scrollTo(0, 0)")  # the fixed header is drawn mid-picture otherwise
    save_screenshot(page, screenshot_dir, "launcher-hmi-qr")
    found = PAIRING_URL.fullmatch(scanned)
    assert found, f"the QR code reads {scanned!r}, not a pairing URL"
    assert int(found["port"]) == hmi_port
    ipaddress.ip_address(found["host"])  # the machine's address a tablet reaches
    expect(page.get_by_test_id("hmi-url-cab")).to_have_text(scanned)
    token = found["token"]

    # The tablet: a fresh browser context, no cookie; here it reaches the node over loopback.
    local = urlsplit(scanned)._replace(netloc=f"127.0.0.1:{hmi_port}")
    tablet = chromium.new_context()
    stranger = chromium.new_context()
    try:
        paired = tablet.new_page().goto(local.geturl())
        assert paired is not None and paired.status == 200, "the dashboard, with the token"
        assert [c["value"] for c in tablet.cookies()] == [token], "the token kept as a cookie"
        refused = stranger.new_page().goto(local._replace(query="").geturl())
        assert refused is not None and refused.status == 401, "the dashboard without the token"
    finally:
        tablet.close()
        stranger.close()

    log = open_log(page, "cab", "HMI pairing URL")
    assert "token=…" in log.inner_text()  # the node's line is shown, its token is not
    assert token not in log.inner_text()
    assert token not in launcher.log_path.read_text(), "the token in the launcher's output"
