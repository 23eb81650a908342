"""Keyboard input through pygame key events: keys drive axes that ramp like a real pedal.

    input:
      backend: keyboard
      options:
        axes:
          steer: {positive: left, negative: right, rise_per_s: 3, fall_per_s: 6}
          throttle: {positive: up}
          brake: {positive: down}
        buttons: {horn: h, reverse: r}

Key names are pygame's (`pygame.key.name`): "left", "a", "space", "left shift". Key events
only reach a focused window, so this needs the node's pygame window (or, in tests, the dummy
video driver and posted events). The device consumes KEYDOWN/KEYUP events when polled; bind
every key the node cares about as a button.
"""

from __future__ import annotations

import time
from typing import Annotated

import msgspec
import pygame

from carlaverse.config import ConfigError, StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.errors import DeviceError
from carlaverse.hal.input import Axes, Buttons, Hats, InputDevice

Rate = Annotated[float, msgspec.Meta(gt=0)]


class KeyAxis(StrictStruct):
    positive: str  # key that drives the axis to +1
    negative: str = ""  # key that drives it to -1; empty = a 0..1 axis
    rise_per_s: Rate = 4.0  # [1/s] how fast the axis moves while a key is held
    fall_per_s: Rate = 8.0  # [1/s] how fast it returns to 0 when released


def _default_axes() -> dict[str, KeyAxis]:
    return {
        # steer +1 is full left (ISO 8855: positive yaw is to the left), so the left arrow
        # drives it up; the reverse turned the car away from the key pressed
        "steer": KeyAxis(positive="left", negative="right", rise_per_s=2.0, fall_per_s=4.0),
        "throttle": KeyAxis(positive="up"),
        "brake": KeyAxis(positive="down"),
    }


class KeyboardOptions(StrictStruct):
    axes: dict[str, KeyAxis] = msgspec.field(default_factory=_default_axes)
    buttons: dict[str, str] = msgspec.field(default_factory=dict)


def ramp(value: float, target: float, rate_per_s: float, dt_s: float) -> float:
    """Move `value` toward `target` by at most `rate_per_s · dt_s`."""
    step = rate_per_s * max(0.0, dt_s)
    return min(target, value + step) if target > value else max(target, value - step)


def key_code(name: str, where: str) -> int:
    try:
        return pygame.key.key_code(name)
    except ValueError as exc:
        raise ConfigError(
            "input.options (backend 'keyboard')",
            f"{where}: unknown key name {name!r}; use pygame key names such as "
            "'left', 'a', 'space', 'left shift'",
        ) from exc


class KeyboardInput(InputDevice):
    """Axes ramp toward ±1 while their keys are held and back to 0 when released."""

    Options = KeyboardOptions

    def __init__(self, options: KeyboardOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        try:
            if not pygame.display.get_init():
                pygame.display.init()
        except pygame.error as exc:
            raise DeviceError(f"keyboard input needs SDL video ({exc})") from exc
        self.codes = self._resolve(options)
        self.pressed: set[int] = set()
        self.values = dict.fromkeys(options.axes, 0.0)
        self.last_t = clock()

    @staticmethod
    def _resolve(options: KeyboardOptions) -> dict[str, int]:
        codes = {f"button {n}": key_code(k, f"buttons.{n}") for n, k in options.buttons.items()}
        for name, axis in options.axes.items():
            codes[f"+{name}"] = key_code(axis.positive, f"axes.{name}.positive")
            if axis.negative:
                codes[f"-{name}"] = key_code(axis.negative, f"axes.{name}.negative")
        return codes

    def _poll(self, now: float) -> tuple[Axes, Buttons, Hats]:
        for event in pygame.event.get((pygame.KEYDOWN, pygame.KEYUP)):
            (self.pressed.add if event.type == pygame.KEYDOWN else self.pressed.discard)(event.key)
        dt, self.last_t = now - self.last_t, now
        for name, axis in self.options.axes.items():
            target = self._held(f"+{name}") - self._held(f"-{name}")
            rate = axis.rise_per_s if target else axis.fall_per_s
            self.values[name] = ramp(self.values[name], target, rate, dt)
        buttons = {name: bool(self._held(f"button {name}")) for name in self.options.buttons}
        return dict(self.values), buttons, {}

    def _held(self, key: str) -> int:
        code = self.codes.get(key)
        return 1 if code is not None and code in self.pressed else 0
