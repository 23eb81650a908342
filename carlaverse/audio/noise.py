"""Shaped noise for every noisy source: octave bands of looping noise, mixed per emitter.

Filtering noise per emitter per block (a filter bank each) would cost most of the audio
budget. Instead eight octave bands of white noise are made once, circularly by FFT so their
loop has no seam, and each emitter reads them at its own offset (so no two emitters sound
alike) and mixes them with its own band gains: a gather and a multiply-add per block.
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

BAND_CENTRES_HZ = (63.0, 125.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0, 8000.0)
TABLE_SAMPLES = 1 << 18  # [samples] 5.5 s at 48 kHz: longer than any repetition one notices
MAX_BLOCK = 8192  # [samples] the table repeats its start this far, so a read never wraps


class NoiseBands:
    """Octave-band noise tables (bands × TABLE_SAMPLES), each band of RMS 1."""

    def __init__(self, sample_rate_hz: int, rng: np.random.Generator) -> None:
        spectrum = np.fft.rfft(rng.standard_normal(TABLE_SAMPLES))
        octaves = np.log2(np.maximum(np.fft.rfftfreq(TABLE_SAMPLES, 1.0 / sample_rate_hz), 1.0))
        tables = []
        for k, centre in enumerate(BAND_CENTRES_HZ):
            band = np.fft.irfft(spectrum * _band_weight(octaves, k, np.log2(centre)))
            tables.append(band / np.sqrt(np.mean(band**2)))
        # samples × bands, the start repeated at the end: one emitter's block is one slice.
        looped = np.concatenate([tables, np.asarray(tables)[:, :MAX_BLOCK]], axis=1)
        self.tables = np.ascontiguousarray(looped.T, dtype=np.float32)
        self.samples = TABLE_SAMPLES
        self._window_view: np.ndarray | None = None
        # Adjacent bands overlap, so their mix has more power than the sum of theirs.
        self.covariance = np.asarray(tables) @ np.asarray(tables).T / TABLE_SAMPLES

    def unit_power(self, gains: np.ndarray) -> np.ndarray:
        """Band gains (… × bands) scaled so that their mix has RMS 1."""
        gains = np.atleast_2d(gains)
        power = np.sum((gains @ self.covariance) * gains, axis=1)
        return gains / np.sqrt(np.maximum(power, 1e-24))[:, None]

    def read(self, offsets: np.ndarray, gains0: np.ndarray, gains1: np.ndarray,
             block: int) -> np.ndarray:  # fmt: skip
        """(E × block) noise: band gains (E × bands) ramped from gains0 to gains1; offsets
        in [0, TABLE_SAMPLES), block ≤ MAX_BLOCK."""
        bands = self._windows(block)[offsets]  # E × bands × block, one gather
        # Start value and slope of each emitter's block in one product (E × 2 × block).
        ends = np.stack([gains0, gains1 - gains0], axis=1).astype(np.float32)
        start_delta = np.matmul(ends, bands)
        return start_delta[:, 0] + start_delta[:, 1] * ramp(block)[None, :]

    def _windows(self, block: int) -> np.ndarray:
        """Every block-long window of the tables, as a view (no copy): windows × bands × block."""
        if self._window_view is None or self._window_view.shape[-1] != block:
            self._window_view = sliding_window_view(self.tables, block, axis=0)
        return self._window_view


def _band_weight(octaves: np.ndarray, k: int, centre: float) -> np.ndarray:
    """Amplitude of band k: raised-cosine flanks one octave wide, so the powers of adjacent
    bands add up to one; the outer bands run on to DC and to Nyquist."""
    x = octaves - centre
    if k == 0:
        x = np.maximum(x, 0.0)
    if k == len(BAND_CENTRES_HZ) - 1:
        x = np.minimum(x, 0.0)
    power = np.where(np.abs(x) < 1.0, 0.5 + 0.5 * np.cos(np.pi * x), 0.0)
    return np.sqrt(power)


def ramp(block: int) -> np.ndarray:
    """(block,) from just above 0 to 1: the weight of a block's end value at each sample."""
    return (np.arange(1, block + 1, dtype=np.float32)) / block


class Gusts:
    """A slow random modulation per emitter: AR(1) per block, log-normal gain, mean ~1."""

    def __init__(self, capacity: int, rng: np.random.Generator) -> None:
        self.value = np.zeros(capacity)
        self.rng = rng

    def reset(self, slots: np.ndarray) -> None:
        self.value[slots] = self.rng.standard_normal(len(slots))

    def step(self, slots: np.ndarray, block_s: float, time_constant_s: float,
             depth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """Gain at the block's start and end (E,), for `depth` in nepers per unit value."""
        rho = np.exp(-block_s / time_constant_s)
        before = self.value[slots]
        after = rho * before + np.sqrt(1.0 - rho * rho) * self.rng.standard_normal(len(slots))
        self.value[slots] = after
        norm = np.exp(-(depth**2))  # E[exp(2·depth·value)] = exp(2·depth²): RMS stays 1
        return np.exp(depth * before) * norm, np.exp(depth * after) * norm
