"""MediaPipe's pose landmarker on RGB frames: 33 world landmarks in the camera HAL's frame.

MediaPipe gives world landmarks in metres about the hips with x to the image's right, y down
and z away from the camera; the HAL's (and `kinematics`') frame has y up and z towards the
camera, the same turned half a turn about x, so handedness (and every joint angle) is kept.
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from carlaverse.body.errors import PoseRuntimeMissing
from carlaverse.body.model import require

TO_HAL = np.array([1.0, -1.0, -1.0])  # MediaPipe world (x right, y down, z away) -> HAL


@dataclass(frozen=True)
class Landmarks:
    world: np.ndarray  # (33, 3) [m] about the hips; x right, y up, z to the camera
    image: np.ndarray  # (33, 2) normalized image coordinates: x right, y down, 0..1
    visibility: np.ndarray  # (33,) 0..1


@contextlib.contextmanager
def _stderr_silenced() -> Iterator[None]:
    """File descriptor 2 to /dev/null for a moment: MediaPipe's C++ runtime writes its start-up
    chatter (TFLite delegate, glog warnings) there, and no setting of mediapipe 1.x turns it
    off. Errors still arrive, as the Python exceptions mediapipe raises."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "wb") as devnull:
            os.dup2(devnull.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _tasks():
    try:
        import mediapipe
        from mediapipe.tasks.python import BaseOptions, vision
    except ModuleNotFoundError as exc:
        raise PoseRuntimeMissing(
            f"body pose needs mediapipe ({exc.name} is missing): pip install -e '.[body]' "
            f"&& pip install --no-deps 'mediapipe==1.2.2'"
        ) from exc
    return mediapipe, BaseOptions, vision


class PoseLandmarker:
    """One person's landmarks per frame, tracked across frames (video mode)."""

    def __init__(self, model: Path | None = None, min_confidence: float = 0.5) -> None:
        mediapipe, base_options, vision = _tasks()
        self._image = mediapipe.Image
        self._srgb = mediapipe.ImageFormat.SRGB
        options = vision.PoseLandmarkerOptions(
            base_options=base_options(model_asset_path=str(require(model))),
            running_mode=vision.RunningMode.VIDEO,
            num_poses=1,
            min_pose_detection_confidence=min_confidence,
            min_tracking_confidence=min_confidence,
        )
        with _stderr_silenced():
            self._landmarker = vision.PoseLandmarker.create_from_options(options)
        self._last_ms = -1
        self._seen_anyone = False

    def detect(self, rgb: np.ndarray, t: float) -> Landmarks | None:
        """Landmarks of the person in `rgb` ((h, w, 3) uint8) captured at `t` [s], or None."""
        stamp_ms = max(self._last_ms + 1, round(t * 1000.0))  # video mode needs them rising
        self._last_ms = stamp_ms
        frame = self._image(image_format=self._srgb, data=np.ascontiguousarray(rgb))
        if self._seen_anyone:
            found = self._landmarker.detect_for_video(frame, stamp_ms)
        else:  # the first landmark pass logs one more start-up warning
            with _stderr_silenced():
                found = self._landmarker.detect_for_video(frame, stamp_ms)
        if not found.pose_world_landmarks:
            return None
        self._seen_anyone = True
        world = np.array([(p.x, p.y, p.z) for p in found.pose_world_landmarks[0]]) * TO_HAL
        image = np.array([(p.x, p.y) for p in found.pose_landmarks[0]])
        visibility = np.array([p.visibility or 0.0 for p in found.pose_landmarks[0]])
        return Landmarks(world, image, visibility)

    def close(self) -> None:
        self._landmarker.close()

    def __enter__(self) -> PoseLandmarker:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
