"""The walk node's smaller parts: the scripted headset, the controllers' stick, the skeleton
source choice, and the view reading the walker's head from shared memory."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
from carlaverse_nodes.walk.body import BodySettings, open_skeleton_source
from carlaverse_nodes.walk.shared_state import STATE

from carlaverse import hal
from carlaverse.cli import main
from carlaverse.config import ConfigError
from carlaverse.fov import EyeFov
from carlaverse.hal.xr import XrActions, XrHeadset
from carlaverse.render.live import OwnPose
from carlaverse.shm_layouts import OwnPoseBlock
from tests.hal.helpers import ManualClock

SCRIPT = [
    {"t": 0.0, "axes": {"move_x": 0.0, "move_y": 0.0, "head_yaw_deg": 0.0}},
    {
        "t": 2.0,
        "axes": {"move_x": 0.0, "move_y": 1.0, "head_yaw_deg": 90.0},
        "buttons": {"run": True},
    },
    {"t": 4.0, "axes": {"move_x": -1.0}, "buttons": {"interact": True, "run": False}},
]


def test_the_sim_headset_follows_its_script() -> None:
    clock = ManualClock()
    options = {"posture": "standing", "yaw_amplitude_rad": 0.0, "pitch_amplitude_rad": 0.0,
               "sway_m": 0.0, "script": SCRIPT}  # fmt: skip
    xr = hal.open_xr({"backend": "sim", "options": options}, clock=clock)
    clock.advance(1.0)  # half-way between the first two keyframes
    a = xr.actions()
    assert a.move == pytest.approx((0.0, 0.5)) and not a.run
    pose = xr.pose()
    w, _, y, _ = pose.orientation
    assert 2 * math.atan2(y, w) == pytest.approx(math.radians(45.0))  # head yaw interpolated
    assert pose.position == pytest.approx((0.0, 1.65, 0.0))  # standing, no sway
    clock.advance(3.5)
    a = xr.actions()
    # (−1, 1) held beyond the last keyframe, scaled back onto the unit circle
    assert a.move == pytest.approx((-math.sqrt(0.5), math.sqrt(0.5)))
    assert a.interact and not a.run


def test_a_script_naming_an_unknown_channel_is_refused() -> None:
    bad = {"script": [{"t": 0, "axes": {"throttle": 1.0}}]}
    with pytest.raises(ConfigError, match=r"script\[0\] names \['throttle'\]"):
        hal.open_xr({"backend": "sim", "options": bad})


def test_a_headset_without_controllers_reports_no_actions() -> None:
    class Bare(XrHeadset):
        def _pose(self, now: float):
            return (0.0, 1.7, 0.0), (1.0, 0.0, 0.0, 0.0), True

    assert Bare(None).actions() == XrActions()


def test_skeleton_source_choice() -> None:
    assert open_skeleton_source(BodySettings()) is None  # `none`, the default
    with pytest.raises(ConfigError, match="unknown skeleton source 'kinect'"):
        open_skeleton_source(BodySettings(source="kinect"))
    with pytest.raises(ConfigError, match="cannot be loaded"):
        open_skeleton_source(BodySettings(source="tests.walk.body_fixture:nothing"))
    source = open_skeleton_source(BodySettings(source="tests.walk.body_fixture:make"))
    assert source is not None and source.poll() is not None
    source.close()


def test_join_with_an_unknown_skeleton_source_says_so_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "walk.yaml"
    config.write_text("body: {source: kinect}\n")
    argv = ["join", "walk", "--config", str(config), "--id", "w", "--session", "t",
            "--connect", "tcp/127.0.0.1:9", "--duration", "1"]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("carlaverse join: walk: body.source: unknown skeleton source 'kinect'")
    assert len(err.splitlines()) == 1


WRITER = """
import sys
from carlaverse_nodes.walk.shared_state import STATE
from carlaverse.shm import SharedBlock, new_record
block = SharedBlock(sys.argv[1], STATE, create=True)
record = new_record(STATE)
record["x"], record["y"], record["yaw"] = 3.0, 4.0, 0.5
record["pitch"], record["roll"], record["running"] = -0.2, 0.1, 1
record["eyes"] = 1  # the headset's frusta [rad], left eye then right eye
for eye, (left, right) in (("left_eye", (-0.9, 0.7)), ("right_eye", (-0.7, 0.9))):
    record[eye + "_left"], record[eye + "_right"] = left, right
    record[eye + "_up"], record[eye + "_down"] = 0.8, -0.85
block.write(record)
print("ready", flush=True)
sys.stdin.read()  # until the test is done
block.close()
"""


def test_the_view_reads_the_walkers_head_from_shared_memory() -> None:
    """The walk loop's block, written by another process, as a `--view` process reads it."""
    name = f"carlaverse-test-walk-{os.getpid()}"
    writer = subprocess.Popen([sys.executable, "-c", WRITER, name], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True)  # fmt: skip
    try:
        assert writer.stdout is not None and writer.stdout.readline().strip() == "ready"
        own = OwnPose(OwnPoseBlock(name, STATE, "pedestrian"), "walker")
        actor = own.actor()
        eyes = own.eyes
        own.close()
    finally:
        writer.communicate("", timeout=10)
    assert actor is not None
    assert (actor.x, actor.y, actor.yaw, actor.pitch, actor.roll) == pytest.approx(
        (3.0, 4.0, 0.5, -0.2, 0.1)
    )  # the first-person camera nods and tilts with the head
    assert eyes == (EyeFov(-0.9, 0.7, 0.8, -0.85), EyeFov(-0.7, 0.9, 0.8, -0.85))


@pytest.mark.parametrize(("direction", "expected_deg"), [("head", 90.0), ("controller", -20.0)])
def test_walking_follows_the_head_or_the_hand(direction: str, expected_deg: float) -> None:
    """The head looks 90° left, the hand points 20° right: `gait.direction` picks which."""
    from carlaverse_nodes.walk.config import WalkNodeConfig
    from carlaverse_nodes.walk.gait import GaitSettings
    from carlaverse_nodes.walk.walk_control import WalkControl

    clock = ManualClock()
    script = [{"t": 0.0, "axes": {"move_y": 1.0, "head_yaw_deg": 90.0, "hand_yaw_deg": -20.0}}]
    options = {"yaw_amplitude_rad": 0.0, "pitch_amplitude_rad": 0.0, "script": script}
    config = WalkNodeConfig(gait=GaitSettings(direction=direction))
    control = WalkControl(config, hal.open_xr({"backend": "sim", "options": options}, clock=clock))
    control.place(0.0, 0.0, math.radians(10.0))  # the stage faces 10° north of east
    for _ in range(90):
        clock.advance(1 / 90)
        out = control.tick(1 / 90)
    assert math.degrees(math.atan2(out.vy, out.vx)) == pytest.approx(10.0 + expected_deg)
    assert math.degrees(out.head.yaw) == pytest.approx(100.0)  # the head: 10° + 90°


def test_a_loop_that_cannot_open_its_devices_reports_one_line() -> None:
    """The loop process puts `{"error": ...}` on its results; the node's step turns that into
    the ValueError that `carlaverse join` prints as one line."""
    import queue
    import threading

    from carlaverse_nodes.walk.config import WalkNodeConfig
    from carlaverse_nodes.walk.loop_process import WalkLoopSpec, run_walk_loop
    from carlaverse_nodes.walk.shared_state import CONTROL

    from carlaverse.hal import InputConfig
    from carlaverse.shm import SharedBlock

    config = WalkNodeConfig(input=InputConfig(backend="wiimote"))
    name = f"carlaverse-test-walk-loop-{os.getpid()}"
    blocks = [SharedBlock(f"{name}-state", STATE, create=True),
              SharedBlock(f"{name}-control", CONTROL, create=True)]  # fmt: skip
    results: queue.Queue = queue.Queue()
    try:
        spec = WalkLoopSpec(config, blocks[0].name, blocks[1].name)
        run_walk_loop(spec, queue.Queue(), results, threading.Event())
    finally:
        for block in blocks:
            block.close()
    report = results.get_nowait()
    assert report["error"].startswith("BackendNotFoundError: ")
    assert "wiimote" in report["error"] and "\n" not in report["error"]
    assert results.empty()  # no runner, no summary
