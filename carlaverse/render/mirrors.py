"""Rear-view and door mirrors: a camera per mirror renders into a texture shown on its glass.

Each mirror (`own_config.Mirror`) has an offscreen texture buffer of its own, drawn before the
rig's outputs every frame, whose camera sits at the glass and looks where the mirror points
(`yaw_deg` 180: straight back). The glass is a card in the cockpit at the mirror's place,
turned to face the eye, showing that texture flipped left to right.

Why flipped, and which side things appear on: seen from above, with the vehicle heading +x
and its left +y, a camera looking back (−x) with +z up has its image's right along
forward × up = (−1, 0, 0) × (0, 0, 1) = (0, +1, 0): the vehicle's left. So something behind
and to the left is in the right half of that camera's image. A plane mirror swaps front and
back but not left and right: facing the glass, the driver sees what is behind on their left
in the left half of the mirror. Hence the glass shows the camera's image mirrored (its u
coordinate runs right to left), which puts that object in the glass's left half.

A flat mirror shows what it subtends at the eye: its field of view is 2·atan(w / 2d) across
(w its width, d its distance from the eye) unless the config gives one (a convex mirror's).
The mirrors' cameras see the world but not the cockpit: the cockpit is drawn only for the
rig's own cameras (`own_vehicle`), whose masks drop the mirror bit.
"""

from __future__ import annotations

import math

from panda3d.core import (
    BitMask32,
    Camera,
    CardMaker,
    GraphicsOutput,
    NodePath,
    PerspectiveLens,
    Texture,
)

from carlaverse.render.cockpit import panda
from carlaverse.render.graphics import RenderError
from carlaverse.render.meshes import Color, MeshBuilder
from carlaverse.render.own_config import Mirror
from carlaverse.render.rig import HeadPosition

MIRROR_MASK = BitMask32.bit(6)  # the mirrors' cameras draw with this bit only
NEAR_M = 0.05  # [m] the mirror camera's near plane
HOUSING: Color = (0.06, 0.06, 0.07, 1.0)
BUFFER_SORT = -20  # mirror buffers render before the outputs that show them


def mirror_fov(mirror: Mirror, head: HeadPosition) -> tuple[float, float]:
    """(horizontal, vertical) field of view [rad]: the config's, or a flat mirror's."""
    w, h = mirror.size
    if mirror.fov_deg is not None:
        fov_h = math.radians(mirror.fov_deg)
    else:
        d = math.dist(mirror.at, (head.x, head.y, head.z))
        fov_h = 2 * math.atan(w / (2 * d))
    return fov_h, 2 * math.atan(math.tan(fov_h / 2) * h / w)


def texture_size(mirror: Mirror) -> tuple[int, int]:
    """[px] powers of two near `texture_px` across and its share of the glass's height up.

    Panda3D pads a render target of any other size up to powers of two and the glass would
    show the padding; the image's pixels need not be square, the lens fixes the proportions.
    """
    w, h = mirror.size

    def power_of_two(px: float) -> int:
        return 2 ** max(3, round(math.log2(px)))

    return power_of_two(mirror.texture_px), power_of_two(mirror.texture_px * h / w)


class MirrorView:
    """One mirror: its buffer, its camera (under `anchor`), its glass (under `cockpit`)."""

    def __init__(self, host: GraphicsOutput, world: NodePath, anchor: NodePath,
                 cockpit: NodePath, mirror: Mirror, head: HeadPosition) -> None:  # fmt: skip
        self.mirror = mirror
        self.texture = Texture(f"mirror/{mirror.name}")
        width, height = texture_size(mirror)
        buffer = host.make_texture_buffer(f"mirror/{mirror.name}", width, height, self.texture)
        if buffer is None:
            raise RenderError(f"own.mirrors {mirror.name!r}: no {width}x{height} texture buffer")
        buffer.set_sort(BUFFER_SORT)
        self.buffer = buffer
        self.camera = self._camera(world, anchor, head)
        self.region = buffer.make_display_region()
        self.region.set_camera(self.camera)
        self.region.set_clear_color_active(True)
        self.region.set_clear_depth_active(True)
        self.glass = self._glass(cockpit, head)

    def _camera(self, world: NodePath, anchor: NodePath, head: HeadPosition) -> NodePath:
        fov_h, fov_v = mirror_fov(self.mirror, head)
        lens = PerspectiveLens()
        lens.set_fov(math.degrees(fov_h), math.degrees(fov_v))
        lens.set_near_far(NEAR_M, 400.0)
        cam = Camera(f"mirror/{self.mirror.name}", lens)
        cam.set_scene(world)
        cam.set_camera_mask(MIRROR_MASK)
        node = anchor.attach_new_node(cam)
        node.set_pos(*panda(self.mirror.at))
        node.set_hpr(self.mirror.yaw_deg, self.mirror.pitch_deg, 0.0)
        return node

    def set_far(self, far_m: float) -> None:
        lens = self.camera.node().get_lens()
        lens.set_near_far(NEAR_M, far_m)

    def _glass(self, cockpit: NodePath, head: HeadPosition) -> NodePath:
        """The glass facing the eye, its image mirrored (u from 1 at the left to 0)."""
        w, h = self.mirror.size
        mount = cockpit.attach_new_node(f"mirror/{self.mirror.name}")
        mount.set_pos(*panda(self.mirror.at))
        at, eye = panda(self.mirror.at), panda((head.x, head.y, head.z))
        mount.look_at(*(2 * a - e for a, e in zip(at, eye, strict=True)))  # +y away from the eye
        card = CardMaker("glass")
        card.set_frame(-w / 2, w / 2, -h / 2, h / 2)
        card.set_uv_range((1.0, 0.0), (0.0, 1.0))
        glass = mount.attach_new_node(card.generate())
        glass.set_texture(self.texture)
        glass.set_light_off(1)
        glass.set_shader_off(1)
        glass.set_color(1.0, 1.0, 1.0, 1.0)
        housing = MeshBuilder("housing")
        housing.box((0.0, 0.035, -h / 2 - 0.015), (w + 0.03, 0.06, h + 0.03), HOUSING)
        mount.attach_new_node(housing.node())
        return mount

    def set_sky(self, sky: Color) -> None:
        self.region.set_clear_color(sky)

    def set_active(self, active: bool) -> None:
        self.buffer.set_active(active)

    def close(self) -> None:
        self.glass.remove_node()
        self.camera.remove_node()
        engine = self.buffer.get_engine()
        if engine is not None:
            engine.remove_window(self.buffer)
