"""The shared browser fixture drives a real Chromium against a real local HTTP server."""

from __future__ import annotations

import functools
import http.server
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.browser import save_screenshot

pytestmark = pytest.mark.browser


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: object) -> None:
        pass


@pytest.fixture
def site(tmp_path: Path) -> Iterator[str]:
    (tmp_path / "index.html").write_text(
        "<title>probe</title><link rel='icon' href='data:,'><p id='out'></p>"
        "<script>document.getElementById('out').textContent = String(6 * 7);</script>"
    )
    handler = functools.partial(_QuietHandler, directory=str(tmp_path))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/index.html"
    finally:
        server.shutdown()
        server.server_close()


def test_page_runs_scripts_and_screenshots(page, site: str, screenshot_dir: Path) -> None:
    page.goto(site)
    page.wait_for_function("document.getElementById('out').textContent === '42'")
    assert page.title() == "probe"
    shot = save_screenshot(page, screenshot_dir, "probe")
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert page.errors == []
