"""Controls: the input device's named channels → the driver's command, through the YAML.

The hardware layer (carlaverse.hal.input) turns physical axes and keys into named channels
(`steer`, `throttle`, `axis3`, `button7`, hat `dpad`). This module assigns channels to vehicle
functions and shapes them, as the paper's control module does:

    controls:
      steer:    {source: steer, curve: "sgn(x) * abs(x) ** 1.4"}
      throttle: {source: throttle, deadzone: 0.03, curve: "x ** 1.6"}
      brake:    {source: pedals, half: negative, curve: "x ** 2"}  # combined pedal axis
      buttons:
        indicator_left: [button4, "hat:dpad:left"]

Every action also answers to the channel `touch:<action>`: the web HMI's touchscreen taps
arrive as those buttons (carlaverse_nodes.drive.touch), so they take the same path as a key.

Per axis: pick the channel, optionally one half of a bipolar axis, invert, apply a dead zone
(rescaled so full travel still reaches 1), then the curve expression (compiled once by the
restricted evaluator, carlaverse.expr), then clamp. Buttons become rising edges (`pressed`)
and levels (`held`) per action.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Annotated, Literal, Protocol

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.expr import ExpressionError, check_cost, compile_curve

log = logging.getLogger(__name__)

ACTIONS = (
    "indicator_left", "indicator_right", "hazard", "indicator_reset", "lane_change_assist",
    "lights_next", "lights_prev", "lights_cycle", "low_beam", "fog", "high_beam", "flash",
    "interior",
    "gear_up", "gear_down", "gear_reverse", "gear_neutral", "gear_drive",
    "gear_1", "gear_2", "gear_3", "gear_4", "gear_5", "gear_6", "gear_7", "gear_8",
    "horn",
)  # fmt: skip
H_SHIFTER_ACTIONS = tuple(f"gear_{n}" for n in range(1, 9))
HAT_DIRECTIONS = {"up": (1, 1), "down": (1, -1), "left": (0, -1), "right": (0, 1)}
TOUCH_PREFIX = "touch:"  # the web HMI's buttons: touch:<action>


class AxisMapping(StrictStruct):
    source: str  # input channel name
    half: Literal["full", "positive", "negative"] = "full"  # use one side of a bipolar axis
    invert: bool = False
    deadzone: Annotated[float, msgspec.Meta(ge=0, lt=1)] = 0.0  # fraction of travel
    curve: str = "x"  # y = f(x), e.g. "sgn(x) * abs(x) ** 1.8"


class ControlsConfig(StrictStruct):
    """The `controls:` section of a drive config."""

    steer: AxisMapping = AxisMapping(source="steer")
    throttle: AxisMapping = AxisMapping(source="throttle")
    brake: AxisMapping = AxisMapping(source="brake")
    clutch: AxisMapping | None = None
    # action → channel(s): a button name, or "hat:<name>:up|down|left|right".
    buttons: dict[str, str | list[str]] = {}

    def __post_init__(self) -> None:
        unknown = sorted(set(self.buttons) - set(ACTIONS))
        if unknown:
            raise ValueError(f"controls.buttons: unknown action(s) {unknown}; known: {ACTIONS}")
        for action, sources in self.buttons.items():
            for source in [sources] if isinstance(sources, str) else sources:
                check_source(source, f"controls.buttons.{action}")
        for name, axis in self.axes().items():
            check_curve(axis.curve, f"controls.{name}.curve", bipolar=name == "steer")

    def axes(self) -> dict[str, AxisMapping]:
        found = {"steer": self.steer, "throttle": self.throttle, "brake": self.brake}
        if self.clutch is not None:
            found["clutch"] = self.clutch
        return found


def check_source(source: str, where: str) -> None:
    if source.startswith("hat:"):
        parts = source.split(":")
        if len(parts) != 3 or not parts[1] or parts[2] not in HAT_DIRECTIONS:
            raise ValueError(
                f"{where}: {source!r} is not a hat source; write 'hat:<name>:up|down|left|right'"
            )


def check_curve(text: str, where: str, bipolar: bool) -> None:
    """Compile and try the curve over its input range now, not at 1 kHz while driving: it must
    evaluate at every sample, within the cost budget, and on the steering axis be odd."""
    if text.strip() == "x":
        return  # the identity: `_Axis` skips the evaluator for it
    xs = [i / 20.0 for i in range(-20 if bipolar else 0, 21)]
    try:
        curve = compile_curve(text)
        ys = [curve(x) for x in xs]
        check_cost(text, curve, xs)
    except ExpressionError as exc:
        raise ValueError(f"{where}: {exc}") from exc
    if bipolar:
        check_odd(text, where, dict(zip(xs, ys, strict=True)))


ODD_TOLERANCE = 1e-6  # of full lock: ~0.03 mrad at the road wheels, far below any feel


def check_odd(text: str, where: str, ys: Mapping[float, float]) -> None:
    """A steering curve must turn a left input left and the mirrored right input right by as
    much: f(-x) = -f(x) at every sample `ys` (x → f(x), symmetric about 0)."""
    worst = max(ys, key=lambda x: abs(ys[x] + ys[-x]))
    if abs(ys[worst] + ys[-worst]) <= ODD_TOLERANCE:
        return
    x = abs(worst)
    raise ValueError(
        f"{where}: {text!r} must be odd (f(-x) = -f(x)) so that left and right steer opposite "
        f"ways by as much; got f({-x:g})={ys[-x]:.4g}, f({x:g})={ys[x]:.4g}; shape the "
        f"magnitude and keep the sign, e.g. sgn(x) * pow(abs(x), 2)"
    )


class RawInput(Protocol):
    """What an input device reports (carlaverse.hal.InputState fits). Read-only, so any
    mapping type satisfies it (the loop's merged dicts, a device's state)."""

    @property
    def axes(self) -> Mapping[str, float]: ...
    @property
    def buttons(self) -> Mapping[str, bool]: ...


@dataclass(slots=True)
class DriverCommand:
    steer: float = 0.0  # −1 (full right) .. 1 (full left)
    throttle: float = 0.0  # 0..1
    brake: float = 0.0  # 0..1
    clutch: float = 0.0  # 0 (engaged) .. 1 (pedal down)
    pressed: frozenset[str] = field(default_factory=frozenset)  # rising edges this tick
    held: frozenset[str] = field(default_factory=frozenset)  # actions held now


class _Axis:
    """One compiled axis mapping; identity curves skip the evaluator altogether."""

    __slots__ = ("curve", "deadzone", "half", "invert", "lo", "source")

    def __init__(self, mapping: AxisMapping, lo: float) -> None:
        self.source = mapping.source
        self.half, self.invert, self.deadzone = mapping.half, mapping.invert, mapping.deadzone
        text = mapping.curve.strip()
        self.curve: Callable[[float], float] | None = None if text == "x" else compile_curve(text)
        self.lo = lo  # lower clamp: −1 for steering, 0 for pedals

    def shape(self, raw: float) -> float:
        x = -raw if self.invert else raw
        if self.half == "positive":
            x = x if x > 0.0 else 0.0
        elif self.half == "negative":
            x = -x if x < 0.0 else 0.0
        if self.deadzone:
            magnitude = abs(x) - self.deadzone
            x = (
                0.0
                if magnitude <= 0.0
                else (magnitude if x > 0 else -magnitude) / (1.0 - self.deadzone)
            )
        # Clamp into the range the curve was checked on at load time, then its output.
        x = self.lo if x < self.lo else 1.0 if x > 1.0 else x
        if self.curve is not None:
            x = self.curve(x)
            x = self.lo if x < self.lo else 1.0 if x > 1.0 else x
        return x


class Controls:
    """Stateful mapper: remembers the buttons held last tick to report rising edges."""

    def __init__(self, config: ControlsConfig) -> None:
        self.config = config
        self._steer = _Axis(config.steer, -1.0)
        self._throttle = _Axis(config.throttle, 0.0)
        self._brake = _Axis(config.brake, 0.0)
        self._clutch = _Axis(config.clutch, 0.0) if config.clutch else None
        # Per action: its plain button channels (a set, for a C-speed disjointness test)
        # and its hat directions as (hat, axis index, sign).
        self._buttons: list[tuple[str, frozenset[str], tuple[tuple[str, int, int], ...]]] = []
        for action in ACTIONS:
            sources = config.buttons.get(action, [])
            listed = [sources] if isinstance(sources, str) else sources
            listed = [*listed, TOUCH_PREFIX + action]
            plain = frozenset(s for s in listed if not s.startswith("hat:"))
            hats = tuple(_hat_source(s) for s in listed if s.startswith("hat:"))
            self._buttons.append((action, plain, hats))
        self._held: frozenset[str] = frozenset()
        self.curve_errors = 0  # curve evaluations that failed; the linear value was used
        self.has_h_shifter = any(a in config.buttons for a in H_SHIFTER_ACTIONS)

    def read(self, raw: RawInput) -> DriverCommand:
        """Map one input sample. Missing channels read as released / centred."""
        axes = raw.axes
        held = self._held_actions(raw)
        pressed = held - self._held
        self._held = held
        return DriverCommand(
            steer=self._axis(self._steer, axes),
            throttle=self._axis(self._throttle, axes),
            brake=self._axis(self._brake, axes),
            clutch=self._axis(self._clutch, axes) if self._clutch else 0.0,
            pressed=pressed,
            held=held,
        )

    def _axis(self, axis: _Axis, axes: Mapping[str, float]) -> float:
        raw = axes.get(axis.source, 0.0)
        try:
            return axis.shape(raw)
        except ExpressionError as exc:
            self.curve_errors += 1
            if self.curve_errors == 1 or self.curve_errors % 1000 == 0:
                log.warning(
                    "%s (%d failures so far); using the linear value", exc, self.curve_errors
                )
            return max(axis.lo, min(1.0, raw))

    def _held_actions(self, raw: RawInput) -> frozenset[str]:
        down = {name for name, value in raw.buttons.items() if value}
        hats: Mapping[str, tuple[int, int]] = getattr(raw, "hats", None) or {}
        held = [
            action
            for action, plain, hat_sources in self._buttons
            if (down and not plain.isdisjoint(down))
            or (hat_sources and any(_hat_held(h, hats) for h in hat_sources))
        ]
        return frozenset(held) if held else _NOTHING


_NOTHING: frozenset[str] = frozenset()


def _hat_source(source: str) -> tuple[str, int, int]:
    """'hat:dpad:left' → ('dpad', axis 0, sign −1); validated by check_source at load."""
    _, name, direction = source.split(":")
    axis, sign = HAT_DIRECTIONS[direction]
    return name, axis, sign


def _hat_held(source: tuple[str, int, int], hats: Mapping[str, tuple[int, int]]) -> bool:
    value = hats.get(source[0])
    return value is not None and value[source[1]] == source[2]
