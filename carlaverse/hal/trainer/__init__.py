"""Smart trainers: the bike node's power and cadence source and its resistance actuator.

A trainer reports rider power [W] and cadence [1/min], and takes either a target power (ERG
mode), the road grade it should simulate, or a resistance level [%] (what the bike node's
calibrated table commands). Backends: `sim` (a simulated rider), `ftms` (a Bluetooth FTMS
trainer through bleak) and `ftms_sim` (a simulated FTMS trainer speaking the same bytes).
Third parties add more under the entry-point group `carlaverse.hal.trainer`.
"""

from __future__ import annotations

import math

import msgspec

from carlaverse.hal.device import Device, DeviceConfig
from carlaverse.hal.errors import DeviceError
from carlaverse.hal.registry import BackendSpec, Registry

BACKENDS = {
    "sim": BackendSpec("carlaverse.hal.trainer.sim", "SimTrainer"),
    "ftms": BackendSpec("carlaverse.hal.trainer.ftms_ble", "BleFtmsTrainer", "bike"),
    "ftms_sim": BackendSpec("carlaverse.hal.trainer.ftms_sim", "SimFtmsTrainer"),
}


class TrainerConfig(DeviceConfig):
    """`trainer:` block of a node config."""


class TrainerState(msgspec.Struct, frozen=True):
    t: float  # [s] device clock
    power_w: float  # [W] rider power at the cranks
    cadence_rpm: float  # [1/min]
    speed_mps: float | None = None  # [m/s] wheel speed, when the trainer measures one


class TrainerDevice(Device):
    """Base class: `read` samples the rider; `set_target_power`/`set_grade` set resistance."""

    def read(self) -> TrainerState:
        now = self.clock()
        power_w, cadence_rpm = self._read(now)
        return TrainerState(now, max(0.0, power_w), max(0.0, cadence_rpm), self._speed(now))

    def set_target_power(self, power_w: float) -> None:
        """ERG mode: the trainer holds this power [W] whatever the cadence."""
        if not (math.isfinite(power_w) and power_w >= 0):
            raise ValueError(f"target power {power_w} W must be finite and >= 0")
        self._set_target_power(power_w)

    def set_grade(self, grade_percent: float) -> None:
        """Simulation mode: resistance of a road with this grade [%] (leaves ERG mode)."""
        if not (math.isfinite(grade_percent) and -40 <= grade_percent <= 40):
            raise ValueError(f"grade {grade_percent} % must be within -40..40")
        self._set_grade(grade_percent)

    def set_resistance(self, percent: float) -> None:
        """Resistance level [%] of the trainer's brake, 0..100."""
        if not (math.isfinite(percent) and 0 <= percent <= 100):
            raise ValueError(f"resistance {percent} % must be within 0..100")
        self._set_resistance(percent)

    def _read(self, now: float) -> tuple[float, float]:
        raise NotImplementedError

    def _speed(self, now: float) -> float | None:
        return None

    def _set_resistance(self, percent: float) -> None:
        raise DeviceError(f"the {type(self).__name__} trainer takes no resistance level")

    def _set_target_power(self, power_w: float) -> None:
        raise NotImplementedError

    def _set_grade(self, grade_percent: float) -> None:
        raise NotImplementedError


def registry() -> Registry[TrainerDevice]:
    return Registry("trainer", TrainerDevice, BACKENDS)
