"""The actor layer: road users drawn by kind at their extents, moving as they move.

Each vehicle is a placed node (position and heading) holding its body, scaled to its extent
from one prototype per kind (`bodies`, so 200 cars share one mesh) with its lamps
(`lamps.LampSet`), and its wheels in metres (`running_gear.Wheelset`), which roll by the
distance the actor moved along its heading and whose front pair steers by the actor's
road-wheel angle (sent, or from its yaw rate and speed: `motion`); a two-wheeler's handlebar
turns with its front wheel. A cyclist's legs pedal
with the rolled distance. Pedestrians are articulated figures (`figure.Figure`): posed from
the skeleton a walker sends, else walking with a gait from their speed (`gait`), its phase
advancing with the distance walked.

Where a motion has to start somewhere (the gait's phase, the crank's angle) it starts at an
angle taken from the actor's id, so a crowd does not walk in step and a frame is reproducible.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Iterable
from dataclasses import dataclass, field

from panda3d.core import NodePath

from carlaverse.messages import Extent
from carlaverse.render import palette
from carlaverse.render.bodies import (
    WHEELS,
    bar_place,
    bar_prototype,
    leg_geometry,
    prototype,
    wheel_places,
)
from carlaverse.render.figure import FIGURE_HEIGHT_M, HIP_Z, Figure
from carlaverse.render.frame import ActorDraw
from carlaverse.render.gait import advance_phase, crank_angle, pelvis_drop, walking_angles
from carlaverse.render.lamps import LAMPS, LampSet, lamp_prototype
from carlaverse.render.motion import Motion
from carlaverse.render.running_gear import (
    Handlebar,
    PedallingLegs,
    Wheelset,
    limb_prototype,
    road_wheel,
    spoked_wheel,
)

ARTICULATED = "pedestrian"  # the kind drawn as a `Figure`
# Clothing for walkers, picked by id (the figure's torso): muted colours of everyday wear.
SHIRTS = (palette.ACTOR_COLORS["pedestrian"], (0.25, 0.35, 0.55, 1.0), (0.55, 0.15, 0.15, 1.0),
          (0.85, 0.85, 0.80, 1.0), (0.30, 0.45, 0.30, 1.0), (0.40, 0.40, 0.42, 1.0))  # fmt: skip


def start_angle(actor_id: str) -> float:
    """[rad] a reproducible angle per actor, where its gait or crank starts."""
    return 2 * math.pi * (zlib.crc32(actor_id.encode()) % 3600) / 3600


@dataclass(slots=True)
class _Drawn:
    node: NodePath  # placed: position and attitude, unscaled (metres)
    kind: str  # what it is drawn as: a kind, or "figure"
    size: tuple[float, float, float]
    body: NodePath | None = None  # scaled to the extent (unit-frame prototype, lamps)
    lamps: LampSet | None = None
    wheels: Wheelset | None = None
    bar: Handlebar | None = None
    legs: PedallingLegs | None = None
    figure: Figure | None = None
    motion: Motion = field(default_factory=Motion)
    start: float = 0.0  # [rad] where its gait or crank started
    phase: float = 0.0  # [rad] a walker's gait
    walked_m: float = 0.0  # [m] the distance its gait has taken in


def _style(actor: ActorDraw) -> str:
    return "figure" if actor.kind == ARTICULATED else actor.kind


class ActorLayer:
    """Keeps one node per visible actor in step with the frames it is given."""

    def __init__(self, parent: NodePath) -> None:
        self.root = parent.attach_new_node("actors")
        self._protos: dict[tuple[str, bool], NodePath] = {}
        self.lamp_prototype = lamp_prototype()  # shared by every lamp: `lighting.lamps`
        self._limb = limb_prototype()
        self._bar = bar_prototype()
        self._wheel = {"road": road_wheel(), "spoked": spoked_wheel()}
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
            size = (actor.width, actor.length, actor.height)
            if drawn is None or drawn.kind != _style(actor) or drawn.size != size:
                if drawn is not None:
                    drawn.node.remove_node()
                drawn = self._drawn[actor.actor_id] = self._make(actor)
            drawn.motion.advance(t, actor.x, actor.y, actor.yaw)
            if drawn.figure is not None:
                _walk(drawn, drawn.figure, actor)
            else:
                _ride(drawn, actor, t)
        for gone in [i for i in self._drawn if i not in seen]:
            self._drawn.pop(gone).node.remove_node()

    def _make(self, actor: ActorDraw) -> _Drawn:
        node = self.root.attach_new_node(actor.actor_id)
        size = (actor.width, actor.length, actor.height)
        start = start_angle(actor.actor_id)
        drawn = _Drawn(node, _style(actor), size, start=start, phase=start)
        if drawn.kind == "figure":
            shirt = SHIRTS[zlib.crc32(actor.actor_id.encode()) % len(SHIRTS)]
            drawn.figure = Figure(node, shirt)
            return drawn
        key = (actor.kind, actor.ego)
        if key not in self._protos:
            self._protos[key] = prototype(*key)
        drawn.body = node.attach_new_node("body")
        drawn.body.set_scale(*size)
        self._protos[key].instance_to(drawn.body)
        if actor.kind in LAMPS:
            drawn.lamps = LampSet(drawn.body, LAMPS[actor.kind], self.lamp_prototype)
        extent = Extent(actor.length, actor.width, actor.height)
        wheel = self._wheel["spoked" if actor.kind == "bicycle" else "road"]
        drawn.wheels = Wheelset(node, wheel_places(actor.kind, extent), wheel)
        bar = bar_place(actor.kind, extent)
        if bar is not None:
            drawn.bar = Handlebar(node, bar, self._bar)
        if actor.kind == "bicycle":
            drawn.legs = PedallingLegs(node, leg_geometry(extent), self._limb)
        return drawn


def _ride(drawn: _Drawn, a: ActorDraw, t: float) -> None:
    """Place a vehicle, roll and steer its wheels, pedal, light its lamps."""
    drawn.node.set_pos_hpr(a.x, a.y, a.z, math.degrees(a.yaw) - 90.0, -math.degrees(a.pitch),
                           math.degrees(a.roll))  # fmt: skip
    m = drawn.motion
    wheels = WHEELS.get(a.kind)
    if drawn.wheels is not None and wheels is not None:
        drawn.wheels.roll(m.rolled_m)
        speed = a.speed if a.speed is not None else m.speed_mps
        yaw_rate = a.yaw_rate if a.yaw_rate is not None else m.yaw_rate
        steer = a.steer
        if steer is None:
            steer = m.road_wheel_angle(wheels.wheelbase_m(a.length), speed, yaw_rate)
        drawn.wheels.steer(steer)
        if drawn.bar is not None:
            drawn.bar.steer(steer)
    if drawn.legs is not None and drawn.wheels is not None and drawn.wheels.places:
        radius = drawn.wheels.places[0].radius_m
        drawn.legs.pedal(crank_angle(m.rolled_m, radius, start=drawn.start))
    if drawn.lamps is not None:
        drawn.lamps.light(a.lights, t)


def _walk(drawn: _Drawn, figure: Figure, a: ActorDraw) -> None:
    """Pose a walker from its skeleton, or with a gait from its speed and distance walked."""
    if a.skeleton:
        figure.place(a.x, a.y, a.z, a.yaw, a.height)
        figure.pose(a.skeleton)
        return
    scale = a.height / FIGURE_HEIGHT_M
    hip = HIP_Z * scale  # [m] the figure's hips, its legs' length
    speed = abs(a.speed) if a.speed is not None else abs(drawn.motion.speed_mps)
    walked, drawn.walked_m = drawn.motion.walked_m - drawn.walked_m, drawn.motion.walked_m
    drawn.phase = advance_phase(drawn.phase, walked, speed, hip)
    figure.place(a.x, a.y, a.z - pelvis_drop(drawn.phase, speed, hip), a.yaw, a.height)
    figure.pose(walking_angles(drawn.phase, speed, hip))
