"""A two-wheeler's handlebar turns with the steer, as its front wheel does (scene graph).

Derivation, independent of the renderer: a vehicle heading h = (cos ψ, sin ψ) has its left at
l = (−sin ψ, cos ψ). Steering left by δ (positive, counter-clockwise seen from above, as the
protocol's road-wheel angle) turns the bar about its stem by δ counter-clockwise, taking l to
l·cos δ − h·sin δ: the bar's left end moves back along the heading by (W/2)·sin δ and its
right end forward, W the bar's span (measured, not taken from the model). The front wheel's
axle, turned by the same δ, stays parallel to the bar.
"""

from __future__ import annotations

import math

import pytest
from panda3d.core import NodePath, Point3, Vec3

from carlaverse.messages import KIND_EXTENTS
from carlaverse.render.actors import ActorLayer
from carlaverse.render.frame import ActorDraw

YAW = 0.4  # [rad] any heading: the bar's frame is the actor's


def steered(kind: str, steer: float) -> tuple[NodePath, NodePath, NodePath]:
    """The world, the bar and the front wheel's hub of one actor drawn with `steer` [rad]."""
    world = NodePath("world")
    layer = ActorLayer(world)
    e = KIND_EXTENTS[kind]
    actor = ActorDraw(f"{kind}-1", kind, 3.0, -2.0, 0.0, YAW, e.length, e.width, e.height,
                      steer=steer, speed=4.0)  # fmt: skip
    layer.update([actor], 0.0)
    bar = world.find("**/handlebar/bar")
    assert not bar.is_empty(), f"a {kind} has no handlebar of its own"
    hubs = world.find_all_matches("**/wheel")
    front = max(hubs, key=lambda hub: hub.get_pos(world).dot(Vec3(math.cos(YAW), math.sin(YAW), 0)))
    return world, bar, front


@pytest.mark.parametrize("kind", ["bicycle", "motorcycle"])
@pytest.mark.parametrize("steer", [0.0, 0.35, -0.25])
def test_the_bar_turns_with_the_steer(kind: str, steer: float) -> None:
    world, bar, front = steered(kind, steer)
    left = world.get_relative_point(bar, Point3(-0.5, 0.0, 0.5))  # the actor's −x: its left
    right = world.get_relative_point(bar, Point3(0.5, 0.0, 0.5))
    stem = (left + right) * 0.5
    span = (right - left).length()
    heading = Vec3(math.cos(YAW), math.sin(YAW), 0.0)
    to_left = Vec3(-math.sin(YAW), math.cos(YAW), 0.0)
    assert (left - stem).dot(heading) == pytest.approx(-span / 2 * math.sin(steer), abs=1e-4)
    assert (left - stem).dot(to_left) == pytest.approx(span / 2 * math.cos(steer), abs=1e-4)
    assert (right - stem).dot(heading) == pytest.approx(span / 2 * math.sin(steer), abs=1e-4)
    axle = world.get_relative_vector(front, Vec3(1.0, 0.0, 0.0))  # the hub's x: its axle
    assert axle.cross(right - left).length() == pytest.approx(0.0, abs=1e-4 * span)
