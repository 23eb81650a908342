"""A pure-pursuit driver: the honest scripted driver of the `sim` input.

It sees what a human sees (where the vehicle is, where the road goes, how fast it is going)
and answers with what a human does (steering-wheel angle, throttle, brake), so the vehicle's
own physics stays in the loop. Steering follows pure pursuit on the kinematic bicycle:
δ = atan(2 L sin α / l_d), with α the heading error to the look-ahead point; speed follows a
proportional controller that brakes to a stop at the end of the path.
"""

from __future__ import annotations

import itertools
import math
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct

Positive = Annotated[float, msgspec.Meta(gt=0)]

# The headless nodes' scripted lap: a rounded 120 m × 80 m block starting at the spawn.
_BLOCK = [(0, 0), (50, 0), (60, 10), (60, 70), (50, 80), (-50, 80), (-60, 70), (-60, 10), (-50, 0)]


def scripted_route(laps: int = 3) -> list[tuple[float, float]]:
    """Waypoints [m] of `laps` laps of the block, ending back at the spawn (spawn frame)."""
    return [(float(x), float(y)) for _ in range(laps) for x, y in _BLOCK] + [(0.0, 0.0)]


class PathFollow(StrictStruct):
    waypoints: Annotated[list[tuple[float, float]], msgspec.Meta(min_length=2)]  # [m] x, y
    target_speed_mps: Annotated[float, msgspec.Meta(ge=0)] = 8.0  # [m/s]
    lookahead_m: Positive = 6.0  # [m]
    wheelbase_m: Positive = 2.8  # [m]
    max_steer_rad: Positive = 0.6  # [rad] road-wheel angle that steer = ±1 stands for
    speed_gain: Positive = 0.5  # [1/(m/s)] pedal per m/s of speed error
    stop_distance_m: Positive = 10.0  # [m] start braking to a stop this far from the end
    steer_axis: str = "steer"
    throttle_axis: str = "throttle"
    brake_axis: str = "brake"


class VehicleState(msgspec.Struct, frozen=True):
    x: float  # [m]
    y: float  # [m]
    yaw: float  # [rad] counter-clockwise from +x
    speed: float  # [m/s]


class PurePursuit:
    """Tracks progress along the path; `controls` maps a vehicle state to pedal and wheel."""

    def __init__(self, path: PathFollow) -> None:
        self.path = path
        self.index = 0  # nearest waypoint so far; only moves forward
        self.arc_m = [0.0]  # [m] path length from the first waypoint to each waypoint
        for a, b in itertools.pairwise(path.waypoints):
            self.arc_m.append(self.arc_m[-1] + math.dist(a, b))

    def controls(self, state: VehicleState) -> dict[str, float]:
        self._advance(state)
        target = self._lookahead_point(state)
        alpha = math.atan2(target[1] - state.y, target[0] - state.x) - state.yaw
        distance = max(math.hypot(target[0] - state.x, target[1] - state.y), 1e-6)
        delta = math.atan2(2 * self.path.wheelbase_m * math.sin(alpha), distance)  # [rad]
        pedal = self.path.speed_gain * (self._speed_goal(state) - state.speed)
        return {
            self.path.steer_axis: max(-1.0, min(1.0, delta / self.path.max_steer_rad)),
            self.path.throttle_axis: max(0.0, min(1.0, pedal)),
            self.path.brake_axis: max(0.0, min(1.0, -pedal)),
        }

    def _advance(self, state: VehicleState) -> None:
        points = self.path.waypoints
        best = min(
            range(self.index, min(len(points), self.index + 50)),
            key=lambda i: math.hypot(points[i][0] - state.x, points[i][1] - state.y),
        )
        self.index = best

    def _lookahead_point(self, state: VehicleState) -> tuple[float, float]:
        points = self.path.waypoints
        for point in points[self.index :]:
            if math.hypot(point[0] - state.x, point[1] - state.y) >= self.path.lookahead_m:
                return point
        return points[-1]

    def _speed_goal(self, state: VehicleState) -> float:
        """Target speed, ramped down to 0 over the stop distance before the last waypoint."""
        nearest = self.path.waypoints[self.index]
        to_nearest = math.hypot(nearest[0] - state.x, nearest[1] - state.y)
        remaining = self.arc_m[-1] - self.arc_m[self.index] + to_nearest  # [m]
        fraction = min(1.0, remaining / self.path.stop_distance_m)
        return self.path.target_speed_mps * fraction
