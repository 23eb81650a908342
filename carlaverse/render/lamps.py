"""Vehicle lamps: where each kind has them, and how each glows for the actor's light bits.

Roles and the bits that light them (`carlaverse.messages` LIGHT_*):

- `head`: full with low or high beam, dim with only the parking (position) lamps;
- `tail`: the rear red lamps, bright with the brake, dim with any position lamp on;
- `left`, `right`: indicators, flashing while their blinker bit is set (`frame.blink_on`);
- `reverse`: white while reversing.

Lamp boxes are in a kind's unit frame (`bodies`): 0.02 deep, their outer faces on the box's
ends (y = ±0.5), standing proud of the body's end faces (`bodies.END`), so no face of a lamp
lies on a face of the body: seen square-on, a polygon offset did not reliably win that tie. A
lamp is unlit by the scene's lights (it glows in any weather).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from panda3d.core import NodePath

from carlaverse.messages import (
    LIGHT_BRAKE,
    LIGHT_HIGH_BEAM,
    LIGHT_LEFT_BLINKER,
    LIGHT_LOW_BEAM,
    LIGHT_PARKING,
    LIGHT_REVERSE,
    LIGHT_RIGHT_BLINKER,
)
from carlaverse.render import palette
from carlaverse.render.frame import blink_on
from carlaverse.render.meshes import Color, MeshBuilder

# A box in a unit frame: (x, y, z) of its bottom face's centre, and its (sx, sy, sz).
Box = tuple[tuple[float, float, float], tuple[float, float, float]]
Role = Literal["head", "tail", "left", "right", "reverse"]
POSITION_BITS = LIGHT_PARKING | LIGHT_LOW_BEAM | LIGHT_HIGH_BEAM
BEAM_BITS = LIGHT_LOW_BEAM | LIGHT_HIGH_BEAM

# (full, dim, off) per role
HEAD_LAMP: tuple[Color, Color, Color] = (
    (1.0, 0.98, 0.90, 1.0), (0.78, 0.77, 0.72, 1.0), (0.50, 0.52, 0.55, 1.0))  # fmt: skip
TAIL_LAMP: tuple[Color, Color, Color] = (
    palette.BRAKE_LAMP[0], (0.70, 0.04, 0.04, 1.0), palette.BRAKE_LAMP[1])  # fmt: skip
REVERSE_LAMP: tuple[Color, Color, Color] = (
    (1.0, 1.0, 1.0, 1.0), (1.0, 1.0, 1.0, 1.0), (0.55, 0.55, 0.56, 1.0))  # fmt: skip


@dataclass(frozen=True, slots=True)
class Lamp:
    role: Role
    box: Box


def _pair(role: Role, x: float, y: float, z: float, size: tuple[float, float, float],
          ) -> tuple[Lamp, Lamp]:  # fmt: skip
    return Lamp(role, ((-x, y, z), size)), Lamp(role, ((x, y, z), size))


def _sides(x: float, y: float, z: float, size: tuple[float, float, float]) -> tuple[Lamp, Lamp]:
    """An indicator at each side; the actor frame's −x is the vehicle's left."""
    return Lamp("left", ((-x, y, z), size)), Lamp("right", ((x, y, z), size))


FRONT, REAR = 0.49, -0.49  # a lamp box 0.02 deep, its outer face on the box's end


def four_wheeler(head: tuple[float, float, float, float], tail: tuple[float, float, float, float],
                 blink_x: float, reverse_x: float) -> tuple[Lamp, ...]:  # fmt: skip
    """Head and tail lamps at (x, z, width, height), indicators outboard of them at `blink_x`."""
    hx, hz, hw, hh = head
    tx, tz, tw, th = tail
    return (
        *_pair("head", hx, FRONT, hz, (hw, 0.02, hh)),
        *_sides(blink_x, FRONT, hz, (0.05, 0.02, hh)),
        *_pair("tail", tx, REAR, tz, (tw, 0.02, th)),
        *_sides(blink_x, REAR, tz, (0.05, 0.02, th)),
        *_pair("reverse", reverse_x, REAR, tz, (0.07, 0.02, th * 0.7)),
    )


def _motorcycle() -> tuple[Lamp, ...]:
    """In metres at 2.1 × 0.8 × 1.5, converted to the unit frame."""
    length, width, height = 2.1, 0.8, 1.5

    def unit(x: float, y: float, z: float, sx: float, sy: float, sz: float) -> Box:
        return (x / width, y / length, z / height), (sx / width, sy / length, sz / height)

    return (
        Lamp("head", unit(0.0, 1.029, 0.86, 0.16, 0.042, 0.1)),
        Lamp("left", unit(-0.2, 1.0, 0.88, 0.06, 0.04, 0.05)),
        Lamp("right", unit(0.2, 1.0, 0.88, 0.06, 0.04, 0.05)),
        Lamp("tail", unit(0.0, -1.029, 0.69, 0.12, 0.042, 0.06)),
        Lamp("left", unit(-0.13, -1.0, 0.7, 0.05, 0.04, 0.04)),
        Lamp("right", unit(0.13, -1.0, 0.7, 0.05, 0.04, 0.04)),
    )


LAMPS: dict[str, tuple[Lamp, ...]] = {
    "car": four_wheeler((0.32, 0.33, 0.18, 0.06), (0.33, 0.40, 0.16, 0.07), 0.435, 0.2),
    "van": four_wheeler((0.33, 0.25, 0.16, 0.06), (0.38, 0.20, 0.1, 0.1), 0.44, 0.25),
    "truck": four_wheeler((0.33, 0.14, 0.16, 0.05), (0.36, 0.34, 0.12, 0.035), 0.45, 0.24),
    "bus": four_wheeler((0.34, 0.15, 0.14, 0.05), (0.36, 0.20, 0.12, 0.07), 0.44, 0.24),
    "motorcycle": _motorcycle(),
}


def lamp_color(role: Role, bits: int, flash: bool) -> Color:
    """What a lamp of `role` shows for the light bits, `flash` the indicators' phase."""
    if role == "head":
        level = 0 if bits & BEAM_BITS else 1 if bits & LIGHT_PARKING else 2
        return HEAD_LAMP[level]
    if role == "tail":
        level = 0 if bits & LIGHT_BRAKE else 1 if bits & POSITION_BITS else 2
        return TAIL_LAMP[level]
    if role == "reverse":
        return REVERSE_LAMP[0 if bits & LIGHT_REVERSE else 2]
    bit = LIGHT_LEFT_BLINKER if role == "left" else LIGHT_RIGHT_BLINKER
    return palette.BLINKER_LAMP[0 if bits & bit and flash else 1]


def lamp_prototype() -> NodePath:
    """A unit box, white: each lamp instances it, scaled and coloured per actor."""
    mesh = MeshBuilder("lamp")
    mesh.box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (1.0, 1.0, 1.0, 1.0))
    return NodePath(mesh.node())


class LampSet:
    """One actor's lamps under its (unit-scaled) body node, recoloured when their state changes."""

    def __init__(self, body: NodePath, lamps: tuple[Lamp, ...], prototype: NodePath) -> None:
        self.lamps = [(lamp.role, self._place(body, lamp.box, prototype)) for lamp in lamps]
        self._shown: tuple[int, bool] | None = None

    @staticmethod
    def _place(body: NodePath, box: Box, prototype: NodePath) -> NodePath:
        (x, y, z), size = box
        lamp = body.attach_new_node("lamp")
        lamp.set_pos(x, y, z)
        lamp.set_scale(*size)
        lamp.set_light_off(1)
        prototype.instance_to(lamp)
        return lamp

    def light(self, bits: int, t: float) -> None:
        """Show the lamps for the light bits at render time `t` [s]."""
        state = (bits, blink_on(t))
        if state == self._shown:
            return
        self._shown = state
        for role, node in self.lamps:
            node.set_color(*lamp_color(role, *state))
