"""Golden step responses of the motion-cueing algorithm (paper, "Motion Cueing")."""

from __future__ import annotations

import itertools

import pytest

from carlaverse.physics.filters import smoothstep
from carlaverse.physics.impulse import ImpulseResponse
from carlaverse.physics.motion_cueing import MotionCue, MotionCueing, MotionCueingParams

DT = 0.001  # [s] the drive loop's period
P = MotionCueingParams()


def run(mca: MotionCueing, seconds: float, speed: float = 20.0, **inputs: float) -> list[MotionCue]:
    values = {"ax": 0.0, "ay": 0.0, "az": 0.0, "brake": 0.0, "steer": 0.0} | inputs
    return [mca.update(DT, speed_mps=speed, **values) for _ in range(round(seconds / DT))]


def washout_time(speed: float) -> float:
    share = smoothstep(0.0, P.washout_speed_mps, speed)
    return P.washout_low_speed_s + share * (P.washout_high_speed_s - P.washout_low_speed_s)


def test_pitch_step_sign_steady_state_and_washout() -> None:
    mca = MotionCueing(P)
    held = run(mca, 1.5, ax=3.0)
    # Steady state: θ = a_x/a_ref·f_scale(20 m/s = 1). After 1.5 s the 0.1 s low-pass and the
    # 0.03 s attack have settled to e^(−11) ≈ 2e-5 of the step: 0.5 % is generous.
    assert held[-1].pitch == pytest.approx(3.0 / P.a_ref_mps2_per_rad, rel=0.005)
    assert all(c.pitch >= 0.0 for c in held)
    released = run(mca, washout_time(20.0), ax=0.0)
    # τ = time/4 → e^(−4) ≈ 1.8 % left, plus the low-pass lag (τ_lpf/τ ≈ 0.14 of it): < 5 %.
    assert abs(released[-1].pitch) < 0.05 * held[-1].pitch
    assert min(c.pitch for c in released) >= 0.0  # no false cue past neutral


def test_roll_step_from_lateral_acceleration_and_steer() -> None:
    mca = MotionCueing(P)
    cue = run(mca, 2.0, ay=2.0, steer=0.5)[-1]
    expected = 2.0 / P.ay_ref_mps2_per_rad + P.k_steer_rad * 0.5
    assert cue.roll == pytest.approx(expected, rel=0.005)
    assert run(mca, washout_time(20.0))[-1].roll == pytest.approx(0.0, abs=0.05 * expected)


def test_pitch_from_acceleration_is_suppressed_at_standstill() -> None:
    # f_scale(0) = 0: an IMU that reads acceleration while stopped must not tilt the rig.
    cue = run(MotionCueing(P), 1.0, speed=0.0, ax=3.0)[-1]
    assert cue.pitch == pytest.approx(0.0, abs=1e-12)


def test_brake_pitches_nose_down_and_fires_one_emergency_heave() -> None:
    mca = MotionCueing(P)
    cues = run(mca, 1.0, brake=1.0)
    dip = min(c.heave for c in cues)
    # Half-sine of amplitude −0.015 m through the attack filter: at least 80 % of it shows.
    assert dip < 0.8 * P.emergency_heave_m
    # The pedal's rate term k_impulse·ḃ dips the nose beyond k_b while the pedal moves ...
    assert min(c.pitch for c in cues) < P.k_brake_rad
    held = run(mca, washout_time(20.0), brake=1.0)
    # ... and the washout brings it back to the steady k_b·b_LPF (b_LPF → 1); the overshoot
    # (≈ 20 % of k_b) decays to e^(−4) of itself: 1 % covers it.
    assert held[-1].pitch == pytest.approx(P.k_brake_rad, rel=0.01)
    # Held pedal: no second impulse — the heave only ever climbs back toward neutral.
    assert all(b.heave >= a.heave for a, b in itertools.pairwise(held))


def test_slow_brake_application_is_not_an_emergency() -> None:
    mca = MotionCueing(P)
    cues = []
    for i in range(2000):  # pedal 0 → 1 over 2 s: rate 0.5/s, below the 3/s trigger
        cues.append(mca.update(DT, 0.0, 0.0, 0.0, 20.0, i / 2000.0, 0.0))
    assert min(c.heave for c in cues) > 0.1 * P.emergency_heave_m


def test_heave_from_vertical_jerk_returns_to_neutral() -> None:
    mca = MotionCueing(P)
    peak = max(c.heave for c in run(mca, 0.3, az=5.0))
    assert peak > 0.002  # a 5 m/s² step: jerk clamped, clearly felt
    settled = run(mca, washout_time(20.0), az=5.0)
    # Sustained a_z has no jerk, so the heave goes home: within 5 % of its peak in the
    # washout time (τ = time/4 leaves 1.8 %, the jerk low-pass's tail adds a little).
    assert abs(settled[-1].heave) < 0.05 * peak


def test_output_is_clamped_to_platform_limits() -> None:
    cue = run(MotionCueing(P), 1.0, ax=50.0, ay=-50.0, az=0.0)[-1]
    assert cue.pitch == P.pitch_limit_rad
    assert cue.roll == -P.roll_limit_rad


def test_washout_is_slower_at_speed() -> None:
    def residual(speed: float) -> float:
        mca = MotionCueing(P)
        run(mca, 1.0, speed=speed, ay=3.0)
        return run(mca, 0.8, speed=speed)[-1].roll

    assert 0.0 <= residual(2.0) < residual(30.0)


def test_collision_makes_a_heave_and_tilt_jolt_that_ends() -> None:
    mca = MotionCueing(P)
    mca.collision(ImpulseResponse(dvx_body=-2.0, dvy_body=0.0, dyaw_rate=0.0, dvz=0.0))
    cues = run(mca, P.collision_pulse_s)
    peak = max(c.heave for c in cues)
    assert peak > 0.5 * P.collision_heave_m_per_mps * 2.0
    assert min(c.pitch for c in cues) < 0.0  # frontal hit: nose dips
    after = run(mca, washout_time(20.0))[-1]
    assert abs(after.heave) < 0.05 * peak  # back within 5 % in the washout time
    assert after.pitch <= 0.0  # and never past neutral
