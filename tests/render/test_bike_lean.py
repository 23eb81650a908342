"""Pixels: a bike turning left is drawn leaning left.

The bike loop rides a steady turn; its pose goes through the wire bytes into a real world
view, and the real renderer draws it offscreen from a free camera 5 m behind the bike,
looking along its heading. A leaning bike's top is displaced to the side it leans to, its
wheels stay on the road: so the centroid column of the upper half of its silhouette lies to
that side of the lower half's. Which image side is the bike's left comes from the rig's
own projection of a point to its left, not from an assumption about the camera.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from carlaverse_nodes.bike.bike_loop import BikeLoop
from carlaverse_nodes.bike.config import BikeNodeConfig, resolve_table

from carlaverse import messages as m
from carlaverse.messages import Extent
from carlaverse.render.cameras import Eye
from carlaverse.render.frame import SceneFrame, frame_from_view
from carlaverse.render.renderer import Renderer
from carlaverse.render.rig import HeadPosition, RenderConfig, Resolution, SimpleRig, layout
from carlaverse.render.rig import project_column as column_of
from carlaverse.world.remote_actor import InterpolationSettings
from carlaverse.world.world_view import WorldView
from tests.render.support import changed

pytestmark = pytest.mark.usefixtures("offscreen_gl")

HEAD = HeadPosition(x=0.0, y=0.0, z=1.0)
RIG = RenderConfig(
    output="offscreen",
    camera=SimpleRig(resolution=Resolution(width=320, height=240), fov_deg=60, head=HEAD),
)
NOON = m.Weather(0, 0.0, sun_altitude_deg=60.0, sun_azimuth_deg=200.0)
BEHIND_M = 5.0  # [m] camera behind the bike
DT = 0.005  # [s]


def turning_pose(steer_axis: float) -> m.Pose:
    """The bike loop's pose after 1 s of a steady turn at 5 m/s (steer axis > 0: left)."""
    config = BikeNodeConfig()
    loop = BikeLoop(config, resolve_table(config))
    loop.place(0.0, 0.0, 0.0)
    for _ in range(200):
        out = loop.step(DT, 5.0, steer_axis, 0.0)
    return out.pose(1)


def silhouette(pose: m.Pose, save_shot, name: str) -> tuple[np.ndarray, Eye]:
    """Pixels the bike changes, seen from behind along its heading."""
    view = WorldView("camera", InterpolationSettings())
    view.intake.present("rider")
    view.intake.pose("rider", m.encode_pose(pose), rx_t=pose.t)
    view.intake.weather(NOON)
    view.update(pose.t)
    b = BikeNodeConfig().bicycle
    size = Extent(b.length_m, b.width_m, b.height_m)
    frame = frame_from_view(view, pose.t, kinds={"rider": "bicycle"}, extents={"rider": size})
    (bike,) = frame.actors
    eye = Eye(bike.x - BEHIND_M * math.cos(bike.yaw), bike.y - BEHIND_M * math.sin(bike.yaw),
              0.0, bike.yaw)  # fmt: skip
    with Renderer(RIG, None) as r:
        r.draw(frame, eye=eye)
        shown = r.camera_images()[0]
        r.draw(SceneFrame(pose.t, (), None, NOON), eye=eye)
        empty = r.camera_images()[0]
    save_shot(name, shown)
    return changed(shown, empty), eye


def top_shift_px(mask: np.ndarray) -> float:
    """Centroid column of the silhouette's upper half minus its lower half's [px]."""
    rows, cols = np.nonzero(mask)
    assert rows.size > 200, "the bike is not in the picture"
    middle = (rows.min() + rows.max()) / 2
    return float(cols[rows < middle].mean() - cols[rows >= middle].mean())


@pytest.mark.parametrize(("steer_axis", "side"), [(0.4, "left"), (-0.4, "right")])
def test_a_turning_bike_is_drawn_leaning_into_the_turn(steer_axis, side, save_shot) -> None:
    pose = turning_pose(steer_axis)
    assert (pose.wz > 0) == (side == "left")  # counter-clockwise yaw: a left turn
    mask, _ = silhouette(pose, save_shot, f"bike_turning_{side}")
    cam = layout(RIG.camera).cameras[0]
    # image direction of the bike's left: a point 1 m to its left, seen from the camera
    left_px = column_of(cam, BEHIND_M, 1.0) - column_of(cam, BEHIND_M, 0.0)
    toward = 1.0 if side == "left" else -1.0
    shift = top_shift_px(mask)
    # The lean is atan(v·ω/g) ≈ 29°: the upper half's centroid, about a metre up, moves
    # ~0.5 m to the side, ~0.5 · |left_px| px; the wheels move little. Ask for a fifth.
    assert shift * math.copysign(1.0, left_px) * toward > 0.1 * abs(left_px), (shift, left_px)
