"""Block convolution of every emitter at once: overlap-save with one partition.

Each emitter slot keeps the last `n_fft − block` samples of its signal. Per block, those and
the new block form one frame per emitter, and one real FFT over all frames (E × n_fft, in
float32) gives their spectra; a filter of up to `n_fft − block + 1` taps, applied as a
product with its spectrum, then yields the block exactly in the frame's last `block`
samples (the circular wrap-around falls only on the discarded head). The spatialiser sums
the emitters' products per channel before the one inverse FFT per channel: the cost of
going back to time does not grow with the emitter count.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.fft


def fft_size(block: int, filter_taps: int) -> int:
    """The smallest power of two holding a block and a filter's history."""
    return 1 << math.ceil(math.log2(block + filter_taps))


class OverlapSave:
    """The signal history of every emitter slot, turned into block spectra."""

    def __init__(self, capacity: int, block: int, n_fft: int) -> None:
        if n_fft < 2 * block:
            raise ValueError(f"n_fft {n_fft} must hold two blocks of {block}")
        self.block = block
        self.n_fft = n_fft
        self.bins = n_fft // 2 + 1
        self.history = np.zeros((capacity, n_fft - block), dtype=np.float32)

    def clear(self, slots: np.ndarray) -> None:
        self.history[slots] = 0.0

    def spectra(self, slots: np.ndarray, signal: np.ndarray) -> np.ndarray:
        """(E × bins) complex64 spectra of each slot's history followed by its new block
        `signal` (E × block); the history moves on by the block."""
        frames = np.concatenate([self.history[slots], signal], axis=1, dtype=np.float32)
        self.history[slots] = frames[:, self.block :]
        return scipy.fft.rfft(frames, axis=1)

    def blocks(self, spectra: np.ndarray) -> np.ndarray:
        """The valid block (… × block) of filtered frame spectra (… × bins)."""
        return scipy.fft.irfft(spectra, self.n_fft, axis=-1)[..., -self.block :]
