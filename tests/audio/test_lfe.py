"""The 5.1 layout's LFE channel, read back from a rendered WAV: below its cutoff it carries
the sum of every emitter (the power the five speakers share), above it nothing but the
16-bit floor."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from carlaverse.audio.panning import LFE_CUTOFF_HZ
from tests.audio.measure import RATE, render_wav, scenes

LFE_CHANNEL = 3  # FL FR FC LFE BL BR


def band_power_db(x: np.ndarray, low_hz: float, high_hz: float) -> float:
    """Power [dB] between low_hz and high_hz, of all channels of `x` together."""
    f = np.fft.rfftfreq(len(x), 1.0 / RATE)
    spectrum = np.abs(np.fft.rfft(x, axis=0)) ** 2
    return float(10.0 * np.log10(spectrum[(f >= low_hz) & (f < high_hz)].sum()))


def test_the_lfe_carries_the_emitters_below_its_cutoff_and_nothing_above(tmp_path: Path) -> None:
    # Three engines idling to mid revs (firing at 30, 50, 80 Hz) around the listener, and
    # road noise: bass from several directions, and far more treble than bass.
    engines = [(f"e{rpm}", "engine", 90.0, rpm, 0.5, (15 * np.cos(a), 15 * np.sin(a), 0.5),
                (0.0, 0.0, 0.0)) for rpm, a in ((900, 0.3), (1500, 2.0), (2400, -2.0))]  # fmt: skip
    tyres = [("t", "tyres", 85.0, 15.0, 0.3, (-10.0, 5.0, 0.0), (0.0, 0.0, 0.0))]
    audio, _ = render_wav(tmp_path / "lfe.wav", scenes(engines + tyres, 2.0), layout="5.1")
    audio = audio[int(0.3 * RATE) :]  # once every sound has arrived
    speakers = np.delete(audio, LFE_CHANNEL, axis=1)

    def lfe_and_speakers(low_hz: float, high_hz: float) -> tuple[float, float]:
        lfe = band_power_db(audio[:, LFE_CHANNEL], low_hz, high_hz)
        return lfe, band_power_db(speakers, low_hz, high_hz)

    # Well below the cutoff (the filter loses < 0.2 dB at 80 Hz): each emitter at unit gain,
    # as its panning gains (of unit power) spread it over the speakers.
    lfe_bass, speakers_bass = lfe_and_speakers(20.0, 80.0)
    assert abs(lfe_bass - speakers_bass) < 1.0, (lfe_bass, speakers_bass)
    # Two octaves and more above it, a 4th-order low-pass is down ≥ 48 dB; what is left is
    # the 16-bit WAV's quantisation floor, while the speakers keep their treble.
    for low_hz, high_hz in ((4 * LFE_CUTOFF_HZ, 1000.0), (1000.0, 4000.0), (4000.0, 20000.0)):
        lfe, shared = lfe_and_speakers(low_hz, high_hz)
        assert lfe < lfe_bass - 45.0, f"LFE {low_hz:g}–{high_hz:g} Hz: {lfe - lfe_bass:.1f} dB"
        assert shared > speakers_bass - 20.0, "the scene has treble for the LFE to reject"
