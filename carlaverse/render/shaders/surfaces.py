"""The surfaces' shader, vertex and fragment source, for a preset, a time of day and a
weather: lit per pixel (`per_pixel.py`) or per vertex (`per_vertex.py`) as the preset says
(`quality.Preset.per_pixel`), on the parts both share (`surface_parts.py`).
"""

from __future__ import annotations

from typing import Any

from carlaverse.render.quality import Preset
from carlaverse.render.shaders.per_pixel import PIXEL_FS, PIXEL_VS
from carlaverse.render.shaders.per_vertex import VERTEX_LIT_FS, VERTEX_LIT_VS
from carlaverse.render.shaders.program import program
from carlaverse.render.shaders.surface_parts import (
    EMISSION,
    SHADOW_LOOKUP,
    SURFACE_HEAD,
    VERTEX_IN,
)


def surface_sources(preset: Preset, night: bool, sun_up: bool, flags: int | None = None,
                    wet: bool = True) -> tuple[str, str]:  # fmt: skip
    """Vertex and fragment source of the surface shader for this preset and time of day;
    `flags` (POOLS 1, WINDOWS 2, UNTEXTURED 4) compiled in, else read from `surface.z`;
    `wet` False compiles the weather's wetness in as 0 (a dry day)."""
    vs_body, fs_body = (PIXEL_VS, PIXEL_FS) if preset.per_pixel else (VERTEX_LIT_VS, VERTEX_LIT_FS)
    key: dict[str, Any] = {"night": night, "sun_up": sun_up, "flags": flags, "wet": wet}
    vs = program(preset, SURFACE_HEAD, VERTEX_IN, vs_body, **key)
    fs = program(preset, SURFACE_HEAD, SHADOW_LOOKUP, EMISSION, fs_body, **key)
    return vs, fs
