"""Speaker layouts and 2-D vector-base amplitude panning (VBAP, Pulkki 1997).

A source between two adjacent speakers gets gains g solving  g1·l1 + g2·l2 = p  (unit vectors
in the horizontal plane), normalised to unit power; a source in a gap wider than 180° (behind
a stereo pair) goes to the nearer speaker. Panning is pure amplitude: every speaker carries
the same signal at a different gain, with no delay between them.

Azimuths in degrees counter-clockwise from the front (90° = left), as in the HRTF sets.
Channel order is the WAV/SMPTE order (5.1: FL FR FC LFE BL BR). `ringN` puts speaker k at
k·360/N degrees, counter-clockwise from the front.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LFE = None  # a channel without a direction: the low-frequency effects channel stays silent
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
        angles = np.radians([azimuths_deg[i] for i in self.speakers])
        self._vectors = np.stack([np.cos(angles), np.sin(angles)], axis=1)  # S × 2
        self._pairs = self._adjacent_pairs(angles)

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
        for pair in self._pairs:
            pair_gains = p @ pair.inverse.T  # E × 2
            inside = np.all(pair_gains >= -1e-9, axis=1)
            g[inside] = 0.0
            g[np.ix_(inside, pair.channels)] = np.maximum(pair_gains[inside], 0.0)
        g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-12)
        out = np.zeros((len(p), self.channels))
        out[:, self.speakers] = g
        return out

    def _nearest(self, p: np.ndarray) -> np.ndarray:
        g = np.zeros((len(p), len(self.speakers)))
        g[np.arange(len(p)), np.argmax(p @ self._vectors.T, axis=1)] = 1.0
        return g

    def diffuse(self) -> np.ndarray:
        """Gains (channels,) of a sound from everywhere: equal power on every speaker."""
        out = np.zeros(self.channels)
        out[self.speakers] = 1.0 / np.sqrt(len(self.speakers))
        return out


class Panned:
    """Speaker output with the renderer's spatialiser interface: the state is the gains."""

    def __init__(self, layout: str) -> None:
        self.layout = layout
        self.vbap = Vbap(layout_azimuths(layout))
        self.channels = self.vbap.channels

    def state(self, directions: np.ndarray, diffuse: np.ndarray) -> np.ndarray:
        """(E × channels) gains for head-frame unit directions, blended towards diffuse."""
        d = diffuse[:, None]
        return (1.0 - d) * self.vbap.gains(directions) + d * self.vbap.diffuse()[None, :]

    def silent(self, n: int) -> np.ndarray:
        return np.zeros((n, self.channels))

    def take(self, state: np.ndarray, sel: np.ndarray) -> np.ndarray:
        return state[sel]

    def mix(self, spectra: np.ndarray, state: np.ndarray) -> np.ndarray:
        """(channels × F) speaker spectra of the emitters' spectra (E × F)."""
        return state.T.astype(np.float32) @ spectra
