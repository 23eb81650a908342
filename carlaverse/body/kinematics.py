"""Joint angles of a person from 33 body landmarks, as the paper's Pose Process derives them.

The torso gives the body frame: the shoulder vector `v_shoulder` (right shoulder → left
shoulder) and the body's longitudinal vector `v_body` (neck → mid-hip; MediaPipe has no neck
landmark, so the neck is the mid-shoulder point). Their cross product is the body's depth
normal, v_back = v_shoulder × v_body, which points out of the person's back. The rotation
R_body whose columns are the body's forward (−v_back), left (v_shoulder) and up (−v_body) axes
is taken as the rotation nearest to those three unit vectors (the orthogonal Procrustes
solution), because measured shoulders and spine are never exactly perpendicular. Every limb
vector is brought into the body frame by R_body⁻¹ = R_bodyᵀ.

Joint convention — the renderer's (`carlaverse.render.figure`): each joint's (roll, pitch, yaw)
[rad] turns the segment below it about the body's forward (x), left (y) and up (z) axes,
right-handed, roll first, then pitch, then yaw (R = R_z(yaw) R_y(pitch) R_x(roll)), starting
from the rest pose with the limbs hanging straight down. A shoulder or hip is a spherical joint:
its rotation takes the rest segment (pointing down, its bend direction forward for an arm,
backward for a leg) onto the measured upper segment, its twist fixed by the plane the lower
segment bends in. An elbow or knee is a hinge: its angle is the one between upper and lower
segment, sent as pitch (−angle for an elbow, which bends forward; +angle for a knee).
The neck's rotation is the head frame (ears, eyes, mouth) relative to the body frame.

Landmarks are (33, 3) [m] in any right-handed frame (the camera HAL's: x right, y up, z to
the camera); the angles do not depend on where the camera stands.
"""

from __future__ import annotations

import math

import numpy as np

from carlaverse.hal.camera import LANDMARK_NAMES

LANDMARK_INDEX = {name: i for i, name in enumerate(LANDMARK_NAMES)}

# (upper joint, hinge joint, root landmark, middle landmark, end landmark, hinge sign)
# The hinge sign is the pitch that bends the lower segment its natural way: an elbow forward
# (negative pitch), a knee backward (positive pitch).
LIMBS = (
    ("left_shoulder", "left_elbow", "left_shoulder", "left_elbow", "left_wrist", -1.0),
    ("right_shoulder", "right_elbow", "right_shoulder", "right_elbow", "right_wrist", -1.0),
    ("left_hip", "left_knee", "left_hip", "left_knee", "left_ankle", 1.0),
    ("right_hip", "right_knee", "right_hip", "right_knee", "right_ankle", 1.0),
)
JOINTS = ("neck", *(joint for limb in LIMBS for joint in limb[:2]))

# Below this sine of the hinge angle (about 3°) a limb counts as straight: the lower segment
# no longer says how the upper one is twisted, so the twist-free swing from rest is used.
STRAIGHT_SIN = 0.05
DOWN = np.array([0.0, 0.0, -1.0])


def point(landmarks: np.ndarray, name: str) -> np.ndarray:
    return np.asarray(landmarks[LANDMARK_INDEX[name]], dtype=np.float64)


def nearest_rotation(columns: np.ndarray) -> np.ndarray:
    """The rotation matrix closest (Frobenius) to a 3×3 matrix of roughly orthonormal columns."""
    u, _, vt = np.linalg.svd(columns)
    d = np.sign(np.linalg.det(u @ vt))  # keep it a rotation, never a reflection
    return u @ np.diag([1.0, 1.0, d]) @ vt


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def body_rotation(landmarks: np.ndarray) -> np.ndarray:
    """R_body: columns are the body's forward, left and up axes in the landmarks' frame."""
    left_shoulder = point(landmarks, "left_shoulder")
    right_shoulder = point(landmarks, "right_shoulder")
    neck = (left_shoulder + right_shoulder) / 2
    mid_hip = (point(landmarks, "left_hip") + point(landmarks, "right_hip")) / 2
    v_shoulder = left_shoulder - right_shoulder
    v_body = mid_hip - neck
    v_back = np.cross(v_shoulder, v_body)
    return nearest_rotation(np.column_stack([_unit(-v_back), _unit(v_shoulder), _unit(-v_body)]))


def head_rotation(landmarks: np.ndarray) -> np.ndarray:
    """The head's forward, left and up axes: left from the ears, up from mouth to eyes."""
    left = point(landmarks, "left_ear") - point(landmarks, "right_ear")
    eyes = (point(landmarks, "left_eye") + point(landmarks, "right_eye")) / 2
    mouth = (point(landmarks, "mouth_left") + point(landmarks, "mouth_right")) / 2
    up = eyes - mouth
    return nearest_rotation(np.column_stack([_unit(np.cross(left, up)), _unit(left), _unit(up)]))


def euler_from_rotation(r: np.ndarray) -> tuple[float, float, float]:
    """(roll, pitch, yaw) [rad] with R = R_z(yaw) R_y(pitch) R_x(roll).

    At pitch ±π/2 roll and yaw turn about the same axis; the roll is then 0, which gives
    the same rotation."""
    pitch = math.asin(max(-1.0, min(1.0, -r[2, 0])))
    if abs(r[2, 0]) > 1.0 - 1e-9:
        return 0.0, pitch, math.atan2(-r[0, 1], r[1, 1])
    return math.atan2(r[2, 1], r[2, 2]), pitch, math.atan2(r[1, 0], r[0, 0])


def rotation_from_euler(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """R = R_z(yaw) R_y(pitch) R_x(roll): the joint convention's rotation."""
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch),
                              math.sin(pitch), math.cos(yaw), math.sin(yaw))  # fmt: skip
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def swing(from_dir: np.ndarray, to_dir: np.ndarray) -> np.ndarray:
    """The shortest rotation taking unit vector `from_dir` onto unit vector `to_dir`."""
    axis = np.cross(from_dir, to_dir)
    sin, cos = np.linalg.norm(axis), float(np.dot(from_dir, to_dir))
    if sin < 1e-12:
        # parallel: nothing to do; antiparallel: half a turn about any perpendicular axis
        return np.eye(3) if cos > 0 else rotation_from_euler(math.pi, 0.0, 0.0)
    k = axis / sin
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + sin * kx + (1 - cos) * (kx @ kx)


def limb_angles(
    upper: np.ndarray, lower: np.ndarray, hinge_sign: float
) -> tuple[tuple[float, float, float], float]:
    """Upper joint (roll, pitch, yaw) and hinge angle [rad] from body-frame segment vectors.

    At rest the segment hangs down (−z) and bends towards x (`hinge_sign` −1: the lower
    segment swings forward; +1: backward)."""
    down, low = _unit(upper), _unit(lower)
    bend = low - np.dot(low, down) * down  # the lower segment's part across the upper one
    hinge = math.atan2(np.linalg.norm(np.cross(down, low)), float(np.dot(down, low)))
    if np.linalg.norm(bend) < STRAIGHT_SIN:
        rotation = swing(DOWN, down)
    else:
        x = -hinge_sign * _unit(bend)  # the rest frame's x axis, carried along with the limb
        z = -down
        rotation = np.column_stack([x, np.cross(z, x), z])
    return euler_from_rotation(rotation), hinge


def joint_angles(landmarks: np.ndarray) -> dict[str, tuple[float, float, float]]:
    """(roll, pitch, yaw) [rad] per joint of `JOINTS` from (33, 3) landmarks."""
    to_body = body_rotation(landmarks).T  # R_body⁻¹
    angles = {"neck": euler_from_rotation(to_body @ head_rotation(landmarks))}
    for joint, hinge_joint, root, middle, end, sign in LIMBS:
        a, b, c = point(landmarks, root), point(landmarks, middle), point(landmarks, end)
        upper, hinge = limb_angles(to_body @ (b - a), to_body @ (c - b), sign)
        angles[joint] = upper
        angles[hinge_joint] = (0.0, sign * hinge, 0.0)
    return angles
