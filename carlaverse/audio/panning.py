"""Speaker layouts and 2-D vector-base amplitude panning (VBAP, Pulkki 1997).

A source between two adjacent speakers gets gains g solving  g1·l1 + g2·l2 = p  (unit vectors
in the horizontal plane), normalised to unit power; a source in a gap wider than 180° (behind
a stereo pair) goes to the nearer speaker. Panning is pure amplitude: every speaker carries
the same signal at a different gain, with no delay between them.

Azimuths in degrees counter-clockwise from the front (90° = left), as in the HRTF sets.
Channel order is the WAV/SMPTE order (5.1: FL FR FC LFE BL BR). `ringN` puts speaker k at
k·360/N degrees, counter-clockwise from the front.

The low-frequency effects channel has no direction: it carries the sum of every emitter
(gain and absorption, no panning), low-passed at LFE_CUTOFF_HZ by a 4th-order Butterworth
filter run on the block in time, its state carried from block to block (as a receiver's
bass management would feed a subwoofer; its +10 dB playback gain is the receiver's).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, sosfilt

LFE = None  # a channel without a direction: the low-frequency effects channel
LFE_CUTOFF_HZ = 120.0  # [Hz] the LFE channel's low-pass (−3 dB)
LFE_ORDER = 4  # −24 dB per octave above the cutoff
LAYOUT_AZIMUTHS: dict[str, tuple[float | None, ...]] = {
    "stereo": (30.0, -30.0),
    "quad": (45.0, -45.0, 135.0, -135.0),
    "5.1": (30.0, -30.0, 0.0, LFE, 110.0, -110.0),
}


def layout_azimuths(layout: str) -> tuple[float | None, ...]:
    """Speaker azimuths [deg] of a named layout (`stereo`, `quad`, `5.1`, `ringN`)."""
    if layout.startswith("ring"):
        n = int(layout[4:])
        return tuple(k * 360.0 / n for k in range(n))
    try:
        return LAYOUT_AZIMUTHS[layout]
    except KeyError:
        known = ", ".join([*LAYOUT_AZIMUTHS, "ringN"])
        raise ValueError(f"speaker layout {layout!r} is not one of {known}") from None


@dataclass(frozen=True)
class SpeakerPair:
    """Two adjacent speakers (channel indices) and the inverse of their base matrix."""

    channels: tuple[int, int]
    inverse: np.ndarray  # 2 × 2


class Vbap:
    """Gains per source and speaker for a horizontal layout."""

    def __init__(self, azimuths_deg: tuple[float | None, ...]) -> None:
        self.channels = len(azimuths_deg)
        self.speakers = [i for i, az in enumerate(azimuths_deg) if az is not None]
        angles = np.radians([az for az in azimuths_deg if az is not None])  # the speakers'
        self._vectors = np.stack([np.cos(angles), np.sin(angles)], axis=1)  # S × 2
        self._pairs = self._adjacent_pairs(angles)
        # The pairs as arrays, for all sources at once: P × 2 channels, P × 2 × 2 inverses.
        self._pair_channels = np.array([pair.channels for pair in self._pairs], dtype=np.int64)
        self._inverses = np.array([pair.inverse for pair in self._pairs]).reshape(-1, 2, 2)

    def _adjacent_pairs(self, angles: np.ndarray) -> list[SpeakerPair]:
        order = np.argsort(np.mod(angles, 2 * np.pi))
        pairs = []
        for a, b in zip(order, np.roll(order, -1), strict=True):
            gap = np.mod(angles[b] - angles[a], 2 * np.pi)
            if len(order) < 2 or gap >= np.pi:
                continue  # no pair spans a gap this wide: its sources go to the nearer speaker
            base = np.stack([self._vectors[a], self._vectors[b]], axis=1)  # columns l1, l2
            pairs.append(SpeakerPair((int(a), int(b)), np.linalg.inv(base)))
        return pairs

    def gains(self, directions: np.ndarray) -> np.ndarray:
        """(E × channels) unit-power gains for (E × 3) head-frame directions; only the
        horizontal part counts (a source overhead pans by its azimuth)."""
        p = directions[:, :2]
        p = p / np.maximum(np.linalg.norm(p, axis=1, keepdims=True), 1e-9)
        g = self._nearest(p)
        if self._pairs:
            self._between_pair(p, g)
        g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-12)
        out = np.zeros((len(p), self.channels))
        out[:, self.speakers] = g
        return out

    def _between_pair(self, p: np.ndarray, g: np.ndarray) -> None:
        """Into `g`: the gains of each source inside a pair's arc (on a shared speaker,
        the later pair of the ring order), from every pair's solution at once."""
        pair_gains = np.einsum("ej,pkj->epk", p, self._inverses)  # E × P × 2
        inside = np.all(pair_gains >= -1e-9, axis=2)
        held = np.flatnonzero(inside.any(axis=1))
        last = len(self._pairs) - 1 - np.argmax(inside[held, ::-1], axis=1)
        g[held] = 0.0
        for side in (0, 1):
            g[held, self._pair_channels[last, side]] = np.maximum(pair_gains[held, last, side], 0)

    def _nearest(self, p: np.ndarray) -> np.ndarray:
        g = np.zeros((len(p), len(self.speakers)))
        g[np.arange(len(p)), np.argmax(p @ self._vectors.T, axis=1)] = 1.0
        return g

    def diffuse(self) -> np.ndarray:
        """Gains (channels,) of a sound from everywhere: equal power on every speaker."""
        out = np.zeros(self.channels)
        out[self.speakers] = 1.0 / np.sqrt(len(self.speakers))
        return out


@dataclass(frozen=True)
class PannedWeights:
    """Per emitter: its response (gain × absorption, E × F) and its speaker gains (E × C)."""

    response: np.ndarray
    gains: np.ndarray


class Panned:
    """Speaker output with the renderer's spatialiser interface: each emitter's weights are
    its response and its speaker gains, kept apart (a product per speaker would cost C times
    the work of the mix, which is one matrix product per block)."""

    def __init__(self, layout: str, sample_rate_hz: int) -> None:
        self.layout = layout
        azimuths = layout_azimuths(layout)
        self.vbap = Vbap(azimuths)
        self.channels = self.vbap.channels
        self.lfe = LowFrequencyEffects([i for i, az in enumerate(azimuths) if az is LFE],
                                       sample_rate_hz)  # fmt: skip

    def weights(self, response: np.ndarray, directions: np.ndarray,
                diffuse: np.ndarray) -> PannedWeights:  # fmt: skip
        """Gains for head-frame unit directions (E × 3), blended towards diffuse (E,) 0..1;
        every emitter at unit gain into the LFE channel."""
        d = diffuse[:, None]
        gains = (1.0 - d) * self.vbap.gains(directions) + d * self.vbap.diffuse()[None, :]
        gains[:, self.lfe.channels] = 1.0
        return PannedWeights(response, gains.astype(np.float32))

    def silent(self, n: int, bins: int) -> PannedWeights:
        return PannedWeights(np.zeros((n, bins), dtype=np.complex64),
                             np.zeros((n, self.channels), dtype=np.float32))  # fmt: skip

    def take(self, weights: PannedWeights, sel: np.ndarray | slice) -> PannedWeights:
        return PannedWeights(weights.response[sel], weights.gains[sel])

    def mix(self, spectra: np.ndarray, weights: PannedWeights) -> np.ndarray:
        """(channels × F) speaker spectra of the emitters' spectra (E × F)."""
        return weights.gains.T @ (spectra * weights.response)

    def finish(self, block: np.ndarray) -> np.ndarray:
        """The rendered block (channels × samples) with its LFE channel low-passed."""
        return self.lfe.process(block)


class LowFrequencyEffects:
    """The LFE channels' low-pass, with its state between blocks."""

    def __init__(self, channels: list[int], sample_rate_hz: int) -> None:
        self.channels = channels
        self._sos = butter(LFE_ORDER, LFE_CUTOFF_HZ, fs=sample_rate_hz, output="sos")
        # Sections × channels × 2, at rest: a filter that has only heard silence.
        self._state = np.zeros((self._sos.shape[0], len(channels), 2))

    def process(self, block: np.ndarray) -> np.ndarray:
        if not self.channels:
            return block
        low, self._state = sosfilt(self._sos, block[self.channels], axis=-1, zi=self._state)
        block[self.channels] = low
        return block
