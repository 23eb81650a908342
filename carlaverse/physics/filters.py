"""Scalar signal helpers shared by the vehicle, steering-feel and motion-cueing models.

Everything here works on plain floats: the drive loop runs at 1 kHz in pure Python, where a
numpy call costs more than the arithmetic it would save.
"""

from __future__ import annotations

import math


def clamp(value: float, lo: float, hi: float) -> float:
    return lo if value < lo else hi if value > hi else value


def smoothstep(edge0: float, edge1: float, value: float) -> float:
    """0 below edge0, 1 above edge1, a C¹-continuous cubic in between (no step, no kink)."""
    if value <= edge0:
        return 0.0
    if value >= edge1:
        return 1.0
    t = (value - edge0) / (edge1 - edge0)
    return t * t * (3.0 - 2.0 * t)


def deadband(value: float, width: float) -> float:
    """Zero inside ±width; outside, shifted toward zero so the output stays continuous."""
    if value > width:
        return value - width
    if value < -width:
        return value + width
    return 0.0


def interp(x: float, xs: tuple[float, ...], ys: tuple[float, ...]) -> float:
    """Piecewise-linear lookup, held constant outside the table (xs ascending)."""
    if x <= xs[0]:
        return ys[0]
    for i in range(1, len(xs)):
        if x <= xs[i]:
            x0 = xs[i - 1]
            return ys[i - 1] + (ys[i] - ys[i - 1]) * (x - x0) / (xs[i] - x0)
    return ys[-1]


def lpf_alpha(dt: float, tau_s: float) -> float:
    """Blend factor of a discrete first-order low-pass with time constant tau_s [s].

    The exact discretisation (1 − e^(−dt/τ)) keeps the filter's time constant independent of
    the loop rate, so a config tuned at 1 kHz behaves the same at 250 Hz.
    """
    if tau_s <= 0.0:
        return 1.0
    return 1.0 - math.exp(-dt / tau_s)


class LowPass:
    """First-order low-pass filter y' = (x − y)/τ, with a cached blend factor per dt."""

    __slots__ = ("_alpha", "_dt", "tau_s", "value")

    def __init__(self, tau_s: float, value: float = 0.0) -> None:
        self.tau_s = tau_s
        self.value = value
        self._dt = -1.0
        self._alpha = 1.0

    def update(self, x: float, dt: float) -> float:
        if dt != self._dt:
            self._dt = dt
            self._alpha = lpf_alpha(dt, self.tau_s)
        self.value += (x - self.value) * self._alpha
        return self.value

    def reset(self, value: float = 0.0) -> None:
        self.value = value
