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

since p(τ) − p = ∫₀^τ Rz(wz s) (v + b min(s, ta)) ds: with C(t) = ∫₀^t Rz(wz s) ds =
t [[s1, −c1], [c1, s1]] and D(t) = ∫₀^t s Rz(wz s) ds, that is C(τ) u + (D(ta) − ta C(ta)) b,
and D(ta) − ta C(ta) is the second matrix. Each coefficient is computed in a form that keeps its
precision as x → 0: c1 = 2 sin²(x/2) / x, es = −c1 / x, ec by its series below |x| = 0.1.
"""

from __future__ import annotations

from math import pi as PI
from math import sin
from typing import NamedTuple

import numpy as np

from carlaverse.messages import Pose
from carlaverse.support.angles import wrap_angle, wrap_angles

SERIES_BELOW = 0.1  # [rad] |x| under which ec is its series (sin x − x cancels)
# A turn angle closer to 0 than this is replaced by it: every coefficient then takes its limit
# (s1 → 1, c1 → 0, es → −½, ec → 0) without a branch, and its square does not underflow.
NO_TURN = 1e-150  # [rad]


# ------------------------------------------------------------------ one actor


def project(p: Pose, dt: float) -> Pose:
    """The pose `dt` seconds after `p` (dt < 0: before it), by the module's model."""
    # Runs per remote actor per frame: locals, and no helper calls in the common case.
    vx, vy, vz, w = p.vx, p.vy, p.vz, p.wz
    bx, by, bz = p.ax + w * vy, p.ay - w * vx, p.az  # [m/s²] beyond the turn
    vb = vx * bx + vy * by + vz * bz
    vv = vx * vx + vy * vy + vz * vz
    stops = vv + vb * dt < 0.0  # the speed along v reaches zero within dt
    ta = -vv / vb if stops else dt
    ux, uy, uz = vx + bx * ta, vy + by * ta, vz + bz * ta  # turning frame
    x = w * dt
    x = NO_TURN if -NO_TURN < x < NO_TURN else x
    sx, h = sin(x), sin(0.5 * x)
    s1, c1 = sx / x, 2.0 * h * h / x
    cx = 1.0 - x * c1
    if stops:
        xa = w * ta  # the turn while b acts
        xa = NO_TURN if -NO_TURN < xa < NO_TURN else xa
        ha = sin(0.5 * xa)
        s1a, c1a = sin(xa) / xa, 2.0 * ha * ha / xa
        ax, ay, az = -w * uy, w * ux, 0.0  # b acts no more: the turn's own acceleration
    else:
        xa, s1a, c1a = x, s1, c1
        ax, ay, az = bx - w * uy, by + w * ux, bz
    es = -c1a / xa
    if -SERIES_BELOW < xa < SERIES_BELOW:
        x2 = xa * xa
        ec = xa * (-1 / 6 + x2 * (1 / 120 + x2 * (-1 / 5040 + x2 / 362880)))
    else:
        ec = (s1a - 1.0) / xa
    t2 = ta * ta
    # angles: nearly always in range already, so two comparisons instead of a division
    roll, pitch, yaw = p.roll + p.wx * dt, p.pitch + p.wy * dt, p.yaw + w * dt
    return Pose(
        p.seq, p.t + dt,
        p.x + dt * (s1 * ux - c1 * uy) + t2 * (es * bx - ec * by),
        p.y + dt * (c1 * ux + s1 * uy) + t2 * (ec * bx + es * by),
        p.z + dt * uz - 0.5 * t2 * bz,
        roll if -PI <= roll < PI else wrap_angle(roll),
        pitch if -PI <= pitch < PI else wrap_angle(pitch),
        yaw if -PI <= yaw < PI else wrap_angle(yaw),
        cx * ux - sx * uy, sx * ux + cx * uy, uz, p.wx, p.wy, w,
        cx * ax - sx * ay, sx * ax + cx * ay, az, flags=p.flags,
    )  # fmt: skip


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
    # Each numpy call costs about as much as its arithmetic at a few hundred actors: the
    # formulas are arranged for few calls (and the rare stopping actor costs a second pass).
    w = m.wz
    x = w * dt
    yaw = wrap_angles(m.yaw + x)
    sx, cx, s1, c1, es, ec = _turn(x)
    vx, vy = m.vx, m.vy
    if m.ax is None or m.ay is None:  # b = 0: constant turn rate and velocity
        px = m.x + dt * (s1 * vx - c1 * vy)
        py = m.y + dt * (c1 * vx + s1 * vy)
        return Projected(px, py, m.z + m.vz * dt, yaw, cx * vx - sx * vy, sx * vx + cx * vy,
                         m.vz)  # fmt: skip
    vz = m.vz
    bx, by, bz = m.ax + w * vy, m.ay - w * vx, m.az
    vb = vx * bx + vy * by + vz * bz
    vv = vx * vx + vy * vy + vz * vz
    ahead = vv + vb * dt  # < 0: the speed along v reaches zero within dt
    if ahead.min(initial=0.0) < 0.0:
        stops = ahead < 0.0
        ta: np.ndarray | float = np.where(stops, -vv / np.where(stops, vb, 1.0), dt)
        es, ec = _turn(w * ta)[4:]
    else:
        ta = dt
    ux, uy, uz = vx + bx * ta, vy + by * ta, vz + bz * ta
    t2 = ta * ta
    px = m.x + dt * (s1 * ux - c1 * uy) + t2 * (es * bx - ec * by)
    py = m.y + dt * (c1 * ux + s1 * uy) + t2 * (ec * bx + es * by)
    pz = m.z + dt * uz - 0.5 * t2 * bz
    return Projected(px, py, pz, yaw, cx * ux - sx * uy, sx * ux + cx * uy, uz)


def _turn(x: np.ndarray) -> tuple[np.ndarray, ...]:
    """sin x, cos x, s1, c1, es and ec of turns by x [rad]."""
    if np.abs(x).max(initial=0.0) < SERIES_BELOW:  # nearly always: |wz dt| is small
        # Their series in y = x², no sine (the sine of a thousand angles costs as much as
        # twenty products): s1 = 1 + y·q, ec = x·q, c1 = x·k, es = −k; each is exact to
        # double precision below |x| = 0.1 (the first term left out is under 2e-15 of it).
        y = x * x
        q = -1 / 6 + y * (1 / 120 + y * (-1 / 5040 + y / 362880))
        k = 0.5 + y * (-1 / 24 + y * (1 / 720 + y * (-1 / 40320 + y / 3628800)))
        s1 = 1.0 + y * q
        return x * s1, 1.0 - y * k, s1, x * k, -k, x * q
    x = np.where(np.abs(x) < NO_TURN, NO_TURN, x)
    sx, h = np.sin(x), np.sin(0.5 * x)
    s1, c1 = sx / x, 2.0 * (h * h) / x
    x2 = x * x
    series = x * (-1 / 6 + x2 * (1 / 120 + x2 * (-1 / 5040 + x2 / 362880)))
    ec = np.where(np.abs(x) < SERIES_BELOW, series, (s1 - 1.0) / x)
    return sx, 1.0 - x * c1, s1, c1, -c1 / x, ec
