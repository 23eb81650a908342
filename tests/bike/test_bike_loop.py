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
