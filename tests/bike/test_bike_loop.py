"""The bike loop body: resistance → trainer command, pose telemetry, impulse handling."""

from __future__ import annotations

import math

import pytest
from carlaverse_nodes.bike.bike_loop import BikeLoop
from carlaverse_nodes.bike.config import BikeNodeConfig, RoadSettings, resolve_table

from carlaverse import messages as m
from carlaverse.messages import Impulse

DT = 0.005  # [s]


def loop_on(grade_percent: float) -> BikeLoop:
    config = BikeNodeConfig(road=RoadSettings(grade_percent=grade_percent))
    return BikeLoop(config, resolve_table(config))


def test_climbs_and_headwinds_command_more_resistance() -> None:
    flat = loop_on(0.0).step(DT, 6.0, 0.0, 0.0)
    climb = loop_on(6.0).step(DT, 6.0, 0.0, 0.0)
    headwind = loop_on(0.0).step(DT, 6.0, 0.0, -5.0)
    descent = loop_on(-6.0).step(DT, 6.0, 0.0, 0.0)
    assert descent.resistance_percent == 0.0 < flat.resistance_percent
    assert flat.resistance_percent < headwind.resistance_percent < climb.resistance_percent
    assert climb.resistance_n == pytest.approx(
        0.004 * 90 * 9.81 * math.cos(math.atan(0.06)) + 90 * 9.81 * math.sin(math.atan(0.06))
        + 0.27 * 36.0, rel=1e-9,
    )  # fmt: skip


# Pose.roll is ISO 8855 (x forward, y left, z up; roll about x by the right-hand rule turns
# y toward z): positive lifts the left side, i.e. the RIGHT side goes down. A bike leaning
# left has roll < 0. Every consumer (renderer, Rerun, CARLA bridge) reads it so.


def test_a_left_turn_leans_left_on_the_wire() -> None:
    """A bike balances a steady turn by leaning into it until gravity and the centripetal force
    meet in its plane: tan φ = v²·κ/g = v·ω/g, toward the centre of the turn."""
    loop = loop_on(0.0)
    loop.place(0.0, 0.0, math.pi / 2)
    for _ in range(200):
        out = loop.step(DT, 5.0, 0.2, 0.0)  # steer axis 0.2 of 0.6 rad full lock
    pose = m.decode_pose(m.encode_pose(out.pose(7)))  # as every consumer receives it
    speed = math.hypot(pose.vx, pose.vy)
    assert pose.seq == 7 and speed == pytest.approx(5.0, rel=1e-6)
    assert pose.wz > 0  # yaw rate counter-clockwise: a left turn
    assert pose.roll < 0  # left side down
    # wz travels as float16 (11-bit significand: within 0.05 %); roll as float32
    assert -pose.roll == pytest.approx(math.atan(speed * pose.wz / 9.81), rel=1e-3)
    assert pose.z == 0.0


def test_a_bike_pushed_from_the_right_lies_on_its_left_side() -> None:
    loop = loop_on(0.0)
    loop.place(0.0, 0.0, 0.0)  # heading +x: its left is +y
    loop.step(DT, 5.0, 0.0, 0.0)
    from_the_right = impulse(1, (0.0, 450.0, 0.0))  # 5 m/s toward +y: above the 3 m/s fall
    out = loop.step(DT, 5.0, 0.0, 0.0, [from_the_right], now=1.0)
    assert out.fallen
    roll = m.decode_pose(m.encode_pose(out.pose())).roll
    assert roll == pytest.approx(-math.pi / 2, abs=1e-6)  # lying on its left side


def impulse(seq: int, j: tuple[float, float, float]) -> Impulse:
    return Impulse(seq, 0.0, 1, j, (0.0, 0.0, 0.5), (1.0, 0.0, 0.0), "npc-1", "car", 3.0)


def test_an_impulse_applies_once_and_a_wild_one_is_dropped() -> None:
    loop = loop_on(0.0)
    knock = impulse(1, (0.0, 90.0, 0.0))  # 1 m/s to the left
    assert loop.step(DT, 5.0, 0.0, 0.0, [knock, knock]).impulses_applied == 1
    assert loop.step(DT, 5.0, 0.0, 0.0, [knock]).impulses_applied == 0
    out = loop.step(DT, 5.0, 0.0, 0.0, [impulse(2, (9e9, 0.0, 0.0)), impulse(3, (math.nan, 0, 0))])
    assert out.impulses_applied == 0 and loop.impulses_dropped == 2
    assert out.ffb.vibration_magnitude > 1000  # the first knock still shakes the fork


def test_the_shipped_bike_config_is_valid(capsys: pytest.CaptureFixture[str]) -> None:
    from carlaverse.cli import main

    assert main(["config", "validate", "bike-sim"]) == 0
    assert "bike-sim.yaml: valid bike" in capsys.readouterr().out


def test_a_step_in_the_wheel_reading_is_ridden_as_a_body_can() -> None:
    """A trainer reports speed in steps (BLE, 1-4 Hz; a sim profile jumps). A rider cannot
    gain 4 m/s in one 5 ms tick (800 m/s² in the pose, projected by every receiver's dead
    reckoning): a strong sprint is about 2.5 m/s² and braking is bounded near 0.6 g, where
    the rider goes over the bar (Wilson, Bicycling Science). So 2 → 6 m/s takes (6-2)/3 =
    1.33 s at the 3 m/s² the bike allows, 6 → 0 takes 6/6 = 1 s, and no tick's acceleration
    on the wire exceeds those limits; steady riding is unchanged."""
    loop = loop_on(0.0)
    out = loop.step(DT, 2.0, 0.0, 0.0)
    assert out.speed_mps == 2.0  # the first reading is how fast the rider already goes
    speeds, accels = [], []
    for reading in [6.0] * round(2.0 / DT) + [0.0] * round(1.5 / DT):
        out = loop.step(DT, reading, 0.0, 0.0)
        speeds.append(out.speed_mps)
        accels.append(math.hypot(out.ax, out.ay))
    up = next(k for k, v in enumerate(speeds) if v >= 6.0 - 1e-9) + 1
    assert up * DT == pytest.approx(4.0 / 3.0, abs=2 * DT)
    down = next(k for k, v in enumerate(speeds[round(2.0 / DT) :]) if v <= 1e-9) + 1
    assert down * DT == pytest.approx(1.0, abs=2 * DT)
    assert max(accels) <= 6.0 + 1e-6
    assert max(accels[: round(2.0 / DT)]) <= 3.0 + 1e-6
