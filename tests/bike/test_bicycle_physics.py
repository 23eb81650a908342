"""The single-track bicycle: geometry, lean, collision impulses; golden values worked by hand."""

from __future__ import annotations

import math

import pytest

from carlaverse.physics.bicycle import Bicycle, BicycleParams, lean_angle

DT = 0.005  # [s] the bike loop's 200 Hz tick


def ride(bike: Bicycle, seconds: float, speed: float, steer: float) -> None:
    for _ in range(round(seconds / DT)):
        bike.step(DT, speed, steer)


def test_straight_ride_covers_speed_times_time() -> None:
    bike = Bicycle(BicycleParams())
    bike.place(10.0, -5.0, math.pi / 2)
    ride(bike, 4.0, 5.0, 0.0)
    s = bike.state
    assert s.x == pytest.approx(10.0, abs=1e-9)
    assert s.y == pytest.approx(-5.0 + 20.0, rel=1e-9)  # 5 m/s × 4 s, north
    assert (s.vx, s.vy) == pytest.approx((0.0, 5.0), abs=1e-9)  # absolute velocity
    assert s.lean_rad == 0.0


def test_constant_steer_rides_the_kinematic_circle() -> None:
    """R = L / (cos β · tan δ) at the CG, β = atan(l_r/L · tan δ): 0.2 rad fork, L = 1.08 m
    gives tan δ = 0.20271, β = atan(0.41667 · 0.20271) = 0.08426, R = 5.3470 m."""
    p = BicycleParams()
    bike = Bicycle(p)
    ride(bike, 0.01, 4.0, 0.2)
    start = (bike.state.x, bike.state.y)
    beta = math.atan(p.cg_to_rear_m / p.wheelbase_m * math.tan(0.2))
    radius = p.wheelbase_m / (math.cos(beta) * math.tan(0.2))
    assert radius == pytest.approx(5.3470, abs=1e-3)
    assert bike.state.yaw_rate == pytest.approx(4.0 / radius, rel=1e-9)
    ride(bike, 2 * math.pi * radius / 4.0, 4.0, 0.2)  # one lap
    assert math.dist(start, (bike.state.x, bike.state.y)) < 0.05  # [m] back where it began


def test_lean_balances_gravity_in_a_steady_turn() -> None:
    # tan φ = v·ψ̇/g = 5 · 0.5 / 9.81 = 0.254842 → φ = 0.249531 rad (14.3°), leaning left
    assert lean_angle(5.0, 0.5, 1.0) == pytest.approx(0.249531, abs=1e-6)
    assert lean_angle(5.0, -0.5, 1.0) == pytest.approx(-0.249531, abs=1e-6)
    assert lean_angle(20.0, 2.0, 0.785) == 0.785  # clamped at the rider's limit
    bike = Bicycle(BicycleParams())
    ride(bike, 1.0, 5.0, 0.1)
    s = bike.state
    assert s.lean_rad == pytest.approx(math.atan(5.0 * s.yaw_rate / 9.81), rel=1e-9)
    assert s.lean_rad > 0  # a left turn leans left


def test_a_head_on_knock_stops_the_bike_and_it_rides_on_after() -> None:
    p = BicycleParams()
    bike = Bicycle(p)
    ride(bike, 1.0, 5.0, 0.0)
    hit = bike.apply_impulse((-90.0 * 6.0, 0.0, 0.0))  # Δv = −6 m/s against 5 m/s: fall
    assert hit.fell and bike.state.fallen
    hit_soft = Bicycle(p)
    ride(hit_soft, 1.0, 2.0, 0.0)
    soft = hit_soft.apply_impulse((-90.0 * 2.5, 0.0, 0.0))  # Δv = −2.5 m/s: stops, no fall
    assert not soft.fell
    x0 = hit_soft.state.x
    ride(hit_soft, p.stop_hold_s - 0.05, 2.0, 0.0)  # pedalling on: the bike stays put
    assert hit_soft.state.speed_mps == 0.0
    assert hit_soft.state.x == pytest.approx(x0, abs=0.02)
    ride(hit_soft, 0.2, 2.0, 0.0)
    assert hit_soft.state.speed_mps == pytest.approx(2.0, abs=0.01)  # riding again


def test_a_side_impact_throws_the_bike_to_the_side_it_was_pushed() -> None:
    p = BicycleParams()
    bike = Bicycle(p)
    ride(bike, 1.0, 5.0, 0.0)  # heading +x
    bike.apply_impulse((0.0, -90.0 * 4.0, 0.0))  # pushed to the right (−y), Δv 4 m/s
    assert bike.state.fallen
    assert bike.state.lean_rad == pytest.approx(-math.pi / 2)  # lies on its right side
    ride(bike, 0.5, 5.0, 0.0)
    assert bike.state.speed_mps == 0.0 and bike.state.vy < 0  # still sliding right, no riding
    ride(bike, p.fall_hold_s, 5.0, 0.0)
    assert not bike.state.fallen and bike.state.lean_rad == 0.0


def test_a_small_push_moves_the_bike_sideways_and_fades() -> None:
    bike = Bicycle(BicycleParams())
    ride(bike, 0.5, 5.0, 0.0)
    hit = bike.apply_impulse((0.0, 90.0 * 1.0, 0.0))  # 1 m/s to the left
    assert not hit.fell and hit.dv_lateral_mps == pytest.approx(1.0)
    y0 = bike.state.y
    ride(bike, 2.0, 5.0, 0.0)
    # ∫ e^(−t/τ) dt over 2 s with τ = 0.3 s ≈ 0.3 m of drift, then none
    assert bike.state.y - y0 == pytest.approx(0.3, abs=0.02)
    assert abs(bike.state.vy) < 0.01
