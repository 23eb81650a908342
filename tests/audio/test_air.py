"""Air: ISO 9613-1 absorption against the standard's table, and how closely the renderer's
flat-loss-plus-one-pole fit follows it."""

from __future__ import annotations

import numpy as np
import pytest

from carlaverse.audio.air import (
    AirAbsorption,
    absorption_db_per_m,
    one_pole_response,
    speed_of_sound_mps,
    unit_delays,
)
from carlaverse.audio.config import AirConfig

RATE = 48_000


@pytest.mark.parametrize(
    ("exact_hz", "table_db_per_km"),
    # ISO 9613-1 Table 1, 20 °C, 70 % relative humidity, 101.325 kPa, at the exact
    # midband frequencies of the octave bands.
    [
        (125.89, 0.34),
        (501.19, 2.80),
        (1000.0, 4.98),
        (1995.3, 9.02),
        (3981.1, 22.9),
        (7943.3, 76.6),
    ],
)
def test_absorption_matches_the_iso_table(exact_hz: float, table_db_per_km: float) -> None:
    got = float(absorption_db_per_m(exact_hz, AirConfig())) * 1e3
    assert got == pytest.approx(table_db_per_km, rel=0.02)


def test_speed_of_sound_at_20_c() -> None:
    assert speed_of_sound_mps(AirConfig()) == pytest.approx(343.2, abs=0.1)


@pytest.mark.parametrize(
    ("distance_m", "tolerance_db"),
    # One pole is steeper than the ISO curve between the fit points; the error grows with
    # the loss (at 400 m: 3.6 dB at 2 kHz modelled as 4.7 dB).
    [(10.0, 0.5), (50.0, 0.5), (100.0, 0.5), (200.0, 0.5), (400.0, 1.5)],
)
def test_the_fit_follows_iso_from_500_hz_to_4_khz(distance_m: float, tolerance_db: float) -> None:
    n_fft = 8192
    flat, pole = AirAbsorption(AirConfig(), RATE).fit(np.array([distance_m]))
    response = np.abs(one_pole_response(pole, unit_delays(n_fft))[0]) * flat[0]
    f = np.fft.rfftfreq(n_fft, 1.0 / RATE)
    band = (f >= 500.0) & (f <= 4000.0)
    fitted = -20.0 * np.log10(response[band])
    iso = absorption_db_per_m(f[band], AirConfig()) * distance_m
    assert np.max(np.abs(fitted - iso)) < tolerance_db
    # Exact where it is fitted.
    for exact in (1000.0, 4000.0):
        k = int(np.argmin(np.abs(f - exact)))
        loss = -20.0 * np.log10(response[k])
        assert loss == pytest.approx(absorption_db_per_m(f[k], AirConfig()) * distance_m, abs=0.02)
