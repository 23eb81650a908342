"""The motion cueing's limits against the platform's: refused at load, clipped in the loop.

A motion device rejects a frame beyond its `MotionLimits` (hal.motion_packet). Two places keep
that from ever reaching the 1 kHz loop as an exception: the config load compares the cueing's
clamps with the device's limits, and the loop clips what is left (rpm, torque, anything the
cueing does not clamp) to the device's limits and counts it.
"""

from __future__ import annotations

from pathlib import Path

import msgspec
import pytest
import yaml
from carlaverse_nodes.drive.config import DriveNodeConfig, load_drive_config

from carlaverse.config import ConfigError
from carlaverse.hal.motion_server import LogPlatform, MotionServer
from carlaverse.hal.motion_server.platform import LogPlatformOptions
from tests.drive.support import run_real_loop
from tests.support import wait_until


def write_config(tmp_path: Path, **sections: object) -> Path:
    path = tmp_path / "drive.yaml"
    path.write_text(yaml.safe_dump({"node": {"kind": "drive"}, **sections}))
    return path


def test_cueing_beyond_the_device_limit_is_refused_at_load_naming_both_fields(
    tmp_path: Path,
) -> None:
    # The cueing clamps roll to ±0.12 rad by default; a platform that takes only ±0.1 rad
    # would reject every frame of a hard corner. The load says so, naming both fields.
    device = {"backend": "udp", "options": {"limits": {"roll_rad": 0.1}}}
    path = write_config(tmp_path, motion=device)
    with pytest.raises(ConfigError) as caught:
        load_drive_config(path)
    message = str(caught.value)
    assert "motion_cueing.roll_limit_rad 0.12 exceeds motion.options.limits.roll_rad 0.1" in (
        message
    )
    assert str(path) in message and "\n" not in message  # one line, naming the file


def test_cueing_within_the_device_limits_loads(tmp_path: Path) -> None:
    path = write_config(
        tmp_path,
        motion={"backend": "sim", "options": {"limits": {"roll_rad": 0.1, "heave_m": 0.03}}},
        motion_cueing={"roll_limit_rad": 0.1},  # equal is within: the packet check is |v| > limit
    )
    config, _ = load_drive_config(path)
    assert config.motion_cueing.roll_limit_rad == 0.1


# The device in the next test takes at most 2000 rpm and 100 N·m. At full throttle from rest
# the compact car (configs/vehicles/compact-car.yaml) launches at 2600 rpm with 170–200 N·m
# (its torque curve from 1500 to 3500 rpm): both beyond the device's limits at once.
DEVICE_RPM, DEVICE_TORQUE_NM = 2000.0, 100.0
LOOP_S = 1.5  # [s]


def test_a_hard_launch_is_clipped_to_the_device_limits_and_the_loop_runs_on() -> None:
    with MotionServer(LogPlatform(LogPlatformOptions()), "127.0.0.1", 0) as server:
        port = server.address[1]
        config = msgspec.convert(
            {
                "node": {"kind": "drive"},
                "input": {
                    "backend": "sim",
                    "options": {"profile": [{"t": 0, "axes": {"throttle": 1.0}}]},
                },
                "motion": {
                    "backend": "udp",
                    "options": {
                        "port": port,
                        "limits": {"rpm": DEVICE_RPM, "torque_nm": DEVICE_TORQUE_NM},
                    },
                },
                "loop": {"realtime_priority": 0},  # leave the test process's priority alone
            },
            DriveNodeConfig,
        )
        _, vehicle = load_drive_config(Path(__file__).parents[2] / "configs/drive-desktop.yaml")
        summary, exitcode = run_real_loop(config, vehicle, LOOP_S)
        sent = summary["motion_sent"] + 1  # and the neutral frame the device sends on close
        wait_until(lambda: server.stats.received >= sent, 5, f"{sent} frames at the server")
    # The loop ran its whole duration and ended by itself, not at the first over-limit frame
    # (10 ticks: the first frame at 100 Hz). Its tick count depends on the machine's load: a
    # starved loop restarts its deadlines rather than racing to catch up.
    assert exitcode == 0 and summary["ticks"] > 100
    frames = server.platform.frames()  # type: ignore[attr-defined]
    assert server.stats.invalid_value == 0 and len(frames) == sent
    # Clipped, not dropped: the launch reaches the device's limits and never passes them.
    assert max(f.rpm for f in frames) == DEVICE_RPM
    assert max(f.torque for f in frames) == DEVICE_TORQUE_NM
    assert 0 < summary["motion_clipped"] < sent
