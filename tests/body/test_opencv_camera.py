"""The `opencv` camera on a real VideoCapture source (a video file written here), and what the
pose process does when its camera ends mid-run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from carlaverse.body.pose_process import CameraBodySource
from carlaverse.body.skeleton import BodyConfig
from carlaverse.hal.camera import CameraConfig
from carlaverse.hal.device import open_device
from carlaverse.hal.errors import DeviceError
from carlaverse.render.frame import joint_angles
from tests.support import wait_until

cv2 = pytest.importorskip("cv2")
FRAMES = 8
SIZE = (640, 480)  # [px] width, height


def _video(tmp_path: Path, rgb: np.ndarray) -> Path:
    path = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30, SIZE)
    assert writer.isOpened(), "OpenCV cannot write MJPG here"
    for _ in range(FRAMES):
        writer.write(cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    writer.release()
    return path


def test_frames_come_as_rgb_then_the_end_is_one_line(tmp_path: Path) -> None:
    from carlaverse.hal.camera import registry

    red = np.zeros((SIZE[1], SIZE[0], 3), np.uint8)
    red[..., 0] = 220
    clip = CameraConfig(backend="opencv", options={"device": str(_video(tmp_path, red))})
    with open_device(registry(), clip, CameraConfig) as camera:
        frame = camera.read()
        assert frame.image.shape == (SIZE[1], SIZE[0], 3)
        red_mean, blue_mean = frame.image[..., 0].mean(), frame.image[..., 2].mean()
        assert red_mean > 200 and blue_mean < 30  # RGB order, not OpenCV's BGR
        with pytest.raises(DeviceError, match=r"clip.avi' ended \(unplugged, or the end"):
            for _ in range(FRAMES + 1):
                camera.read()


def test_the_pose_process_says_why_it_stopped(tmp_path: Path, pose_model: Path,
                                              grace_hopper: Path) -> None:  # fmt: skip
    from carlaverse.hal.camera.opencv import letterbox

    photo = cv2.cvtColor(cv2.imread(str(grace_hopper)), cv2.COLOR_BGR2RGB)
    clip = _video(tmp_path, letterbox(photo, *SIZE))
    camera = CameraConfig(backend="opencv", options={"device": str(clip)})
    source = CameraBodySource(BodyConfig(camera=camera, model=str(pose_model))).start()
    try:
        skeleton = wait_until(source.poll, 30, "a skeleton of the clip")
        wait_until(lambda: source.poll() is None and source.stopped, 30, "the clip's end")
    finally:
        source.close()
    # Only what is seen is sent: her head; the elbows and legs are off the picture.
    angles = joint_angles(skeleton)
    assert list(angles) == ["neck"]
    assert np.abs(np.degrees(angles["neck"])).max() < 15
    assert "clip.avi' ended" in source.stopped and "\n" not in source.stopped
