"""Tables computed once so that the per-block work of tonal sources is a lookup, not sines.

An engine's waveform depends on its load only through its harmonic amplitudes, so one cycle
(0..4π of the firing phase: the half orders repeat only then) is tabulated per load step and
read with linear interpolation in phase and load. A siren's tone is one more row of the same
table (two cycles over 0..4π), so engines and sirens are read together in one lookup. Each
entry holds its value and the step to the next as one complex number: one gather gives both
ends of the interpolation. A hammer blow (its noise envelope and the ring of the struck
plate) is one table indexed by the time since the blow.
"""

from __future__ import annotations

import numpy as np

from carlaverse.audio import voicing as shape

CYCLE_SAMPLES = 4096  # table points per cycle (a power of two): interpolation error < −80 dB
LOAD_STEPS = 16  # engine load 0..1 in this many intervals
BLOW_S = 0.6  # [s] a hammer blow's table: the ring has decayed by 43 dB then


SIREN_ROW = LOAD_STEPS + 1  # the tone table's siren row (repeated once: its "next load")


class Wavetables:
    """The tone (engine loads, siren) and hammer-blow tables at one sample rate."""

    def __init__(self, sample_rate_hz: float) -> None:
        rows = np.concatenate([_engine_table(), [_siren_table()] * 2])
        steps = np.diff(rows, axis=1)  # float32, as the interpolation subtracted them
        self._tones = (rows[:, :-1] + 1j * steps).astype(np.complex64).ravel()
        n = int(BLOW_S * sample_rate_hz)
        t = np.arange(n + 1) / sample_rate_hz
        self.hit_envelope = np.exp(-t / shape.HIT_DECAY_S).astype(np.float32)
        self.hit_envelope[-1] = 0.0
        partials = np.sin(2 * np.pi * shape.CLANK_HZ[:, None] * t[None, :]).sum(axis=0)
        self.clank = (partials * np.exp(-t / shape.CLANK_DECAY_S)).astype(np.float32)
        self.clank[-1] = 0.0
        self.blow_samples = n

    def tone(self, phase: np.ndarray, row: np.ndarray, frac: np.ndarray) -> np.ndarray:
        """(E × block) tones at `phase` [rad, any value: the table is one period of 4π] from
        table rows `row` (E,) blended `frac` (E,) of the way to the next row (an engine's
        load between two steps)."""
        i, f = _cycle_index(phase, 4 * np.pi)
        i += (row * CYCLE_SAMPLES)[:, None]
        near, far = self._tones.take(i), self._tones.take(i + CYCLE_SAMPLES)
        near_value = near.real + near.imag * f
        far_value = far.real + far.imag * f
        return near_value + (far_value - near_value) * frac.astype(np.float32)[:, None]


def engine_row(load: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The tone table's row (E,) and the blend to the next (E,) of an engine at `load` 0..1."""
    position = load * LOAD_STEPS
    row = np.minimum(position.astype(np.int64), LOAD_STEPS - 1)
    return row, position - row


def _cycle_index(phase: np.ndarray, period: float) -> tuple[np.ndarray, np.ndarray]:
    """Table index (wrapped into one period: CYCLE_SAMPLES is a power of two, so a mask
    does it, far cheaper than a float modulo) and the fraction to the next point."""
    x = phase * np.float32(CYCLE_SAMPLES / period)
    whole = np.floor(x)
    i = whole.astype(np.int64)
    i &= CYCLE_SAMPLES - 1
    return i, x - whole


def _engine_table() -> np.ndarray:
    phase = np.linspace(0.0, 4 * np.pi, CYCLE_SAMPLES + 1)
    rows = []
    for load in np.linspace(0.0, 1.0, LOAD_STEPS + 1):
        amps = shape.ENGINE_AMPLITUDES * (1.0 + load * shape.ENGINE_LOAD_TILT)
        amps = amps / np.sqrt(0.5 * np.sum(amps**2))  # RMS 1
        rows.append(np.sin(np.outer(phase, shape.ENGINE_ORDERS)) @ amps)
    return np.asarray(rows, dtype=np.float32)


def _siren_table() -> np.ndarray:
    phase = np.linspace(0.0, 4 * np.pi, CYCLE_SAMPLES + 1)
    orders = np.array([1.0, 3.0, 5.0])
    tone = np.sin(np.outer(phase, orders)) @ shape.SIREN_HARMONICS
    return (tone / np.sqrt(0.5 * np.sum(shape.SIREN_HARMONICS**2))).astype(np.float32)
