"""Physical scenarios rendered to WAV and measured: movement, Doppler, distance, range.

The listener stands at the origin facing east (+x), so north (+y) is to their left.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from carlaverse.audio.air import absorption_db_per_m, speed_of_sound_mps
from carlaverse.audio.config import AirConfig
from tests.audio.measure import (
    RATE,
    band_level_db,
    lag_s,
    level_db,
    lowpass,
    peak_hz,
    render_wav,
    scenes,
    windows,
)

C_MPS = speed_of_sound_mps(AirConfig())


def car(x0: float, y0: float, vx: float, vy: float, rpm: float = 3000.0) -> list:
    """An engine and its tyres moving together in a straight line."""
    return [
        ("car.engine", "engine", 85.0, rpm, 0.5, (x0, y0, 0.5), (vx, vy, 0.0)),
        ("car.tyres", "tyres", 80.0, 15.0, 0.0, (x0, y0, 0.0), (vx, vy, 0.0)),
    ]


PASS_BY = car(10.0, 40.0, 0.0, -20.0)


def test_a_car_passing_left_to_right_moves_energy_and_itd_from_left_to_right(
    tmp_path: Path,
) -> None:
    # 10 m ahead, from 40 m on the left to 40 m on the right at 20 m/s (4 s).
    audio, _ = render_wav(tmp_path / "pass.wav", scenes(PASS_BY, 4.0))
    first, last = audio[int(0.3 * RATE) : int(1.0 * RATE)], audio[int(3.0 * RATE) : int(3.7 * RATE)]
    ild = [level_db(w[:, 0]) - level_db(w[:, 1]) for w in windows(audio[int(0.3 * RATE) :], 0.5)]
    assert ild[0] > 6.0 and ild[-1] < -6.0, f"ILD per 0.5 s [dB] {np.round(ild, 1)}"
    # The ILD falls through the pass (small wiggles allowed: the HRTF is not monotonic).
    assert np.all(np.diff(ild) < 1.5), f"ILD per 0.5 s [dB] {np.round(ild, 1)}"
    # ITD from the low band (< 1.5 kHz, where the phase of the wave carries it).
    early, late = lowpass(first, 1500.0), lowpass(last, 1500.0)
    itd_early, itd_late = lag_s(early[:, 0], early[:, 1]), lag_s(late[:, 0], late[:, 1])
    assert 2e-4 < itd_early < 9e-4, f"left ear should lead by 0.2–0.9 ms, got {itd_early * 1e3} ms"
    assert -9e-4 < itd_late < -2e-4, f"right ear should lead, got {itd_late * 1e3} ms"


def test_stereo_pans_the_same_pass_by_amplitude_alone(tmp_path: Path) -> None:
    audio, _ = render_wav(tmp_path / "pass.wav", scenes(PASS_BY, 4.0), layout="stereo")
    balance = [level_db(w[:, 0]) - level_db(w[:, 1]) for w in windows(audio[RATE // 4 :], 0.5)]
    assert balance[0] > 20.0 and balance[-1] < -20.0, np.round(balance, 1)
    # Centre: both speakers carry the same signal at different gains, with no lag.
    centre = audio[int(1.8 * RATE) : int(2.2 * RATE)]
    assert lag_s(centre[:, 0], centre[:, 1]) == 0.0


def test_binaural_has_interaural_differences_where_panning_has_none(tmp_path: Path) -> None:
    # A standing engine 20 m away, 15° to the left.
    angle = np.radians(15.0)
    still = [("e", "tyres", 80.0, 15.0, 0.0, (20 * np.cos(angle), 20 * np.sin(angle), 0.0),
              (0.0, 0.0, 0.0))]  # fmt: skip
    ears, _ = render_wav(tmp_path / "b.wav", scenes(still, 2.0))
    speakers, _ = render_wav(tmp_path / "s.wav", scenes(still, 2.0), layout="stereo")
    ears, speakers = ears[RATE:], speakers[RATE:]
    low = lowpass(ears, 1500.0)
    itd = lag_s(low[:, 0], low[:, 1])
    assert 5e-5 < itd < 4e-4, f"binaural ITD at 15° left: {itd * 1e3:.3f} ms"
    assert np.corrcoef(ears[:, 0], ears[:, 1])[0, 1] < 0.95  # the ears hear filtered copies
    assert lag_s(speakers[:, 0], speakers[:, 1]) == 0.0
    assert np.corrcoef(speakers[:, 0], speakers[:, 1])[0, 1] > 0.9999  # one signal, two gains
    assert level_db(speakers[:, 0]) > level_db(speakers[:, 1]) + 3.0  # left speaker louder


def test_doppler_ratio_within_one_percent_of_c_over_c_minus_v(tmp_path: Path) -> None:
    """Peak frequency of an engine at constant rpm, heading straight for the listener and
    straight away, against the same engine standing."""

    def heard(x0: float, v: float) -> float:
        engine = [("e", "engine", 95.0, 3000.0, 0.3, (x0, 0.5, 0.0), (v, 0.0, 0.0))]
        audio, _ = render_wav(tmp_path / "d.wav", scenes(engine, 1.5), layout="stereo")
        return peak_hz(audio[int(0.45 * RATE) : int(1.45 * RATE), 0])

    speed_mps = 30.0  # [m/s] 108 km/h
    standing = heard(-60.0, 0.0)
    approaching = heard(-100.0, speed_mps) / standing
    receding = heard(5.0, speed_mps) / standing
    assert approaching == pytest.approx(C_MPS / (C_MPS - speed_mps), rel=0.01)
    assert receding == pytest.approx(C_MPS / (C_MPS + speed_mps), rel=0.01)
    # It is the exact relation, not the first-order one (1 ± v/c) that differs by 1.2 %.
    assert approaching == pytest.approx(C_MPS / (C_MPS - speed_mps), rel=1e-3)


def test_level_falls_six_db_per_doubling_plus_air_absorption(tmp_path: Path) -> None:
    """Tyre noise straight ahead at 20, 40, 80 and 160 m; third-octave levels per doubling."""
    distances = (20.0, 40.0, 80.0, 160.0)
    bands = (500.0, 1000.0, 2000.0, 4000.0)
    levels = []
    for d in distances:
        tyres = [("t", "tyres", 100.0, 15.0, 0.5, (d, 0.0, 0.0), (0.0, 0.0, 0.0))]
        audio, _ = render_wav(tmp_path / "l.wav", scenes(tyres, 1.2), layout="stereo")
        start = int((d / C_MPS + 0.1) * RATE)  # once the sound has arrived
        levels.append([band_level_db(audio[start : start + RATE // 2, 0], f) for f in bands])
    drops = -np.diff(np.asarray(levels), axis=0)  # doublings × bands [dB]
    for i, d in enumerate(distances[:-1]):
        expected = 20 * np.log10(2.0) + absorption_db_per_m(np.array(bands), AirConfig()) * d
        assert drops[i] == pytest.approx(expected, abs=0.3), (
            f"{d:g}→{2 * d:g} m: drop {np.round(drops[i], 2)} dB, expected "
            f"{np.round(expected, 2)} dB at {bands} Hz"
        )


def test_a_siren_out_of_range_is_silent_and_audible_in_range(tmp_path: Path) -> None:
    far = [("s", "siren", 120.0, 2.0, 0.0, (2000.0, 0.0, 0.0), (0.0, 0.0, 0.0))]
    audio, _ = render_wav(tmp_path / "far.wav", scenes(far, 1.5), max_distance_m=400.0)
    assert not np.any(audio), "a siren beyond max_distance_m must be digital silence"
    near = [("s", "siren", 120.0, 2.0, 0.0, (300.0, 0.0, 0.0), (0.0, 0.0, 0.0))]
    audio, _ = render_wav(tmp_path / "near.wav", scenes(near, 1.3), max_distance_m=400.0)
    arrival = int((300.0 / C_MPS + 0.05) * RATE)
    assert not np.any(audio[: int(0.8 * 300.0 / C_MPS * RATE)]), "heard before it could arrive"
    assert level_db(audio[arrival:]) > -60.0
