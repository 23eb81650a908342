"""The sun's shadow map: a depth-only camera looking down the sun's rays over the eye's area.

An orthographic camera covers a square film of `shadow_film_m` around a point ahead of the
eye and renders the scene's depth into a texture each frame; the surface shader compares a
fragment's depth from the sun against it (`sampler2DShadow`, filtered by the hardware). The
film's centre snaps to whole texels in the sun's frame, so a moving eye does not make shadow
edges crawl. Below the horizon the pass is switched off: no sun, no shadows, no cost.

Nodes that should cast no shadow (the sky, rain, glare) hide from `SHADOW_MASK`; the rig's
cameras draw with `VIEW_MASK`.
"""

from __future__ import annotations

from panda3d.core import (
    BitMask32,
    Camera,
    ColorWriteAttrib,
    CullFaceAttrib,
    FrameBufferProperties,
    GraphicsOutput,
    GraphicsPipe,
    LightAttrib,
    Mat4,
    NodePath,
    OrthographicLens,
    Point3,
    RenderState,
    SamplerState,
    ShaderAttrib,
    Texture,
    TextureAttrib,
    Vec3,
    WindowProperties,
)

from carlaverse.render.graphics import Graphics, RenderError
from carlaverse.render.quality import Preset

VIEW_MASK = BitMask32.bit(0)
SHADOW_MASK = BitMask32.bit(1)
DEPTH_RANGE_M = 600.0  # [m] along the rays: the tallest building and the sun's low slant
AHEAD = 0.4  # the film's centre lies this share of its size ahead of the eye
SUN_UP_Z = 0.02  # the sun casts shadows above this height of its unit vector (~1.1°)
BIAS = Mat4.scale_mat(0.5) * Mat4.translate_mat(0.5, 0.5, 0.5)  # clip space -> texture space


class SunShadow:
    """Renders the depth the sun sees and hands it, with its matrix, to the world's shaders."""

    def __init__(self, world: NodePath, graphics: Graphics, preset: Preset) -> None:
        self.world = world
        self.size_px, self.film_m = preset.shadow_map_px, preset.shadow_film_m
        self.depth = _depth_texture()
        self.buffer = _depth_buffer(graphics, self.size_px, self.depth)
        self.lens = OrthographicLens()
        self.lens.set_film_size(self.film_m, self.film_m)
        self.lens.set_near_far(-DEPTH_RANGE_M / 2, DEPTH_RANGE_M / 2)
        camera = Camera("sun_shadow", self.lens)
        camera.set_camera_mask(SHADOW_MASK)
        camera.set_initial_state(_depth_only())
        self.camera = world.attach_new_node(camera)
        region = self.buffer.make_display_region()
        region.set_camera(self.camera)
        region.set_clear_depth_active(True)
        region.set_clear_depth(1.0)
        self._towards_sun = Vec3(0, 0, 1)
        world.set_shader_input("shadow_map", self.depth)
        world.set_shader_input("shadow_texel", self.film_m / self.size_px)
        world.set_shader_input("shadow_on", 0.0)
        world.set_shader_input("shadow_mat", Mat4.ident_mat())

    def aim(self, towards_sun: tuple[float, float, float]) -> None:
        """Point the camera down the sun's rays; a sun below the horizon stops the pass."""
        self._towards_sun = Vec3(*towards_sun)
        up = self._towards_sun.z > SUN_UP_Z
        self.buffer.set_active(up)
        self.world.set_shader_input("shadow_on", 1.0 if up else 0.0)

    def follow(self, eye: NodePath) -> None:
        """Centre the film a little ahead of `eye` (the rig's head), snapped to texels."""
        forward = self.world.get_relative_vector(eye, Vec3(0, 1, 0))
        forward.z = 0.0
        if forward.length_squared() > 1e-9:
            forward.normalize()
        centre = eye.get_pos(self.world) + forward * (AHEAD * self.film_m)
        centre.z = 0.0
        self.camera.set_pos(Point3(0, 0, 0))
        self.camera.look_at(-self._towards_sun, _up_for(self._towards_sun))
        local = self.world.get_mat(self.camera).xform_point(centre)
        texel = self.film_m / self.size_px
        snapped = Point3(round(local.x / texel) * texel, 0.0, round(local.z / texel) * texel)
        self.camera.set_pos(self.camera.get_mat(self.world).xform_point(snapped))
        world_to_texture = self.world.get_mat(self.camera) * self.lens.get_projection_mat()
        self.world.set_shader_input("shadow_mat", world_to_texture * BIAS)

    def close(self) -> None:
        self.buffer.get_engine().remove_window(self.buffer)


def _up_for(towards_sun: Vec3) -> Vec3:
    """An up vector not parallel to the rays (the sun may stand at the zenith)."""
    return Vec3(0, 1, 0) if abs(towards_sun.z) > 0.99 else Vec3(0, 0, 1)


def _depth_texture() -> Texture:
    tex = Texture("sun_depth")
    tex.set_minfilter(SamplerState.FT_shadow)
    tex.set_magfilter(SamplerState.FT_shadow)
    tex.set_wrap_u(SamplerState.WM_border_color)
    tex.set_wrap_v(SamplerState.WM_border_color)
    tex.set_border_color((1, 1, 1, 1))  # beyond the film: lit
    return tex


def _depth_buffer(graphics: Graphics, size_px: int, depth: Texture) -> GraphicsOutput:
    fb = FrameBufferProperties()
    fb.set_depth_bits(24)
    host = graphics.outputs[0]
    buffer = graphics.engine.make_output(
        graphics.pipe, "sun_shadow", -10, fb, WindowProperties.size(size_px, size_px),
        GraphicsPipe.BF_refuse_window, host.get_gsg(), host,
    )  # fmt: skip
    if buffer is None:
        raise RenderError(f"no {size_px}² depth buffer for sun shadows on {graphics.pipe_name}")
    buffer.add_render_texture(depth, GraphicsOutput.RTM_bind_or_copy, GraphicsOutput.RTP_depth)
    buffer.set_clear_color_active(False)
    return buffer


def _depth_only() -> RenderState:
    """Depth only, fixed-function, back faces (fewer self-shadowing artefacts)."""
    return RenderState.make(
        ColorWriteAttrib.make(ColorWriteAttrib.C_off),
        ShaderAttrib.make_off(),
        LightAttrib.make_all_off(),
        TextureAttrib.make_all_off(),
        CullFaceAttrib.make_reverse(),
        100,
    )
