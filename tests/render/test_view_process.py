"""The view's render process against a live session (router, authority, a scripted node and
`carlaverse join drive --backend sim` as processes): it reads the drive node's own pose from
shared memory, sees the scripted node through its own connection, writes frames, and ends.
`join drive --view` itself (the CLI hook) is tested in test_join_view.py."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from carlaverse.render.frame import SceneFrame
from carlaverse.render.renderer import Renderer
from carlaverse.render.rig import RenderConfig, Resolution, SimpleRig
from tests.render.support import car, changed
from tests.support import Cluster, wait_until

pytestmark = pytest.mark.usefixtures("offscreen_gl")

RIG = RenderConfig(
    output="offscreen",
    camera=SimpleRig(resolution=Resolution(width=320, height=180), fov_deg=90),
    max_fps=20,
)
# A slow circle 37..53 m ahead of the drive node's start (origin, heading east): it stays
# within the view's ±45° while the car drives the first side of its block. A car there is
# some 14 × 5 px at this resolution.
SCRIPTED = """
path: {type: circle, center: [45.0, 0.0], radius: 8.0, speed_mps: 2.0}
"""


def _png(path: Path) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB"))


def _empty_scene() -> np.ndarray:
    """The view with nobody in it: ground and sky look the same from anywhere on the map."""
    with Renderer(RIG, None) as r:
        r.draw(SceneFrame(0.0, (car("d1", 0.0, 0.0, ego=True),)), follow="d1")
        return r.images()[0]


def test_view_process_shows_the_scripted_node_and_reports(tmp_path: Path) -> None:
    from carlaverse_nodes.drive.shared_state import STATE

    from carlaverse.render.process import ViewProcess, ViewSpec
    from carlaverse.shm import block_name
    from carlaverse.shm_layouts import OwnPoseBlock
    from carlaverse.transport.node_client import NodeSettings
    from carlaverse.transport.session import FabricSettings

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
            "--backend", "sim", "--duration", "20", name="drive",
        )  # fmt: skip
        own = OwnPoseBlock(block_name("t", "d1", "state"), STATE)
        spec = ViewSpec(NodeSettings(node_id="d1", session="t"),
                        FabricSettings(connect=[cluster.endpoint]), RIG, own,
                        out_dir=str(out), out_every_s=0.5)  # fmt: skip
        view = ViewProcess(spec).start()
        try:
            wait_until(lambda: len(list(out.glob("frame-*.png"))) >= 8, 60, "8 frames")
        finally:
            summary = view.close()
        assert drive.alive(), drive.output()[-2000:]
    finally:
        cluster.close()
    assert summary.error == "" and summary.frames >= 20, summary
    assert not _alive(summary.pid)
    _assert_frames_show_a_car(sorted(out.glob("frame-*.png")), summary.written)


def _assert_frames_show_a_car(frames: list[Path], written: int) -> None:
    assert len(frames) == written >= 4
    empty = _empty_scene()
    shown = [changed(_png(f), empty).sum() for f in frames]
    # The first frames may come before the drive loop's first tick (the view looks over the
    # map then) or the scripted node's first pose; most show the car ahead, and only the car.
    # Four seconds of riding at most: then the drive node may have come up beside it.
    riding = [n for n in shown if n < empty.shape[0] * empty.shape[1] // 4]
    assert len(riding) >= min(8, len(frames) // 2), shown
    riding = riding[:8]
    assert sum(n > 20 for n in riding) >= len(riding) - 2, shown


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"
