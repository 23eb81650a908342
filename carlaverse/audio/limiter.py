"""The master limiter: keeps every sample under full scale without hard clipping.

Per block: if the block's peak (after the current gain) would exceed the ceiling, the gain
drops at once for the whole block (nothing overshoots, ever); otherwise it recovers towards 1
with the release time constant. A clean mix never touches it (gain stays exactly 1).
"""

from __future__ import annotations

import math

import numpy as np

CEILING = 0.98  # peak after limiting, below 16-bit full scale with margin for dither
RELEASE_S = 0.5  # [s] time constant of the gain's recovery


class Limiter:
    def __init__(self, sample_rate_hz: int, block: int) -> None:
        self.gain = 1.0
        self.release = math.exp(-block / (sample_rate_hz * RELEASE_S))
        self.blocks_limited = 0

    def process(self, block: np.ndarray) -> np.ndarray:
        """(samples × channels) float32 scaled by the limiter gain; within ±CEILING."""
        recovered = 1.0 - (1.0 - self.gain) * self.release
        peak = max(float(block.max()), -float(block.min())) if block.size else 0.0
        gain = min(recovered, CEILING / peak) if peak > 0.0 else recovered
        if gain < recovered:
            self.blocks_limited += 1
        start, self.gain = self.gain, gain
        if start == gain == 1.0:  # the usual case: untouched
            return np.ascontiguousarray(block, dtype=np.float32)
        ramp = np.linspace(start, gain, block.shape[0], dtype=np.float32)
        if gain < start:
            ramp[:] = gain  # a fall is immediate: no sample of this block may overshoot
        return (block * ramp[:, None]).astype(np.float32)
