"""Dead reckoning: where an actor is `dt` seconds after a sample of its motion.

One motion model for every place that projects an actor — the authority's tick (`egos_at`),
the traffic engine between its steps (`NpcFrame.at`), a node's world view (`RemoteActor`,
`NpcTable`) — so the collision check and every screen put the same actor at the same place.
`project` moves one `Pose`; `project_many` moves columns of many actors at once, with the
same arithmetic (tests/test_dead_reckoning.py holds the two to 1e-9).

The model: constant turn rate and acceleration (CTRA), in the world frame of `messages`.

- The horizontal velocity turns at the yaw rate `wz`: an actor sampled on a circle stays on
  that circle (the constant-velocity model would leave it along the tangent).
- The part of the sampled acceleration the turn does not explain, b = a − wz ẑ × v (speeding
  up or braking), is held in the turning frame: v(τ) = Rz(wz τ) (v + b τ). On a circle
  b = 0; with wz = 0 this is constant acceleration (DIS's FVW model). At τ = 0 the model's
  acceleration is the sampled one, so it agrees with FVW to second order, and improves on it
  when the actor turns.
- A braking actor is not projected into reverse: b is followed only until the speed along the
  sampled velocity would reach zero (t* = −|v|² / (v·b), when t* lies between 0 and dt,
  forward or back in time), then the actor coasts at what is left, still turning.
- z moves with vz and b's vertical part; roll, pitch and yaw advance at wx, wy, wz and are
  wrapped to [−π, π).
- NPC rows (`messages.NPC_DTYPE`) carry no acceleration and no vertical speed: their
  acceleration is unknown, not zero, so it is taken to be the turn's own (b = 0: constant
  turn rate and velocity, CTRV).

Position after τ (ta = τ, or t* for a stopping actor; u = v + b ta; x = wz τ, xa = wz ta):

    p(τ) = p + τ [[s1, −c1], [c1, s1]](x) u + ta² [[es, −ec], [ec, es]](xa) b
    s1 = sin x / x     c1 = (1 − cos x) / x     es = (cos x − 1) / x²     ec = (sin x − x) / x²

(τ·[[s1, −c1], [c1, s1]] is ∫₀^τ Rz(wz s) ds; the second term is what b adds, derived in the
test). Each coefficient is written in a form that keeps its precision as x → 0.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from carlaverse.messages import Pose

SERIES_BELOW = 0.1  # [rad] |x| under which ec uses its series (sin x − x cancels)
# A turn angle of exactly 0 is replaced by this: every coefficient then takes its limit (sin x
# / x = 1, ...) without a branch, and yaw + 1e-300 is yaw.
NO_TURN = 1e-300  # [rad]


def wrap_angle(a: float) -> float:
    """Map an angle [rad] to [−π, π)."""
    return a - 2 * math.pi * math.floor((a + math.pi) / (2 * math.pi))


def wrap_angles(a: np.ndarray) -> np.ndarray:
    """`wrap_angle` for an array of angles."""
    return a - 2 * np.pi * np.floor((a + np.pi) / (2 * np.pi))


# ------------------------------------------------------------------ one actor


def project(p: Pose, dt: float) -> Pose:
    """The pose `dt` seconds after `p` (dt < 0: before it), by the module's model."""
    w = p.wz
    bx, by, bz = p.ax + w * p.vy, p.ay - w * p.vx, p.az  # [m/s²] beyond the turn
    vb = p.vx * bx + p.vy * by + p.vz * bz
    vv = p.vx * p.vx + p.vy * p.vy + p.vz * p.vz
    stops = vv < -vb * dt  # the speed along v reaches zero within dt
    ta = -vv / vb if stops else dt
    ux, uy, uz = p.vx + bx * ta, p.vy + by * ta, p.vz + bz * ta  # turning frame
    x = w * dt or NO_TURN
    sx, h = math.sin(x), math.sin(0.5 * x)
    cx, s1, c1 = 1.0 - 2.0 * h * h, sx / x, 2.0 * h * h / x
    es, ec = _lag(w * ta or NO_TURN) if stops else _lag(x, sx, h)
    t2 = ta * ta
    kx, ky = (0.0, 0.0) if stops else (bx, by)  # what b still adds to the acceleration
    ax, ay = kx - w * uy, ky + w * ux
    return Pose(
        p.seq, p.t + dt,
        p.x + dt * (s1 * ux - c1 * uy) + t2 * (es * bx - ec * by),
        p.y + dt * (c1 * ux + s1 * uy) + t2 * (ec * bx + es * by),
        p.z + dt * uz - 0.5 * t2 * bz,
        wrap_angle(p.roll + p.wx * dt), wrap_angle(p.pitch + p.wy * dt),
        wrap_angle(p.yaw + w * dt),
        cx * ux - sx * uy, sx * ux + cx * uy, uz, p.wx, p.wy, w,
        cx * ax - sx * ay, sx * ax + cx * ay, 0.0 if stops else bz, flags=p.flags,
    )  # fmt: skip


def _lag(x: float, sx: float | None = None, h: float | None = None) -> tuple[float, float]:
    """es and ec of a turn by x ≠ 0 [rad] (sin x and sin(x/2) where already known)."""
    sx = math.sin(x) if sx is None else sx
    h = (math.sin(0.5 * x) if h is None else h) / (0.5 * x)
    if abs(x) < SERIES_BELOW:
        x2 = x * x
        return -0.5 * h * h, x * (-1 / 6 + x2 * (1 / 120 + x2 * (-1 / 5040 + x2 / 362880)))
    return -0.5 * h * h, (sx - x) / x / x


# ------------------------------------------------------------------ many actors


class Motion(NamedTuple):
    """Many actors' samples as columns (float64 arrays of one length, or floats), world frame.

    `ax` None: the acceleration was not measured (NPC rows), taken as the turn's own."""

    x: np.ndarray  # [m]
    y: np.ndarray  # [m]
    z: np.ndarray  # [m]
    yaw: np.ndarray  # [rad]
    vx: np.ndarray  # [m/s]
    vy: np.ndarray  # [m/s]
    vz: np.ndarray | float  # [m/s]
    wz: np.ndarray  # [rad/s] yaw rate
    ax: np.ndarray | None = None  # [m/s²]
    ay: np.ndarray | None = None  # [m/s²]
    az: np.ndarray | float = 0.0  # [m/s²]


class Projected(NamedTuple):
    """Many actors at the projected time (roll, pitch and the acceleration are left out:
    none of the array users draws or checks them)."""

    x: np.ndarray  # [m]
    y: np.ndarray  # [m]
    z: np.ndarray  # [m]
    yaw: np.ndarray  # [rad]
    vx: np.ndarray  # [m/s]
    vy: np.ndarray  # [m/s]
    vz: np.ndarray | float  # [m/s]


def npc_motion(rows: np.ndarray) -> Motion:
    """The motion of NPC rows (`messages.NPC_DTYPE`): no acceleration, no vertical speed."""
    f = np.float64
    return Motion(rows["x"].astype(f), rows["y"].astype(f), rows["z"].astype(f),
                  rows["yaw"].astype(f), rows["vx"].astype(f), rows["vy"].astype(f), 0.0,
                  rows["yaw_rate"].astype(f))  # fmt: skip


def project_many(m: Motion, dt: np.ndarray | float) -> Projected:
    """`project` for every actor of `m`, each by its `dt` [s] (an array, or one for all)."""
    w = m.wz
    x = _nonzero(w * dt)
    sx, h = np.sin(x), np.sin(0.5 * x)
    h2 = h * h
    cx, s1, c1 = 1.0 - 2.0 * h2, sx / x, 2.0 * h2 / x
    yaw = wrap_angles(m.yaw + x)
    if m.ax is None or m.ay is None:  # b = 0: constant turn rate and velocity
        ux, uy = m.vx, m.vy
        px = m.x + dt * (s1 * ux - c1 * uy)
        py = m.y + dt * (c1 * ux + s1 * uy)
        return Projected(px, py, m.z + m.vz * dt, yaw, cx * ux - sx * uy, sx * ux + cx * uy,
                         m.vz)  # fmt: skip
    bx, by, bz = m.ax + w * m.vy, m.ay - w * m.vx, m.az
    vb = m.vx * bx + m.vy * by + m.vz * bz
    vv = m.vx * m.vx + m.vy * m.vy + m.vz * m.vz
    stops = vv < -vb * dt
    if stops.any():
        ta = np.where(stops, -vv / np.where(stops, vb, 1.0), dt)
        es, ec = _lag_many(_nonzero(w * ta))
    else:
        ta = dt
        es, ec = _lag_many(x, sx, h)
    ux, uy, uz = m.vx + bx * ta, m.vy + by * ta, m.vz + bz * ta
    t2 = ta * ta
    px = m.x + dt * (s1 * ux - c1 * uy) + t2 * (es * bx - ec * by)
    py = m.y + dt * (c1 * ux + s1 * uy) + t2 * (ec * bx + es * by)
    pz = m.z + dt * uz - 0.5 * t2 * bz
    return Projected(px, py, pz, yaw, cx * ux - sx * uy, sx * ux + cx * uy, uz)


def _nonzero(x: np.ndarray) -> np.ndarray:
    return np.where(x == 0.0, NO_TURN, x)


def _lag_many(
    x: np.ndarray, sx: np.ndarray | None = None, h: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """`_lag` for turns by x ≠ 0 [rad]."""
    sx = np.sin(x) if sx is None else sx
    h = (np.sin(0.5 * x) if h is None else h) / (0.5 * x)
    x2 = x * x
    series = x * (-1 / 6 + x2 * (1 / 120 + x2 * (-1 / 5040 + x2 / 362880)))
    return -0.5 * h * h, np.where(np.abs(x) < SERIES_BELOW, series, (sx - x) / x / x)
