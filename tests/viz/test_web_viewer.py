"""`carlaverse view --serve`: the web viewer loads in headless Chromium and shows the scene."""

from __future__ import annotations

import os
import re
import threading
from pathlib import Path

import numpy as np
import psutil
import pytest

from carlaverse.viz.scene import KIND_COLORS
from tests.recording.conftest import World
from tests.support import Proc, wait_until
from tests.viz.chromium import CHROMIUM, Chromium

pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(
        not CHROMIUM.exists(),
        reason="needs Debian chromium at /usr/bin/chromium (apt-get install -y chromium)",
    ),
]
SCREENSHOT_KEEP = Path(os.environ.get("CARLAVERSE_SCREENSHOT", "/tmp/carlaverse-web-viewer.png"))


def _scene_pixels(png: bytes) -> int:
    """Pixels of the 3D view in the colours of the actors' kinds (car, van, truck)."""
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import io

    import pygame

    image = pygame.surfarray.array3d(pygame.image.load(io.BytesIO(png), "shot.png"))
    view = image.transpose(1, 0, 2).astype(int)[60:680, 0:900]  # the world view, left
    hits = 0
    for kind in ("car", "van", "truck"):
        hits += int((np.abs(view - np.array(KIND_COLORS[kind])).sum(axis=2) < 60).sum())
    return hits


def test_served_web_viewer_shows_the_scene(world: World, tmp_path: Path) -> None:
    view = Proc(["view", "--session", "view", "--connect", world.endpoint, "--serve"])
    stop = threading.Event()
    traffic = threading.Thread(target=world.synthetic.run, args=(stop,))
    browser = None
    try:
        url = _url(view.wait_for_line(lambda line: _url(line) is not None, 30))
        assert url.startswith("http://127.0.0.1:")
        children = psutil.Process(view.proc.pid).children(recursive=True)
        listening = _listening(children)
        assert listening and all(ip == "127.0.0.1" for ip, _ in listening), listening
        wait_until(lambda: world.synthetic.queries["map"], 20, "the viewer to join")
        traffic.start()
        browser = Chromium()
        browser.open(url)
        # the wasm viewer takes several seconds in software WebGL before the scene appears
        shot = wait_until(lambda: _shot_with_scene(browser), 60, "the scene in a screenshot", 1.0)
        (tmp_path / "web-viewer.png").write_bytes(shot)
        SCREENSHOT_KEEP.write_bytes(shot)
    finally:
        if browser is not None:
            browser.close()
        stop.set()
        if traffic.is_alive():
            traffic.join()
        assert view.stop() == 0, view.output()[-2000:]
    _, alive = psutil.wait_procs(children, timeout=10)
    assert not alive, "the served rerun process stops with the view"


def _shot_with_scene(browser: Chromium) -> bytes | None:
    shot = browser.screenshot()
    return shot if _scene_pixels(shot) > 200 else None


def _url(line: str) -> str | None:
    """The web viewer's URL, if `line` is the view's line that says it."""
    match = re.search(r"web viewer: (\S+)", line)
    return match.group(1) if match else None


def _listening(children: list[psutil.Process]) -> list[tuple[str, int]]:
    """TCP addresses the view's child processes (the rerun server) listen on."""
    out = []
    for child in children:
        for conn in child.net_connections(kind="tcp"):
            if conn.status == psutil.CONN_LISTEN:
                out.append((conn.laddr.ip, conn.laddr.port))
    return out
