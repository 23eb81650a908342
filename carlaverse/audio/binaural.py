"""Headphone output: each emitter filtered by the head-related transfer function of the
direction its sound arrives from (nearest measured direction), for both ears.

Works on spectra: the renderer hands over every emitter's block spectrum (overlap-save frames)
and gets the two ears' spectra back, the sum over emitters done before the inverse FFT, so
the cost of going back to time is two inverse FFTs per block whatever the emitter count.
A sound from all around (an area source the listener stands in, rain, wind) gets the
diffuse-field response: the mean magnitude over all directions, the same for both ears.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from carlaverse.audio.hrtf import HrirSet

DIFFUSE_DELAY_SAMPLES = 40  # the diffuse response's bulk delay: about the HRIRs' onset


@dataclass(frozen=True)
class BinauralState:
    """Per emitter: the measured direction used and how diffuse the sound is (0..1)."""

    direction: np.ndarray  # (E,) index into the HRIR set
    diffuse: np.ndarray  # (E,)


class Binaural:
    channels = 2
    channel_names = ("left", "right")

    def __init__(self, hrirs: HrirSet, n_fft: int) -> None:
        self.hrirs = hrirs
        self._units = hrirs.unit_vectors()  # D × 3
        self._spectra = np.fft.rfft(hrirs.irs, n_fft, axis=-1).astype(np.complex64)  # D×2×F
        magnitude = np.sqrt(np.mean(np.abs(self._spectra) ** 2, axis=(0, 1)))  # F
        w = np.pi * np.arange(magnitude.size) / (magnitude.size - 1)
        self._diffuse = (magnitude * np.exp(-1j * w * DIFFUSE_DELAY_SAMPLES)).astype(np.complex64)

    def state(self, directions: np.ndarray, diffuse: np.ndarray) -> BinauralState:
        """For head-frame unit directions (E × 3: x forward, y left, z up)."""
        return BinauralState(np.argmax(directions @ self._units.T, axis=1), diffuse)

    def silent(self, n: int) -> BinauralState:
        return BinauralState(np.zeros(n, dtype=np.int64), np.zeros(n))

    def take(self, state: BinauralState, sel: np.ndarray) -> BinauralState:
        return BinauralState(state.direction[sel], state.diffuse[sel])

    def mix(self, spectra: np.ndarray, state: BinauralState) -> np.ndarray:
        """(2 × F) ear spectra of the emitters' spectra (E × F)."""
        spread = np.flatnonzero(state.diffuse > 0.0)
        if spread.size == 0:
            return np.einsum("ef,ecf->cf", spectra, self._spectra[state.direction])
        point = spectra * (1.0 - state.diffuse)[:, None].astype(np.float32)
        ears = np.einsum("ef,ecf->cf", point, self._spectra[state.direction])
        weights = state.diffuse[spread, None].astype(np.float32)
        return ears + (spectra[spread] * weights).sum(axis=0)[None, :] * self._diffuse[None, :]
