"""A seated participant's head: looks left and right (yaw sine), nods slightly, and sways by
seeded mean-reverting noise. Deterministic given seed and clock."""

from __future__ import annotations

import math
import time
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.noise import OrnsteinUhlenbeck
from carlaverse.hal.xr import XrHeadset

NonNegative = Annotated[float, msgspec.Meta(ge=0)]
Positive = Annotated[float, msgspec.Meta(gt=0)]


class SimHeadsetOptions(StrictStruct):
    seed: int = 0
    eye_height_m: NonNegative = 1.2  # [m] seated
    yaw_amplitude_rad: NonNegative = 0.4  # [rad] look left/right
    yaw_period_s: Positive = 6.0  # [s]
    pitch_amplitude_rad: NonNegative = 0.05  # [rad] nod
    pitch_period_s: Positive = 2.3  # [s]
    sway_m: NonNegative = 0.01  # [m] typical head translation
    step_s: Positive = 0.01  # [s] noise time grid


def yaw_pitch_quaternion(yaw: float, pitch: float) -> tuple[float, float, float, float]:
    """(w, x, y, z) for yaw about +y, then pitch about the head's +x."""
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    return (cy * cp, cy * sp, sy * cp, -sy * sp)


class SimHeadset(XrHeadset):
    Options = SimHeadsetOptions

    def __init__(self, options: SimHeadsetOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        self.t0 = clock()
        self.noise = OrnsteinUhlenbeck(options.seed, 3, options.step_s, 1.0, 1.0)

    def _pose(self, now: float) -> tuple[tuple[float, float, float], tuple, bool]:
        o = self.options
        t = now - self.t0
        sway = o.sway_m * math.sqrt(2) * self.noise.at(t)  # OU(σ=1, θ=1) has std 1/√2
        position = (float(sway[0]), o.eye_height_m + float(sway[1]), float(sway[2]))
        yaw = o.yaw_amplitude_rad * math.sin(2 * math.pi * t / o.yaw_period_s)
        pitch = o.pitch_amplitude_rad * math.sin(2 * math.pi * t / o.pitch_period_s)
        return position, yaw_pitch_quaternion(yaw, pitch), True
