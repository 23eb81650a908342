"""A synthetic walker: 33 MediaPipe-ordered landmarks of a person walking in place.

Segment lengths are anthropometric fractions of body height (Winter, "Biomechanics and Motor
Control of Human Movement"); the gait is sinusoidal: hips flex ±`hip_swing_rad`, knees flex
during swing, arms swing against the legs. Enough to drive an avatar and to test the walk
node's joint-angle code against known angles.
"""

from __future__ import annotations

import math

import numpy as np

# Fractions of body height H.
HIP_HEIGHT = 0.530
SHOULDER_HEIGHT = 0.818
NOSE_HEIGHT = 0.930
THIGH, SHANK, FOOT_HEIGHT, FOOT_LENGTH = 0.245, 0.246, 0.039, 0.152
UPPER_ARM, FOREARM, HAND = 0.186, 0.146, 0.108
SHOULDER_HALF_WIDTH, HIP_HALF_WIDTH = 0.129, 0.095


def _limb(root: np.ndarray, angles: list[float], lengths: list[float]) -> list[np.ndarray]:
    """Joint positions of a planar chain hanging down from `root`, swinging in the y-z plane;
    angles [rad] are cumulative forward flexion from vertical."""
    points, point, total = [], root.copy(), 0.0
    for angle, length in zip(angles, lengths, strict=True):
        total += angle
        point = point + length * np.array([0.0, -math.cos(total), math.sin(total)])
        points.append(point)
    return points


def walker_landmarks(phase: float, height_m: float, hip_swing_rad: float) -> np.ndarray:
    """(33, 3) float32 [m], hip-centred, at gait phase [rad]."""
    h = height_m
    out = np.zeros((33, 3))
    for side, sign in ((0, 1.0), (1, -1.0)):  # left (+x), right (-x)
        s = math.sin(phase + side * math.pi)
        hip_angle = hip_swing_rad * s
        knee_angle = -max(0.0, 1.2 * hip_swing_rad * math.sin(phase + side * math.pi + 0.8))
        hip = np.array([sign * HIP_HALF_WIDTH * h, 0.0, 0.0])
        knee, ankle = _limb(hip, [hip_angle, knee_angle], [THIGH * h, SHANK * h])
        shoulder = np.array([sign * SHOULDER_HALF_WIDTH * h, (SHOULDER_HEIGHT - HIP_HEIGHT) * h, 0])
        elbow, wrist, hand = _limb(
            shoulder, [-0.8 * hip_angle, 0.3, 0.0], [UPPER_ARM * h, FOREARM * h, HAND * h]
        )
        out[23 + side], out[25 + side], out[27 + side] = hip, knee, ankle
        out[29 + side] = ankle + np.array([0, -FOOT_HEIGHT * h, -0.25 * FOOT_LENGTH * h])
        out[31 + side] = ankle + np.array([0, -FOOT_HEIGHT * h, 0.75 * FOOT_LENGTH * h])
        out[11 + side], out[13 + side], out[15 + side] = shoulder, elbow, wrist
        out[17 + side] = hand + np.array([sign * 0.02 * h, 0, 0])  # pinky
        out[19 + side] = hand  # index
        out[21 + side] = wrist + np.array([-sign * 0.02 * h, -0.03 * h, 0.02 * h])  # thumb
    _head(out, h)
    return out.astype(np.float32)


def _head(out: np.ndarray, h: float) -> None:
    nose = np.array([0.0, (NOSE_HEIGHT - HIP_HEIGHT) * h, 0.06 * h])
    out[0] = nose
    for i, x, dy, dz in ((1, 0.015, 0.02, -0.005), (2, 0.03, 0.02, -0.01), (3, 0.045, 0.02, -0.02),
                         (7, 0.075, 0.0, -0.06), (9, 0.025, -0.04, -0.01)):  # fmt: skip
        out[i] = nose + np.array([x * h / 1.75, dy * h / 1.75, dz * h / 1.75])  # for 1.75 m
        mirror = i + (3 if i < 4 else 1)
        out[mirror] = nose + np.array([-x * h / 1.75, dy * h / 1.75, dz * h / 1.75])


def project(landmarks: np.ndarray, width: int, height: int, height_m: float) -> np.ndarray:
    """(33, 2) pixel coordinates of a frontal orthographic view fitting the body."""
    scale = 0.8 * height / (1.1 * height_m)  # [px/m]
    u = width / 2 - landmarks[:, 0] * scale  # camera faces the walker: left is image right
    v = height * 0.55 - landmarks[:, 1] * scale
    return np.stack([u, v], axis=1)
