"""Scripted motion along closed paths, as an exact function of session time.

A scripted participant's pose is `path.pose_at(t)`, so any process that knows the path knows
where the participant truly was at any session time: tests and the WAN harness measure the
interpolation error of remote actors against it.
"""

from __future__ import annotations

import math
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.messages import Pose

Positive = Annotated[float, msgspec.Meta(gt=0)]


class CirclePath(StrictStruct, tag="circle"):
    center: tuple[float, float] = (0.0, 0.0)  # [m]
    radius: Positive = 20.0  # [m]
    speed_mps: float = 14.0  # [m/s], negative runs clockwise
    phase_deg: float = 0.0  # [deg] position angle at t = 0

    def pose_at(self, t: float) -> Pose:
        w = self.speed_mps / self.radius  # [rad/s]
        th = math.radians(self.phase_deg) + w * t
        c, s = math.cos(th), math.sin(th)
        r, cx, cy = self.radius, self.center[0], self.center[1]
        heading = th + math.copysign(math.pi / 2, w)
        return Pose(
            0, t, cx + r * c, cy + r * s, 0.0, 0.0, 0.0, math.remainder(heading, math.tau),
            -r * w * s, r * w * c, 0.0, 0.0, 0.0, w, -r * w * w * c, -r * w * w * s, 0.0,
        )  # fmt: skip


class PolylinePath(StrictStruct, tag="polyline"):
    """A closed polygon driven at constant speed (velocity jumps at the corners)."""

    points: list[tuple[float, float]]  # [m]
    speed_mps: Positive = 10.0  # [m/s]
    offset_m: float = 0.0  # [m] arc length at t = 0

    def __post_init__(self) -> None:
        if len(self.points) < 2:
            raise ValueError("a polyline path needs at least two points")

    def pose_at(self, t: float) -> Pose:
        segments = list(zip(self.points, [*self.points[1:], self.points[0]], strict=True))
        lengths = [math.dist(a, b) for a, b in segments]
        s = (self.offset_m + self.speed_mps * t) % sum(lengths)
        for (a, b), length in zip(segments, lengths, strict=True):
            if s <= length and length > 0:
                ux, uy = (b[0] - a[0]) / length, (b[1] - a[1]) / length
                v = self.speed_mps
                x, y = a[0] + ux * s, a[1] + uy * s
                return Pose(0, t, x, y, yaw=math.atan2(uy, ux), vx=ux * v, vy=uy * v)
            s -= length
        a = self.points[0]
        return Pose(0, t, a[0], a[1])


PathSpec = CirclePath | PolylinePath
