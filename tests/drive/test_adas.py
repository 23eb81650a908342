"""ADAS overrides through the loop: cruise control, lane keeping, the driver's brake, expiry."""

from __future__ import annotations

import math

import pytest
from carlaverse_nodes.drive.adas import AdasArbiter, AdasParams

from carlaverse.messages import Override
from tests.drive.support import DT, desktop_loop, keys, run


def cruise(seq: int, speed: float, **extra: object) -> Override:
    return Override(seq, 0.0, "acc-study", cruise_speed_mps=speed, **extra)  # type: ignore[arg-type]


def test_cruise_control_replaces_the_pedals_and_holds_the_speed() -> None:
    loop = desktop_loop()
    loop.engage_drive()
    assert loop.submit_override(cruise(1, 15.0))
    out = run(loop, 25.0, keys(0.0, 0.0))  # the driver's feet are off the pedals
    # ± 0.3 m/s: the PI's residual ripple with the shifts of a 6-speed automatic.
    assert out.speed_mps == pytest.approx(15.0, abs=0.3)
    assert out.adas.cruise_active and out.adas.sources == "acc-study"
    assert out.ego_state(1, 0.0).adas == "acc-study"  # visible to the fabric and recording
    # The driver's throttle is replaced, not added: flooring it changes nothing.
    out = run(loop, 2.0, keys(0.0, 1.0))
    assert out.speed_mps == pytest.approx(15.0, abs=0.5)


def test_the_drivers_brake_always_wins_over_cruise_control() -> None:
    loop = desktop_loop()
    loop.place(0.0, 0.0, 0.0, 20.0)
    loop.engage_drive()
    loop.submit_override(cruise(1, 30.0))  # cruise wants to accelerate
    out = run(loop, 0.2, keys(0.0, 0.0, 0.6))
    # The driver's own brake, through the desktop config's curve x^1.5.
    assert out.brake == pytest.approx(0.6**1.5) and out.throttle == 0.0
    assert out.adas.driver_brake_override and not out.adas.cruise_active
    speed = out.speed_mps
    assert run(loop, 1.0, keys(0.0, 0.0, 0.6)).speed_mps < speed - 3.0  # really braking
    out = run(loop, 0.5, keys(0.0, 0.0, 0.0))  # foot off: cruise resumes
    assert out.adas.cruise_active and out.throttle > 0.0


def test_lane_keeping_adds_steering_torque_to_the_wheel() -> None:
    base, assisted = desktop_loop(), desktop_loop()
    for loop in (base, assisted):
        loop.place(0.0, 0.0, 0.0, 20.0)
        loop.engage_drive()
    assisted.submit_override(Override(1, 0.0, "lkas", lane_keep_torque_nm=1.5))
    a = run(base, 0.3, keys(0.05, 0.3))
    b = run(assisted, 0.3, keys(0.05, 0.3))
    full_scale = assisted.config.steering_feel.full_scale_torque_nm
    # +1.5 N·m toward the left is −1.5/6·10000 = −2500 units on the wire (+ = right); ±2
    # for rounding each command to an integer.
    assert b.ffb.constant_force - a.ffb.constant_force == pytest.approx(
        -1.5 / full_scale * 10000, abs=2
    )
    assert b.adas.lane_keep_torque_nm == 1.5 and not b.adas.cruise_active


def test_overrides_expire_and_can_be_withdrawn() -> None:
    t = [0.0]
    loop = desktop_loop(clock=lambda: t[0])
    loop.engage_drive()
    loop.submit_override(cruise(1, 10.0, expires_t=2.0))
    assert loop.step(DT, keys()).adas.cruise_active
    t[0] = 2.0
    out = loop.step(DT, keys())
    assert not out.adas.cruise_active and out.adas.sources == "" and out.state_changed
    loop.submit_override(cruise(2, 10.0))
    assert loop.step(DT, keys()).adas.cruise_active
    loop.submit_override(Override(3, 0.0, "acc-study", active=False))
    assert loop.step(DT, keys()).adas.sources == ""


def test_duplicates_and_bad_values_are_dropped_and_counted() -> None:
    arbiter = AdasArbiter(AdasParams())
    assert arbiter.submit(cruise(5, 10.0), 0.0)
    assert not arbiter.submit(cruise(5, 12.0), 0.0)  # same seq: a re-delivery
    assert not arbiter.submit(cruise(4, 12.0), 0.0)  # older: reordered
    assert arbiter.duplicates == 2
    bad = [
        cruise(6, math.nan),
        cruise(7, -3.0),
        cruise(8, 500.0),
        Override(9, 0.0, "x", lane_keep_torque_nm=math.inf),
        Override(10, 0.0, ""),
    ]
    assert not any(arbiter.submit(o, 0.0) for o in bad)
    assert arbiter.rejected == 5


def test_refresh_timeout_lapses_a_silent_source() -> None:
    arbiter = AdasArbiter(AdasParams(override_timeout_s=0.5))
    arbiter.submit(cruise(1, 10.0), now=0.0)
    arbiter.apply(0.0, 0.0, 0.0, 5.0, DT, now=0.4)
    assert arbiter.state.cruise_active
    arbiter.apply(0.0, 0.0, 0.0, 5.0, DT, now=0.6)
    assert not arbiter.state.cruise_active
