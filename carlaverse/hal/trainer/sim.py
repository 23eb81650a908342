"""A simulated rider on a simulated smart trainer.

The rider rides at a preferred power that rises with the grade (people push harder uphill:
`grade_gain` per percent) and fluctuates as seeded mean-reverting noise; in ERG mode the
trainer holds the target power and only cadence wanders. Deterministic given seed and clock.
"""

from __future__ import annotations

import time
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.noise import OrnsteinUhlenbeck
from carlaverse.hal.trainer import TrainerDevice

NonNegative = Annotated[float, msgspec.Meta(ge=0)]


class SimTrainerOptions(StrictStruct):
    seed: int = 0
    rider_power_w: NonNegative = 180.0  # [W] on the flat
    power_sigma_w: NonNegative = 15.0  # [W] typical fluctuation
    cadence_rpm: NonNegative = 85.0  # [1/min]
    cadence_sigma_rpm: NonNegative = 3.0  # [1/min]
    grade_gain: NonNegative = 0.06  # [1/%] extra power fraction per percent of grade
    step_s: Annotated[float, msgspec.Meta(gt=0)] = 0.25  # [s] noise time grid


class SimTrainer(TrainerDevice):
    Options = SimTrainerOptions

    def __init__(self, options: SimTrainerOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        self.t0 = clock()
        # unit-variance noise, scaled per channel below; reverts over about 2 s
        self.noise = OrnsteinUhlenbeck(options.seed, 2, options.step_s, 1.0, 0.5)
        self.target_power_w: float | None = None  # [W] ERG target, None in simulation mode
        self.grade_percent = 0.0  # [%]

    def _read(self, now: float) -> tuple[float, float]:
        o = self.options
        z_power, z_cadence = self.noise.at(now - self.t0)
        cadence = o.cadence_rpm + o.cadence_sigma_rpm * z_cadence
        if self.target_power_w is not None:
            return self.target_power_w, cadence
        preferred = o.rider_power_w * max(0.0, 1.0 + o.grade_gain * self.grade_percent)
        return preferred + o.power_sigma_w * z_power, cadence

    def _set_target_power(self, power_w: float) -> None:
        self.target_power_w = power_w

    def _set_grade(self, grade_percent: float) -> None:
        self.target_power_w = None
        self.grade_percent = grade_percent
