"""Joysticks, wheels and pedals through SDL (pygame), with rumble where the device has it.

Which physical axis, button or hat becomes which channel is configuration:

    input:
      backend: pygame
      options:
        device: "G29"                 # part of the name; or `index: 0`
        axes:
          steer: {index: 0}
          throttle: {index: 2, invert: true, unipolar: true}
          brake: {index: 3, invert: true, unipolar: true, deadzone: 0.02}
        buttons: {horn: 4, reverse: 5}
        hats: {dpad: 0}

With no mapping every raw channel is reported as `axis0`, `button3`, `hat0`.

SDL updates joystick state when events are pumped, which needs pygame's display module
initialised: on a headless host set `SDL_VIDEODRIVER=dummy` (the CLI does); when the node's
renderer pumps pygame events itself, set `pump_events: false`.
"""

from __future__ import annotations

import time
from typing import Annotated

import msgspec
import pygame

from carlaverse.config import StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.errors import DeviceError
from carlaverse.hal.input import Axes, Buttons, Hats, InputDevice

Index = Annotated[int, msgspec.Meta(ge=0)]


class AxisMap(StrictStruct):
    index: Index
    invert: bool = False
    unipolar: bool = False  # pedal: raw -1..1 becomes 0..1
    deadzone: Annotated[float, msgspec.Meta(ge=0, lt=1)] = 0.0  # fraction of the range


class PygameOptions(StrictStruct):
    device: str = ""  # part of the joystick name; empty = use `index`
    index: Index = 0
    axes: dict[str, AxisMap] = msgspec.field(default_factory=dict)
    buttons: dict[str, Index] = msgspec.field(default_factory=dict)
    hats: dict[str, Index] = msgspec.field(default_factory=dict)
    pump_events: bool = True


def map_axis(raw: float, axis: AxisMap) -> float:
    """Raw SDL axis (-1..1) -> channel value (-1..1, or 0..1 when unipolar)."""
    value = -raw if axis.invert else raw
    if axis.unipolar:
        value = (value + 1.0) / 2.0
    magnitude = abs(value)
    if magnitude <= axis.deadzone:
        return 0.0
    scaled = (magnitude - axis.deadzone) / (1.0 - axis.deadzone)
    return min(1.0, scaled) if value > 0 else -min(1.0, scaled)


def start_sdl(pump_events: bool) -> None:
    """Initialise SDL's joystick (and, for pumping, display) subsystems once."""
    try:
        if pump_events and not pygame.display.get_init():
            pygame.display.init()
        pygame.joystick.init()
    except pygame.error as exc:
        raise DeviceError(
            f"SDL cannot start ({exc}); on a headless host set SDL_VIDEODRIVER=dummy, or set "
            "`pump_events: false` when the node pumps pygame events itself"
        ) from exc


def list_joysticks() -> list[str]:
    """Names of the joysticks SDL sees now, by index."""
    start_sdl(pump_events=True)
    pygame.event.pump()
    return [pygame.joystick.Joystick(i).get_name() for i in range(pygame.joystick.get_count())]


def describe_joysticks() -> list[str]:
    """One line per joystick: index, name, and its axis/button/hat counts."""
    rows = []
    for i, name in enumerate(list_joysticks()):
        js = pygame.joystick.Joystick(i)
        rows.append(
            f"{i}: {name} ({js.get_numaxes()} axes, {js.get_numbuttons()} buttons, "
            f"{js.get_numhats()} hats)"
        )
    return rows


def find_joystick(options: PygameOptions) -> pygame.joystick.JoystickType:
    names = list_joysticks() if options.pump_events else _names_without_pump()
    if options.device:
        matches = [i for i, n in enumerate(names) if options.device.lower() in n.lower()]
        index = matches[0] if matches else None
    else:
        index = options.index if options.index < len(names) else None
    if index is None:
        wanted = repr(options.device) if options.device else f"index {options.index}"
        found = ", ".join(f"{i}: {n}" for i, n in enumerate(names)) or "none"
        raise DeviceError(
            f"no joystick matches {wanted}; SDL sees: {found}. Is it plugged in and "
            "readable? `carlaverse doctor` lists what is detected."
        )
    return pygame.joystick.Joystick(index)


def _names_without_pump() -> list[str]:
    start_sdl(pump_events=False)
    return [pygame.joystick.Joystick(i).get_name() for i in range(pygame.joystick.get_count())]


class PygameJoystick(InputDevice):
    """One SDL joystick, its channels named by the options."""

    Options = PygameOptions

    def __init__(self, options: PygameOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        self.joystick = find_joystick(options)
        self.name = self.joystick.get_name()
        self._check_mapping()

    def _check_mapping(self) -> None:
        counts = {
            "axes": self.joystick.get_numaxes(),
            "buttons": self.joystick.get_numbuttons(),
            "hats": self.joystick.get_numhats(),
        }
        for kind, mapping in (("axes", self.options.axes), ("buttons", self.options.buttons),
                              ("hats", self.options.hats)):  # fmt: skip
            for channel, spec in mapping.items():
                index = spec.index if isinstance(spec, AxisMap) else spec
                if index >= counts[kind]:
                    raise DeviceError(
                        f"input.options.{kind}.{channel}: index {index} but {self.name!r} "
                        f"has {counts[kind]} {kind} (0..{counts[kind] - 1})"
                    )

    def _poll(self, now: float) -> tuple[Axes, Buttons, Hats]:
        if self.options.pump_events:
            pygame.event.pump()
        return self._axes(), self._buttons(), self._hats()

    def _axes(self) -> Axes:
        js = self.joystick
        if not self.options.axes:
            return {f"axis{i}": js.get_axis(i) for i in range(js.get_numaxes())}
        return {name: map_axis(js.get_axis(m.index), m) for name, m in self.options.axes.items()}

    def _buttons(self) -> Buttons:
        js = self.joystick
        mapping = self.options.buttons or {f"button{i}": i for i in range(js.get_numbuttons())}
        return {name: bool(js.get_button(i)) for name, i in mapping.items()}

    def _hats(self) -> Hats:
        js = self.joystick
        mapping = self.options.hats or {f"hat{i}": i for i in range(js.get_numhats())}
        hats = {name: js.get_hat(i) for name, i in mapping.items()}
        return {name: (int(x), int(y)) for name, (x, y) in hats.items()}

    def _rumble(self, low: float, high: float, duration_ms: int) -> bool:
        return bool(self.joystick.rumble(low, high, duration_ms))

    def _close(self) -> None:
        self.joystick.stop_rumble()
        self.joystick.quit()
