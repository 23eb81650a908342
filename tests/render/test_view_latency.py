"""What a view frame costs and how late it shows motion, measured by the render process itself
and checked here against its written frames: a writer thread plays a node's loop (stamped
states at about 1 kHz in a real shared-memory block), the view draws them in its own process
(no authority: plain ground, the free camera over the empty map), writes every frame, and the
own car jumps out of sight at a known stamp."""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from carlaverse.messages import Extent
from carlaverse.render.process import ViewSummary
from carlaverse.render.rig import RenderConfig, Resolution, SimpleRig
from tests.render.support import changed
from tests.support import wait_until

pytestmark = pytest.mark.usefixtures("offscreen_gl")

# max_fps far above what llvmpipe draws: frames follow each other with no pacing wait, so a
# frame's period is its parts (draw + read-back + write) and nothing else.
RIG = RenderConfig(
    output="offscreen", camera=SimpleRig(resolution=Resolution(width=320, height=180), fov_deg=90),
    max_fps=1000.0, quality="flat",
)  # fmt: skip
# A 40 m block: from the free camera (170 m south of the map's centre, 90 m up, fov 90° over
# 320 px) it spans some 40 m / 190 m × 320 px / (π/2) ≈ 43 px, far above pixel noise.
BIG = Extent(length=40.0, width=20.0, height=10.0)
AWAY_M = 5000.0  # [m] where the car jumps to: beyond the draw distance, out of every frame
FRAMES_BEFORE = 20  # frames written before the jump


class LoopPlayer(threading.Thread):
    """Writes the drive state at ~1 kHz, each record stamped as the drive loop stamps it."""

    def __init__(self, name: str) -> None:
        super().__init__(daemon=True)
        from carlaverse_nodes.drive.shared_state import STATE

        from carlaverse.shm import SharedBlock

        self.block = SharedBlock(name, STATE, create=True)
        self.record = np.zeros((), dtype=STATE)
        self.record["running"] = 1
        self.x = 0.0
        self.jump_ns = 0  # the stamp of the first record with the car away
        self.stop = threading.Event()

    def run(self) -> None:
        while not self.stop.is_set():
            self.record["x"] = self.x
            self.record["written_ns"] = time.monotonic_ns()
            self.block.write(self.record)
            if self.x == AWAY_M and not self.jump_ns:
                self.jump_ns = int(self.record["written_ns"])
            time.sleep(0.001)

    def close(self) -> None:
        self.stop.set()
        self.join()
        self.block.close()  # the creator: unlinks it


def _png(path: Path) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB"))


def test_view_parts_add_up_and_motion_to_photon_is_the_first_frame_showing_it(
    tmp_path: Path,
) -> None:
    from carlaverse_nodes.drive.shared_state import STATE

    from carlaverse.render.live import OwnPoseBlock
    from carlaverse.render.process import FRAMES_LOG, FREE, ViewProcess, ViewSpec
    from carlaverse.transport.node_client import NodeSettings
    from carlaverse.transport.session import FabricSettings

    name = f"cv-latency-{time.monotonic_ns()}"
    player = LoopPlayer(name)
    player.start()
    out = tmp_path / "frames"
    log = out / FRAMES_LOG
    spec = ViewSpec(NodeSettings(node_id="d1", session=f"lat{time.monotonic_ns()}"),
                    FabricSettings(listen=[], connect=[]), RIG,
                    OwnPoseBlock(name, STATE, extent=BIG), FREE, str(out), out_every_s=1e-6,
                    map_timeout_s=0.5)  # fmt: skip
    view = ViewProcess(spec).start()
    try:
        wait_until(lambda: _lines(log) >= FRAMES_BEFORE, 90, f"{FRAMES_BEFORE} frames")
        player.x = AWAY_M
        wait_until(lambda: player.jump_ns and _first_after(log, player.jump_ns) is not None
                   and _lines(log) >= _first_after(log, player.jump_ns) + 3, 60,
                   "3 frames after the jump")  # fmt: skip
    finally:
        summary = view.close()
        player.close()
    assert summary.error == "", summary
    frames = [json.loads(line) for line in log.read_text().splitlines()]
    _assert_parts_add_up(summary, frames)
    _assert_jump_seen_first_at(summary, frames, out, player.jump_ns)


def _lines(log: Path) -> int:
    return len(log.read_text().splitlines()) if log.exists() else 0


def _first_after(log: Path, jump_ns: int) -> int | None:
    """Index of the first written frame drawn from a state stamped at or after the jump."""
    for i, line in enumerate(log.read_text().splitlines()):
        if json.loads(line)["state_ns"] >= jump_ns:
            return i
    return None


def _assert_parts_add_up(summary: ViewSummary, frames: list[dict[str, int]]) -> None:
    """With no pacing wait, one frame follows the other: the frame period measured from the
    photon stamps (one clock, taken by the view at each read-back) is the sum of the frame's
    parts. So fps × mean frame time ≈ 1, and the period from the stamps agrees with fps.
    20 %: the first frames (shader compiles) weigh on a mean but not on a median."""
    s = summary
    assert s.frames >= len(frames) >= FRAMES_BEFORE + 3, s
    assert s.readback_frames == s.frames and s.written == s.frames, s
    parts = s.draw_ms_p50 + s.readback_ms_p50 + s.write_ms_p50
    assert s.fps * s.frame_ms_mean / 1e3 == pytest.approx(1.0, rel=0.2), s
    stamps = np.array([f["photon_ns"] for f in frames], dtype=np.int64)
    period_ms = float(np.median(np.diff(stamps))) * 1e-6
    assert parts == pytest.approx(period_ms, rel=0.2), (parts, period_ms, s)
    assert s.fps == pytest.approx(1e3 / period_ms, rel=0.2), (period_ms, s)


def _assert_jump_seen_first_at(
    summary: ViewSummary, frames: list[dict[str, int]], out: Path, jump_ns: int
) -> None:
    """The first frame drawn from a state at or after the jump shows the car gone and the one
    before still shows it; its latency from the jump lies between a frame's draw + read-back
    (a frame cannot show what it has not drawn) and two whole frames (the jump lands just after
    a frame read its state: that frame is drawn, then the next one) plus 150 ms of scheduling
    on a loaded 2-core machine."""
    s = summary
    k = next(i for i, f in enumerate(frames) if f["state_ns"] >= jump_ns)
    assert k >= FRAMES_BEFORE - 1, (k, frames)
    pngs = [_png(out / f["png"]) for f in frames[k - 2 : k + 1]]
    still = changed(pngs[1], pngs[0]).sum()  # two frames with the car in place
    jumped = changed(pngs[2], pngs[1]).sum()
    # The block covers ~43 × 20 px at least (see BIG); frames without motion differ by noise.
    assert still < 50 and jumped > 300, (still, jumped)
    latency_ms = (frames[k]["photon_ns"] - jump_ns) * 1e-6
    lower = 0.5 * (s.draw_ms_p50 + s.readback_ms_p50)
    upper = 2 * s.frame_ms_p99 + 150.0
    assert lower < latency_ms < upper, (lower, latency_ms, upper, s)
    # The summary's figure is over every frame, each from its own state's stamp: same bounds.
    assert s.motion_to_photon_frames >= s.frames - 2, s
    assert lower < s.motion_to_photon_ms_p50 < upper, s
