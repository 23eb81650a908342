"""Tables computed once so that the per-block work of tonal sources is a lookup, not sines.

An engine's waveform depends on its load only through its harmonic amplitudes, so one cycle
(0..4π of the firing phase: the half orders repeat only then) is tabulated per load step and
read with linear interpolation in phase and load. A siren's tone is one table; a hammer blow
(its noise envelope and the ring of the struck plate) is one table indexed by the time since
the blow.
"""

from __future__ import annotations

import numpy as np

from carlaverse.audio import voicing as shape

CYCLE_SAMPLES = 4096  # table points per cycle: linear interpolation error < −80 dB
LOAD_STEPS = 16  # engine load 0..1 in this many intervals
BLOW_S = 0.6  # [s] a hammer blow's table: the ring has decayed by 43 dB then


class Wavetables:
    """The engine, siren and hammer-blow tables at one sample rate."""

    def __init__(self, sample_rate_hz: float) -> None:
        self._engine = _engine_table().ravel()  # (LOAD_STEPS + 1) rows of CYCLE_SAMPLES + 1
        self._siren = _siren_table()  # CYCLE_SAMPLES + 1
        n = int(BLOW_S * sample_rate_hz)
        t = np.arange(n + 1) / sample_rate_hz
        self.hit_envelope = np.exp(-t / shape.HIT_DECAY_S).astype(np.float32)
        self.hit_envelope[-1] = 0.0
        partials = np.sin(2 * np.pi * shape.CLANK_HZ[:, None] * t[None, :]).sum(axis=0)
        self.clank = (partials * np.exp(-t / shape.CLANK_DECAY_S)).astype(np.float32)
        self.clank[-1] = 0.0
        self.blow_samples = n

    def engine(self, phase: np.ndarray, load: np.ndarray) -> np.ndarray:
        """(E × block) engine tone at `phase` [rad, 0..4π], `load` (E,) 0..1."""
        row = load * LOAD_STEPS
        low = np.minimum(row.astype(np.int64), LOAD_STEPS - 1)
        frac = (row - low).astype(np.float32)[:, None]
        i, f = _cycle_index(phase, 4 * np.pi)
        i += (low * (CYCLE_SAMPLES + 1))[:, None]  # into the flattened table
        table, stride = self._engine, CYCLE_SAMPLES + 1
        near = _lerp(table.take(i), table.take(i + 1), f)
        far = _lerp(table.take(i + stride), table.take(i + stride + 1), f)
        return near + (far - near) * frac

    def siren(self, phase: np.ndarray) -> np.ndarray:
        """(E × block) siren tone at `phase` [rad, 0..4π]: the table holds two cycles."""
        i, f = _cycle_index(phase, 4 * np.pi)
        return _lerp(self._siren.take(i), self._siren.take(i + 1), f)


def _cycle_index(phase: np.ndarray, period: float) -> tuple[np.ndarray, np.ndarray]:
    x = phase * np.float32(CYCLE_SAMPLES / period)
    i = np.minimum(x.astype(np.int64), CYCLE_SAMPLES - 1)
    return i, x - i


def _lerp(a: np.ndarray, b: np.ndarray, f: np.ndarray) -> np.ndarray:
    return a + (b - a) * f


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
