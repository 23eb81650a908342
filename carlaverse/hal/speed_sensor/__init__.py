"""Wheel-speed sensors: how fast the real wheel turns (e.g. a bike on rollers).

Backends: `sim` (a speed profile) and `serial` (an ESP32's line protocol, see
`serial_esp32`); a BLE CSC backend may follow.
Third parties add more under the entry-point group `carlaverse.hal.speed_sensor`.
"""

from __future__ import annotations

import msgspec

from carlaverse.hal.device import Device, DeviceConfig
from carlaverse.hal.registry import BackendSpec, Registry

BACKENDS = {
    "sim": BackendSpec("carlaverse.hal.speed_sensor.sim", "SimSpeedSensor"),
    "serial": BackendSpec("carlaverse.hal.speed_sensor.serial_esp32", "SerialSpeedSensor", "bike"),
}


class SpeedSensorConfig(DeviceConfig):
    """`speed_sensor:` block of a node config."""


class WheelSpeed(msgspec.Struct, frozen=True):
    t: float  # [s] device clock
    speed_mps: float  # [m/s] wheel surface speed
    revolutions: float  # wheel revolutions since the sensor opened


class SpeedSensor(Device):
    """Base class: `read` samples speed and the revolution count."""

    def read(self) -> WheelSpeed:
        now = self.clock()
        speed_mps, revolutions = self._read(now)
        return WheelSpeed(now, speed_mps, revolutions)

    def _read(self, now: float) -> tuple[float, float]:
        raise NotImplementedError


def registry() -> Registry[SpeedSensor]:
    return Registry("speed_sensor", SpeedSensor, BACKENDS)
