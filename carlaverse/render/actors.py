"""The actor layer: egos and NPCs drawn by kind at their extents, with brake and turn lamps.

Each kind has one prototype mesh in a unit frame (`bodies`); an actor instances it and
scales it to its extent, so 200 cars share one mesh. Lamps are separate small boxes per
actor, coloured each frame from the light bits (`LIGHT_BRAKE`, `LIGHT_LEFT_BLINKER`,
`LIGHT_RIGHT_BLINKER`). Blinkers flash at 1.5 Hz
(UN ECE R48: 90 ± 30 flashes per minute) off the render time, so a frame is reproducible.
A pedestrian that sends a skeleton is drawn as an articulated `figure.Figure` instead.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from panda3d.core import NodePath

from carlaverse.messages import LIGHT_BRAKE, LIGHT_LEFT_BLINKER, LIGHT_RIGHT_BLINKER
from carlaverse.render import palette
from carlaverse.render.bodies import (
    BRAKE_LAMPS,
    LAMP_KINDS,
    LEFT_BLINKERS,
    RIGHT_BLINKERS,
    Box,
    lamp_prototype,
    prototype,
)
from carlaverse.render.figure import Figure
from carlaverse.render.frame import ActorDraw

BLINK_HZ = 1.5  # [Hz]


@dataclass(slots=True)
class _Drawn:
    node: NodePath
    kind: str
    brake: list[NodePath]
    left: list[NodePath]
    right: list[NodePath]
    shown: tuple[bool, bool, bool] | None = None
    figure: Figure | None = None  # a walker articulated from its skeleton


ARTICULATED = "pedestrian"  # the kind drawn as a `Figure` when it sends a skeleton


def _style(actor: ActorDraw) -> str:
    """What an actor is drawn as: its kind's boxes, or an articulated figure."""
    return "figure" if actor.skeleton and actor.kind == ARTICULATED else actor.kind


class ActorLayer:
    """Keeps one node per visible actor in step with the frames it is given."""

    def __init__(self, parent: NodePath) -> None:
        self.root = parent.attach_new_node("actors")
        self._protos: dict[tuple[str, bool], NodePath] = {}
        self._lamp = lamp_prototype()
        self._drawn: dict[str, _Drawn] = {}

    def __len__(self) -> int:
        return len(self._drawn)

    def update(self, actors: Iterable[ActorDraw], t: float, hide: str | None = None) -> None:
        """Draw `actors` at render time `t` [s]; `hide` is the actor the camera sits in."""
        seen = set()
        for actor in actors:
            if actor.actor_id == hide:
                continue
            seen.add(actor.actor_id)
            drawn = self._drawn.get(actor.actor_id)
            if drawn is None or drawn.kind != _style(actor):
                if drawn is not None:
                    drawn.node.remove_node()
                drawn = self._drawn[actor.actor_id] = self._make(actor)
            if drawn.figure is not None:
                drawn.figure.place(actor.x, actor.y, actor.z, actor.yaw, actor.height)
                drawn.figure.pose(actor.skeleton or {})
                continue
            _place(drawn.node, actor)
            _light(drawn, actor.lights, t)
        for gone in [i for i in self._drawn if i not in seen]:
            self._drawn.pop(gone).node.remove_node()

    def _make(self, actor: ActorDraw) -> _Drawn:
        node = self.root.attach_new_node(actor.actor_id)
        if _style(actor) == "figure":
            body = palette.ACTOR_COLORS[ARTICULATED]
            return _Drawn(node, "figure", [], [], [], figure=Figure(node, body))
        key = (actor.kind, actor.ego)
        if key not in self._protos:
            self._protos[key] = prototype(*key)
        self._protos[key].instance_to(node)
        if actor.kind not in LAMP_KINDS:
            return _Drawn(node, actor.kind, [], [], [])
        lamps = [[self._lamp_at(node, box) for box in boxes]
                 for boxes in (BRAKE_LAMPS, LEFT_BLINKERS, RIGHT_BLINKERS)]  # fmt: skip
        return _Drawn(node, actor.kind, *lamps)

    def _lamp_at(self, node: NodePath, box: Box) -> NodePath:
        (x, y, z), size = box
        lamp = node.attach_new_node("lamp")
        lamp.set_pos(x, y, z)
        lamp.set_scale(*size)
        lamp.set_light_off(1)
        lamp.set_depth_offset(1)  # flush with the body's end face: drawn over it, not fighting
        self._lamp.instance_to(lamp)
        return lamp


def _place(node: NodePath, a: ActorDraw) -> None:
    node.set_pos_hpr_scale(
        a.x,
        a.y,
        a.z,
        math.degrees(a.yaw) - 90.0,
        -math.degrees(a.pitch),
        math.degrees(a.roll),
        a.width,
        a.length,
        a.height,
    )


def blink_on(t: float) -> bool:
    """Whether a flashing blinker is lit at render time `t` [s]."""
    return (t * BLINK_HZ) % 1.0 < 0.5


def _light(drawn: _Drawn, bits: int, t: float) -> None:
    flash = blink_on(t)
    state = (
        bool(bits & LIGHT_BRAKE),
        bool(bits & LIGHT_LEFT_BLINKER) and flash,
        bool(bits & LIGHT_RIGHT_BLINKER) and flash,
    )
    if state == drawn.shown:
        return
    drawn.shown = state
    for lamps, on, (bright, dark) in zip(
        (drawn.brake, drawn.left, drawn.right),
        state,
        (palette.BRAKE_LAMP, palette.BLINKER_LAMP, palette.BLINKER_LAMP),
        strict=True,
    ):
        for lamp in lamps:
            lamp.set_color(*(bright if on else dark))
