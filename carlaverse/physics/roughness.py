"""Road roughness after ISO 8608: a class's spectrum and a seeded profile along the path.

ISO 8608 classifies a road by the power spectral density of its vertical displacement over
spatial frequency n [cycles/m] (one-sided):

    G_d(n) = G_d(n0) · (n / n0)^(−w),   n0 = 0.1 cycles/m,  w = 2

G_d(n0) of a class is the geometric mean of its range: class A (very good) 16·10⁻⁶ m³, and
each class four times the one before (B 64·10⁻⁶ … H 262144·10⁻⁶ m³), so the profile's
amplitude doubles from class to class. The standard's band is 0.011 ≤ n ≤ 2.83 cycles/m
(wavelengths from 90 m down to 0.35 m; shorter ones the tyre's contact patch swallows).

The profile is one periodic realisation by harmonic superposition on an FFT grid:

    h(s) = Σ_k √(2·G_d(n_k)·Δn) · cos(2π·n_k·s + φ_k),   n_k = k·Δn inside the band

with phases φ_k uniform in [0, 2π) from the profile's own seeded generator, summed by one
inverse FFT onto a grid of `spacing_m` and read by linear interpolation. The realisation's
periodogram at each n_k is G_d(n_k) exactly and its variance is ∫ G_d dn over the band; the
same seed gives the same road. The period (`samples · spacing_m`, 1638 m by default) is long
against any wavelength of the band, so the repeat is not felt.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

RoughnessClass = Literal["A", "B", "C", "D", "E", "F", "G", "H"]
CLASSES: tuple[RoughnessClass, ...] = ("A", "B", "C", "D", "E", "F", "G", "H")
N0 = 0.1  # [cycles/m] reference spatial frequency
WAVINESS = 2.0  # w [-]
BAND = (0.011, 2.83)  # [cycles/m] the standard's spatial-frequency band
CLASS_A_GD_N0 = 16e-6  # [m³] G_d(n0) of class A, geometric mean of its range
DEFAULT_SPACING_M = 0.05  # [m] grid spacing: 7 points per shortest wavelength of the band
DEFAULT_SAMPLES = 2**15  # grid points: a 1638.4 m period at the default spacing


def class_gd_n0(roughness_class: RoughnessClass) -> float:
    """G_d(n0) [m³] of an ISO 8608 class: 16·10⁻⁶ m³ for A, ×4 per class after it."""
    return CLASS_A_GD_N0 * 4.0 ** CLASSES.index(roughness_class)


def displacement_psd(roughness_class: RoughnessClass, n: np.ndarray) -> np.ndarray:
    """G_d(n) [m³] of the class at spatial frequencies n [cycles/m] (ISO 8608, w = 2)."""
    return class_gd_n0(roughness_class) * (np.asarray(n) / N0) ** (-WAVINESS)


class RoughnessProfile:
    """One seeded realisation of a class; `height(s)` [m] at path distance s [m]."""

    def __init__(
        self,
        roughness_class: RoughnessClass,
        seed: int,
        *,
        spacing_m: float = DEFAULT_SPACING_M,
        samples: int = DEFAULT_SAMPLES,
    ) -> None:
        self.roughness_class = roughness_class
        self.seed = seed
        self.spacing_m = spacing_m
        self.period_m = samples * spacing_m
        self.rng = np.random.default_rng(seed)  # owned by the model: its phases only
        grid = self._realise(samples)
        # A plain list: the loop reads two values a tick, and list indexing is several times
        # cheaper than indexing a numpy array from Python.
        self._table: list[float] = [*grid.tolist(), float(grid[0])]  # closed for wrap-around

    def _realise(self, samples: int) -> np.ndarray:
        dn = 1.0 / self.period_m  # [cycles/m] the grid's frequency step
        n = np.arange(samples // 2 + 1) * dn
        inside = (n >= BAND[0]) & (n <= BAND[1])
        amplitude = np.zeros_like(n)
        amplitude[inside] = np.sqrt(2.0 * displacement_psd(self.roughness_class, n[inside]) * dn)
        phase = self.rng.uniform(0.0, 2.0 * math.pi, n.size)
        # irfft(X)[j] = (1/N)·Σ X_k e^{2πi·kj/N} (+ conjugates): X_k = N/2·A_k·e^{iφ_k} gives
        # Σ A_k cos(2π n_k s_j + φ_k) on s_j = j·spacing.
        spectrum = samples / 2.0 * amplitude * np.exp(1j * phase)
        return np.fft.irfft(spectrum, samples)

    def height(self, s: float) -> float:
        """Profile height [m] at path distance s [m] (any sign: the profile repeats)."""
        position = (s % self.period_m) / self.spacing_m
        i = int(position)
        frac = position - i
        table = self._table
        return table[i] + frac * (table[i + 1] - table[i])

    @property
    def variance_m2(self) -> float:
        """∫ G_d dn over the band [m²]: the profile's mean square, analytically (w = 2)."""
        return class_gd_n0(self.roughness_class) * N0**2 * (1.0 / BAND[0] - 1.0 / BAND[1])
