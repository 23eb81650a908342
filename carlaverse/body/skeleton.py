"""What a skeleton source is, its options, and how its joint angles become a `Skeleton`.

The contract between a walk node and any skeleton source (the shipped `camera` and
`synthetic` ones in `sources`, or a lab's own): `poll()` hands out the newest `Skeleton` not
yet handed out, never blocking, and `close()` ends the source. Both the sources and the pose
process import this module, and it imports neither of them.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Annotated, Literal, Protocol

import msgspec
import numpy as np

from carlaverse import messages as m
from carlaverse.body.kinematics import JOINTS, LANDMARK_INDEX, LIMBS
from carlaverse.config import StrictStruct
from carlaverse.hal.camera import CameraConfig

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
    """What a walk node polls every step for its avatar's joints."""

    def poll(self) -> m.Skeleton | None:
        """The newest skeleton since the last poll, or None; never blocks. `t` is the capture
        time on `time.monotonic()`, `seq` is left to the node."""
        ...

    def close(self) -> None: ...


def visible_joints(angles: JointAngles, visibility: np.ndarray, minimum: float) -> JointAngles:
    """The joints whose landmarks are all at least `minimum` visible."""
    seen = {name for name, i in LANDMARK_INDEX.items() if visibility[i] >= minimum}
    return {joint: value for joint, value in angles.items() if seen >= set(JOINT_LANDMARKS[joint])}


def angles_bytes(angles: JointAngles) -> tuple[list[str], bytes]:
    """Joint names in `JOINTS` order and their (roll, pitch, yaw) as float32 little-endian."""
    names = [j for j in JOINTS if j in angles]
    return names, np.array([angles[j] for j in names], dtype="<f4").reshape(-1).tobytes()
