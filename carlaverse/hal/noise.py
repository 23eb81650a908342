"""Seeded noise for simulated devices, stepped on a fixed time grid.

A simulated device must give the same output for the same seed and the same clock readings,
however often it is polled. So the noise advances in whole steps of `step_s` from the
device's start, and its value at time t is a function of the seed and t alone.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np


class OrnsteinUhlenbeck:
    """Mean-reverting Gaussian noise (a random walk when `reversion_per_s` is 0)."""

    def __init__(
        self,
        seed: int,
        size: int,
        step_s: float,
        sigma: float,
        reversion_per_s: float = 0.0,
        mean: float | Sequence[float] | np.ndarray = 0.0,
    ) -> None:
        self.rng = np.random.default_rng(seed)
        self.step_s = step_s  # [s]
        self.mean = np.broadcast_to(np.asarray(mean, dtype=float), (size,)).copy()
        self.value = self.mean.copy()
        self.steps = 0
        # exact discretisation: x' = mean + a (x - mean) + b z, z ~ N(0, 1)
        self.a = math.exp(-reversion_per_s * step_s)
        if reversion_per_s > 0:
            self.b = sigma * math.sqrt((1 - self.a**2) / (2 * reversion_per_s))
        else:
            self.b = sigma * math.sqrt(step_s)

    def at(self, t: float) -> np.ndarray:
        """The value at `t` seconds after the start; time never runs backwards."""
        due = math.floor(t / self.step_s + 1e-9)
        n = due - self.steps
        if n > 0:
            # Step one at a time so the result is bit-identical however the steps are batched.
            for z in self.rng.standard_normal((n, self.value.size)):
                self.value = self.mean + self.a * (self.value - self.mean) + self.b * z
            self.steps = due
        return self.value
