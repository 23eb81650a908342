"""Small kinematic helpers shared by the renderers: angle wrapping and dead reckoning."""

from __future__ import annotations

import math

from carlaverse.messages import Pose


def wrap_angle(a: float) -> float:
    """Map an angle to (−π, π]."""
    return a - 2 * math.pi * math.floor((a + math.pi) / (2 * math.pi))


def project(p: Pose, dt: float) -> Pose:
    """Dead-reckon `p` by `dt` seconds with its velocity and acceleration (DIS's FVW model).

    A braking actor is not projected into reverse: the deceleration is followed only until
    the velocity along its current direction would reach zero (t* = |v|² / −(v·a)), then the
    actor coasts at what is left — a stopping car stops instead of backing up. Turning
    (a ⟂ v, as on a circle) never triggers it.
    """
    va = p.vx * p.ax + p.vy * p.ay + p.vz * p.az
    vv = p.vx * p.vx + p.vy * p.vy + p.vz * p.vz
    accel_t = dt
    if va < 0 and vv < -va * dt:
        accel_t = max(0.0, vv / -va)
    h = 0.5 * accel_t * accel_t
    vx, vy, vz = p.vx + p.ax * accel_t, p.vy + p.ay * accel_t, p.vz + p.az * accel_t
    coast = dt - accel_t
    return Pose(
        p.seq, p.t + dt,
        p.x + p.vx * accel_t + p.ax * h + vx * coast,
        p.y + p.vy * accel_t + p.ay * h + vy * coast,
        p.z + p.vz * accel_t + p.az * h + vz * coast,
        wrap_angle(p.roll + p.wx * dt), wrap_angle(p.pitch + p.wy * dt),
        wrap_angle(p.yaw + p.wz * dt),
        vx, vy, vz, p.wx, p.wy, p.wz, p.ax, p.ay, p.az, flags=p.flags,
    )  # fmt: skip
