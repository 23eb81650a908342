"""Joint angles from landmarks: known angles in, the same angles out, wherever the camera is."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carlaverse.body.forward import posed_landmarks
from carlaverse.body.kinematics import (
    JOINTS,
    body_rotation,
    euler_from_rotation,
    joint_angles,
    rotation_from_euler,
)
from carlaverse.hal.camera.walker import walker_landmarks

EXACT = 1e-9  # [rad] double precision through SVD and atan2: only rounding remains

POSE = {
    "neck": (0.1, -0.2, 0.3),
    "left_shoulder": (0.5, -0.7, 0.3), "left_elbow": (0.0, -1.0, 0.0),
    "right_shoulder": (-0.4, 0.2, -0.6), "right_elbow": (0.0, -0.5, 0.0),
    "left_hip": (0.1, -0.4, 0.2), "left_knee": (0.0, 0.8, 0.0),
    "right_hip": (-0.2, 0.3, -0.1), "right_knee": (0.0, 0.3, 0.0),
}  # fmt: skip
# The person faces the camera (forward = +z of the camera frame, left = +x, up = +y).
FACING_CAMERA = np.column_stack([(0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)])


def _assert_angles(found: dict, expected: dict, tol: float = EXACT) -> None:
    for joint in JOINTS:
        assert found[joint] == pytest.approx(expected.get(joint, (0.0, 0.0, 0.0)), abs=tol), joint


def test_a_posed_person_facing_the_camera_gives_back_its_angles() -> None:
    _assert_angles(joint_angles(posed_landmarks(POSE, FACING_CAMERA)), POSE)


def test_angles_do_not_depend_on_where_the_camera_stands() -> None:
    body = FACING_CAMERA @ rotation_from_euler(0.3, -0.2, 2.5)  # turned away, leaning
    landmarks = posed_landmarks(POSE, body, origin=np.array([1.0, -0.4, 3.0]))
    _assert_angles(joint_angles(landmarks), POSE)
    assert body_rotation(landmarks) == pytest.approx(body, abs=EXACT)


def test_rest_pose_is_all_zero() -> None:
    _assert_angles(joint_angles(posed_landmarks({}, FACING_CAMERA)), {})


def test_the_renderers_documented_examples() -> None:
    """figure.py: left_shoulder roll +π/2 lifts the left arm sideways; pitch −π/2 ahead."""
    sideways = posed_landmarks({"left_shoulder": (math.pi / 2, 0, 0), "left_elbow": (0, -0.4, 0)},
                               FACING_CAMERA)  # fmt: skip
    elbow, shoulder = sideways[13], sideways[11]
    assert (elbow - shoulder)[0] > 0.3 and abs((elbow - shoulder)[1]) < 1e-9  # out to its left
    ahead = posed_landmarks({"left_shoulder": (0, -math.pi / 2, 0)}, FACING_CAMERA)
    assert (ahead[13] - ahead[11]) == pytest.approx([0, 0, 0.186 * 1.75], abs=1e-9)
    assert joint_angles(sideways)["left_shoulder"] == pytest.approx((math.pi / 2, 0, 0), abs=EXACT)


def test_synthetic_walker_gives_the_gait_it_was_made_with() -> None:
    """The sim camera's walker: hips flex ±swing·sin(phase), arms swing −0.8× against the
    legs, elbows bend 0.3 rad, knees flex in swing (walker.py); forward flexion is −pitch."""
    swing_rad = 0.35
    for phase in np.linspace(0, 2 * math.pi, 13):
        found = joint_angles(walker_landmarks(phase, 1.75, swing_rad))
        for side, offset in (("left", 0.0), ("right", math.pi)):
            hip = swing_rad * math.sin(phase + offset)
            knee = max(0.0, 1.2 * swing_rad * math.sin(phase + offset + 0.8))
            tol = 1e-5  # the walker's landmarks are float32
            assert found[f"{side}_hip"] == pytest.approx((0, -hip, 0), abs=tol)
            assert found[f"{side}_knee"] == pytest.approx((0, knee, 0), abs=tol)
            assert found[f"{side}_shoulder"] == pytest.approx((0, 0.8 * hip, 0), abs=tol)
            assert found[f"{side}_elbow"] == pytest.approx((0, -0.3, 0), abs=tol)


def test_arm_straight_ahead_is_the_gimbal_lock_and_keeps_the_rotation() -> None:
    """At pitch −π/2 roll and yaw turn about one axis: any split is the same arm."""
    posed = {"left_shoulder": (0.4, -math.pi / 2, 0.3), "left_elbow": (0, -0.8, 0)}
    found = joint_angles(posed_landmarks(posed, FACING_CAMERA))["left_shoulder"]
    assert rotation_from_euler(*found) == pytest.approx(
        rotation_from_euler(*posed["left_shoulder"]), abs=1e-7
    )


def test_a_straight_arm_gets_the_twist_free_swing() -> None:
    found = joint_angles(posed_landmarks({"left_shoulder": (0.3, -0.5, 0.0)}, FACING_CAMERA))
    assert found["left_elbow"] == pytest.approx((0, 0, 0), abs=EXACT)
    r = rotation_from_euler(*found["left_shoulder"])
    expected_dir = rotation_from_euler(0.3, -0.5, 0.0) @ np.array([0, 0, -1.0])
    assert r @ np.array([0, 0, -1.0]) == pytest.approx(expected_dir, abs=1e-9)


angle = st.floats(-2.5, 2.5)
pitch = st.floats(-1.3, 1.3)  # off the gimbal lock at ±π/2
hinge = st.floats(0.1, 2.6)  # bent: a straight limb has no twist to recover


@settings(max_examples=60, deadline=None)
@given(shoulder=st.tuples(angle, pitch, angle), elbow=hinge, hip=st.tuples(angle, pitch, angle),
       knee=hinge, neck=st.tuples(st.floats(-0.8, 0.8), pitch, st.floats(-1.2, 1.2)),
       body=st.tuples(angle, pitch, angle))  # fmt: skip
def test_any_pose_any_camera_round_trips(shoulder, elbow, hip, knee, neck, body) -> None:
    posed = {"neck": neck, "right_shoulder": shoulder, "right_elbow": (0, -elbow, 0),
             "left_hip": hip, "left_knee": (0, knee, 0)}  # fmt: skip
    found = joint_angles(posed_landmarks(posed, rotation_from_euler(*body)))
    _assert_angles(found, posed, tol=1e-7)


@given(st.tuples(angle, pitch, angle))
def test_euler_round_trip(rpy) -> None:
    assert euler_from_rotation(rotation_from_euler(*rpy)) == pytest.approx(rpy, abs=1e-9)
