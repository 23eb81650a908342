"""Parts of a road user that move with its motion: wheels that roll and steer, legs that pedal.

A wheel is a pivot at its hub (turned by the steer, front axle only) holding a spinning node
scaled to the wheel's radius and tread; both sit in the actor's unscaled frame (metres), so a
turning wheel stays round whatever the actor's proportions. Wheel meshes are prototypes in a
unit size (radius 1, tread 1, axle along x) that every wheel instances.

Angles: Panda3D's H turns about +z (counter-clockwise from above: a left steer is positive),
its P about +x, the actor's right: rolling forward turns the top of a wheel forward, which is
a negative P. A limb hangs along −z from its pivot; `figure`'s pitch (positive backward) is a
P of the opposite sign.
"""

from __future__ import annotations

import math

from panda3d.core import NodePath

from carlaverse.render.bodies import FRAME, BarPlace, LegGeometry, WheelPlace
from carlaverse.render.gait import leg_to, pedal
from carlaverse.render.meshes import Color, MeshBuilder
from carlaverse.render.shapes import beam, disc_x, facing, ring_x

TYRE: Color = (0.05, 0.05, 0.05, 1.0)
RIM: Color = (0.62, 0.63, 0.66, 1.0)
HOLE: Color = (0.10, 0.10, 0.11, 1.0)
SPOKES = 5  # rim windows on a road wheel: their turn shows the roll


def road_wheel() -> NodePath:
    """A tyre with a rim and five windows on each side, unit radius and tread."""
    mesh = MeshBuilder("wheel")
    mesh.cylinder_x((0.0, 0.0, 0.0), 1.0, (1.0, 1.0), TYRE, sides=12)
    for side in (-1.0, 1.0):
        disc_x(mesh, (side * 0.505, 0.0, 0.0), (0.62, 0.62), side, RIM, sides=10)
        x = side * 0.51
        for k in range(SPOKES):
            a = 2 * math.pi * k / SPOKES
            corners = [
                (x, r * math.cos(a + da), r * math.sin(a + da))
                for r, da in ((0.22, -0.3), (0.52, -0.22), (0.52, 0.22), (0.22, 0.3))
            ]
            facing(mesh, corners, (side, 0.0, 0.0), HOLE)
    return NodePath(mesh.node())


def spoked_wheel() -> NodePath:
    """A bicycle wheel: a thin tyre and rim, three spokes across and a hub."""
    mesh = MeshBuilder("wheel/spoked")
    ring_x(mesh, (0.0, 0.0, 0.0), 1.0, 1.0, 0.86, TYRE, sides=16)
    for k in range(3):
        a = math.pi * k / 3
        c, s = 0.88 * math.cos(a), 0.88 * math.sin(a)
        beam(mesh, (0.0, -c, -s), (0.0, c, s), 0.4, 0.04, RIM)
    mesh.cylinder_x((0.0, 0.0, 0.0), 1.6, (0.1, 0.1), RIM, sides=8)
    return NodePath(mesh.node())


class Wheelset:
    """One actor's wheels under its (unscaled, placed) node."""

    def __init__(self, parent: NodePath, places: list[WheelPlace], prototype: NodePath) -> None:
        self.places = places
        self.hubs: list[NodePath] = []
        self.spins: list[NodePath] = []
        for place in places:
            hub = parent.attach_new_node("wheel")
            hub.set_pos(place.x, place.y, place.radius_m)
            spin = hub.attach_new_node("spin")
            spin.set_scale(place.tyre_m, place.radius_m, place.radius_m)
            prototype.instance_to(spin)
            self.hubs.append(hub)
            self.spins.append(spin)

    def roll(self, rolled_m: float) -> None:
        """Turn every wheel by the distance rolled along the heading [m]: rolled / r [rad]."""
        for place, spin in zip(self.places, self.spins, strict=True):
            spin.set_p(-math.degrees(rolled_m / place.radius_m))

    def steer(self, angle: float) -> None:
        """Turn the front wheels by the road-wheel angle [rad], left positive."""
        for place, hub in zip(self.places, self.hubs, strict=True):
            if place.front:
                hub.set_h(math.degrees(angle))


class Handlebar:
    """A two-wheeler's handlebar under its (unscaled, placed) node, turned about its stem by
    the steer, as the front wheel is: a left steer (positive) takes its left end back."""

    def __init__(self, parent: NodePath, place: BarPlace, prototype: NodePath) -> None:
        self.stem = parent.attach_new_node("handlebar")
        self.stem.set_pos(*place.stem)
        bar = self.stem.attach_new_node("bar")
        bar.set_scale(*place.size)
        prototype.instance_to(bar)

    def steer(self, angle: float) -> None:
        """Turn the bar by the road-wheel angle [rad], left positive."""
        self.stem.set_h(math.degrees(angle))


def limb_prototype() -> NodePath:
    """A unit box hanging below its pivot (scaled per segment: thickness, thickness, length)."""
    mesh = MeshBuilder("limb")
    mesh.box((0.0, 0.0, -1.0), (1.0, 1.0, 1.0), (1.0, 1.0, 1.0, 1.0))
    return NodePath(mesh.node())


def _hang(parent: NodePath, name: str, prototype: NodePath, thick: float, length: float,
          color: Color) -> NodePath:  # fmt: skip
    pivot = parent.attach_new_node(name)
    segment = pivot.attach_new_node("segment")
    segment.set_scale(thick, thick, length)
    segment.set_color(*color)
    prototype.instance_to(segment)
    return pivot


class PedallingLegs:
    """A cyclist's legs and cranks: each foot on its pedal, the knee ahead of the hip–pedal line."""

    def __init__(self, parent: NodePath, legs: LegGeometry, prototype: NodePath,
                 color: Color = FRAME) -> None:  # fmt: skip
        self.legs = legs
        self.sides: list[tuple[float, NodePath, NodePath, NodePath]] = []
        for offset, x in ((0.0, legs.hip_half_width_m), (math.pi, -legs.hip_half_width_m)):
            hip = _hang(parent, "hip", prototype, legs.thickness_m, legs.thigh_m, color)
            hip.set_pos(x, *legs.hip)
            knee = _hang(hip, "knee", prototype, legs.thickness_m, legs.shin_m, color)
            knee.set_pos(0.0, 0.0, -legs.thigh_m)
            crank = _hang(parent, "crank", prototype, 0.025, legs.crank_m, color)
            crank.set_pos(x * 0.7, *legs.bottom_bracket)
            self.sides.append((offset, hip, knee, crank))

    def pedal(self, crank: float) -> None:
        """The right pedal at `crank` [rad] from top dead centre (forward), the left opposite."""
        g = self.legs
        for offset, hip, knee, arm in self.sides:
            angle = crank + offset
            foot = pedal(g.bottom_bracket, angle, g.crank_m)
            hip_pitch, knee_pitch = leg_to(g.hip, foot, g.thigh_m, g.shin_m)
            hip.set_p(-math.degrees(hip_pitch))
            knee.set_p(-math.degrees(knee_pitch))
            arm.set_p(180.0 - math.degrees(angle))  # the arm hangs down at rest: up is P 180°
