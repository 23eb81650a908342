"""Head poses from OpenXR's stage frame into the world frame and into Unreal's (CARLA's).

OpenXR (right-handed): +x right, +y up, −z forward. The world (right-handed, the road
network's): x east, y north, z up; an actor's yaw counter-clockwise from east, pitch nose
down positive, roll right side down positive (ISO 8855, as `Pose` and the renderer use).
Unreal/CARLA (left-handed): +x forward, +y right, +z up; `carla.Rotation(pitch, yaw, roll)` in
degrees, yaw clockwise seen from above, pitch nose up positive, roll right side down positive.

The stage sits in the world at `StageAnchor` (its origin, and the world yaw its −z faces).

Unreal: the paper splits the OpenXR quaternion into intrinsic YZX Euler angles (a about +y,
then b about the new +z, then c about the new +x) and inverts the handedness by negating two
of them. Read about OpenXR's +y, +z and +x, a head turned left gives a > 0, one looking up
c > 0, one tilted onto its left ear b > 0; in Unreal the head turned left has yaw < 0,
looking up pitch > 0, tilted left roll < 0. So yaw = −a, pitch = c, roll = −b (the paper says
"pitch and roll": it reads the angles about Unreal's axes, where forward is OpenXR's −z and
FRotator counts pitch and roll against the right-hand rule — the same two flips).
`unreal_rotation_yzx` is that reading. `carla.Rotation` however composes yaw, then pitch,
then roll (about OpenXR's y, x, z: YXZ), so YZX angles are exact only while pitch or roll is
zero; with both (a head nodding while tilted) the camera turns wrong — by 16° of yaw at 30°
pitch and 30° roll (tests/walk/test_xr_maths.py). `unreal_rotation` decomposes in
FRotator's own order and is exact; the walk node turns heads into the world frame
(`openxr_to_world`) and a CARLA camera from there (`render/carla_bridge.to_unreal`), which is
the same rotation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from carlaverse.support.angles import wrap_angle, wrap_degrees

Quaternion = tuple[float, float, float, float]  # (w, x, y, z)
Matrix = tuple[tuple[float, float, float], ...]


@dataclass(frozen=True, slots=True)
class StageAnchor:
    x: float = 0.0  # [m] world position of the stage origin
    y: float = 0.0
    yaw: float = 0.0  # [rad] world yaw of the stage's forward (−z) axis


@dataclass(frozen=True, slots=True)
class WorldHead:
    """The head in the world: position [m] and ISO 8855 angles [rad]."""

    x: float
    y: float
    z: float
    yaw: float
    pitch: float
    roll: float


def quaternion_matrix(q: Quaternion) -> Matrix:
    """Rotation matrix of a unit quaternion (w, x, y, z); normalised first."""
    w, x, y, z = q
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if n == 0:
        raise ValueError("zero quaternion: no orientation")
    w, x, y, z = w / n, x / n, y / n, z / n
    return (
        (1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
        (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
        (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
    )


def stage_to_body(v: tuple[float, float, float]) -> tuple[float, float, float]:
    """An OpenXR stage vector in (forward, left, up) components."""
    return (-v[2], -v[0], v[1])


def openxr_to_world(
    position: tuple[float, float, float], orientation: Quaternion, stage: StageAnchor
) -> WorldHead:
    """The head pose in the world frame."""
    r = quaternion_matrix(orientation)
    column = lambda j: (r[0][j], r[1][j], r[2][j])  # noqa: E731  head axis j in stage coords
    back, right = column(2), column(0)  # the head's +z and +x
    forward = stage_to_body((-back[0], -back[1], -back[2]))  # the head's −z
    left = stage_to_body((-right[0], -right[1], -right[2]))  # the head's −x
    up = stage_to_body(column(1))
    yaw_in_stage = math.atan2(forward[1], forward[0])
    pitch = -math.asin(max(-1.0, min(1.0, forward[2])))  # nose down positive
    roll = math.atan2(left[2], up[2])  # right side down positive: the left side rises
    f, lt, u = stage_to_body(position)
    c, s = math.cos(stage.yaw), math.sin(stage.yaw)
    return WorldHead(
        stage.x + f * c - lt * s, stage.y + f * s + lt * c, u,
        wrap_angle(stage.yaw + yaw_in_stage), pitch, roll,
    )  # fmt: skip


def yzx_euler(orientation: Quaternion) -> tuple[float, float, float]:
    """Intrinsic YZX angles (a, b, c) [rad]: R = Ry(a)·Rz(b)·Rx(c) in OpenXR's axes."""
    r = quaternion_matrix(orientation)
    # Ry(a)Rz(b)Rx(c): r10 = sin b, r11 = cos b cos c, r12 = −cos b sin c,
    # r00 = cos a cos b, r20 = −sin a cos b.
    b = math.asin(max(-1.0, min(1.0, r[1][0])))
    a = math.atan2(-r[2][0], r[0][0])
    c = math.atan2(-r[1][2], r[1][1])
    return a, b, c


def yxz_euler(orientation: Quaternion) -> tuple[float, float, float]:
    """Intrinsic YXZ angles (a, c, b) [rad]: R = Ry(a)·Rx(c)·Rz(b) — yaw, pitch, roll."""
    r = quaternion_matrix(orientation)
    # Ry(a)Rx(c)Rz(b): r12 = −sin c, r02 = sin a cos c, r22 = cos a cos c,
    # r10 = cos c sin b, r11 = cos c cos b.
    c = math.asin(max(-1.0, min(1.0, -r[1][2])))
    a = math.atan2(r[0][2], r[2][2])
    b = math.atan2(r[1][0], r[1][1])
    return a, c, b


@dataclass(frozen=True, slots=True)
class UnrealRotation:
    """`carla.Rotation` fields [deg]."""

    pitch: float
    yaw: float
    roll: float


def _unreal(a: float, b: float, c: float, stage_yaw_deg: float) -> UnrealRotation:
    """Yaw a, roll b, pitch c about OpenXR's +y, +z, +x [rad] as Unreal degrees."""
    return UnrealRotation(
        pitch=math.degrees(c), yaw=wrap_degrees(stage_yaw_deg - math.degrees(a)),
        roll=-math.degrees(b),
    )  # fmt: skip


def unreal_rotation_yzx(orientation: Quaternion, stage_yaw_deg: float = 0.0) -> UnrealRotation:
    """The paper's reading: YZX Euler angles, handedness inverted (see the module docstring).

    `stage_yaw_deg` is the Unreal yaw the stage's forward faces (Unreal degrees, clockwise).
    """
    a, b, c = yzx_euler(orientation)
    return _unreal(a, b, c, stage_yaw_deg)


def unreal_rotation(orientation: Quaternion, stage_yaw_deg: float = 0.0) -> UnrealRotation:
    """The head's rotation as `carla.Rotation` composes it (yaw, pitch, roll): exact."""
    a, c, b = yxz_euler(orientation)
    return _unreal(a, b, c, stage_yaw_deg)
