"""The sky: a dome around the eye, drawn behind everything by the sky shader, and its clouds.

The dome is a sphere centred on the rig's head every frame, so it never comes nearer and the
sun stays at its direction however far the eye moves. Its vertex shader puts it on the far
plane and it is drawn after the opaque scene with a less-or-equal depth test, so only the
pixels nothing else covered are shaded (the sky costs what shows of it, not a full screen).
Its shader (`shaders.sky`) colours each direction: the gradient from horizon to zenith, the
glow and disc of the sun, clouds from a tileable noise texture thresholded by cloudiness, and
the fog layer in front.

The cloud texture is fractal value noise made here from a seeded generator: the same on every
node and every run, nothing downloaded.
"""

from __future__ import annotations

import math

import numpy as np
from panda3d.core import (
    BitMask32,
    CardMaker,
    ColorBlendAttrib,
    DepthTestAttrib,
    Geom,
    GeomNode,
    GeomTriangles,
    GeomVertexData,
    GeomVertexFormat,
    GeomVertexWriter,
    NodePath,
    SamplerState,
    Shader,
    Texture,
    Vec3,
)

from carlaverse.render.quality import Preset
from carlaverse.render.shaders import SUN_DISC_RAD
from carlaverse.render.shaders.sky import sky_sources, sun_sources

CLOUD_PX = 256  # side of the cloud texture
CLOUD_OCTAVES = 6
CLOUD_SEED = 42
# The dome's tessellation: per pixel a coarse one does; lit per vertex its clouds need ~4°.
RINGS, SEGMENTS = 12, 48
FINE_RINGS, FINE_SEGMENTS = 25, 90
LOWEST_DEG = -10.0  # [deg] the dome's lower edge


class SkyDome:
    """The dome node under `world`, hidden from the cameras in `hide_from`."""

    def __init__(self, world: NodePath, preset: Preset, radius_m: float,
                 hide_from: BitMask32) -> None:  # fmt: skip
        rings, segments = (RINGS, SEGMENTS) if preset.per_pixel else (FINE_RINGS, FINE_SEGMENTS)
        self.node = world.attach_new_node(sphere("sky", radius_m, rings, segments))
        self.node.set_shader(Shader.make(Shader.SL_GLSL, *sky_sources(preset)))
        self.node.set_shader_input("cloud_map", cloud_texture())
        self.node.set_bin("fixed", 0)  # after the opaque scene, before rain and glare
        self.node.set_depth_write(False)
        self.node.set_attrib(DepthTestAttrib.make(DepthTestAttrib.M_less_equal))
        self.node.set_two_sided(True)
        self.node.set_light_off(1)
        self.node.hide(hide_from)
        self.radius_m = radius_m
        self.sun = None if preset.per_pixel else self._sun_card(preset)

    def _sun_card(self, preset: Preset) -> NodePath:
        """The disc where the sky is lit per vertex: a card added over the sky, drawn after it."""
        half = SUN_DISC_RAD * 1.3 * self.radius_m  # [m] the disc's edge fades out to here
        maker = CardMaker("sun")
        maker.set_frame(-half, half, -half, half)
        card = self.node.attach_new_node(maker.generate())
        card.set_shader(Shader.make(Shader.SL_GLSL, *sun_sources(preset)))
        card.set_attrib(ColorBlendAttrib.make(ColorBlendAttrib.M_add,
                        ColorBlendAttrib.O_one, ColorBlendAttrib.O_one))  # fmt: skip
        card.set_bin("fixed", 1)
        return card

    def aim(self, towards_sun: tuple[float, float, float]) -> None:
        """Put the sun's card at its direction, facing the eye."""
        if self.sun is not None:
            self.sun.set_pos(Vec3(*towards_sun) * self.radius_m)
            self.sun.look_at(0.0, 0.0, 0.0)

    def follow(self, eye: NodePath) -> None:
        """Centre the dome on `eye` (the rig's head)."""
        self.node.set_pos(eye.get_pos(self.node.get_parent()))


def sphere(name: str, radius: float, rings: int, segments: int) -> GeomNode:
    """A cap of a UV sphere of `radius` [m] from LOWEST_DEG up, positions only: below it the
    ground covers the view (what shows past the ground's edge is the clear colour, the
    horizon's), so the dome rasterises half a picture, not a whole one."""
    data = GeomVertexData(name, GeomVertexFormat.get_v3(), Geom.UH_static)
    vertex = GeomVertexWriter(data, "vertex")
    lowest = math.radians(LOWEST_DEG)
    for i in range(rings + 1):
        lat = lowest + (math.pi / 2 - lowest) * i / rings
        for j in range(segments + 1):
            lon = 2 * math.pi * j / segments
            vertex.add_data3(
                radius * math.cos(lat) * math.cos(lon),
                radius * math.cos(lat) * math.sin(lon),
                radius * math.sin(lat),
            )
    tris = GeomTriangles(Geom.UH_static)
    row = segments + 1
    for i in range(rings):
        for j in range(segments):
            a, b = i * row + j, (i + 1) * row + j
            tris.add_vertices(a, b, a + 1)
            tris.add_vertices(a + 1, b, b + 1)
    geom = Geom(data)
    geom.add_primitive(tris)
    node = GeomNode(name)
    node.add_geom(geom)
    return node


def cloud_noise(size: int = CLOUD_PX, octaves: int = CLOUD_OCTAVES,
                seed: int = CLOUD_SEED) -> np.ndarray:  # fmt: skip
    """Tileable fractal value noise in 0..1, (size, size) float32."""
    rng = np.random.default_rng(seed)
    total = np.zeros((size, size), np.float64)
    weight = 0.0
    for octave in range(octaves):
        cells = 4 * 2**octave
        if cells > size:
            break
        amplitude = 0.55**octave
        total += amplitude * _smooth_upsample(rng.random((cells, cells)), size)
        weight += amplitude
    noise = total / weight
    lo, hi = noise.min(), noise.max()
    return ((noise - lo) / max(hi - lo, 1e-9)).astype(np.float32)


def _smooth_upsample(grid: np.ndarray, size: int) -> np.ndarray:
    """`grid` stretched to size × size with smoothstep interpolation, wrapping at the edges."""
    cells = grid.shape[0]
    u = np.arange(size) * cells / size
    i0 = np.floor(u).astype(int)
    f = u - i0
    f = f * f * (3 - 2 * f)
    i1 = (i0 + 1) % cells
    rows = grid[i0] * (1 - f)[:, None] + grid[i1] * f[:, None]
    return rows[:, i0] * (1 - f)[None, :] + rows[:, i1] * f[None, :]


def cloud_texture() -> Texture:
    """The cloud noise as a repeating single-channel texture."""
    noise = (cloud_noise() * 255).astype(np.uint8)
    tex = Texture("clouds")
    tex.setup_2d_texture(CLOUD_PX, CLOUD_PX, Texture.T_unsigned_byte, Texture.F_luminance)
    tex.set_ram_image(noise.tobytes())
    tex.set_wrap_u(SamplerState.WM_repeat)
    tex.set_wrap_v(SamplerState.WM_repeat)
    tex.set_minfilter(SamplerState.FT_linear_mipmap_linear)
    tex.set_magfilter(SamplerState.FT_linear)
    return tex
