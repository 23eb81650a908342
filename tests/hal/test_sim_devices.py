"""The other families' `sim` backends, and the FFB/motion clients end to end with the servers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from carlaverse import hal
from carlaverse.config import ConfigError
from carlaverse.hal.camera import LANDMARK_NAMES
from carlaverse.hal.ffb_packet import ZERO_COMMAND, FfbCommand, FfbPacketError
from carlaverse.hal.ffb_server import FfbServer, LogActuator
from carlaverse.hal.ffb_server.actuator import LogActuatorOptions
from carlaverse.hal.motion_packet import NEUTRAL_FRAME, MotionFrame, MotionPacketError
from carlaverse.hal.motion_server import LogPlatform, MotionServer
from carlaverse.hal.motion_server.platform import LogPlatformOptions
from tests.hal.helpers import ManualClock
from tests.support import wait_until


def test_sim_ffb_records_and_zeroes_on_close() -> None:
    clock = ManualClock()
    ffb = hal.open_ffb({"backend": "sim"}, clock=clock)
    ffb.send(FfbCommand(constant_force=300))
    clock.advance(0.01)
    ffb.send(FfbCommand(damper=5))
    assert ffb.current == FfbCommand(damper=5)
    assert [t for t, _ in ffb.history] == [1000.0, 1000.01]
    with pytest.raises(FfbPacketError, match="constant_force"):
        ffb.send(FfbCommand(constant_force=20000))
    ffb.close()
    assert ffb.current == ZERO_COMMAND and ffb.closed


def test_sim_motion_records_validates_and_goes_neutral_on_close() -> None:
    motion = hal.open_motion({"backend": "sim", "options": {"limits": {"roll_rad": 0.2}}})
    motion.send(MotionFrame(roll=0.1))
    with pytest.raises(MotionPacketError, match="roll"):
        motion.send(MotionFrame(roll=0.3))
    with pytest.raises(MotionPacketError, match="not finite"):
        motion.send(MotionFrame(pitch=math.nan))
    assert motion.current == MotionFrame(roll=0.1)
    motion.close()
    assert motion.current == NEUTRAL_FRAME


def test_udp_clients_reach_the_servers() -> None:
    actuator = LogActuator(LogActuatorOptions())
    platform = LogPlatform(LogPlatformOptions())
    with (
        FfbServer(actuator, "127.0.0.1", 0) as ffb_server,
        MotionServer(platform, "127.0.0.1", 0) as motion_server,
    ):
        ffb = hal.open_ffb({"backend": "udp", "options": {"port": ffb_server.address[1]}})
        motion = hal.open_motion({"backend": "udp", "options": {"port": motion_server.address[1]}})
        ffb.send(FfbCommand(spring_stiffness=1000, spring_saturation=10000))
        motion.send(MotionFrame(heave=0.015625))
        wait_until(lambda: ffb_server.stats.applied and motion_server.stats.frames, 5, "both")
        ffb.close()  # sends the zero command
        motion.close()  # sends the neutral frame
        wait_until(lambda: ffb_server.stats.applied == 2, 5, "zero from close")
        wait_until(lambda: motion_server.stats.frames == 2, 5, "neutral from close")
    assert actuator.applied() == [
        FfbCommand(spring_stiffness=1000, spring_saturation=10000),
        ZERO_COMMAND,
    ]
    assert platform.frames() == [MotionFrame(heave=0.015625), NEUTRAL_FRAME]


def test_udp_client_to_a_closed_port_counts_errors_and_never_raises() -> None:
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    ffb = hal.open_ffb({"backend": "udp", "options": {"port": port}})
    for _ in range(5):  # ICMP port unreachable surfaces as ECONNREFUSED on a later send
        ffb.send(FfbCommand(damper=1))
    assert ffb.sender.sent + ffb.sender.errors == 5 and ffb.sender.errors >= 1
    ffb.close()


def test_sim_trainer_rider() -> None:
    clock = ManualClock()
    trainer = hal.open_trainer({"backend": "sim", "options": {"seed": 1}}, clock=clock)
    flat = []
    for _ in range(400):
        clock.advance(0.25)
        flat.append(trainer.read().power_w)
    assert abs(np.mean(flat) - 180.0) < 10.0 and 5.0 < np.std(flat) < 30.0
    trainer.set_grade(5.0)
    climb = []
    for _ in range(400):
        clock.advance(0.25)
        climb.append(trainer.read())
    assert np.mean([s.power_w for s in climb]) > 220  # 180 W · (1 + 0.06 · 5) = 234 W
    assert all(60 < s.cadence_rpm < 110 for s in climb)
    trainer.set_target_power(150.0)
    clock.advance(0.25)
    assert trainer.read().power_w == 150.0
    with pytest.raises(ValueError, match="grade"):
        trainer.set_grade(80)
    with pytest.raises(ValueError, match="target power"):
        trainer.set_target_power(-1)


def test_sim_trainer_is_deterministic() -> None:
    def run(seed: int) -> list[float]:
        clock = ManualClock()
        trainer = hal.open_trainer({"backend": "sim", "options": {"seed": seed}}, clock=clock)
        out = []
        for _ in range(20):
            clock.advance(0.3)
            out.append(trainer.read().power_w)
        return out

    assert run(3) == run(3) and run(3) != run(4)


def test_sim_speed_sensor_integrates_its_profile_exactly() -> None:
    clock = ManualClock()
    options = {"wheel_circumference_m": 2.0, "profile": [{"t": 0, "speed_mps": 0},
               {"t": 10, "speed_mps": 10}, {"t": 20, "speed_mps": 10}]}  # fmt: skip
    sensor = hal.open_speed_sensor({"backend": "sim", "options": options}, clock=clock)
    clock.advance(5.0)
    early = sensor.read()
    assert early.speed_mps == 5.0 and early.revolutions == pytest.approx(12.5 / 2.0)
    clock.advance(10.0)
    later = sensor.read()  # 50 m ramp + 50 m at 10 m/s
    assert later.speed_mps == 10.0 and later.revolutions == pytest.approx(100.0 / 2.0)
    with pytest.raises(ConfigError, match="increasing t"):
        hal.open_speed_sensor(
            {"backend": "sim", "options": {"profile": [{"t": 1, "speed_mps": 1}] * 2}}
        )


def test_sim_headset_pose() -> None:
    clock = ManualClock()
    xr = hal.open_xr({"backend": "sim", "options": {"yaw_period_s": 4.0}}, clock=clock)
    clock.advance(1.0)  # a quarter period: full yaw to one side
    pose = xr.pose()
    w, x, y, z = pose.orientation
    assert math.isclose(w * w + x * x + y * y + z * z, 1.0, rel_tol=1e-9)
    yaw = 2 * math.atan2(y, w)  # pitch is small, so the y component carries the yaw
    assert yaw == pytest.approx(0.4, abs=0.02)
    assert abs(pose.position[1] - 1.2) < 0.1 and pose.tracked


def test_sim_camera_walker_has_a_plausible_skeleton() -> None:
    clock = ManualClock()
    camera = hal.open_camera({"backend": "sim", "options": {"render": True}}, clock=clock)
    lengths = []
    for _ in range(30):
        clock.advance(0.05)
        frame = camera.read()
        lm = frame.landmarks
        assert lm.shape == (33, 3) and len(LANDMARK_NAMES) == 33
        hip, knee, ankle = lm[23], lm[25], lm[27]
        lengths.append((np.linalg.norm(knee - hip), np.linalg.norm(ankle - knee)))
        assert lm[0][1] > lm[11][1] > lm[23][1] > lm[25][1] > lm[27][1]  # head above feet
    # Rigid segments: thigh 0.245 H and shank 0.246 H of a 1.75 m body, whatever the phase.
    assert np.allclose(lengths, [(0.245 * 1.75, 0.246 * 1.75)] * 30, atol=1e-5)
    assert frame.image.shape == (240, 320, 3) and frame.image.any()


def test_sim_camera_legs_swing_in_antiphase() -> None:
    clock = ManualClock()
    camera = hal.open_camera({"backend": "sim", "options": {"cadence_steps_per_min": 120}},
                             clock=clock)  # fmt: skip
    clock.advance(0.25)  # a quarter stride at 1 stride/s
    lm = camera.read().landmarks
    assert lm[27][2] * lm[28][2] < 0  # one ankle ahead, the other behind
