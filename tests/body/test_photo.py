"""MediaPipe with the offline-built model on a real photograph (matplotlib's grace_hopper.jpg,
512×600 px, a head-and-shoulders portrait facing the camera)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from carlaverse.body.kinematics import body_rotation, joint_angles, rotation_from_euler

# Points labelled by hand on the photo [px] (x right, y down). The tolerance: a joint centre
# under clothes is uncertain by about 2 cm, ~24 px here (the pupils are 75 px ≈ 6.3 cm apart).
LABELLED_PX = {
    "nose": (262, 235), "left_eye": (305, 192), "right_eye": (225, 195),
    "mouth_left": (292, 270), "mouth_right": (240, 272),
    "left_shoulder": (445, 430), "right_shoulder": (85, 430),
}  # fmt: skip
TOLERANCE_PX = 24.0
INDEX = {"nose": 0, "left_eye": 2, "right_eye": 5, "mouth_left": 9, "mouth_right": 10,
         "left_shoulder": 11, "right_shoulder": 12}  # fmt: skip


@pytest.fixture(scope="module")
def found(pose_model: Path, grace_hopper: Path):
    from PIL import Image

    from carlaverse.body.landmarker import PoseLandmarker

    rgb = np.asarray(Image.open(grace_hopper).convert("RGB"))
    with PoseLandmarker(pose_model) as landmarker:
        landmarks = landmarker.detect(rgb, 0.0)
    assert landmarks is not None, "no person found in grace_hopper.jpg"
    return landmarks, rgb.shape


def test_landmarks_where_a_person_labelled_them(found) -> None:
    landmarks, (height, width, _) = found
    for name, (x, y) in LABELLED_PX.items():
        u, v = landmarks.image[INDEX[name]] * (width, height)
        assert math.hypot(u - x, v - y) < TOLERANCE_PX, f"{name} at ({u:.0f}, {v:.0f}) px"
    face_and_shoulders = [INDEX[n] for n in LABELLED_PX]
    assert landmarks.visibility[face_and_shoulders].min() > 0.9
    assert landmarks.visibility[25:].max() < 0.1  # the legs are not in the picture


def test_derived_angles_of_a_portrait(found) -> None:
    world = found[0].world
    forward, left, _up = body_rotation(world).T
    # She faces the camera (+z), within 25°; her shoulders are level within 10°.
    assert math.degrees(math.acos(forward[2])) < 25
    assert abs(math.degrees(math.asin(left[1]))) < 10
    angles = joint_angles(world)
    # The head sits upright on the torso: each neck angle within 15°.
    assert np.abs(np.degrees(angles["neck"])).max() < 15
    # Both upper arms hang: within 50° of the body's down axis (the elbows are off the photo).
    for side in ("left", "right"):
        arm = rotation_from_euler(*angles[f"{side}_shoulder"]) @ np.array([0.0, 0.0, -1.0])
        assert math.degrees(math.acos(-arm[2])) < 50, side
