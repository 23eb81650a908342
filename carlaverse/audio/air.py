"""Sound in air: its speed, its absorption (ISO 9613-1) and a one-pole low-pass that fits it.

Absorption grows roughly with the square of frequency at high frequencies, and so does the
loss of a one-pole low-pass well below its corner (10·log10(1 + (f/fc)²) ≈ 4.34·(f/fc)² dB).
Below a few kHz the ISO curve flattens (oxygen relaxation), which a broadband loss covers. So
each emitter gets a flat gain and one pole, fitted for the distance its sound travelled to
match the ISO loss exactly at `FIT_LOW_HZ` and `FIT_HIGH_HZ` (tests/audio/test_air.py
measures the error in between and beyond).
"""

from __future__ import annotations

import math

import numpy as np

from carlaverse.audio.config import AirConfig

REFERENCE_PRESSURE_KPA = 101.325  # [kPa]
REFERENCE_TEMPERATURE_K = 293.15  # [K]
TRIPLE_POINT_K = 273.16  # [K] of water
FIT_LOW_HZ, FIT_HIGH_HZ = 1000.0, 4000.0  # [Hz] where the fit matches ISO 9613-1 exactly
FIT_ROUNDS = 6  # alternations between the flat loss and the pole: converged to < 0.01 dB
TABLE_POINTS = 512  # distances tabulated, geometric: < 0.01 dB between two of them
MAX_POLE = 0.97  # keeps the pole's impulse response inside the renderer's FFT history


def speed_of_sound_mps(air: AirConfig) -> float:
    """[m/s] in dry air at the configured temperature (343.2 m/s at 20 °C)."""
    return 331.3 * math.sqrt(1.0 + air.temperature_c / 273.15)


def absorption_db_per_m(frequency_hz: np.ndarray | float, air: AirConfig) -> np.ndarray:
    """Pure-tone atmospheric absorption coefficient α [dB/m], ISO 9613-1 equations (3)–(5)."""
    f = np.asarray(frequency_hz, dtype=np.float64)
    t = air.temperature_c + 273.15  # [K]
    p = air.pressure_kpa / REFERENCE_PRESSURE_KPA
    tr = t / REFERENCE_TEMPERATURE_K
    saturation = 10.0 ** (-6.8346 * (TRIPLE_POINT_K / t) ** 1.261 + 4.6151)
    h = air.humidity_percent * saturation / p  # molar concentration of water vapour [%]
    fr_o = p * (24.0 + 4.04e4 * h * (0.02 + h) / (0.391 + h))  # oxygen relaxation [Hz]
    fr_n = p * tr**-0.5 * (9.0 + 280.0 * h * math.exp(-4.170 * (tr ** (-1 / 3) - 1.0)))
    return (
        8.686
        * f**2
        * (
            1.84e-11 / p * tr**0.5
            + tr**-2.5
            * (
                0.01275 * math.exp(-2239.1 / t) / (fr_o + f**2 / fr_o)
                + 0.1068 * math.exp(-3352.0 / t) / (fr_n + f**2 / fr_n)
            )
        )
    )


class AirAbsorption:
    """Per emitter, for the distance its sound travelled: a flat gain and a one-pole."""

    def __init__(self, air: AirConfig, sample_rate_hz: float, max_distance_m: float = 5e3):
        self.alpha_low, self.alpha_high = absorption_db_per_m(
            np.array([FIT_LOW_HZ, FIT_HIGH_HZ]), air
        )
        self._cos_low = math.cos(2.0 * math.pi * FIT_LOW_HZ / sample_rate_hz)
        self._cos_high = math.cos(2.0 * math.pi * FIT_HIGH_HZ / sample_rate_hz)
        # The fit is smooth in distance: tabulated once, interpolated per block.
        self._grid = np.geomspace(0.1, 1.5 * max_distance_m, TABLE_POINTS)
        self._flat, self._pole = self.fit(self._grid)

    def at(self, distance_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`fit` from the table: (flat gain, pole) per distance."""
        d = np.asarray(distance_m, dtype=np.float64)
        return np.interp(d, self._grid, self._flat), np.interp(d, self._grid, self._pole)

    def fit(self, distance_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(flat gain, pole a of y[n] = (1 − a)·x[n] + a·y[n−1]) per distance."""
        d = np.asarray(distance_m, dtype=np.float64)
        loss_low, loss_high = self.alpha_low * d, self.alpha_high * d  # [dB]
        flat_db = np.zeros_like(d)
        for _ in range(FIT_ROUNDS):
            pole = _pole_for_loss(np.maximum(loss_high - flat_db, 0.0), self._cos_high)
            flat_db = np.maximum(loss_low - _pole_loss_db(pole, self._cos_low), 0.0)
        return 10.0 ** (-flat_db / 20.0), pole


def _pole_for_loss(loss_db: np.ndarray, cos_w: float) -> np.ndarray:
    """The pole whose digital one-pole loses `loss_db` at cos ω = `cos_w` (exact root)."""
    g2 = 10.0 ** (-loss_db / 10.0)  # power gain
    one_minus = np.maximum(1.0 - g2, 1e-12)
    b = 1.0 - g2 * cos_w
    a = (b - np.sqrt(np.maximum(b * b - one_minus * one_minus, 0.0))) / one_minus
    return np.clip(np.where(loss_db > 1e-9, a, 0.0), 0.0, MAX_POLE)


def _pole_loss_db(pole: np.ndarray, cos_w: float) -> np.ndarray:
    power = (1.0 - pole) ** 2 / (1.0 - 2.0 * pole * cos_w + pole * pole)
    return -10.0 * np.log10(power)


def unit_delays(n_fft: int) -> np.ndarray:
    """e^{−jω} on the rfft grid of `n_fft` points (complex64), for `one_pole_response`."""
    return np.exp(-2j * np.pi * np.arange(n_fft // 2 + 1) / n_fft).astype(np.complex64)


def one_pole_response(pole: np.ndarray, delays: np.ndarray,
                      scale: np.ndarray | float = 1.0) -> np.ndarray:  # fmt: skip
    """Complex response (E × F) of scale · (1 − a) / (1 − a·e^{−jω}); `delays` from
    unit_delays. In real arithmetic (a complex division costs more than all the rest):
    with d = 1 − a·e^{−jω} = (1 − a·cos ω) + j·a·sin ω, 1/d = conj(d) / |d|², |d|² summed
    from its parts (1 + a² − 2a·cos ω would cancel near DC in float32)."""
    a = np.asarray(pole, dtype=np.float32)[:, None]
    k = ((1.0 - a) * np.asarray(scale, dtype=np.float32).reshape(-1, 1)).astype(np.float32)
    re = 1.0 - a * delays.real
    im = a * delays.imag  # = −a·sin ω
    g = k / (re * re + im * im)
    out = np.empty((a.shape[0], delays.size), dtype=np.complex64)
    np.multiply(g, re, out=out.real)
    np.multiply(g, im, out=out.imag)
    return out
