"""From source to ear: how long the sound took, from where it left, and the delay line that
turns a changing travel time into the Doppler shift.

The sound heard at time t left the source at t − τ, when the source (moving with velocity v)
was at p − v·τ; τ solves |p − v·τ − L| = c·τ (L the listener). Reading each emitter's signal
through a delay line at t − τ(t) then shifts its pitch by exactly c / (c − v_r) for a source
approaching at radial speed v_r at emission (and c / (c + v_r) receding), with no pitch
formula anywhere; a moving listener is covered too, as τ follows L(t).
"""

from __future__ import annotations

import numpy as np

MIN_DISTANCE_M = 1.0  # [m] levels are given at 1 m; closer is not louder (and 1/r stays finite)


def travel_time_s(relative_m: np.ndarray, velocity_mps: np.ndarray, c_mps: float) -> np.ndarray:
    """τ [s] per emitter: `relative_m` = p − L now (E × 3), `velocity_mps` of the source."""
    dv = np.einsum("ij,ij->i", relative_m, velocity_mps)
    vv = np.einsum("ij,ij->i", velocity_mps, velocity_mps)
    dd = np.einsum("ij,ij->i", relative_m, relative_m)
    c2 = c_mps * c_mps
    vv = np.minimum(vv, 0.81 * c2)  # a supersonic source has no single arrival: cap at 0.9 c
    root = np.sqrt(dv * dv + (c2 - vv) * dd)
    return (root - dv) / (c2 - vv)


class DelayLines:
    """One ring buffer per emitter slot, written with the source's signal, read late.

    Each row holds one guard sample past the ring's end, a copy of its first, so that the
    sample after any read position is the next in memory: one gather finds both samples
    the interpolation needs, with no wrap-around arithmetic."""

    def __init__(self, capacity: int, max_delay_s: float, sample_rate_hz: int, block: int):
        needed = int(max_delay_s * sample_rate_hz) + 2 * block + 4
        self.length = 1 << int(np.ceil(np.log2(needed)))  # a power of two: index & mask
        self.rate = float(sample_rate_hz)
        self.block = block
        self.buffer = np.zeros((capacity, self.length + 1), dtype=np.float32)  # + guard
        self.written = 0  # [samples] written so far into every line (they advance together)
        self.max_delay_samples = self.length - 2 * block - 4
        self._ramp = np.arange(1, block + 1) / block  # weight of the end delay per sample
        self._offsets = np.arange(block, dtype=np.float64)

    def clear(self, slots: np.ndarray) -> None:
        self.buffer[slots] = 0.0

    def process(self, slots: np.ndarray, signal: np.ndarray, delay0_s: np.ndarray,
                delay1_s: np.ndarray) -> np.ndarray:  # fmt: skip
        """Write one block per slot; read it back delayed by a delay ramped from delay0_s at
        the block's start to delay1_s at its end (linear interpolation between samples)."""
        start = self.written
        self._write(slots, signal, start & (self.length - 1))
        self.written += self.block
        # Clipping the ends clips the whole ramp: it is linear in between.
        d0, d1 = (np.clip(d * self.rate, 1.0, self.max_delay_samples) for d in (delay0_s, delay1_s))
        # Read positions relative to the ring's start, made positive (a whole number of
        # rings on, which & mask removes) so that truncation is the floor: the sample's
        # offset in the block less its delay d0 + (d1 − d0)·ramp [samples].
        position = np.outer(d0 - d1, self._ramp)
        position += self._offsets + float((start & (self.length - 1)) + self.length)
        position -= d0[:, None]
        whole = position.astype(np.int64)
        frac = (position - whole).astype(np.float32)
        whole &= self.length - 1
        whole += (slots * (self.length + 1))[:, None]
        lines = self.buffer.ravel()
        here = lines.take(whole)
        return here + (lines.take(whole + 1) - here) * frac

    def _write(self, slots: np.ndarray, signal: np.ndarray, column: int) -> None:
        first = min(self.block, self.length - column)  # up to the ring's end, then from 0
        self.buffer[slots, column : column + first] = signal[:, :first]
        if first < self.block:
            self.buffer[slots, : self.block - first] = signal[:, first:]
        if column == 0 or first < self.block:  # the first sample changed: so does its guard
            self.buffer[slots, self.length] = self.buffer[slots, 0]
