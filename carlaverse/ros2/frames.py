"""The session's frames in ROS terms (REP 103, REP 105).

The session's world frame is the road network's: x east, y north, z up [m] -- ENU, which is
REP 103's `map` frame as it stands, so positions pass unchanged. A pose's angles are ISO 8855
(x forward, y left, z up; roll right-side-down positive, pitch nose-down positive, yaw
counter-clockwise from +x), which are REP 103's body axes and its right-handed roll, pitch and
yaw about them: the orientation is the quaternion of yaw about z, then pitch about the new y,
then roll about the new x. Odometry's twist is in the child (body) frame (REP 105), so the
world-frame velocities of a pose are turned into the body frame and back.
"""

from __future__ import annotations

import math

Quaternion = tuple[float, float, float, float]  # (x, y, z, w)
Vec3 = tuple[float, float, float]
Matrix = tuple[Vec3, Vec3, Vec3]


def quaternion_from_rpy(roll: float, pitch: float, yaw: float) -> Quaternion:
    """The unit quaternion of intrinsic z-y'-x'' rotations (yaw, pitch, roll) [rad]."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def rpy_from_quaternion(q: Quaternion) -> Vec3:
    """(roll, pitch, yaw) [rad] of a quaternion (normalised here); pitch clamped at ±90°."""
    x, y, z, w = q
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if not norm > 0 or not math.isfinite(norm):
        raise ValueError(f"quaternion {q} has no direction")
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def rotation(roll: float, pitch: float, yaw: float) -> Matrix:
    """Rows of R = Rz(yaw) Ry(pitch) Rx(roll): body vector -> world vector."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return (
        (cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr),
        (sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr),
        (-sp, cp * sr, cp * cr),
    )


def to_body(r: Matrix, v: Vec3) -> Vec3:
    """A world-frame vector in the body frame (Rᵀ v)."""
    return (
        r[0][0] * v[0] + r[1][0] * v[1] + r[2][0] * v[2],
        r[0][1] * v[0] + r[1][1] * v[1] + r[2][1] * v[2],
        r[0][2] * v[0] + r[1][2] * v[1] + r[2][2] * v[2],
    )


def to_world(r: Matrix, v: Vec3) -> Vec3:
    """A body-frame vector in the world frame (R v)."""
    return (
        r[0][0] * v[0] + r[0][1] * v[1] + r[0][2] * v[2],
        r[1][0] * v[0] + r[1][1] * v[1] + r[1][2] * v[2],
        r[2][0] * v[0] + r[2][1] * v[1] + r[2][2] * v[2],
    )


def stamp(t: float) -> dict[str, int]:
    """builtin_interfaces/Time of a session time [s] (Unix-aligned, so it is ROS time)."""
    sec = math.floor(t)  # split first: t * 1e9 would round away ~100 ns at Unix times
    nanosec = round((t - sec) * 1e9)
    if nanosec == 1_000_000_000:
        sec, nanosec = sec + 1, 0
    return {"sec": max(-(2**31), min(2**31 - 1, sec)), "nanosec": nanosec}


def seconds(time: dict[str, int]) -> float:
    return time["sec"] + time["nanosec"] * 1e-9
