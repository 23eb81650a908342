"""Walking by thumbstick: direction, speed limits, acceleration limits (golden values by hand)."""

from __future__ import annotations

import math

import pytest
from carlaverse_nodes.walk.gait import GaitSettings, Walker, limit_acceleration, stick_velocity

NO_DEAD_ZONE = 0.0


def test_full_forward_stick_walks_along_the_heading() -> None:
    # heading 90° (north): forward is +y
    vx, vy = stick_velocity((0.0, 1.0), math.pi / 2, 1.4, NO_DEAD_ZONE)
    assert (vx, vy) == pytest.approx((0.0, 1.4), abs=1e-12)


def test_stick_right_strafes_to_the_right_of_the_heading() -> None:
    # facing east, right is south (−y)
    assert stick_velocity((1.0, 0.0), 0.0, 2.0, NO_DEAD_ZONE) == pytest.approx((0.0, -2.0))
    # facing north-east, a diagonal stick (0.6 right, 0.8 forward) at 1 m/s:
    # forward 0.8·(√½, √½) + right 0.6·(√½, −√½) = (1.4·√½, 0.2·√½)
    h = math.sqrt(0.5)
    assert stick_velocity((0.6, 0.8), math.pi / 4, 1.0, NO_DEAD_ZONE) == pytest.approx(
        (1.4 * h, 0.2 * h)
    )


def test_dead_zone_is_zero_and_the_rest_is_rescaled() -> None:
    assert stick_velocity((0.05, 0.05), 0.0, 1.4, 0.1) == (0.0, 0.0)  # |s| = 0.0707 < 0.1
    # half-way between the dead zone (0.1) and full (1.0): 0.55 deflection → half speed
    assert stick_velocity((0.0, 0.55), 0.0, 1.4, 0.1) == pytest.approx((0.7, 0.0))


def test_acceleration_and_deceleration_limits() -> None:
    # speeding up from rest toward 1.4 m/s east at 1.5 m/s² for 0.1 s: 0.15 m/s
    assert limit_acceleration((0.0, 0.0), (1.4, 0.0), 1.5, 3.0, 0.1) == pytest.approx((0.15, 0))
    # stopping from 1.4 m/s at 3 m/s² for 0.1 s: 1.1 m/s
    assert limit_acceleration((1.4, 0.0), (0.0, 0.0), 1.5, 3.0, 0.1) == pytest.approx((1.1, 0))
    # a change within the limit is reached exactly
    assert limit_acceleration((1.0, 0.0), (1.1, 0.0), 1.5, 3.0, 0.1) == (1.1, 0.0)


def test_walker_reaches_walking_pace_and_covers_the_distance() -> None:
    gait = GaitSettings(walk_speed_mps=1.4, accel_mps2=1.4, dead_zone=0.0)
    walker = Walker()
    walker.place(10.0, 20.0, 0.0)
    dt = 0.01
    for _ in range(300):  # 3 s of full forward stick, facing north
        walker.step(gait, (0.0, 1.0), False, math.pi / 2, dt)
    # 1 s ramp at 1.4 m/s² covers 0.7 m, then 2 s at 1.4 m/s: 2.8 m; 3.5 m in all (the
    # semi-implicit step adds half a step's speed change: 0.007 m)
    assert walker.vy == pytest.approx(1.4) and walker.vx == pytest.approx(0.0, abs=1e-12)
    assert walker.y - 20.0 == pytest.approx(3.5, abs=0.01)
    assert walker.x == pytest.approx(10.0, abs=1e-9)


def test_run_button_raises_the_limit() -> None:
    gait = GaitSettings(walk_speed_mps=1.4, run_speed_mps=3.0, accel_mps2=100.0)
    walker = Walker()
    for _ in range(10):
        walker.step(gait, (0.0, 1.0), True, 0.0, 0.1)
    assert math.hypot(walker.vx, walker.vy) == pytest.approx(3.0)
