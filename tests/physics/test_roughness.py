"""ISO 8608 roughness: the generated profile has its class's spectrum, amplitude and seed.

Reference values come from the standard, not from the module: the displacement PSD
G_d(n) = G_d(n0)·(n/n0)^−w with n0 = 0.1 cycles/m, waviness w = 2, and G_d(n0) the geometric
mean of each class (A: 16·10⁻⁶ m³, ×4 per class), over 0.011 ≤ n ≤ 2.83 cycles/m. The
spectrum is estimated with scipy's Welch estimator, which is not ours.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import welch

from carlaverse.physics.roughness import RoughnessProfile

ISO_GD_N0 = {"A": 16e-6, "B": 64e-6, "C": 256e-6, "D": 1024e-6, "E": 4096e-6}  # [m³]
N0, W, BAND = 0.1, 2.0, (0.011, 2.83)


def sampled(profile: RoughnessProfile, spacing_m: float, length_m: float) -> np.ndarray:
    """Heights read through the public lookup, on a grid that is not the generator's own."""
    return np.array(
        [profile.height(0.0137 + i * spacing_m) for i in range(int(length_m / spacing_m))]
    )


@pytest.mark.parametrize("roughness_class", ["B", "D"])
def test_the_periodogram_fits_the_iso_8608_class(roughness_class: str) -> None:
    spacing = 0.1  # [m] 5 cycles/m Nyquist, above the band
    heights = sampled(RoughnessProfile(roughness_class, seed=11), spacing, 1500.0)  # type: ignore[arg-type]
    n, psd = welch(heights, fs=1.0 / spacing, nperseg=4096, scaling="density")  # one-sided
    fit = (n >= 0.02) & (n <= 2.0)  # inside the band, clear of its edges' leakage
    slope, intercept = np.polyfit(np.log10(n[fit]), np.log10(psd[fit]), 1)
    gd_n0 = 10 ** (intercept + slope * math.log10(N0))
    # Waviness: −w within 0.1. Level: a class spans a factor 4 around its mean (½× to 2×),
    # so 20 % is a fifth of a class; Welch's averaging over ~7 segments leaves ~±10 % scatter
    # per decade, and linear interpolation between the 5 cm grid points takes ~5 % near
    # 2.8 cycles/m.
    assert slope == pytest.approx(-W, abs=0.1)
    assert gd_n0 == pytest.approx(ISO_GD_N0[roughness_class], rel=0.2)


def test_the_profile_has_the_rms_of_its_band() -> None:
    # σ² = ∫ G_d(n0)·(n0/n)² dn over the band = G_d(n0)·n0²·(1/n_lo − 1/n_hi).
    profile = RoughnessProfile("C", seed=3)
    sigma = math.sqrt(ISO_GD_N0["C"] * N0**2 * (1 / BAND[0] - 1 / BAND[1]))  # 15 mm
    heights = sampled(profile, 0.05, profile.period_m)  # one whole period
    # 3 %: interpolation between grid points lowers the shortest waves' share (< 1 % of σ²).
    assert heights.std() == pytest.approx(sigma, rel=0.03)
    assert abs(heights.mean()) < 0.01 * sigma  # no offset: a profile about its mean


def test_the_same_seed_gives_the_same_road_and_each_class_doubles_it() -> None:
    s = [0.37 * i for i in range(2000)]
    b, again, other = (RoughnessProfile("B", seed=k) for k in (5, 5, 6))
    assert [b.height(x) for x in s] == [again.height(x) for x in s]
    correlation = np.corrcoef([b.height(x) for x in s], [other.height(x) for x in s])[0, 1]
    assert abs(correlation) < 0.3  # another seed, another road
    # Four times the PSD is twice the amplitude: with the same phases, the same road doubled.
    c = RoughnessProfile("C", seed=5)
    assert [c.height(x) for x in s] == pytest.approx([2 * b.height(x) for x in s], abs=1e-12)


def test_the_profile_repeats_with_its_period_and_reads_any_distance() -> None:
    profile = RoughnessProfile("A", seed=1)
    for s in (0.0, 12.34, 999.9):
        assert profile.height(s + profile.period_m) == pytest.approx(profile.height(s), abs=1e-12)
        assert profile.height(s - profile.period_m) == pytest.approx(profile.height(s), abs=1e-12)
