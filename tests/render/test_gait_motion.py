"""The maths behind moving road users, against values worked by hand (no GL needed)."""

from __future__ import annotations

import math

import pytest

from carlaverse.render.gait import (
    advance_phase,
    crank_angle,
    hip_amplitude,
    leg_to,
    pedal,
    pelvis_drop,
    stride_length,
    walking_angles,
)
from carlaverse.render.motion import MAX_ROAD_WHEEL_RAD, Motion, kinematic_steer


def test_stride_follows_alexander() -> None:
    # h = 0.93 m, v = 1.37 m/s: v²/gh = 1.8769/9.1233 = 0.20573; ^0.3 = 0.62222;
    # λ = 2.3 · 0.93 · 0.62222 = 1.3309 m (Perry & Burnfield measured 1.41 m: within 6 %)
    assert stride_length(1.37, 0.93) == pytest.approx(1.3309, abs=5e-4)
    assert stride_length(0.0, 0.93) == 0.0
    assert stride_length(-1.37, 0.93) == stride_length(1.37, 0.93)


def test_feet_a_step_apart_at_double_support() -> None:
    h, v = 0.93, 1.37
    a = hip_amplitude(v, h)
    # straight legs at ±a from the hips: feet 2·h·sin(a) apart, one step = λ/2
    assert 2 * h * math.sin(a) == pytest.approx(stride_length(v, h) / 2)
    at_support = walking_angles(math.pi / 2, v, h)
    assert at_support["left_hip"][1] == pytest.approx(-a)  # left leg ahead (pitch < 0)
    assert at_support["right_hip"][1] == pytest.approx(a)
    assert at_support["left_knee"][1] == pytest.approx(0.0, abs=1e-12)  # straight at contact
    # the hips drop so the angled stance leg's foot is on the ground: h − h·cos(a)
    assert pelvis_drop(math.pi / 2, v, h) == pytest.approx(h * (1 - math.cos(a)))
    standing = walking_angles(1.0, 0.0, h)
    assert all(value == (0.0, 0.0, 0.0) for value in standing.values())


def test_phase_turns_once_per_stride() -> None:
    stride = stride_length(1.4, 0.93)
    assert advance_phase(0.3, stride, 1.4, 0.93) == pytest.approx(0.3 + 2 * math.pi)
    assert advance_phase(0.3, 5.0, 0.0, 0.93) == 0.3  # no stride at rest: no phase


def test_crank_turns_once_per_development() -> None:
    development = 2 * math.pi * 0.34 * 2.1  # wheel circumference × gear ratio [m]
    assert crank_angle(development, 0.34, 2.1, start=0.5) == pytest.approx(0.5 + 2 * math.pi)
    assert pedal((0.0, 0.3), 0.0, 0.17) == pytest.approx((0.0, 0.47))  # top dead centre
    assert pedal((0.0, 0.3), math.pi / 2, 0.17) == pytest.approx((0.17, 0.3))  # forward


@pytest.mark.parametrize("crank", [0.0, 0.7, 1.6, 3.1, 4.4, 5.9])
def test_leg_reaches_its_pedal_with_the_knee_ahead(crank: float) -> None:
    hip, thigh, shin = (-0.27, 0.98), 0.44, 0.49
    foot = pedal((-0.08, 0.28), crank, 0.17)
    hip_pitch, knee_pitch = leg_to(hip, foot, thigh, shin)
    # forward kinematics in the figure's convention: a limb hangs down, pitch swings it back
    thigh_dir = -hip_pitch  # [rad] from straight down, forward positive
    knee = (hip[0] + thigh * math.sin(thigh_dir), hip[1] - thigh * math.cos(thigh_dir))
    shin_dir = thigh_dir - knee_pitch
    reached = (knee[0] + shin * math.sin(shin_dir), knee[1] - shin * math.cos(shin_dir))
    assert reached == pytest.approx(foot, abs=1e-9)
    assert knee_pitch > 0  # the knee bends, never the wrong way
    # the knee is ahead of the line hip→foot
    cross = (foot[0] - hip[0]) * (knee[1] - hip[1]) - (foot[1] - hip[1]) * (knee[0] - hip[0])
    assert cross > 0


def test_kinematic_steer() -> None:
    # L = 2.7 m, ω = 0.5 rad/s, v = 6 m/s: δ = atan(0.225) = 12.68°
    assert math.degrees(kinematic_steer(2.7, 0.5, 6.0)) == pytest.approx(12.68, abs=0.01)
    # reversing with the wheels turned left yaws clockwise: ω < 0, v < 0, δ > 0
    assert kinematic_steer(2.7, -0.2, -2.0) > 0
    assert kinematic_steer(2.7, 5.0, 0.5) == MAX_ROAD_WHEEL_RAD  # beyond full lock: full lock
    assert kinematic_steer(2.7, 0.3, 0.0) == 0.0


def test_motion_rolls_walks_and_skips_jumps() -> None:
    m = Motion()
    m.advance(0.0, 0.0, 0.0, 0.0)
    m.advance(0.1, 1.0, 0.0, 0.05)  # 1 m ahead in 0.1 s, turning
    assert m.rolled_m == pytest.approx(math.cos(0.025))  # along the mean heading
    assert m.walked_m == pytest.approx(1.0)
    assert m.speed_mps == pytest.approx(10 * math.cos(0.025))
    assert m.yaw_rate == pytest.approx(0.5)
    m.advance(0.2, 0.0, 0.0, 0.05)  # 1 m back: reversing
    assert m.rolled_m == pytest.approx(math.cos(0.025) - math.cos(0.05))
    assert m.walked_m == pytest.approx(2.0)
    m.advance(5.0, 50.0, 0.0, 0.05)  # a seek: 4.8 s later, 50 m on
    assert m.walked_m == pytest.approx(2.0) and m.speed_mps == 0.0
    m.advance(5.01, 5.0, 0.0, 0.05)  # 45 m in 10 ms: a teleport
    assert m.walked_m == pytest.approx(2.0)
    assert m.road_wheel_angle(2.7, 0.2, 0.4) == m.steer  # too slow: the last angle holds
