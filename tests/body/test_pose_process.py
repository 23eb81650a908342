"""The Pose Process: a child process turns camera frames into skeletons the node polls."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from carlaverse.body.errors import BodyPoseError
from carlaverse.body.pose_process import CameraBodySource
from carlaverse.body.skeleton import BodyConfig
from carlaverse.body.sources import SyntheticBodySource
from carlaverse.hal.camera import CameraConfig
from carlaverse.render.frame import joint_angles
from tests.support import wait_until


def _collect(source, seconds: float) -> list:
    found, end = [], time.monotonic() + seconds
    while time.monotonic() < end:
        skeleton = source.poll()
        if skeleton is not None:
            found.append((time.monotonic(), skeleton))
        time.sleep(0.002)  # the node's loop period stand-in; poll never waits
    return found


def test_sim_camera_through_the_pose_process_at_30_hz() -> None:
    source = CameraBodySource(BodyConfig(camera=CameraConfig(backend="sim"), rate_hz=30.0)).start()
    try:
        wait_until(source.poll, 10, "a first skeleton")
        got = _collect(source, 2.0)
    finally:
        source.close()
    assert not source.alive()
    assert len(got) >= 0.6 * 2.0 * 30, f"{len(got)} skeletons in 2 s"  # 30 Hz, loaded host
    seqs = [s.seq for _, s in got]
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)
    for received, skeleton in got:
        angles = joint_angles(skeleton)
        assert set(angles) == {
            "neck",
            "left_shoulder",
            "left_elbow",
            "right_shoulder",
            "right_elbow",
            "left_hip",
            "left_knee",
            "right_hip",
            "right_knee",
        }
        assert angles["left_elbow"] == pytest.approx((0, -0.3, 0), abs=1e-5)  # walker's bend
        assert abs(angles["left_hip"][1]) <= 0.35 + 1e-5  # within the walker's hip swing
        assert 0 <= received - skeleton.t < 1.0  # stamped at capture, on the node's clock


def test_an_absent_camera_fails_at_start_in_one_line() -> None:
    camera = CameraConfig(backend="opencv", options={"device": 57})
    with pytest.raises(BodyPoseError) as failed:
        CameraBodySource(BodyConfig(camera=camera)).start()
    message = str(failed.value)
    assert message.startswith("camera /dev/video57 cannot be opened") and "\n" not in message


def test_a_missing_model_fails_at_start_in_one_line(grace_hopper: Path, tmp_path: Path) -> None:
    pytest.importorskip("mediapipe")
    camera = CameraConfig(backend="still", options={"path": str(grace_hopper)})
    config = BodyConfig(camera=camera, model=str(tmp_path / "none.task"))
    with pytest.raises(BodyPoseError, match=r"none.task is missing; build it once") as failed:
        CameraBodySource(config).start()
    assert "\n" not in str(failed.value)


def test_synthetic_source_is_paced_by_its_clock() -> None:
    now = [100.0]  # [s] a manual clock: pacing is tested without sleeping
    source = SyntheticBodySource(BodyConfig(rate_hz=50.0), clock=lambda: now[0])
    try:
        first = source.poll()
        now[0] += 0.019
        early = source.poll()  # not due yet: 50 Hz is one per 20 ms
        now[0] += 0.002
        second = source.poll()
        now[0] += 1.0  # a stalled caller gets one skeleton, not a burst of 50
        late, after_late = source.poll(), source.poll()
    finally:
        source.close()
    assert first is not None and early is None and second is not None
    assert (second.seq, second.t) == (first.seq + 1, 100.021)
    assert late is not None and after_late is None
    assert joint_angles(first)["right_elbow"] == pytest.approx((0, -0.3, 0), abs=1e-5)


def _cpus_of_child(cpu: str | int) -> str:
    """The CPUs a fresh process may use after `pin_cpu(cpu)` (a child: the test keeps its own)."""
    code = ("import os; from carlaverse.body.pose_process import pin_cpu; "
            f"print(pin_cpu({cpu!r}), sorted(os.sched_getaffinity(0)))")  # fmt: skip
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="no CPU affinity on this OS")
def test_the_pose_process_stays_on_one_cpu() -> None:
    allowed = sorted(os.sched_getaffinity(0))
    assert _cpus_of_child("last") == f"{allowed[-1]} [{allowed[-1]}]"
    assert _cpus_of_child(allowed[0]) == f"{allowed[0]} [{allowed[0]}]"
    assert _cpus_of_child("any") == f"None {allowed}"  # left to the scheduler


def test_a_cpu_it_may_not_use_fails_at_start_in_one_line() -> None:
    config = BodyConfig(camera=CameraConfig(backend="sim"), cpu=4096)
    with pytest.raises(BodyPoseError) as failed:
        CameraBodySource(config).start()
    message = str(failed.value)
    assert message.startswith("body.options.cpu 4096: the pose process may run on CPUs [")
    assert "\n" not in message
