"""Headlights at night: spotlights on the road from the vehicles nearest the eye, and glare.

The actor layer draws bodies; this layer reads the same `ActorDraw`s for their lamp bits
(`LIGHT_LOW_BEAM`, `LIGHT_HIGH_BEAM`) and

- hands the surface shader one spotlight per vehicle for the `preset.headlights` nearest lit
  vehicles (the one the camera rides in first: its beams light the driver's road), placed at
  the middle of the vehicle's front at lamp height and aimed along its heading;
- draws the lamps of the `preset.glare_lamps` nearest (not the camera's own) as glowing
  sprites, brightest seen from in front.

The beam (ECE R112-like, simplified): a low beam's light stops at a cut-off a little below the
horizontal (tan −0.01, 0.57°), the high beam's above it; sideways it fades out by ±40°; its
intensity falls by e every 3.4° below the cut-off (a low beam is aimed to light the road
20–60 m ahead, not the bonnet: with the road's 1/d³ this gives an even pool from 3 to 10 m).
Intensities are in the units of `sky.py` per steradian, set so that a low beam lights the
road 15 m ahead about as much as a street light lights the road under it (`street_lights`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
from panda3d.core import (
    ColorBlendAttrib,
    Geom,
    GeomNode,
    GeomTriangles,
    GeomVertexArrayFormat,
    GeomVertexData,
    GeomVertexFormat,
    NodePath,
    OmniBoundingVolume,
    PTA_LVecBase4f,
    Shader,
)

from carlaverse.messages import LIGHT_HIGH_BEAM, LIGHT_LOW_BEAM
from carlaverse.render.frame import ActorDraw
from carlaverse.render.quality import Preset
from carlaverse.render.shaders import program
from carlaverse.render.shaders.lamp_glare import GLARE_FS, GLARE_VS
from carlaverse.render.shadows import SHADOW_MASK

LAMP_KINDS = {"car", "van", "truck", "bus", "motorcycle"}
LOW_BEAM_I = 150.0  # intensity per unit solid angle, relative units (see the docstring)
HIGH_BEAM_I = 320.0
LOW_CUTOFF, HIGH_CUTOFF = -0.01, 0.035  # [tan] beam's upper edge, above horizontal positive
LAMP_HEIGHT_M = {"truck": 1.0, "bus": 1.0}  # [m] above the road, default below
DEFAULT_LAMP_HEIGHT_M = 0.65
LAMP_INSET = 0.36  # [width] each lamp's distance from the middle, as a share of the width
GLARE_SIZE_M = 0.9  # [m] side of a lamp's glare sprite


def beam_bits(lights: int) -> int:
    return lights & (LIGHT_LOW_BEAM | LIGHT_HIGH_BEAM)


def lit_vehicles(actors: Iterable[ActorDraw], eye: tuple[float, float, float],
                 count: int) -> list[ActorDraw]:  # fmt: skip
    """The `count` vehicles with beams on nearest to `eye` [m], nearest first."""
    lit = [a for a in actors if a.kind in LAMP_KINDS and beam_bits(a.lights)]
    lit.sort(key=lambda a: (a.x - eye[0]) ** 2 + (a.y - eye[1]) ** 2 + (a.z - eye[2]) ** 2)
    return lit[:count]


def lamp_point(a: ActorDraw, across: float = 0.0) -> tuple[float, float, float]:
    """A lamp on the front face of `a`, `across` [m] to its left of the middle [m]."""
    c, s = math.cos(a.yaw), math.sin(a.yaw)
    height = LAMP_HEIGHT_M.get(a.kind, DEFAULT_LAMP_HEIGHT_M)
    front = a.length / 2
    return (a.x + c * front - s * across, a.y + s * front + c * across, a.z + height)


class Headlights:
    """Spotlight uniforms on `world` and glare sprites for the nearest lit vehicles."""

    def __init__(self, world: NodePath, preset: Preset) -> None:
        self.world, self.count = world, preset.headlights
        self.glare_count = preset.glare_lamps
        self._pos = PTA_LVecBase4f.empty_array(max(self.count, 1))
        self._dir = PTA_LVecBase4f.empty_array(max(self.count, 1))
        if self.count:
            world.set_shader_input("lamp_pos", self._pos)
            world.set_shader_input("lamp_dir", self._dir)
        self.glare = Glare(world, preset) if self.glare_count else None

    def update(self, actors: tuple[ActorDraw, ...], eye: NodePath, own: str | None) -> None:
        """Place the lamps for this frame; `own` is the vehicle the camera rides in."""
        p = eye.get_pos(self.world)
        nearest = lit_vehicles(actors, (p.x, p.y, p.z), max(self.count, self.glare_count))
        for i in range(self.count):
            if i < len(nearest):
                self._set_lamp(i, nearest[i])
            else:
                self._pos[i] = (0.0, 0.0, 0.0, 0.0)
        if self.glare is not None:
            others = [a for a in nearest if a.actor_id != own][: self.glare_count]
            self.glare.update(others, (p.x, p.y, p.z))

    def _set_lamp(self, i: int, a: ActorDraw) -> None:
        high = bool(a.lights & LIGHT_HIGH_BEAM)
        self._pos[i] = (*lamp_point(a), HIGH_BEAM_I if high else LOW_BEAM_I)
        self._dir[i] = (math.cos(a.yaw), math.sin(a.yaw), 0.0, HIGH_CUTOFF if high else LOW_CUTOFF)


class Glare:
    """Two camera-facing sprites per lit vehicle, added to what lies behind them."""

    def __init__(self, world: NodePath, preset: Preset) -> None:
        self.capacity = 2 * preset.glare_lamps
        fmt = GeomVertexArrayFormat()
        fmt.add_column("vertex", 3, Geom.NT_float32, Geom.C_point)
        fmt.add_column("color", 4, Geom.NT_float32, Geom.C_color)
        fmt.add_column("texcoord", 2, Geom.NT_float32, Geom.C_texcoord)
        self.data = GeomVertexData("glare", GeomVertexFormat.register_format(fmt),
                                   Geom.UH_dynamic)  # fmt: skip
        self.data.unclean_set_num_rows(4 * self.capacity)
        tris = GeomTriangles(Geom.UH_static)
        for k in range(self.capacity):
            tris.add_vertices(4 * k, 4 * k + 1, 4 * k + 2)
            tris.add_vertices(4 * k, 4 * k + 2, 4 * k + 3)
        geom = Geom(self.data)
        geom.add_primitive(tris)
        node = GeomNode("glare")
        node.add_geom(geom)
        node.set_bounds(OmniBoundingVolume())  # its sprites move every frame: never culled
        node.set_final(True)
        self.node = world.attach_new_node(node)
        self.node.set_shader(
            Shader.make(Shader.SL_GLSL, program(preset, GLARE_VS), program(preset, GLARE_FS))
        )
        self.node.set_attrib(ColorBlendAttrib.make(ColorBlendAttrib.M_add,
                             ColorBlendAttrib.O_one, ColorBlendAttrib.O_one))  # fmt: skip
        self.node.set_bin("fixed", 20)
        self.node.set_depth_write(False)
        self.node.set_two_sided(True)
        self.node.set_light_off(1)
        self.node.hide(SHADOW_MASK)
        self.rows = np.zeros((4 * self.capacity, 9), np.float32)
        self.rows[:, 7:9] = np.tile([[0, 0], [1, 0], [1, 1], [0, 1]], (self.capacity, 1))

    def update(self, vehicles: list[ActorDraw], eye: tuple[float, float, float]) -> None:
        """Two sprites per vehicle, facing the eye, as bright as the lamps face it."""
        self.rows[:, 0:7] = 0.0  # unused sprites collapse to a point with no light
        lamps = [(lamp_point(a, side * LAMP_INSET * a.width), a)
                 for a in vehicles for side in (1.0, -1.0)][: self.capacity]  # fmt: skip
        if lamps:
            self._sprites(lamps, np.asarray(eye, np.float64))
        array = self.data.modify_array(0)
        # An array is a buffer; the stubs' memoryview item assignment takes only bytes types.
        memoryview(array).cast("B").cast("f")[:] = self.rows.ravel()  # type: ignore[call-overload]

    def _sprites(self, lamps: list[tuple[tuple[float, float, float], ActorDraw]],
                 eye: np.ndarray) -> None:  # fmt: skip
        n = len(lamps)
        at = np.array([p for p, _ in lamps])
        heading = np.array([(math.cos(a.yaw), math.sin(a.yaw)) for _, a in lamps])
        high = np.array([bool(a.lights & LIGHT_HIGH_BEAM) for _, a in lamps])
        view = eye - at
        view /= np.maximum(np.linalg.norm(view, axis=1, keepdims=True), 1e-6)
        facing = np.maximum(0.0, np.einsum("ij,ij->i", heading, view[:, :2]))
        level = facing**2 * np.where(high, 2.0, 1.0)
        right = np.cross(view, (0.0, 0.0, 1.0))
        right /= np.maximum(np.linalg.norm(right, axis=1, keepdims=True), 1e-6)
        up = np.cross(right, view)
        centre = at + view * 0.05  # just in front of the lamp's face
        half = GLARE_SIZE_M / 2
        corners = np.array([(-1, -1), (1, -1), (1, 1), (-1, 1)], np.float64)
        quads = centre[:, None, :] + half * (
            corners[None, :, 0:1] * right[:, None, :] + corners[None, :, 1:2] * up[:, None, :]
        )
        block = self.rows[: 4 * n]
        block[:, 0:3] = quads.reshape(-1, 3)
        block[:, 3] = np.repeat(level, 4)
        block[:, 6] = 1.0
