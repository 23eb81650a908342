"""Force actuators: what the FFB server drives. One per platform API.

An actuator turns a validated `FfbCommand` into device effects. Built in:

- `log`: applies nothing to hardware; logs and remembers every command (tests, dry runs).
- `evdev`: Linux force feedback through python-evdev (`pip install 'carlaverse[evdev]'`).

A Windows DirectInput actuator fits the same interface: subclass `ForceActuator`, implement
`_apply` (create or update DIEFFECT structs for ConstantForce, Spring, Damper, Friction,
Inertia and Sine, and start them), `_zero` (IDirectInputDevice8::SendForceFeedbackCommand with
DISFFC_STOPALL, then parameters to zero) and `_close` (unacquire), and register it under the
entry-point group `carlaverse.hal.ffb_server`. The server owns the contract (validation,
watchdog, logging); an actuator only talks to its device.
"""

from __future__ import annotations

import collections
import logging
import time
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.hal.device import Clock, Device
from carlaverse.hal.ffb_packet import ZERO_COMMAND, FfbCommand
from carlaverse.hal.registry import BackendSpec, Registry

log = logging.getLogger(__name__)

BACKENDS = {
    "log": BackendSpec("carlaverse.hal.ffb_server.actuator", "LogActuator"),
    "evdev": BackendSpec("carlaverse.hal.ffb_server.evdev_actuator", "EvdevActuator", "evdev"),
}


class ForceActuator(Device):
    """Base class: the server calls `apply` per valid packet and `zero` on watchdog/stop."""

    def apply(self, command: FfbCommand) -> None:
        """Make the device produce exactly `command`."""
        self._apply(command)

    def zero(self) -> None:
        """Remove every force at once: constant, spring, damper, friction, inertia, vibration."""
        self._zero()

    def _apply(self, command: FfbCommand) -> None:
        raise NotImplementedError

    def _zero(self) -> None:
        self._apply(ZERO_COMMAND)


def registry() -> Registry[ForceActuator]:
    return Registry("ffb_server", ForceActuator, BACKENDS)


class LogActuatorOptions(StrictStruct):
    history: Annotated[int, msgspec.Meta(ge=1)] = 100_000  # events kept for inspection


class ActuatorEvent(msgspec.Struct, frozen=True):
    t: float  # [s] actuator clock
    kind: str  # "apply" or "zero"
    command: FfbCommand


class LogActuator(ForceActuator):
    """Logs what it would apply and keeps the events; `current` is the force now in effect."""

    Options = LogActuatorOptions

    def __init__(self, options: LogActuatorOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        self.events: collections.deque[ActuatorEvent] = collections.deque(maxlen=options.history)
        self.current = ZERO_COMMAND

    def _apply(self, command: FfbCommand) -> None:
        self.current = command
        self.events.append(ActuatorEvent(self.clock(), "apply", command))
        log.debug("apply %s", command)

    def _zero(self) -> None:
        self.current = ZERO_COMMAND
        self.events.append(ActuatorEvent(self.clock(), "zero", ZERO_COMMAND))
        log.info("all forces zeroed")

    def applied(self) -> list[FfbCommand]:
        """The commands applied so far, in order (zeroing not included)."""
        return [event.command for event in list(self.events) if event.kind == "apply"]
