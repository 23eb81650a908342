"""A pure-pursuit driver: the honest scripted driver of the `sim` input.

It sees what a human sees (where the vehicle is, where the road goes, how fast it is going)
and answers with what a human does (steering-wheel angle, throttle, brake), so the vehicle's
own physics stays in the loop. Steering follows pure pursuit on the kinematic bicycle:
δ = atan(2 L sin α / l_d), with α the heading error to the look-ahead point; speed follows a
proportional controller that brakes to a stop at the end of the path, and, with
`corner_accel_mps2`, slows for bends ahead (`speed_plan`). Pure pursuit cuts a bend's corner
by about l_d²/(2R); with `lookahead_time_s` the look-ahead shrinks with the speed, so a slow
turn at a junction keeps nearer its lane. A path with `loop_from` never
ends: after its last waypoint it goes on at that one (0: a closed loop).

`map_lanes` asks the node for a route along the session map's lanes (`traffic.lane_route`):
the node plans it from its spawn and hands it to the driver (`SimInput.follow`); the
configured waypoints are then driven only in a session without a map.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from typing import Annotated, Literal

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.hal.input.speed_plan import corner_speeds

Positive = Annotated[float, msgspec.Meta(gt=0)]
MIN_LOOKAHEAD_M = 2.5  # [m] the nearest a speed-scaled look-ahead comes

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
    loop_from: Annotated[int, msgspec.Meta(ge=0)] | None = None  # after the last, go on here
    corner_accel_mps2: Positive | None = None  # [m/s²] bends no faster than √(a·R); None: off
    brake_decel_mps2: Positive = 2.5  # [m/s²] slowing planned before a bend
    map_lanes: Literal["none", "car", "bike"] = "none"  # keep to the map's lanes of this kind
    route_seed: int | None = None  # the route's turns (None: from the node id)
    lookahead_time_s: Positive | None = None  # [s] slower: look nearer (v·t, ≥ 2.5 m, ≤ l_d)


class VehicleState(msgspec.Struct, frozen=True):
    x: float  # [m]
    y: float  # [m]
    yaw: float  # [rad] counter-clockwise from +x
    speed: float  # [m/s]


class PurePursuit:
    """Tracks progress along the path; `controls` maps a vehicle state to pedal and wheel."""

    def __init__(self, path: PathFollow) -> None:
        if path.loop_from is not None and path.loop_from >= len(path.waypoints):
            raise ValueError(f"loop_from {path.loop_from}: the path has only "
                             f"{len(path.waypoints)} waypoints")  # fmt: skip
        self.path = path
        self.index = 0  # nearest waypoint so far; only moves forward (round a loop)
        self.arc_m = [0.0]  # [m] path length from the first waypoint to each waypoint
        for a, b in itertools.pairwise(path.waypoints):
            self.arc_m.append(self.arc_m[-1] + math.dist(a, b))
        self.speed_cap: list[float] | None = None  # [m/s] per waypoint, for the bends
        if path.corner_accel_mps2 is not None:
            self.speed_cap = corner_speeds(
                path.waypoints, path.target_speed_mps, path.corner_accel_mps2,
                path.brake_decel_mps2, path.loop_from,
            )  # fmt: skip

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

    def _ahead(self) -> Iterator[int]:
        """The nearest waypoint's index and those after it along the path, each at most once
        (round a loop: from `loop_from` on)."""
        i, last = self.index, len(self.path.waypoints) - 1
        yield i
        for _ in range(last):
            if i < last:
                i += 1
            elif self.path.loop_from is not None:
                i = self.path.loop_from
            else:
                return  # the end of an open path
            yield i

    def _advance(self, state: VehicleState) -> None:
        points = self.path.waypoints
        self.index = min(
            itertools.islice(self._ahead(), 50),
            key=lambda i: math.hypot(points[i][0] - state.x, points[i][1] - state.y),
        )

    def _lookahead_point(self, state: VehicleState) -> tuple[float, float]:
        points = self.path.waypoints
        reach = self.path.lookahead_m  # [m]
        if self.path.lookahead_time_s is not None:  # a slow turn cuts its corner less
            reach = min(reach, max(MIN_LOOKAHEAD_M, abs(state.speed) * self.path.lookahead_time_s))
        i = self.index
        for i in self._ahead():
            point = points[i]
            if math.hypot(point[0] - state.x, point[1] - state.y) >= reach:
                return point
        return points[i]

    def _speed_goal(self, state: VehicleState) -> float:
        """Target speed (slowed for bends when asked), ramped down to 0 over the stop distance
        before the last waypoint of an open path."""
        goal = self.path.target_speed_mps
        if self.speed_cap is not None:
            goal = self.speed_cap[self.index]
        if self.path.loop_from is not None:
            return goal
        nearest = self.path.waypoints[self.index]
        to_nearest = math.hypot(nearest[0] - state.x, nearest[1] - state.y)
        remaining = self.arc_m[-1] - self.arc_m[self.index] + to_nearest  # [m]
        fraction = min(1.0, remaining / self.path.stop_distance_m)
        return min(goal, self.path.target_speed_mps * fraction)
