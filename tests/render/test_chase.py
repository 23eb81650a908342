"""The chase camera's maths: the rig's head lands on the stated eye (checked through Panda3D's
own scene graph), looks down onto the aim point, and trails the actor's yaw with a lag."""

from __future__ import annotations

import math

import pytest

from carlaverse.render.frame import ActorDraw
from carlaverse.render.rig import HeadPosition, SimpleRig

pytestmark = pytest.mark.usefixtures("offscreen_gl")

# The documented geometry: 6 m behind, 2.5 m above the road, looking at 4 m ahead, 1 m up.
BACK_M, UP_M, AIM_AHEAD_M, AIM_UP_M = 6.0, 2.5, 4.0, 1.0
LAG_S = 0.5  # [s] the heading's time constant


def _actor(x: float, y: float, yaw: float, z: float = 0.0) -> ActorDraw:
    return ActorDraw("car-1", "car", x, y, z, yaw, 4.5, 1.8, 1.5, ego=True)


@pytest.mark.parametrize("yaw", [0.0, 1.0, -2.5])
@pytest.mark.parametrize("head", [HeadPosition(), HeadPosition(x=0.1, y=0.37, z=1.2)])
def test_the_rigs_head_sits_behind_and_above_looking_at_the_aim_point(
    yaw: float, head: HeadPosition
) -> None:
    from panda3d.core import NodePath

    from carlaverse.render.cameras import CameraRig
    from carlaverse.render.chase import ChaseCamera
    from carlaverse.render.graphics import Graphics
    from carlaverse.render.rig import Resolution, layout

    rig_layout = layout(SimpleRig(resolution=Resolution(width=64, height=36), head=head))
    graphics = Graphics(rig_layout.outputs, True, "chase-test")
    try:
        world = NodePath("world")
        rig = CameraRig(world, graphics, rig_layout, 100.0)
        actor = _actor(10.0, -5.0, yaw, z=0.3)
        rig.place(ChaseCamera(head).eye(actor, 0.0))
        eye = rig.head.get_pos(world)
        c, s = math.cos(yaw), math.sin(yaw)
        want = (actor.x - BACK_M * c, actor.y - BACK_M * s, actor.z + UP_M)
        assert math.dist(tuple(eye), want) < 1e-4
        # the head looks along its local +y (Panda3D): straight at the aim point
        look = world.get_relative_vector(rig.head, (0, 1, 0))
        aim = (actor.x + AIM_AHEAD_M * c, actor.y + AIM_AHEAD_M * s, actor.z + AIM_UP_M)
        to_aim = [a - e for a, e in zip(aim, want, strict=True)]
        norm = math.hypot(*to_aim)
        assert all(abs(lv - t / norm) < 1e-5 for lv, t in zip(look, to_aim, strict=True))
        # and level: its right-hand side stays horizontal
        assert abs(world.get_relative_vector(rig.head, (1, 0, 0)).z) < 1e-6
    finally:
        graphics.close()


def test_the_heading_trails_a_turn_with_a_first_order_lag() -> None:
    from carlaverse.render.chase import ChaseCamera

    chase = ChaseCamera(HeadPosition())
    assert chase.eye(_actor(0, 0, 0.0), 10.0).yaw == 0.0  # the first frame: the actor's yaw
    turned = math.pi / 2  # the actor turns left by 90° at once and holds it
    heading = 0.0
    for k in range(1, 11):  # 10 frames of 0.05 s
        heading = chase.eye(_actor(0, 0, turned), 10.0 + 0.05 * k).yaw
    # after one time constant a first-order lag has covered 1 - 1/e of the step
    assert heading == pytest.approx(turned * (1 - math.exp(-0.5 / LAG_S)), rel=1e-9)


def test_the_heading_turns_the_short_way_across_pi() -> None:
    from carlaverse.render.chase import ChaseCamera

    chase = ChaseCamera(HeadPosition())
    chase.eye(_actor(0, 0, math.pi - 0.1), 0.0)
    yaw = chase.eye(_actor(0, 0, -math.pi + 0.1), 5 * LAG_S).yaw  # 0.2 rad further left
    # it moved ~0.2 rad left through ±π, not 6.1 rad right
    assert abs(math.remainder(yaw - (math.pi - 0.1), 2 * math.pi) - 0.2) < 0.01


def test_a_jump_back_in_time_or_a_long_gap_starts_on_the_actors_yaw() -> None:
    from carlaverse.render.chase import ChaseCamera

    chase = ChaseCamera(HeadPosition())
    chase.eye(_actor(0, 0, 0.0), 5.0)
    assert chase.eye(_actor(0, 0, 1.0), 4.0).yaw == 1.0  # an earlier still
    assert chase.eye(_actor(0, 0, 2.0), 9.0).yaw == 2.0  # 5 s later: not a clip's next frame
