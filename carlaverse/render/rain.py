"""Rain: streaks of falling drops in a box that travels with the eye.

Each drop is one line segment, its length the distance a drop falls while a frame is exposed
(motion blur), slanted by the wind. The drops' places in the unit box are fixed (seeded); the
vertex shader moves them by the distance fallen since t = 0 and wraps them around the eye, so
a frame depends only on its render time and the rain never runs out, whatever the eye does.
Precipitation (0..1) shows that share of the drops (each has a rank; drops ranked below it
fall). A drop falls at FALL_MPS, a raindrop's terminal speed (~2 mm, Gunn & Kinzer 1949).
"""

from __future__ import annotations

import math

import numpy as np
from panda3d.core import (
    Geom,
    GeomLines,
    GeomNode,
    GeomVertexData,
    GeomVertexFormat,
    GeomVertexWriter,
    NodePath,
    OmniBoundingVolume,
    Shader,
    TransparencyAttrib,
    Vec3,
    Vec4,
)

from carlaverse.messages import Weather
from carlaverse.render.quality import Preset
from carlaverse.render.shaders import program
from carlaverse.render.shaders.rain_streaks import RAIN_FS, RAIN_VS
from carlaverse.render.shadows import SHADOW_MASK

FALL_MPS = 6.5  # [m/s] terminal speed of a ~2 mm raindrop
EXPOSURE_S = 1 / 30  # [s] a frame's motion blur: a streak's length is the fall in it
BOX_M = (24.0, 24.0, 12.0)  # [m] the volume of drops around the eye
SEED = 7


class Rain:
    """The streaks under `world`; `update` sets how many fall and where they are at `t`."""

    def __init__(self, world: NodePath, preset: Preset) -> None:
        self.node = world.attach_new_node(streaks(preset.rain_streaks))
        self.node.set_shader(
            Shader.make(Shader.SL_GLSL, program(preset, RAIN_VS), program(preset, RAIN_FS))
        )
        self.node.set_transparency(TransparencyAttrib.M_alpha)
        self.node.set_bin("fixed", 10)
        self.node.set_depth_write(False)
        self.node.set_light_off(1)
        self.node.hide(SHADOW_MASK)
        self.node.node().set_bounds(OmniBoundingVolume())  # drawn around the eye: never culled
        self.node.node().set_final(True)
        self.node.set_shader_input("rain_box", Vec3(*BOX_M))
        self.update(Weather(0, 0.0), 0.0)

    def update(self, w: Weather, t: float) -> None:
        share = min(1.0, max(0.0, w.precipitation))
        if share <= 0.0:
            self.node.hide()
            return
        self.node.show()
        wind = wind_vector(w)
        fall = (wind[0] * t, wind[1] * t, -FALL_MPS * t)
        self.node.set_shader_input("rain_fall", Vec4(*fall, share))
        self.node.set_shader_input(
            "rain_step", Vec3(-wind[0] * EXPOSURE_S, -wind[1] * EXPOSURE_S, FALL_MPS * EXPOSURE_S)
        )


def wind_vector(w: Weather) -> tuple[float, float]:
    """[m/s] where the wind carries a drop: from its compass bearing, so towards the opposite."""
    toward = math.radians(w.wind_direction_deg + 180.0)
    speed = max(0.0, w.wind_speed_mps)
    return (speed * math.sin(toward), speed * math.cos(toward))


def streaks(count: int) -> GeomNode:
    """`count` drops as line segments: the head at the drop's place, the tail flagged."""
    rng = np.random.default_rng(SEED)
    places = rng.random((max(count, 1), 3))
    ranks = rng.random(max(count, 1))
    data = GeomVertexData("rain", GeomVertexFormat.get_v3c4(), Geom.UH_static)
    data.unclean_set_num_rows(2 * len(places))
    vertex, colour = GeomVertexWriter(data, "vertex"), GeomVertexWriter(data, "color")
    lines = GeomLines(Geom.UH_static)
    for k, ((x, y, z), rank) in enumerate(zip(places, ranks, strict=True)):
        for tail in (0.0, 1.0):
            vertex.set_data3(x, y, z)
            colour.set_data4(rank, tail, 0.0, 1.0)
        lines.add_vertices(2 * k, 2 * k + 1)
    geom = Geom(data)
    geom.add_primitive(lines)
    node = GeomNode("rain")
    node.add_geom(geom)
    return node
