"""Artificial locomotion: the thumbstick's 2D vector, turned into a world velocity along the
walker's forward direction (head yaw or the moving hand's), with walk/run speed limits and
limited acceleration, as the paper's Control Process maps OpenXR action vectors.

Frames: the stick is (x right, y forward) in -1..1; the world is x east, y north; yaw is
counter-clockwise from east [rad].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Literal

import msgspec

from carlaverse.config import StrictStruct

Positive = Annotated[float, msgspec.Meta(gt=0)]
Fraction = Annotated[float, msgspec.Meta(ge=0, lt=1)]


class GaitSettings(StrictStruct):
    walk_speed_mps: Positive = 1.4  # [m/s] full stick, a brisk urban walk
    run_speed_mps: Positive = 3.0  # [m/s] full stick with `run` held
    accel_mps2: Positive = 1.5  # [m/s²] speeding up (a pedestrian reaches 1.4 m/s in ~1 s)
    decel_mps2: Positive = 3.0  # [m/s²] slowing down and turning
    dead_zone: Fraction = 0.1  # stick deflection read as zero (worn sticks drift)
    direction: Literal["head", "controller"] = "head"  # what "forward" on the stick means


def stick_velocity(
    stick: tuple[float, float], heading: float, speed_limit_mps: float, dead_zone: float
) -> tuple[float, float]:
    """World velocity [m/s] the stick asks for: forward along `heading`, right across it.

    The deflection beyond the dead zone is rescaled to 0..1, so the smallest push walks slowly
    instead of jumping to a tenth of the speed.
    """
    sx, sy = stick
    norm = math.hypot(sx, sy)
    if norm <= dead_zone:
        return 0.0, 0.0
    scale = min(1.0, (norm - dead_zone) / (1.0 - dead_zone)) / norm
    forward, right = sy * scale * speed_limit_mps, sx * scale * speed_limit_mps
    c, s = math.cos(heading), math.sin(heading)
    return forward * c + right * s, forward * s - right * c


def limit_acceleration(
    velocity: tuple[float, float],
    goal: tuple[float, float],
    accel: float,
    decel: float,
    dt_s: float,
) -> tuple[float, float]:
    """The velocity after `dt_s` moving toward `goal` [m/s] by at most the allowed change.

    Speeding up is limited by `accel`, anything else (slowing, turning) by `decel` [m/s²].
    """  # fmt: skip
    dvx, dvy = goal[0] - velocity[0], goal[1] - velocity[1]
    change = math.hypot(dvx, dvy)
    speeding_up = math.hypot(*goal) > math.hypot(*velocity)
    allowed = (accel if speeding_up else decel) * dt_s
    if change <= allowed:
        return goal
    k = allowed / change
    return velocity[0] + k * dvx, velocity[1] + k * dvy


@dataclass
class Walker:
    """Where the stage (the tracked room) stands in the world, moved by locomotion.

    The head walks around inside the stage one to one; the thumbstick moves the stage.
    """

    x: float = 0.0  # [m] the stage origin in the world
    y: float = 0.0
    stage_yaw: float = 0.0  # [rad] where the stage's forward (OpenXR −z) points in the world
    vx: float = 0.0  # [m/s] locomotion velocity
    vy: float = 0.0
    ax: float = 0.0  # [m/s²]
    ay: float = 0.0

    def place(self, x: float, y: float, yaw: float) -> None:
        self.x, self.y, self.stage_yaw = x, y, yaw
        self.vx = self.vy = self.ax = self.ay = 0.0

    def step(self, gait: GaitSettings, stick: tuple[float, float], run: bool, heading: float,
             dt_s: float) -> None:  # fmt: skip
        """Advance the stage by `dt_s` [s] under the stick, walking toward `heading` [rad]."""
        limit = gait.run_speed_mps if run else gait.walk_speed_mps
        goal = stick_velocity(stick, heading, limit, gait.dead_zone)
        vx, vy = limit_acceleration((self.vx, self.vy), goal, gait.accel_mps2,
                                    gait.decel_mps2, dt_s)  # fmt: skip
        if dt_s > 0:
            self.ax, self.ay = (vx - self.vx) / dt_s, (vy - self.vy) / dt_s
        self.vx, self.vy = vx, vy
        self.x += vx * dt_s
        self.y += vy * dt_s

    def shift(self, dx: float, dy: float) -> None:
        """Move the stage without walking (a correction back onto walkable ground)."""
        self.x += dx
        self.y += dy
