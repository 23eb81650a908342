"""The renderer's batched parts against plain per-emitter references: one FFT over all
emitters equals a convolution per emitter, one gather per delay line equals interpolating
each line alone, one product per noise block equals mixing each emitter's bands, the
real-arithmetic one-pole equals the complex formula, and pairwise VBAP for all sources at
once equals solving pair by pair."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from carlaverse.audio.air import one_pole_response, unit_delays
from carlaverse.audio.binaural import Binaural
from carlaverse.audio.blockfft import OverlapSave
from carlaverse.audio.noise import NoiseBands
from carlaverse.audio.panning import Vbap, layout_azimuths
from carlaverse.audio.propagation import DelayLines
from carlaverse.audio.renderer import fft_size
from carlaverse.audio.wavetables import CYCLE_SAMPLES, Wavetables
from tests.audio.measure import kemar

BLOCK = 512  # [samples]


def unit_direction(azimuth_deg: np.ndarray) -> np.ndarray:
    a = np.radians(azimuth_deg)
    return np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=1)


def test_one_fft_over_all_emitters_equals_a_convolution_per_emitter() -> None:
    """Five emitters in five directions through HRTF and a one-pole each, block by block,
    against np.convolve and lfilter on each emitter's whole signal."""
    rng = np.random.default_rng(3)
    emitters, blocks = 5, 6
    n_fft = fft_size(BLOCK)
    binaural = Binaural(kemar(), n_fft)
    convolver = OverlapSave(emitters, BLOCK, n_fft)
    signal = rng.standard_normal((emitters, blocks * BLOCK)).astype(np.float32)
    directions = unit_direction(np.array([0.0, 40.0, 95.0, -130.0, 180.0]))
    pole = np.array([0.0, 0.3, 0.6, 0.8, 0.5])
    gain = np.array([1.0, 0.5, 2.0, 0.8, 1.2])
    response = one_pole_response(pole, unit_delays(n_fft), gain)
    weights = binaural.weights(response, directions, np.zeros(emitters))
    slots = np.arange(emitters)
    rendered = np.concatenate([convolver.blocks(binaural.mix(
        convolver.spectra(slots, signal[:, k * BLOCK : (k + 1) * BLOCK]), weights))
        for k in range(blocks)], axis=1)  # fmt: skip
    nearest = np.argmax(directions @ kemar().unit_vectors().T, axis=1)
    expected = np.zeros((2, blocks * BLOCK))
    for e in range(emitters):
        through_air = lfilter([gain[e] * (1.0 - pole[e])], [1.0, -pole[e]], signal[e])
        for ear in range(2):
            hrir = kemar().irs[nearest[e], ear]
            expected[ear] += np.convolve(through_air, hrir)[: blocks * BLOCK]
    assert np.max(np.abs(rendered - expected)) < 1e-5 * np.max(np.abs(expected))


def test_the_real_form_of_the_one_pole_equals_its_complex_formula() -> None:
    delays = unit_delays(1024)
    pole = np.linspace(0.0, 0.97, 40)
    scale = np.linspace(0.1, 3.0, 40)
    exact = scale[:, None] * (1.0 - pole[:, None]) / (1.0 - pole[:, None] * delays[None, :])
    assert np.max(np.abs(one_pole_response(pole, delays, scale) - exact)) < 1e-5 * np.max(
        np.abs(exact)
    )


def test_delay_lines_read_each_line_as_interpolating_it_alone() -> None:
    """Lines of three emitters, read with ramped delays, round the ring several times."""
    rng = np.random.default_rng(4)
    rate = 48_000
    lines = DelayLines(3, 0.1, rate, BLOCK)
    slots = np.array([2, 0, 1])  # out of order, as live slots may be
    blocks = 3 * lines.length // BLOCK
    history = np.zeros((3, 0))
    for k in range(blocks):
        signal = rng.standard_normal((3, BLOCK)).astype(np.float32)
        d0, d1 = rng.uniform(1e-3, 0.09, 3), rng.uniform(1e-3, 0.09, 3)
        start = k * BLOCK
        out = lines.process(slots, signal, d0, d1)
        history = np.concatenate([history, signal], axis=1)
        t = start + np.arange(BLOCK)
        for e in range(3):
            delay = (d0[e] + (d1[e] - d0[e]) * np.arange(1, BLOCK + 1) / BLOCK) * rate
            # Before the first sample the line holds silence (sample −1 is 0).
            padded = np.concatenate([[0.0], history[e]])
            expected = np.interp(t - delay, np.arange(-1, history.shape[1]), padded, left=0.0)
            assert np.max(np.abs(out[e] - expected)) < 1e-5, f"block {k}, emitter {e}"


def test_noise_of_all_emitters_in_one_product_equals_mixing_each_alone() -> None:
    rng = np.random.default_rng(5)
    noise = NoiseBands(48_000, np.random.default_rng(0))
    offsets = rng.integers(0, noise.samples, 7)
    gains0, gains1 = rng.uniform(0.0, 1.0, (7, 8)), rng.uniform(0.0, 1.0, (7, 8))
    out = noise.read(offsets, gains0, gains1, BLOCK)
    ramp = np.arange(1, BLOCK + 1) / BLOCK
    for e, o in enumerate(offsets):
        bands = noise.tables[o : o + BLOCK].astype(np.float64)
        gains = gains0[e] + (gains1[e] - gains0[e]) * ramp[:, None]  # block × bands
        assert np.max(np.abs(out[e] - np.sum(bands * gains, axis=1))) < 1e-5


def test_a_tone_read_past_one_period_wraps_onto_the_table() -> None:
    """The table wraps the phase itself (a mask on the index), as np.mod would."""
    tables = Wavetables(48_000.0)
    phase = np.linspace(0.0, 60.0, 4 * BLOCK, dtype=np.float32).reshape(4, BLOCK)
    row, frac = np.array([0, 7, 15, 17]), np.array([0.0, 0.4, 1.0, 0.0])
    wrapped = np.mod(phase, np.float32(4 * np.pi))
    np.testing.assert_allclose(tables.tone(phase, row, frac), tables.tone(wrapped, row, frac),
                               atol=1e-4)  # fmt: skip
    assert CYCLE_SAMPLES & (CYCLE_SAMPLES - 1) == 0


@pytest.mark.parametrize("layout", ["stereo", "quad", "5.1", "ring8", "ring5"])
def test_vbap_for_all_sources_at_once_equals_solving_pair_by_pair(layout: str) -> None:
    vbap = Vbap(layout_azimuths(layout))
    directions = unit_direction(np.arange(-180.0, 180.0, 1.7))
    p = directions[:, :2]
    expected = vbap._nearest(p)
    for pair in vbap._pairs:  # the pair-by-pair solution: a later pair overrides
        pair_gains = p @ pair.inverse.T
        inside = np.all(pair_gains >= -1e-9, axis=1)
        expected[inside] = 0.0
        expected[np.ix_(inside, pair.channels)] = np.maximum(pair_gains[inside], 0.0)
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    np.testing.assert_allclose(vbap.gains(directions)[:, vbap.speakers], expected, atol=1e-12)
