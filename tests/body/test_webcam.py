"""A real webcam (`pytest --hardware`, someone in front of /dev/video0): frames at the size
asked for, and the pose process turns them into skeletons."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from carlaverse.body.pose_process import CameraBodySource
from carlaverse.body.skeleton import BodyConfig
from carlaverse.hal.camera import CameraConfig, registry
from carlaverse.hal.device import open_device
from tests.support import wait_until

pytestmark = pytest.mark.hardware
DEVICE = int(os.environ.get("CARLAVERSE_TEST_CAMERA", "0"))  # /dev/videoN


def test_webcam_frames_are_640_by_480_rgb() -> None:
    webcam = CameraConfig(backend="opencv", options={"device": DEVICE})
    with open_device(registry(), webcam, CameraConfig) as camera:
        first, second = camera.read(), camera.read()
    assert first.image.shape == (480, 640, 3)
    assert second.t > first.t  # a new frame each read


def test_a_person_in_front_of_the_webcam_gives_skeletons(pose_model: Path) -> None:
    webcam = CameraConfig(backend="opencv", options={"device": DEVICE})
    source = CameraBodySource(BodyConfig(camera=webcam, model=str(pose_model))).start()
    try:
        skeleton = wait_until(source.poll, 20, "a skeleton: stand in front of the camera")
    finally:
        source.close()
    assert "neck" in skeleton.joints
