"""Headphone output: each emitter filtered by the head-related transfer function of the
direction its sound arrives from (nearest measured direction), for both ears.

Works on spectra: the renderer hands over every emitter's block spectrum (overlap-save frames)
and gets the two ears' spectra back, the sum over emitters done before the inverse FFT, so
the cost of going back to time is two inverse FFTs per block whatever the emitter count.
A sound from all around (an area source the listener stands in, rain, wind) gets the
diffuse-field response: the mean magnitude over all directions, the same for both ears.
"""

from __future__ import annotations

import numpy as np

from carlaverse.audio.hrtf import HrirSet

DIFFUSE_DELAY_SAMPLES = 40  # the diffuse response's bulk delay: about the HRIRs' onset


class Binaural:
    """The spatialiser for headphones. Its per-emitter weights are the emitter's two ear
    filters (E × 2 × F): gain and absorption times the HRTF of its direction, blended towards
    the diffuse response; the renderer keeps them, so a block's old filters are the previous
    block's new ones and only the new are computed."""

    channels = 2
    channel_names = ("left", "right")

    def __init__(self, hrirs: HrirSet, n_fft: int) -> None:
        self.hrirs = hrirs
        self._units = hrirs.unit_vectors()  # D × 3
        self._spectra = np.fft.rfft(hrirs.irs, n_fft, axis=-1).astype(np.complex64)  # D×2×F
        magnitude = np.sqrt(np.mean(np.abs(self._spectra) ** 2, axis=(0, 1)))  # F
        w = np.pi * np.arange(magnitude.size) / (magnitude.size - 1)
        self._diffuse = (magnitude * np.exp(-1j * w * DIFFUSE_DELAY_SAMPLES)).astype(np.complex64)

    def weights(self, response: np.ndarray, directions: np.ndarray,
                diffuse: np.ndarray) -> np.ndarray:  # fmt: skip
        """(E × 2 × F) ear filters for responses (E × F), head-frame unit directions (E × 3:
        x forward, y left, z up) and how diffuse each sound is (E,) 0..1: the nearest
        measured direction's HRTF."""
        nearest = np.argmax(directions @ self._units.T, axis=1)
        ears = self._spectra.take(nearest, axis=0)
        spread = np.flatnonzero(diffuse > 0.0)
        if spread.size:
            d = diffuse[spread, None, None].astype(np.float32)
            ears[spread] = (1.0 - d) * ears[spread] + d * self._diffuse[None, None, :]
        ears *= response[:, None, :]
        return ears

    def silent(self, n: int, bins: int) -> np.ndarray:
        return np.zeros((n, 2, bins), dtype=np.complex64)

    def take(self, weights: np.ndarray, sel: np.ndarray | slice) -> np.ndarray:
        return weights[sel]

    def finish(self, block: np.ndarray) -> np.ndarray:
        """The rendered block (2 × samples) as it is: headphones have no filtered channel."""
        return block

    def mix(self, spectra: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """(2 × F) ear spectra of the emitters' spectra (E × F) through their filters (a
        product and a sum: numpy's einsum is slower for this shape)."""
        return (spectra[:, None, :] * weights).sum(axis=0)
