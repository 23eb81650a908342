"""Forward kinematics: the 33 landmarks of a person posed by joint angles.

The inverse of `kinematics.joint_angles`, in the same joint convention, so a test can put known
angles in and expect the same angles out, and a synthetic body source can pose a figure by
script. Segment lengths and widths are fractions of body height (Winter, "Biomechanics and
Motor Control of Human Movement"), as the sim camera's walker uses. Only the landmarks the
angles are computed from are placed (shoulders, elbows, wrists, hips, knees, ankles, nose,
eyes, ears, mouth); the rest stay at the mid-hip.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from carlaverse.body.kinematics import LANDMARK_INDEX, LIMBS, rotation_from_euler
from carlaverse.hal.camera.walker import (
    FOREARM,
    HIP_HALF_WIDTH,
    HIP_HEIGHT,
    SHANK,
    SHOULDER_HALF_WIDTH,
    SHOULDER_HEIGHT,
    THIGH,
    UPPER_ARM,
)

Angles = Mapping[str, tuple[float, float, float]]
SEGMENTS = {"shoulder": (UPPER_ARM, FOREARM), "hip": (THIGH, SHANK)}  # fractions of height
# Head points in the head frame (forward, left, up) [fraction of height], from the neck.
HEAD_POINTS = {
    "nose": (0.06, 0.0, 0.11), "left_eye": (0.05, 0.02, 0.125), "right_eye": (0.05, -0.02, 0.125),
    "left_ear": (0.0, 0.045, 0.115), "right_ear": (0.0, -0.045, 0.115),
    "mouth_left": (0.05, 0.015, 0.09), "mouth_right": (0.05, -0.015, 0.09),
}  # fmt: skip
REST = (0.0, 0.0, 0.0)


def _roots(height_m: float) -> dict[str, np.ndarray]:
    """Shoulder and hip positions in the body frame (forward, left, up) [m], hip-centred."""
    shoulder_up = (SHOULDER_HEIGHT - HIP_HEIGHT) * height_m
    return {
        "left_shoulder": np.array([0.0, SHOULDER_HALF_WIDTH * height_m, shoulder_up]),
        "right_shoulder": np.array([0.0, -SHOULDER_HALF_WIDTH * height_m, shoulder_up]),
        "left_hip": np.array([0.0, HIP_HALF_WIDTH * height_m, 0.0]),
        "right_hip": np.array([0.0, -HIP_HALF_WIDTH * height_m, 0.0]),
    }


def posed_landmarks(
    angles: Angles, body: np.ndarray, height_m: float = 1.75, origin: np.ndarray | None = None
) -> np.ndarray:
    """(33, 3) landmarks [m] of a person whose torso has rotation `body` (columns: forward,
    left, up in the output frame) at `origin` (mid-hip), posed by `angles`."""
    out = np.zeros((33, 3))
    roots = _roots(height_m)
    for joint, hinge_joint, root, middle, end, _sign in LIMBS:
        upper_m, lower_m = (f * height_m for f in SEGMENTS[joint.split("_")[1]])
        turn = rotation_from_euler(*angles.get(joint, REST))
        bend = turn @ rotation_from_euler(*angles.get(hinge_joint, REST))
        a = roots[root]
        b = a + turn @ np.array([0.0, 0.0, -upper_m])
        c = b + bend @ np.array([0.0, 0.0, -lower_m])
        out[LANDMARK_INDEX[root]], out[LANDMARK_INDEX[middle]], out[LANDMARK_INDEX[end]] = a, b, c
    neck = (roots["left_shoulder"] + roots["right_shoulder"]) / 2
    head = rotation_from_euler(*angles.get("neck", REST))
    for name, offset in HEAD_POINTS.items():
        out[LANDMARK_INDEX[name]] = neck + head @ (np.array(offset) * height_m)
    origin = np.zeros(3) if origin is None else origin
    return (out @ body.T + origin).astype(np.float64)
