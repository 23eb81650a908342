"""The hardware layer
(docs/architecture.md §9): one interface per device family, backends chosen by YAML.

    from carlaverse.hal import open_input, open_ffb
    wheel = open_input({"backend": "pygame", "options": {"device": "G29"}})
    ffb = open_ffb(config.ffb, clock=clock)
    state = wheel.poll()                       # InputState(t, axes, buttons, hats)
    ffb.send(FfbCommand(spring_stiffness=4000, spring_saturation=10000))

Families and their entry-point groups (python-can style, see `registry`):
input `carlaverse.hal.input`, force feedback `carlaverse.hal.ffb`, motion platform
`carlaverse.hal.motion`, smart trainer `carlaverse.hal.trainer`, wheel-speed sensor
`carlaverse.hal.speed_sensor`, XR headset `carlaverse.hal.xr`, camera `carlaverse.hal.camera`;
the servers' device backends: `carlaverse.hal.ffb_server`, `carlaverse.hal.motion_server`.
Every family has a `sim` backend, so every node runs headless.

Each `open_*` takes the family's config Struct or the equivalent mapping, an optional clock
(seconds, monotonic; default `time.monotonic`) and a `source` naming where the config came
from for error messages. Errors: see `carlaverse.hal.errors`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from carlaverse.hal import camera, ffb, motion, speed_sensor, trainer, xr
from carlaverse.hal import input as input_family
from carlaverse.hal.camera import Camera, CameraConfig, CameraFrame
from carlaverse.hal.device import Clock, DeviceConfig, open_device
from carlaverse.hal.errors import (
    BackendDependencyError,
    BackendNotFoundError,
    DeviceError,
    HalError,
)
from carlaverse.hal.ffb import FfbConfig, FfbDevice
from carlaverse.hal.ffb_packet import FfbCommand, FfbPacketError
from carlaverse.hal.input import InputConfig, InputDevice, InputState
from carlaverse.hal.motion import MotionConfig, MotionDevice
from carlaverse.hal.motion_packet import MotionFrame, MotionLimits, MotionPacketError
from carlaverse.hal.speed_sensor import SpeedSensor, SpeedSensorConfig, WheelSpeed
from carlaverse.hal.trainer import TrainerConfig, TrainerDevice, TrainerState
from carlaverse.hal.xr import HeadPose, XrConfig, XrHeadset

Config = Mapping[str, Any]


def open_input(
    cfg: InputConfig | Config, *, clock: Clock | None = None, source: str = "input"
) -> InputDevice:
    """Open the input device `cfg` names (wheel, pedals, keyboard, scripted driver)."""
    return open_device(input_family.registry(), cfg, InputConfig, clock=clock, source=source)


def open_ffb(
    cfg: FfbConfig | Config, *, clock: Clock | None = None, source: str = "ffb"
) -> FfbDevice:
    """Open the force-feedback device `cfg` names."""
    return open_device(ffb.registry(), cfg, FfbConfig, clock=clock, source=source)


def open_motion(
    cfg: MotionConfig | Config, *, clock: Clock | None = None, source: str = "motion"
) -> MotionDevice:
    """Open the motion platform `cfg` names."""
    return open_device(motion.registry(), cfg, MotionConfig, clock=clock, source=source)


def open_trainer(
    cfg: TrainerConfig | Config, *, clock: Clock | None = None, source: str = "trainer"
) -> TrainerDevice:
    """Open the smart trainer `cfg` names."""
    return open_device(trainer.registry(), cfg, TrainerConfig, clock=clock, source=source)


def open_speed_sensor(
    cfg: SpeedSensorConfig | Config, *, clock: Clock | None = None, source: str = "speed_sensor"
) -> SpeedSensor:
    """Open the wheel-speed sensor `cfg` names."""
    registry = speed_sensor.registry()
    return open_device(registry, cfg, SpeedSensorConfig, clock=clock, source=source)


def open_xr(cfg: XrConfig | Config, *, clock: Clock | None = None, source: str = "xr") -> XrHeadset:
    """Open the XR headset `cfg` names."""
    return open_device(xr.registry(), cfg, XrConfig, clock=clock, source=source)


def open_camera(
    cfg: CameraConfig | Config, *, clock: Clock | None = None, source: str = "camera"
) -> Camera:
    """Open the camera `cfg` names."""
    return open_device(camera.registry(), cfg, CameraConfig, clock=clock, source=source)


__all__ = [
    "BackendDependencyError",
    "BackendNotFoundError",
    "Camera",
    "CameraConfig",
    "CameraFrame",
    "DeviceConfig",
    "DeviceError",
    "FfbCommand",
    "FfbConfig",
    "FfbDevice",
    "FfbPacketError",
    "HalError",
    "HeadPose",
    "InputConfig",
    "InputDevice",
    "InputState",
    "MotionConfig",
    "MotionDevice",
    "MotionFrame",
    "MotionLimits",
    "MotionPacketError",
    "SpeedSensor",
    "SpeedSensorConfig",
    "TrainerConfig",
    "TrainerDevice",
    "TrainerState",
    "WheelSpeed",
    "XrConfig",
    "XrHeadset",
    "open_camera",
    "open_ffb",
    "open_input",
    "open_motion",
    "open_speed_sensor",
    "open_trainer",
    "open_xr",
]
