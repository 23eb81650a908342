"""A program's full source: `#version`, the `#define`s of its preset (`defines.py`), the
GLSL every program shares (`COMMON`), then its own stages.

`COMMON` is put together in the order GLSL needs (a function before its callers): the inputs,
the optics, the night's lights, a surface's light. The sky, rain and glare programs (`sky.py`,
`rain_streaks.py`, `lamp_glare.py`) share it with the surfaces', so the sky seen directly, the
sky mirrored in a wet road and the fog that swallows a distant house are one function.
"""

from __future__ import annotations

from carlaverse.render.quality import Preset
from carlaverse.render.shaders.defines import shader_defines
from carlaverse.render.shaders.inputs import SCENE_INPUTS
from carlaverse.render.shaders.night_lights import HEADLAMP_BEAMS, STREET_LIGHT_POOLS
from carlaverse.render.shaders.optics import OPTICS
from carlaverse.render.shaders.surface_light import SURFACE_LIGHT

COMMON = "".join((SCENE_INPUTS, OPTICS, HEADLAMP_BEAMS, STREET_LIGHT_POOLS, SURFACE_LIGHT))


def program(preset: Preset, *stages: str, night: bool = False, sun_up: bool = True,
            flags: int | None = None, wet: bool = True) -> str:  # fmt: skip
    """One stage's full source: version, the preset's switches, the common part, the stage."""
    defines = shader_defines(preset, night, sun_up, flags, wet)
    return "\n".join(("#version 330", defines, COMMON, *stages))
