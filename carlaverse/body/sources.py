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
node. A factory raises ValueError in one line when its source cannot start.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Annotated, Any, Literal, Protocol

import msgspec
import numpy as np

from carlaverse import messages as m
from carlaverse.body.kinematics import JOINTS, LANDMARK_INDEX, LIMBS, joint_angles
from carlaverse.config import StrictStruct, convert
from carlaverse.hal.camera import Camera, CameraConfig, registry
from carlaverse.hal.device import open_device

Clock = Callable[[], float]  # [s]
JointAngles = Mapping[str, tuple[float, float, float]]
# The landmarks each joint's angles are computed from; a joint is sent only when all of them
# are visible enough (a limb out of the picture is guessed by MediaPipe, not seen).
NECK_LANDMARKS = ("left_ear", "right_ear", "left_eye", "right_eye", "mouth_left", "mouth_right")
JOINT_LANDMARKS = {"neck": NECK_LANDMARKS} | {
    joint: limb[2:5] for limb in LIMBS for joint in limb[:2]
}


class BodyConfig(StrictStruct):
    """`body.options` of a walk node's config, for the `camera` and `synthetic` sources."""

    camera: CameraConfig = msgspec.field(
        default_factory=lambda: CameraConfig(backend="opencv")
    )  # which camera, when source is camera
    model: str | None = None  # pose landmarker .task; default: the one `build-model` made
    rate_hz: Annotated[float, msgspec.Meta(gt=0, le=120)] = 30.0  # [1/s]
    min_visibility: Annotated[float, msgspec.Meta(ge=0, le=1)] = 0.5  # per landmark, 0..1
    start_timeout_s: Annotated[float, msgspec.Meta(gt=0)] = 60.0  # [s] camera + model ready
    # The CPU the pose process runs on: "last" (of those this process may use), a number, or
    # "any" (the scheduler moves it). MediaPipe's landmarker is one thread busy most of each
    # frame; moved between cores it refills its caches, which showed as a long latency tail
    # (tools/bench/bench_body_pose.py measures both).
    cpu: Literal["last", "any"] | Annotated[int, msgspec.Meta(ge=0)] = "last"


class SkeletonSource(Protocol):
    def poll(self) -> m.Skeleton | None: ...

    def close(self) -> None: ...


def visible_joints(angles: JointAngles, visibility: np.ndarray, minimum: float) -> JointAngles:
    """The joints whose landmarks are all at least `minimum` visible."""
    seen = {name for name, i in LANDMARK_INDEX.items() if visibility[i] >= minimum}
    return {joint: value for joint, value in angles.items() if seen >= set(JOINT_LANDMARKS[joint])}


def angles_bytes(angles: JointAngles) -> tuple[list[str], bytes]:
    """Joint names in `JOINTS` order and their (roll, pitch, yaw) as float32 little-endian."""
    names = [j for j in JOINTS if j in angles]
    return names, np.array([angles[j] for j in names], dtype="<f4").reshape(-1).tobytes()


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
