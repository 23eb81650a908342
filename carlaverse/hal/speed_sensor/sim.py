"""A wheel whose speed follows a piecewise-linear profile; revolutions are its exact integral,
so they are the same however often the sensor is read."""

from __future__ import annotations

import itertools
import time
from typing import Annotated

import msgspec

from carlaverse.config import ConfigError, StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.speed_sensor import SpeedSensor

NonNegative = Annotated[float, msgspec.Meta(ge=0)]


class SpeedPoint(StrictStruct):
    t: NonNegative  # [s] after the sensor opened
    speed_mps: NonNegative  # [m/s]


class SimSpeedOptions(StrictStruct):
    wheel_circumference_m: Annotated[float, msgspec.Meta(gt=0)] = 2.105  # [m] 700x25c
    profile: list[SpeedPoint] = msgspec.field(
        default_factory=lambda: [SpeedPoint(t=0, speed_mps=0), SpeedPoint(t=10, speed_mps=7)]
    )


def speed_at(points: list[SpeedPoint], t: float) -> float:
    """[m/s] linear between points, held beyond the ends."""
    if t <= points[0].t:
        return points[0].speed_mps
    for a, b in itertools.pairwise(points):
        if t <= b.t:
            return a.speed_mps + (b.speed_mps - a.speed_mps) * (t - a.t) / (b.t - a.t)
    return points[-1].speed_mps


def distance_at(points: list[SpeedPoint], t: float) -> float:
    """[m] integral of `speed_at` from 0 to t (trapezoids are exact on linear pieces)."""
    knots = [0.0] + [p.t for p in points if 0.0 < p.t < t] + [max(t, 0.0)]
    return sum(
        (t1 - t0) * (speed_at(points, t0) + speed_at(points, t1)) / 2
        for t0, t1 in itertools.pairwise(knots)
    )


class SimSpeedSensor(SpeedSensor):
    Options = SimSpeedOptions

    def __init__(self, options: SimSpeedOptions, *, clock: Clock = time.monotonic) -> None:
        times = [p.t for p in options.profile]
        if not times or times != sorted(set(times)):
            raise ConfigError(
                "speed_sensor.options (backend 'sim')",
                "profile needs at least one point, in strictly increasing t",
            )
        super().__init__(options, clock=clock)
        self.t0 = clock()

    def _read(self, now: float) -> tuple[float, float]:
        t = now - self.t0
        points = self.options.profile
        revolutions = distance_at(points, t) / self.options.wheel_circumference_m
        return speed_at(points, t), revolutions
