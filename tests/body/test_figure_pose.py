"""The renderer's figure, posed with the angles the body pipeline derives, puts every limb
segment where the landmarks had it: both sides use one joint convention."""

from __future__ import annotations

import numpy as np
import pytest

from carlaverse.body.forward import posed_landmarks
from carlaverse.body.kinematics import (
    LANDMARK_INDEX as index,
)
from carlaverse.body.kinematics import (
    LIMBS,
    head_rotation,
    joint_angles,
    rotation_from_euler,
)

panda3d = pytest.importorskip("panda3d.core")

POSE = {
    "neck": (0.2, -0.3, 0.4),
    "left_shoulder": (1.2, -0.4, 0.5), "left_elbow": (0.0, -1.4, 0.0),  # arm raised, bent
    "right_shoulder": (-0.3, -1.0, -0.2), "right_elbow": (0.0, -0.6, 0.0),  # reaching ahead
    "left_hip": (0.2, -0.9, 0.1), "left_knee": (0.0, 1.3, 0.0),  # a knee lifted
    "right_hip": (-0.1, 0.2, 0.0), "right_knee": (0.0, 0.2, 0.0),
}  # fmt: skip
# A person seen turned and leaning: the camera frame is not the body frame.
BODY_IN_CAMERA = rotation_from_euler(0.1, 0.2, 2.2)
# The body's forward, left and up axes in Panda3D's actor frame (x right, y forward, z up).
BODY_TO_PANDA = np.column_stack([(0, 1, 0), (-1, 0, 0), (0, 0, 1)]).astype(float)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def test_figure_limbs_point_where_the_landmarks_are() -> None:
    from carlaverse.render import palette
    from carlaverse.render.figure import Figure

    landmarks = posed_landmarks(POSE, BODY_IN_CAMERA)
    figure = Figure(panda3d.NodePath("world"), palette.ACTOR_COLORS["pedestrian"])
    figure.pose(joint_angles(landmarks))
    to_body = BODY_IN_CAMERA.T
    for joint, hinge, root, middle, end, _sign in LIMBS:
        for segment, (a, b) in ((joint, (root, middle)), (hinge, (middle, end))):
            seen = _unit(to_body @ (landmarks[index[b]] - landmarks[index[a]]))
            quat = figure.joints[segment].get_quat(figure.node)
            drawn = quat.xform(panda3d.Vec3(0, 0, -1))  # a segment hangs along -z at rest
            assert np.array(drawn) == pytest.approx(BODY_TO_PANDA @ seen, abs=1e-5), segment
    # the head: its forward and up axes as the ears, eyes and mouth say
    head = to_body @ head_rotation(landmarks)
    quat = figure.joints["neck"].get_quat(figure.node)
    for axis in (0, 2):
        rest = panda3d.Vec3(*BODY_TO_PANDA[:, axis])
        assert np.array(quat.xform(rest)) == pytest.approx(BODY_TO_PANDA @ head[:, axis], abs=1e-5)
