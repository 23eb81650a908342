"""The camera rig in the scene: an anchor that follows an actor, the head, and its cameras.

The anchor takes the followed actor's pose (world frame), the head sits at the configured
position in the actor frame (x forward, y left, z up), and every camera of the layout hangs
off the head with its yaw, pitch and roll, rendering into its display region. Panda3D's
cameras look along their local +y; the anchor's heading is therefore yaw − 90°.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from panda3d.core import BitMask32, Camera, DisplayRegion, NodePath, PerspectiveLens

from carlaverse.fov import EyeFov
from carlaverse.render.frame import ActorDraw
from carlaverse.render.graphics import Graphics
from carlaverse.render.meshes import Color
from carlaverse.render.rig import CameraView, RigLayout
from carlaverse.render.stereo import aim_off_axis, off_axis_lens

NEAR_M = 0.1  # [m] near clip plane: close enough for a cockpit


@dataclass(frozen=True, slots=True)
class Eye:
    """Where the rig's anchor is: an actor's pose, or a free camera's [m, rad]."""

    x: float
    y: float
    z: float
    yaw: float
    pitch: float = 0.0  # nose down positive, like actors
    roll: float = 0.0


def overview_eye(bounds: tuple[float, float, float, float]) -> Eye:
    """A free camera above the map's south edge, looking north over it at 30° down."""
    xmin, ymin, xmax, ymax = bounds
    span = max(xmax - xmin, ymax - ymin, 20.0)
    return Eye((xmin + xmax) / 2, ymin - 0.35 * span, 0.45 * span, math.pi / 2, math.radians(30))


CHASE_BACK_M = 7.0  # [m] behind the chased actor's reference point
CHASE_UP_M = 1.8  # [m] above it (the rig's head height comes on top)
CHASE_PITCH = math.radians(10.0)  # [rad] looking down onto it


def chase_eye(actor: ActorDraw) -> Eye:
    """A camera behind and above `actor`, looking along its heading."""
    c, s = math.cos(actor.yaw), math.sin(actor.yaw)
    return Eye(
        actor.x - CHASE_BACK_M * c, actor.y - CHASE_BACK_M * s, actor.z + CHASE_UP_M,
        actor.yaw, CHASE_PITCH,
    )  # fmt: skip


class CameraRig:
    """The anchor, head and cameras of one layout, drawing into `graphics`."""

    def __init__(self, world: NodePath, graphics: Graphics, rig: RigLayout, far_m: float,
                 mask: BitMask32 | None = None) -> None:  # fmt: skip
        self.layout = rig
        self.anchor = world.attach_new_node("rig_anchor")
        head = rig.head
        self.head = self.anchor.attach_new_node("head")
        self.head.set_pos(-head.y, head.x, head.z)  # anchor frame: +x right, +y forward
        self.regions: list[DisplayRegion] = []
        self.eye_lenses: list[PerspectiveLens] = []  # an xr rig's, left then right
        self.far_m = far_m
        self.mask = mask  # the cameras' mask: what hides from it (shadow casters only) is unseen
        for view in rig.cameras:
            self.regions.append(self._camera(world, graphics, view, far_m))

    def _camera(
        self, world: NodePath, graphics: Graphics, view: CameraView, far_m: float
    ) -> DisplayRegion:
        if view.frustum is not None:  # a headset's eye: its own asymmetric frustum
            lens = off_axis_lens(view.frustum, NEAR_M, far_m)
            self.eye_lenses.append(lens)
        else:
            lens = PerspectiveLens()
            lens.set_fov(math.degrees(view.fov_h), math.degrees(view.fov_v))
            lens.set_near_far(NEAR_M, far_m)
        cam = Camera(view.name, lens)
        cam.set_scene(world)
        if self.mask is not None:
            cam.set_camera_mask(self.mask)
        node = self.head.attach_new_node(cam)
        node.set_pos(-view.offset_left_m, 0.0, 0.0)  # head frame: +x right
        node.set_hpr(math.degrees(view.yaw), math.degrees(view.pitch), math.degrees(view.roll))
        region = graphics.outputs[view.output].make_display_region(*view.viewport)
        region.set_camera(node)
        region.set_clear_color_active(True)
        region.set_clear_depth_active(True)
        return region

    def set_eye_frusta(self, eyes: tuple[EyeFov, ...]) -> None:
        """Draw the eyes with these frusta from now on (the headset's, which may change)."""
        for lens, fov in zip(self.eye_lenses, eyes, strict=False):
            aim_off_axis(lens, fov)

    def place(self, eye: Eye) -> None:
        self.anchor.set_pos_hpr(
            eye.x, eye.y, eye.z,
            math.degrees(eye.yaw) - 90.0, -math.degrees(eye.pitch), math.degrees(eye.roll),
        )  # fmt: skip

    def set_sky(self, sky: Color) -> None:
        for region in self.regions:
            region.set_clear_color(sky)
