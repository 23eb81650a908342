"""A head-up display: speed, gear and indicator arrows as a virtual image ahead of the eye.

Read from the own vehicle's dashboard (`frame.Dashboard`, the node loop's shared state): the
speed in whole km/h (rounded: 49.6 km/h reads 50, as a car's digital speedometer does), the
gear (R, N, 1…; none on a bicycle) and a green arrow per indicator while its lamp is lit. It
hangs `distance_m` ahead of the eye, `down_deg` below its horizontal, facing it, drawn over
everything else and unlit, unfogged, unshaded: an image on the windscreen, not an object in
the scene.
"""

from __future__ import annotations

import math

from panda3d.core import NodePath, TextNode

from carlaverse.render.frame import Dashboard
from carlaverse.render.meshes import Color, MeshBuilder
from carlaverse.render.own_config import Hud
from carlaverse.render.shapes import facing

HUD_COLOR: Color = (0.55, 1.0, 0.62, 1.0)
HUD_BIN = 60  # drawn after the scene in the "fixed" bin
KMH_PER_MPS = 3.6


def hud_text(dash: Dashboard) -> str:
    """What the display reads: speed in whole km/h, then the gear if the vehicle has one."""
    text = f"{round(abs(dash.speed_mps) * KMH_PER_MPS)} km/h"
    if dash.gear is None:
        return text
    gear = "R" if dash.gear < 0 else "N" if dash.gear == 0 else str(dash.gear)
    return f"{text}   {gear}"


def _arrow(parent: NodePath, side: float, height: float) -> NodePath:
    """A triangle pointing left (side −1) or right (+1) beside the text, in its plane (x, z)."""
    mesh = MeshBuilder("hud/arrow")
    tip, back, mid = side * 4.6 * height, side * 3.8 * height, 0.35 * height
    corners = [(tip, 0.0, mid), (back, 0.0, mid + 0.45 * height), (back, 0.0, mid - 0.45 * height)]
    facing(mesh, corners, (0.0, -1.0, 0.0), HUD_COLOR)
    return parent.attach_new_node(mesh.node())


class HeadUpDisplay:
    """The display under `parent` (the own vehicle's node), at `eye` (Panda frame) + offset."""

    def __init__(self, parent: NodePath, eye: tuple[float, float, float], hud: Hud) -> None:
        down, left = math.radians(hud.down_deg), math.radians(hud.left_deg)
        d = hud.distance_m
        self.node = parent.attach_new_node("hud")
        self.node.set_pos(eye[0] - d * math.cos(down) * math.sin(left),
                          eye[1] + d * math.cos(down) * math.cos(left),
                          eye[2] - d * math.sin(down))  # fmt: skip
        self.node.set_hpr(hud.left_deg, -hud.down_deg, 0.0)  # facing the eye
        for setting in (self.node.set_light_off, self.node.set_fog_off, self.node.set_shader_off):
            setting(1)
        self.node.set_bin("fixed", HUD_BIN)
        self.node.set_depth_test(False)
        self.node.set_depth_write(False)
        self.text = TextNode("hud/text")
        self.text.set_align(TextNode.A_center)
        self.text.set_text_color(*HUD_COLOR)
        label = self.node.attach_new_node(self.text)
        label.set_scale(hud.text_height_m)
        self.arrows = {side: _arrow(self.node, side, hud.text_height_m) for side in (-1.0, 1.0)}
        self._shown: tuple[str, bool, bool] | None = None

    def show(self, dash: Dashboard | None) -> None:
        """Show `dash`, or nothing without one (a view with no loop of its own)."""
        state = (hud_text(dash), dash.left, dash.right) if dash is not None else ("", False, False)
        if state == self._shown:
            return
        self._shown = state
        self.text.set_text(state[0])
        for side, lit in ((-1.0, state[1]), (1.0, state[2])):
            self.arrows[side].show() if lit else self.arrows[side].hide()
