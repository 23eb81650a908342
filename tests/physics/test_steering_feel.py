"""Steering feel: the parking blend is continuous and equals each model at its end."""

from __future__ import annotations

import math

import pytest

from carlaverse.physics.impulse import ImpulseResponse
from carlaverse.physics.steering_feel import (
    FfbCommandValues,
    SteeringFeel,
    SteeringFeelParams,
    blend_weight,
)
from carlaverse.physics.tyre import self_aligning_torque

PARAMS = SteeringFeelParams()
T_P, RATIO = 0.035, 14.5  # [m], [-] as the compact car
ALPHA, FZ = 0.03, 7800.0  # [rad], [N]: a moderate front slip angle on a loaded axle


def feel(params: SteeringFeelParams = PARAMS) -> SteeringFeel:
    return SteeringFeel(params, T_P, RATIO, redline_rpm=6200.0, cylinders=3)


def command_at(speed_kmh: float, alpha: float = ALPHA) -> FfbCommandValues:
    return feel().update(0.001, speed_kmh / 3.6, alpha, FZ, rpm=0.0)


def pacejka_force_units(alpha: float) -> int:
    """The Pacejka side by hand: M_z through ratio and assist, mapped to ±10000, + = right."""
    torque = self_aligning_torque(FZ, T_P, alpha) * (1.0 - PARAMS.assist) / RATIO
    return round(-torque / PARAMS.full_scale_torque_nm * 10000)


def test_at_standstill_the_command_is_the_parking_model() -> None:
    cmd = command_at(0.0)
    assert cmd.constant_force == 0
    assert cmd.spring_stiffness == PARAMS.parking_spring
    assert cmd.friction == PARAMS.parking_friction


@pytest.mark.parametrize("speed_kmh", [15.0, 15.01, 30.0, 120.0])
def test_from_15_kmh_the_command_is_the_pacejka_model(speed_kmh: float) -> None:
    cmd = command_at(speed_kmh)
    assert cmd.constant_force == pacejka_force_units(ALPHA)
    assert cmd.spring_stiffness == PARAMS.driving_spring
    assert cmd.friction == PARAMS.driving_friction


def test_aligning_torque_pushes_the_wheel_back_to_centre() -> None:
    # Steered left (α > 0): M_z < 0 turns the wheel right, which is + on the wire.
    assert command_at(50.0, alpha=0.03).constant_force > 0
    assert command_at(50.0, alpha=-0.03).constant_force < 0


def test_blend_is_continuous_with_no_step() -> None:
    """Sweep 0..20 km/h in 0.01 km/h steps; no field may jump.

    The steepest field is the spring (6000 units over the 12 km/h band); smoothstep's
    largest slope is 1.5/band, so 0.01 km/h may move it by at most 6000·1.5·0.01/12 = 7.5
    units. Allow 10 (rounding to int adds ±1 at each end).
    """
    previous: list[int] | None = None
    fields = FfbCommandValues.__slots__
    for i in range(1, 2001):
        cmd = command_at(i * 0.01)
        values = [getattr(cmd, f) for f in fields]
        if previous is not None:
            steps = [abs(a - b) for a, b in zip(values, previous, strict=True)]
            assert max(steps) <= 10, (i * 0.01, dict(zip(fields, steps, strict=True)))
        previous = values


def test_blend_weight_ends_and_slope() -> None:
    assert blend_weight(0.0, 3.0, 15.0) == 0.0
    assert blend_weight(3.0 / 3.6, 3.0, 15.0) == 0.0
    assert blend_weight(15.0 / 3.6, 3.0, 15.0) == 1.0
    assert blend_weight(-20.0, 3.0, 15.0) == 1.0  # reversing fast: speed, not velocity
    # Zero slope at both ends (C¹): the weight a hair inside the band is quadratic in the gap.
    eps = 1e-4
    assert blend_weight((15.0 - eps) / 3.6, 3.0, 15.0) == pytest.approx(1.0, abs=1e-7)


def test_collision_jolt_kicks_and_decays() -> None:
    sf = feel()
    quiet = sf.update(0.001, 20.0, 0.0, FZ, rpm=2000.0)
    sf.jolt(ImpulseResponse(dvx_body=-1.0, dvy_body=1.5, dyaw_rate=0.0, dvz=0.0))
    kicked = sf.update(0.001, 20.0, 0.0, FZ, rpm=2000.0)
    assert abs(kicked.constant_force - quiet.constant_force) > 2000
    assert kicked.vibration_magnitude > quiet.vibration_magnitude
    assert kicked.vibration_frequency_hz == PARAMS.jolt_frequency_hz
    for _ in range(2000):  # 2 s ≫ the 0.12 s decay
        later = sf.update(0.001, 20.0, 0.0, FZ, rpm=2000.0)
    assert later == quiet


def test_vibration_follows_engine_rpm_and_road() -> None:
    sf = feel()
    idle = sf.update(0.001, 0.0, 0.0, FZ, rpm=900.0)
    # Three cylinders, four-stroke: 1.5 firings per revolution → 900/60·1.5 = 22.5 Hz.
    assert idle.vibration_frequency_hz in (22, 23)
    # The road shake: the front wheel moving as a(t) = A·sin(2π·f·t). Its RMS is A/√2 and
    # Rice's mean frequency √(mean ȧ² / mean a²)/2π of a sine is f itself. 3 %: the window's
    # first-order mean of a² (= A²/2·(1 − cos 4πft)) keeps a 2f ripple of 1/(4πf·τ) = 4 % of
    # its mean, ±2 % in the RMS; 5 τ leave e^−5 = 0.7 % of the start; the finite-difference
    # rate is 0.07 % low (ω·dt = 0.13).
    amplitude, hz, dt = 40.0, 20.0, 0.001  # [m/s²], [Hz], [s]
    for i in range(round(5 * PARAMS.road_vibration_window_s / dt)):
        shake = amplitude * math.sin(2 * math.pi * hz * i * dt)
        rough = sf.update(dt, 25.0, 0.0, FZ, rpm=2500.0, wheel_accel_mps2=shake)
    expected = PARAMS.road_vibration_per_mps2 * amplitude / math.sqrt(2)
    assert rough.vibration_magnitude == pytest.approx(expected, rel=0.03)
    assert rough.vibration_magnitude > PARAMS.engine_vibration  # the road outweighs the engine
    assert rough.vibration_frequency_hz == hz
