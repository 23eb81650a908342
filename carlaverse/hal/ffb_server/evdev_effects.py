"""FfbCommand -> Linux force-feedback effect parameters, as pure functions.

This module needs no evdev: it maps the packet's 0..10000 scales onto the kernel's
`struct ff_effect` fields (linux/input.h) as plain frozen Structs, so the mapping is tested
everywhere. `evdev_actuator` turns them into `evdev.ff.Effect` ctypes structs and uploads them.

Mapping (kernel ranges in brackets):
- spring: `ff_condition_effect` on the X axis; coefficient = stiffness [0..0x7fff], centre =
  offset [-0x7fff..0x7fff], deadband [0..0xffff, 0xffff = whole axis], saturation both sides
  [0..0xffff].
- damper, friction, inertia: condition effects with coefficient [0..0x7fff] and full
  saturation, so the coefficient alone sets the strength.
- constant: level [-0x7fff..0x7fff], direction 0x4000 so the force acts along the wheel's
  axis; `invert` flips the sign for rigs wired the other way (it flips the spring centre too).
- vibration: periodic sine, magnitude [0..0x7fff], period = round(1000 / f) ms; a zero
  magnitude or frequency means the effect is stopped.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any, Literal

import msgspec

from carlaverse.hal.ffb_packet import FULL_SCALE, FfbCommand

# linux/input-event-codes.h
EV_FF = 0x15
FF_PERIODIC, FF_CONSTANT, FF_SPRING = 0x51, 0x52, 0x53
FF_FRICTION, FF_DAMPER, FF_INERTIA = 0x54, 0x55, 0x56
FF_SINE = 0x5A
FF_GAIN, FF_AUTOCENTER = 0x60, 0x61

S16_MAX = 0x7FFF
U16_MAX = 0xFFFF
DIRECTION_ALONG_AXIS = 0x4000  # 90°: the force lies on the wheel's (X) axis
PLAY_UNTIL_STOPPED = 0  # replay.length 0 = no end (kernel convention)

EffectName = Literal["constant", "spring", "damper", "friction", "inertia", "vibration"]
EFFECT_NAMES: tuple[EffectName, ...] = (
    "constant",
    "spring",
    "damper",
    "friction",
    "inertia",
    "vibration",
)


class ConditionParams(msgspec.Struct, frozen=True):
    """One axis of `struct ff_condition_effect`."""

    coeff: int  # [0..0x7fff] both sides
    saturation: int  # [0..0xffff] both sides
    deadband: int = 0  # [0..0xffff]
    center: int = 0  # [-0x7fff..0x7fff]


class EffectParams(msgspec.Struct, frozen=True):
    """Everything needed to build one `struct ff_effect`."""

    name: EffectName
    type: int  # FF_CONSTANT, FF_SPRING, ...
    level: int = 0  # constant level [-0x7fff..0x7fff]
    condition: ConditionParams | None = None
    magnitude: int = 0  # periodic magnitude [0..0x7fff]
    period_ms: int = 0  # periodic period [ms]
    direction: int = DIRECTION_ALONG_AXIS

    @property
    def silent(self) -> bool:
        """True when the effect produces no force and should not play."""
        if self.type == FF_CONSTANT:
            return self.level == 0
        if self.type == FF_PERIODIC:
            return self.magnitude == 0 or self.period_ms == 0
        c = self.condition
        return c is None or c.coeff == 0 or c.saturation == 0


def scale(value: int, full: int) -> int:
    """Map -10000..10000 onto -full..full, rounding half away from zero."""
    magnitude = (abs(value) * full * 2 + FULL_SCALE) // (2 * FULL_SCALE)
    return magnitude if value >= 0 else -magnitude


def period_ms(frequency_hz: int) -> int:
    """The periodic effect's period [ms] for a frequency [Hz]; 0 when there is none."""
    if frequency_hz <= 0:
        return 0
    return min(U16_MAX, max(1, round(1000 / frequency_hz)))


def spring(command: FfbCommand, invert: bool) -> EffectParams:
    sign = -1 if invert else 1
    condition = ConditionParams(
        coeff=scale(command.spring_stiffness, S16_MAX),
        saturation=scale(command.spring_saturation, U16_MAX),
        deadband=scale(command.spring_deadband, U16_MAX),
        center=sign * scale(command.spring_offset, S16_MAX),
    )
    return EffectParams("spring", FF_SPRING, condition=condition)


def resistance(name: EffectName, kind: int, strength: int) -> EffectParams:
    """Damper, friction or inertia: a condition effect whose coefficient is the strength."""
    condition = ConditionParams(coeff=scale(strength, S16_MAX), saturation=U16_MAX)
    return EffectParams(name, kind, condition=condition)


def constant(command: FfbCommand, invert: bool) -> EffectParams:
    level = scale(command.constant_force, S16_MAX)
    return EffectParams("constant", FF_CONSTANT, level=-level if invert else level)


def vibration(command: FfbCommand) -> EffectParams:
    return EffectParams(
        "vibration",
        FF_PERIODIC,
        magnitude=scale(command.vibration_magnitude, S16_MAX),
        period_ms=period_ms(command.vibration_frequency_hz),
    )


def effect_params(command: FfbCommand, invert: bool = False) -> dict[EffectName, EffectParams]:
    """The six effects that together produce `command`, keyed by name."""
    return {
        "constant": constant(command, invert),
        "spring": spring(command, invert),
        "damper": resistance("damper", FF_DAMPER, command.damper),
        "friction": resistance("friction", FF_FRICTION, command.friction),
        "inertia": resistance("inertia", FF_INERTIA, command.inertia),
        "vibration": vibration(command),
    }


def gain_value(gain_percent: float) -> int:
    """FF_GAIN event value [0..0xffff] for a master gain in percent."""
    return round(U16_MAX * min(100.0, max(0.0, gain_percent)) / 100.0)


def to_evdev(params: EffectParams, ff: ModuleType, effect_id: int = -1) -> Any:
    """An `evdev.ff.Effect` for `params`; `ff` is the `evdev.ff` module (passed in so this
    module imports without evdev). `effect_id` -1 uploads a new effect, else updates it."""
    envelope = ff.Envelope(0, 0, 0, 0)
    if params.type == FF_CONSTANT:
        union = ff.EffectType(ff_constant_effect=ff.Constant(params.level, envelope))
    elif params.type == FF_PERIODIC:
        periodic = ff.Periodic(
            waveform=FF_SINE, period=params.period_ms, magnitude=params.magnitude,
            offset=0, phase=0, envelope=envelope,
        )  # fmt: skip
        union = ff.EffectType(ff_periodic_effect=periodic)
    else:
        union = ff.EffectType(ff_condition_effect=_conditions(params.condition, ff))
    return ff.Effect(
        params.type, effect_id, params.direction, ff.Trigger(0, 0),
        ff.Replay(PLAY_UNTIL_STOPPED, 0), union,
    )  # fmt: skip


def _conditions(condition: ConditionParams | None, ff: ModuleType) -> Any:
    c = condition or ConditionParams(coeff=0, saturation=0)
    x_axis = ff.Condition(
        right_saturation=c.saturation, left_saturation=c.saturation, right_coeff=c.coeff,
        left_coeff=c.coeff, deadband=c.deadband, center=c.center,
    )  # fmt: skip
    return (ff.Condition * 2)(x_axis, ff.Condition())
