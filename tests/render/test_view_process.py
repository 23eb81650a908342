"""`carlaverse join drive --view --offscreen` against a live session: the render process
draws the scripted node where it is, writes frames, and ends with the node."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from carlaverse.config import to_yaml
from carlaverse.render.frame import SceneFrame
from carlaverse.render.renderer import Renderer
from carlaverse.render.rig import RenderConfig, Resolution, SimpleRig
from tests.render.support import car, changed
from tests.support import Cluster, wait_until

pytestmark = pytest.mark.usefixtures("offscreen_gl")

RIG = RenderConfig(
    output="offscreen",
    camera=SimpleRig(resolution=Resolution(width=160, height=90), fov_deg=90),
    max_fps=20,
)
# A slow circle 60..80 m ahead of the drive node's start (origin, heading east): it stays
# within the view's ±45° for the whole run while the car laps its block's first side.
SCRIPTED = """
path: {type: circle, center: [70.0, 0.0], radius: 10.0, speed_mps: 2.0}
"""


def _png(path: Path) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB"))


def _empty_scene() -> np.ndarray:
    """The view with nobody in it: ground and sky look the same from anywhere on the map."""
    with Renderer(RIG, None) as r:
        r.draw(SceneFrame(0.0, (car("d1", 0.0, 0.0, ego=True),)), follow="d1")
        return r.images()[0]


def test_drive_view_shows_the_scripted_node_and_ends_with_the_node(tmp_path: Path) -> None:
    rig = tmp_path / "rig.yaml"
    rig.write_text(to_yaml(RIG))
    scripted = tmp_path / "scripted.yaml"
    scripted.write_text(SCRIPTED)
    out = tmp_path / "frames"
    cluster = Cluster(tmp_path)
    try:
        cluster.router()
        cluster.authority()
        cluster.scripted("s1", scripted)
        drive = cluster.start(
            "join", "drive", "--id", "d1", "--session", "t", "--connect", cluster.endpoint,
            "--backend", "sim", "--duration", "8", "--json", "--view", "--offscreen",
            "--view-out", str(out), "--view-every", "0.5", "--render-config", str(rig),
            name="drive",
        )  # fmt: skip
        assert drive.wait(timeout=90) == 0, drive.output()[-3000:]
        view = drive.json()["extra"]["view"]
    finally:
        cluster.close()
    assert view["error"] == "" and view["frames"] >= 20, view
    frames = sorted(out.glob("frame-*.png"))
    assert len(frames) == view["written"] >= 4
    empty = _empty_scene()
    shown = [changed(_png(f), empty).sum() for f in frames]
    # the first frames may come before the scripted node's first pose; most must show it
    assert sum(n > 6 for n in shown) >= len(frames) // 2, shown
    assert max(shown) < empty.shape[0] * empty.shape[1] // 4, shown  # a car, not a new scene
    wait_until(lambda: not _alive(view["pid"]), 5, "the render process to end")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"
