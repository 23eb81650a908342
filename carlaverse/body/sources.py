"""Skeleton sources: what a walk node polls for its `Skeleton` (~30 Hz).

    body:                              # walk node config (nodes/walk/body.py)
      source: camera                   # or synthetic
      options: {camera: {backend: opencv, options: {device: 0}}, rate_hz: 30}

    body = camera_source(options)      # the factory the walk node calls
    skeleton = body.poll()             # the newest Skeleton since the last poll, or None
    body.close()

`camera` runs the camera and MediaPipe in a process of their own (`pose_process`), so
inference never stalls the node's loop; `synthetic` poses the sim camera's walker in-process
and needs neither a camera nor mediapipe. Both stamp `Skeleton.t` with the frame's capture
time on `time.monotonic()` (the walk node moves it onto session time) and leave `seq` to the
node. A factory raises ValueError in one line when its source cannot start. What a source is,
its options and the Skeleton's joint encoding are in `skeleton`.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

from carlaverse import messages as m
from carlaverse.body.kinematics import joint_angles
from carlaverse.body.skeleton import (
    BodyConfig,
    Clock,
    SkeletonSource,
    angles_bytes,
    visible_joints,
)
from carlaverse.config import convert
from carlaverse.hal.camera import Camera, CameraConfig, registry
from carlaverse.hal.device import open_device


class SyntheticBodySource:
    """The sim camera's walker, posed in-process at `rate_hz`; `clock` [s] paces and stamps."""

    def __init__(self, config: BodyConfig, clock: Clock = time.monotonic) -> None:
        sim = config.camera if config.camera.backend == "sim" else CameraConfig(backend="sim")
        self.camera: Camera = open_device(registry(), sim, CameraConfig, clock=clock,
                                          source="body.camera")  # fmt: skip
        self.clock = clock
        self.period_s = 1.0 / config.rate_hz
        self.min_visibility = config.min_visibility
        self._seq = 0
        self._due = clock()

    def poll(self) -> m.Skeleton | None:
        now = self.clock()
        if now < self._due:
            return None
        self._due += self.period_s
        if self._due <= now:  # the caller stalled: go on from now, never catch up in a burst
            self._due = now + self.period_s
        frame = self.camera.read()
        assert frame.landmarks is not None and frame.visibility is not None  # the sim's contract
        angles = visible_joints(joint_angles(frame.landmarks), frame.visibility,
                                self.min_visibility)  # fmt: skip
        self._seq += 1
        return m.Skeleton(self._seq, now, *angles_bytes(angles))

    def close(self) -> None:
        self.camera.close()


def camera_source(options: Mapping[str, Any]) -> SkeletonSource:
    """The walk node's `body: {source: camera}`: camera + MediaPipe in the pose process."""
    from carlaverse.body.errors import BodyPoseError
    from carlaverse.body.pose_process import CameraBodySource

    config = convert(dict(options), BodyConfig, "body.options")
    try:
        return CameraBodySource(config).start()
    except BodyPoseError as exc:  # the node says it in one line and ends
        raise ValueError(f"body: {exc}") from exc


def synthetic_source(options: Mapping[str, Any]) -> SkeletonSource:
    """The walk node's `body: {source: synthetic}`: the sim walker, in-process."""
    return SyntheticBodySource(convert(dict(options), BodyConfig, "body.options"))
