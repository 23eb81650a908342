"""Cameras: body tracking for the walk node (landmarks) and raw frames.

A frame carries the image, the 33 body landmarks in MediaPipe Pose order, or both. Backends:
`sim` (a synthetic walker: landmarks), `opencv` (a webcam or video through OpenCV: images)
and `still` (a photograph as a camera: images); `carlaverse.body` turns images into
landmarks with MediaPipe. Third parties add more under the entry-point group
`carlaverse.hal.camera`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from carlaverse.hal.device import Device, DeviceConfig
from carlaverse.hal.registry import BackendSpec, Registry

BACKENDS = {
    "sim": BackendSpec("carlaverse.hal.camera.sim", "SimCamera"),
    "opencv": BackendSpec("carlaverse.hal.camera.opencv", "OpenCvCamera", "body"),
    "still": BackendSpec("carlaverse.hal.camera.still", "StillCamera", "body"),
}

LANDMARK_NAMES = (
    "nose", "left_eye_inner", "left_eye", "left_eye_outer", "right_eye_inner", "right_eye",
    "right_eye_outer", "left_ear", "right_ear", "mouth_left", "mouth_right", "left_shoulder",
    "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_pinky",
    "right_pinky", "left_index", "right_index", "left_thumb", "right_thumb", "left_hip",
    "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle", "left_heel",
    "right_heel", "left_foot_index", "right_foot_index",
)  # fmt: skip


class CameraConfig(DeviceConfig):
    """`camera:` block of a node config."""


@dataclasses.dataclass(frozen=True)
class CameraFrame:
    t: float  # [s] device clock at capture
    landmarks: np.ndarray | None  # (33, 3) float32 [m], hip-centred; x right, y up, z to camera
    visibility: np.ndarray | None  # (33,) float32, 0..1
    image: np.ndarray | None  # (height, width, 3) uint8 RGB


class Camera(Device):
    """Base class: `read` returns the newest frame."""

    def read(self) -> CameraFrame:
        return self._read(self.clock())

    def _read(self, now: float) -> CameraFrame:
        raise NotImplementedError


def registry() -> Registry[Camera]:
    return Registry("camera", Camera, BACKENDS)
