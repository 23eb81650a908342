"""How an actor moved between the frames it was drawn in: wheels roll, steer and legs walk by it.

The world sends poses; NPC rows add a velocity and a yaw rate, an own vehicle's loop its speed
and road-wheel angle. What is not sent is taken from the actor's own motion between the
frames the renderer draws (`Motion.advance`):

- rolled distance: the displacement along the heading, summed (negative in reverse). A wheel
  of radius r rolling without slip turns by rolled / r, so the picture never shows it slip.
- walked distance: the path length, summed; a walker's gait advances with it.
- speed and yaw rate: the last step's displacement and turn over its time.

A step longer than `MAX_STEP_S`, one back in time or one faster than `MAX_SPEED_MPS` is a jump
(a seek in a recording, a respawn): nothing rolls or walks over it.

The road-wheel angle, where it is not sent, comes from the kinematic bicycle model: a vehicle
of wheelbase L turning at yaw rate ω at speed v without tyre slip steers δ = atan(L·ω / v)
(Rajamani, Vehicle Dynamics and Control, 2nd ed., §2.2, with the reference at the rear axle;
at the centre of the box the difference is under 2 % for the angles of road driving). Below
`MIN_STEER_SPEED_MPS` the yaw rate says nothing about the steer: the last angle holds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from carlaverse.support.angles import wrap_angle

MAX_STEP_S = 0.5  # [s] a longer gap between two frames is a jump, not a motion
MAX_SPEED_MPS = 70.0  # [m/s] a step faster than this is a teleport
MIN_STEER_SPEED_MPS = 0.5  # [m/s] below this the steer holds its last angle
MAX_ROAD_WHEEL_RAD = math.radians(35.0)  # full lock, as the vehicle configs' default


def kinematic_steer(wheelbase_m: float, yaw_rate: float, speed: float) -> float:
    """δ = atan(L·ω / v) [rad], left positive, limited to full lock; 0 when v is 0."""
    if speed == 0.0:
        return 0.0
    delta = math.atan(wheelbase_m * yaw_rate / speed)
    return max(-MAX_ROAD_WHEEL_RAD, min(MAX_ROAD_WHEEL_RAD, delta))


@dataclass(slots=True)
class Motion:
    """One actor's motion as seen frame by frame (world frame, SI units)."""

    t: float | None = None  # [s] the last frame's time
    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    rolled_m: float = 0.0  # along the heading, signed
    walked_m: float = 0.0  # path length
    speed_mps: float = 0.0  # the last step's, along the heading
    yaw_rate: float = 0.0  # [rad/s] the last step's
    steer: float = 0.0  # [rad] the last road-wheel angle derived

    def advance(self, t: float, x: float, y: float, yaw: float) -> None:
        """Take the actor's pose at frame time `t` [s]."""
        dt = t - self.t if self.t is not None else 0.0
        dx, dy = x - self.x, y - self.y
        moved = math.hypot(dx, dy)
        if 0.0 < dt <= MAX_STEP_S and moved <= MAX_SPEED_MPS * dt:
            mean_yaw = self.yaw + wrap_angle(yaw - self.yaw) / 2
            along = dx * math.cos(mean_yaw) + dy * math.sin(mean_yaw)
            self.rolled_m += along
            self.walked_m += moved
            self.speed_mps = along / dt
            self.yaw_rate = wrap_angle(yaw - self.yaw) / dt
        elif dt != 0.0:  # a jump: the estimates of the last step no longer hold
            self.speed_mps = self.yaw_rate = 0.0
        self.t, self.x, self.y, self.yaw = t, x, y, yaw

    def road_wheel_angle(self, wheelbase_m: float, speed: float, yaw_rate: float) -> float:
        """δ from the kinematic bicycle model, held below MIN_STEER_SPEED_MPS [rad]."""
        if abs(speed) >= MIN_STEER_SPEED_MPS:
            self.steer = kinematic_steer(wheelbase_m, yaw_rate, speed)
        return self.steer
