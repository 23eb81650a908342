"""The renderer's GLSL, as text: what every program shares, the surfaces' shader, and what is
drawn around the eye rather than lit (the sky dome, the sun's disc, rain streaks, lamp glare).

Every program starts with the preset's `#define`s and `COMMON` (`program.program`): colour
space, tone mapping, the sky's radiance in a direction, fog, and `light()` — what a surface
point sends to the eye, split into the part the sun adds (which a shadow removes) and the
rest (sky, street lights, headlights, reflections). The sky seen directly, the sky mirrored
in a wet road and the fog that swallows a distant house are one function.

Two ways to run `light()`, by preset (`quality.Preset.per_pixel`): per pixel (`full`, for a
GPU) or per vertex (`cpu`, for llvmpipe, whose fragment work is the frame). Programs come in
a day and a night variant (`NIGHT`): street lights, headlights and lit windows cost nothing
by day; a dry day compiles the wet terms away (`WET`).

One module a job:

    defines.py        the physical constants and a preset's `#define`s (`shader_defines`)
    program.py        `COMMON` put together, and `program()`: one stage's full source
    inputs.py         COMMON 1: the uniforms, the wet switch, the surface's flags
    optics.py         COMMON 2: colour space, tone mapping, sky radiance, fog, specular
    night_lights.py   COMMON 3: headlamp beams and street lights' pools (night only)
    surface_light.py  COMMON 4: a wet surface's response and `light()`
    surface_parts.py  what both surface programs share: view, vertex inputs, shadow, windows
    per_pixel.py      the surface program lit per pixel (`full`)
    per_vertex.py     the surface program lit per vertex (`cpu`)
    surfaces.py       `surface_sources()`: the surface program for a preset, time and weather
    sky.py            the sky dome and the sun's card (`sky_sources`, `sun_sources`)
    rain_streaks.py   the rain streaks drawn around the eye
    lamp_glare.py     the glare sprite of a lit headlamp

Conventions: world frame (x east, y north, z up) [m]; colours linear RGB in the units of
`render/sky.py` (1.0 = a clear zenith sun on a surface facing it); vertex colours and
textures are sRGB, linearised with γ = 2.2.
"""

from __future__ import annotations

from carlaverse.render.shaders.defines import SUN_DISC_RAD, shader_defines
from carlaverse.render.shaders.program import COMMON, program
from carlaverse.render.shaders.surfaces import surface_sources

__all__ = ["COMMON", "SUN_DISC_RAD", "program", "shader_defines", "surface_sources"]
