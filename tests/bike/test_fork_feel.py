"""Fork force feedback: trail self-centering, road texture, impulse jolts."""

from __future__ import annotations

import pytest
from carlaverse_nodes.bike.fork_feel import ForkFeel, ForkFeelParams, centering_torque

from carlaverse.physics.bicycle import BicycleParams

BIKE = BicycleParams()
P = ForkFeelParams()


def test_trail_pulls_the_fork_back_harder_at_speed() -> None:
    # at rest: −t·m_f·g·sin δ = −0.06 · 35 · 9.81 · sin 0.1 = −2.0567 N·m
    assert centering_torque(P, BIKE, 0.0, 0.1) == pytest.approx(-2.05668, abs=1e-4)
    # at 5 m/s add −t·m_f·v²·tan δ/L = −0.06 · 35 · 25 · 0.100335 / 1.08 = −4.8773 N·m
    assert centering_torque(P, BIKE, 5.0, 0.1) == pytest.approx(-2.05668 - 4.87739, abs=1e-4)
    assert centering_torque(P, BIKE, 5.0, -0.1) == pytest.approx(2.05668 + 4.87739, abs=1e-4)
    command = ForkFeel(P, BIKE).update(0.005, 5.0, 0.1, 0.0)
    assert command.constant_force == round(-6.93407 / P.full_scale_nm * 10000)  # −8668


def test_surface_vibration_grows_with_speed_and_roughness() -> None:
    fork = ForkFeel(P, BIKE)
    smooth = fork.update(0.005, 5.0, 0.0, 0.1)
    rough = fork.update(0.005, 5.0, 0.0, 0.5)
    fast = fork.update(0.005, 8.0, 0.0, 0.5)
    assert smooth.vibration_magnitude == 300  # 600 · 5 m/s · 0.1
    assert rough.vibration_magnitude == 1500 < fast.vibration_magnitude == 2400
    assert rough.vibration_frequency_hz == P.texture_hz
    assert fork.update(0.005, 0.0, 0.0, 1.0).vibration_magnitude == 0  # standing: no texture


def test_an_impulse_jolts_the_fork_and_fades() -> None:
    fork = ForkFeel(P, BIKE)
    fork.add_jolt(2.0, -1.0)  # 2 m/s knock from the left side, to the right
    first = fork.update(0.005, 3.0, 0.0, 0.1)
    assert first.vibration_magnitude == 6000 and first.vibration_frequency_hz == P.jolt_hz
    assert first.constant_force == -6000  # kicked the way the bike was pushed
    for _ in range(round(0.6 / 0.005)):  # 4 time constants later
        last = fork.update(0.005, 3.0, 0.0, 0.1)
    assert last.vibration_magnitude == 180 and last.vibration_frequency_hz == P.texture_hz
    assert abs(last.constant_force) < 120  # 6000 · e^−4 ≈ 110
