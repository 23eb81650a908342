"""Errors of body pose estimation, one tree:

    BodyPoseError (RuntimeError)
    ├── PoseModelError      the .task model is missing or cannot be built
    └── PoseRuntimeMissing  mediapipe is not installed

A camera that cannot be opened is the HAL's `DeviceError`.

Each message is one line naming what is missing and how to get it.
"""

from __future__ import annotations


class BodyPoseError(RuntimeError):
    """Body pose estimation cannot run."""


class PoseModelError(BodyPoseError):
    """The pose landmarker model is missing or could not be built."""


class PoseRuntimeMissing(BodyPoseError):
    """mediapipe is not installed."""
