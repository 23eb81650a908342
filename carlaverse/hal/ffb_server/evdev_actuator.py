"""Linux force feedback through python-evdev's ff API (`pip install 'carlaverse[evdev]'`).

Six effects are uploaded to the device on first use (constant, spring, damper, friction,
inertia, sine vibration) and then updated in place: a packet that changes only the constant
force re-uploads only that effect. Zeroing stops every playing effect with one EV_FF write
each, which the kernel applies immediately; the next valid packet uploads and starts them
again. Effects the device does not support are skipped, with one warning at open.
"""

from __future__ import annotations

import logging
import os
import time
from typing import Annotated

import evdev
import evdev.ff
import msgspec

from carlaverse.config import StrictStruct
from carlaverse.hal.device import Clock
from carlaverse.hal.errors import DeviceError
from carlaverse.hal.ffb_packet import FfbCommand
from carlaverse.hal.ffb_server import evdev_effects as fx
from carlaverse.hal.ffb_server.actuator import ForceActuator

log = logging.getLogger(__name__)


class EvdevOptions(StrictStruct):
    device: str  # /dev/input/eventN, or part of the device name ("G29")
    gain_percent: Annotated[float, msgspec.Meta(ge=0, le=100)] = 100.0  # [%] master gain
    disable_autocenter: bool = True  # our spring is the only centring force
    invert: bool = False  # flip constant force and spring centre for rigs wired the other way


def find_device(spec: str) -> evdev.InputDevice:
    """Open `spec` as a path, or the first force-feedback device whose name contains it."""
    if spec.startswith("/"):
        try:
            return evdev.InputDevice(spec)
        except OSError as exc:
            raise DeviceError(f"cannot open FFB device {spec}: {exc.strerror}") from exc
    candidates = [evdev.InputDevice(path) for path in evdev.list_devices()]
    for device in candidates:
        if spec.lower() in device.name.lower() and fx.EV_FF in device.capabilities():
            return device
    names = ", ".join(f"{os.fsdecode(d.path)} ({d.name})" for d in candidates) or "none readable"
    raise DeviceError(
        f"no force-feedback device matches {spec!r}; input devices: {names}. "
        "Check permissions on /dev/input (the 'input' group) and `carlaverse doctor`."
    )


class EvdevActuator(ForceActuator):
    """Drives one evdev force-feedback device."""

    Options = EvdevOptions

    def __init__(self, options: EvdevOptions, *, clock: Clock = time.monotonic) -> None:
        super().__init__(options, clock=clock)
        self.device = find_device(options.device)
        supported = set(self.device.capabilities().get(fx.EV_FF, []))
        if not supported:
            self.device.close()
            path = os.fsdecode(self.device.path)  # evdev types it str | bytes
            raise DeviceError(f"{path} ({self.device.name}) has no force feedback")
        self.supported = supported
        self.ids: dict[fx.EffectName, int] = {}
        self.uploaded: dict[fx.EffectName, fx.EffectParams] = {}
        self.playing: set[fx.EffectName] = set()
        self._configure(options)

    def _configure(self, options: EvdevOptions) -> None:
        if fx.FF_GAIN in self.supported:
            self.device.write(fx.EV_FF, fx.FF_GAIN, fx.gain_value(options.gain_percent))
        if options.disable_autocenter and fx.FF_AUTOCENTER in self.supported:
            self.device.write(fx.EV_FF, fx.FF_AUTOCENTER, 0)
        missing = [n for n, p in fx.effect_params(FfbCommand()).items() if not self._has(p)]
        if missing:
            log.warning("%s lacks effects %s; they are skipped", self.device.name, missing)

    def _has(self, params: fx.EffectParams) -> bool:
        if params.type == fx.FF_PERIODIC:
            return fx.FF_PERIODIC in self.supported and fx.FF_SINE in self.supported
        return params.type in self.supported

    def _apply(self, command: FfbCommand) -> None:
        for name, params in fx.effect_params(command, self.options.invert).items():
            if self._has(params) and self.uploaded.get(name) != params:
                self._update(name, params)

    def _update(self, name: fx.EffectName, params: fx.EffectParams) -> None:
        if params.silent:
            self._stop(name)
        else:
            effect = fx.to_evdev(params, evdev.ff, self.ids.get(name, -1))
            self.ids[name] = self.device.upload_effect(effect)
            if name not in self.playing:
                self.device.write(fx.EV_FF, self.ids[name], 1)
                self.playing.add(name)
        self.uploaded[name] = params

    def _stop(self, name: fx.EffectName) -> None:
        if name in self.playing:
            self.device.write(fx.EV_FF, self.ids[name], 0)
            self.playing.discard(name)

    def _zero(self) -> None:
        failures: list[OSError] = []
        for name in list(self.playing):  # try every effect even if one write fails
            try:
                self._stop(name)
            except OSError as exc:
                failures.append(exc)
        self.uploaded.clear()  # the next packet re-sends every parameter
        if failures:
            raise failures[0]

    def _close(self) -> None:
        try:
            self._zero()
            for effect_id in self.ids.values():
                self.device.erase_effect(effect_id)
        finally:
            self.device.close()
