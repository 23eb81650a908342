"""Input devices: steering wheels, pedals, joysticks, keyboards, scripted drivers.

A device reports named channels: `axes` in -1..1 (bipolar, e.g. steer) or 0..1 (unipolar,
e.g. throttle), `buttons` as booleans, `hats` as (x, y) in {-1, 0, 1}. Which physical axis
becomes which channel is the backend's typed options, never code.

Backends: `pygame` (SDL joysticks, wheels, pedals; rumble), `keyboard` (pygame key events),
`sim` (a scripted driver or rider). Third parties add more under the entry-point group
`carlaverse.hal.input`.
"""

from __future__ import annotations

import logging
import math

import msgspec

from carlaverse.hal.device import Device, DeviceConfig
from carlaverse.hal.registry import BackendSpec, Registry

log = logging.getLogger(__name__)

BACKENDS = {
    "pygame": BackendSpec("carlaverse.hal.input.pygame_joystick", "PygameJoystick", "input"),
    "keyboard": BackendSpec("carlaverse.hal.input.keyboard", "KeyboardInput", "input"),
    "sim": BackendSpec("carlaverse.hal.input.sim", "SimInput"),
}

Axes = dict[str, float]
Buttons = dict[str, bool]
Hats = dict[str, tuple[int, int]]


class InputConfig(DeviceConfig):
    """`input:` block of a node config."""


class InputState(msgspec.Struct, frozen=True):
    """One sample of every channel."""

    t: float  # [s] device clock when sampled
    axes: Axes
    buttons: Buttons
    hats: Hats = msgspec.field(default_factory=dict)


class InputDevice(Device):
    """Base class. `poll` owns the contract (clamping, NaN guard); backends implement `_poll`."""

    invalid_samples = 0  # NaN axis values replaced by 0

    def poll(self) -> InputState:
        """Read every channel now."""
        now = self.clock()
        axes, buttons, hats = self._poll(now)
        return InputState(now, {k: self._clamp(k, v) for k, v in axes.items()}, buttons, hats)

    def rumble(self, low: float, high: float, duration_ms: int) -> bool:
        """Shake the device's low/high-frequency motors (0..1) for `duration_ms`; False when
        the device cannot rumble."""
        clamp = lambda x: min(1.0, max(0.0, x))  # noqa: E731
        return self._rumble(clamp(low), clamp(high), max(0, int(duration_ms)))

    def _poll(self, now: float) -> tuple[Axes, Buttons, Hats]:
        raise NotImplementedError

    def _rumble(self, low: float, high: float, duration_ms: int) -> bool:
        return False

    def _clamp(self, name: str, value: float) -> float:
        if math.isnan(value):
            self.invalid_samples += 1
            log.debug("input axis %s gave NaN; reporting 0", name)
            return 0.0
        return min(1.0, max(-1.0, value))


def registry() -> Registry[InputDevice]:
    return Registry("input", InputDevice, BACKENDS)
