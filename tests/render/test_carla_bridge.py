"""The CARLA bridge: frame conversions against hand-worked values; the live part needs a server."""

from __future__ import annotations

import math

import pytest

from carlaverse import messages as m
from carlaverse.render.carla_bridge import (
    UnrealTransform,
    from_unreal,
    head_to_unreal,
    light_state_bits,
    server_answers,
    to_unreal,
)


def test_golden_poses() -> None:
    # heading north (yaw +90° counter-clockwise) is yaw −90° in CARLA; y mirrors
    assert to_unreal(10.0, 20.0, 1.0, math.pi / 2) == UnrealTransform(
        10.0, -20.0, 1.0, -0.0, -90.0, 0.0
    )
    # south-west (−135°) → +135° clockwise; nose down 0.1 rad → pitch −5.7296°; roll keeps sign
    t = to_unreal(-3.0, -4.0, 0.5, math.radians(-135), pitch=0.1, roll=-0.05)
    assert (t.x, t.y, t.z) == (-3.0, 4.0, 0.5)
    assert t.yaw == pytest.approx(135.0)
    assert t.pitch == pytest.approx(-5.729578, abs=1e-6)
    assert t.roll == pytest.approx(-2.864789, abs=1e-6)


def test_round_trip() -> None:
    pose = (12.5, -7.25, 0.3, 2.0, 0.04, -0.02)
    assert from_unreal(to_unreal(*pose[:4], pitch=pose[4], roll=pose[5])) == pytest.approx(pose)


def test_head_position_and_camera_yaw_sides() -> None:
    # a driver's eye 0.37 m to the left is at y = −0.37 in CARLA's right-handed-for-y actor frame
    assert head_to_unreal(0.1, 0.37, 1.2) == (0.1, -0.37, 1.2)


def test_light_bits_match_carla() -> None:
    bits = m.LIGHT_BRAKE | m.LIGHT_LEFT_BLINKER | m.LIGHT_LOW_BEAM
    assert light_state_bits(bits) == 8 | 32 | 2  # Brake, LeftBlinker, LowBeam in CARLA 0.9.16
    carla = pytest.importorskip("carla", reason="needs the carla extra")
    vls = carla.VehicleLightState
    assert light_state_bits(m.LIGHT_RIGHT_BLINKER) == int(vls.RightBlinker)
    assert light_state_bits(m.LIGHT_FOG | m.LIGHT_REVERSE) == int(vls.Fog) | int(vls.Reverse)


def test_live_mirror_into_a_carla_server() -> None:
    if not server_answers("127.0.0.1", 2000):
        pytest.skip("no CARLA server answers on 127.0.0.1:2000 (start CarlaUE4.sh to run this)")
    from carlaverse.render.carla_bridge import CarlaBridge
    from carlaverse.render.frame import SceneFrame
    from tests.render.support import car

    bridge = CarlaBridge()
    try:
        bridge.mirror(SceneFrame(0.0, (car("a", 0.0, 0.0), car("b", 10.0, 5.0, yaw=1.0))))
        moved = bridge.actors["b"].get_transform()
        assert moved.location.y == pytest.approx(-5.0, abs=0.05)
        assert moved.rotation.yaw == pytest.approx(-math.degrees(1.0), abs=0.5)
    finally:
        bridge.close()
