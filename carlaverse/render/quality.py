"""Quality presets: what the renderer draws, chosen by what the GL renderer can afford.

- `full`: everything, for a GPU — sun shadows 2048² with soft (4-tap) edges, 4× multisample
  anti-aliasing, 8 headlight spotlights, street lights, clouds, dense rain.
- `cpu`: for a software rasteriser (Mesa llvmpipe), whose cost is per pixel: the same light
  (sky, sun, tone mapping, wet roads, night lights) computed per vertex, the pixel only
  looking up its shadow (a 512² map over a smaller film, one hardware-filtered tap) and its
  texture; actors cast the shadows of their boxes (`shadow_proxies`), the nearest
  vehicle's beams only, sparser rain, no multisampling (llvmpipe: 3–4× the frame). Its
  budget: 1.5× the `flat` frame time at 1920×1080 and 3 × 1920×1080 (docs/benchmarks.md,
  Renderer).
- `flat`: the fixed-function look the renderer had before (one sky colour, vertex lighting,
  no shadows, surfaces in plain palette colours): the cheapest, and the benchmark's baseline.
- `auto` (the default): `cpu` when the driver is a software rasteriser, else `full`.

No Panda3D here: the choice is testable on its own.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Quality = Literal["auto", "full", "cpu", "flat"]
SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast", "software rasterizer", "lavapipe")


@dataclass(frozen=True, slots=True)
class Preset:
    """The features one quality draws and what each may cost."""

    name: str
    shaded: bool  # own GLSL shading (sky, sun, tone mapping, weather, night); else fixed-function
    textured: bool  # the map's procedural textures (asphalt, paving, facades); else plain colours
    per_pixel: bool  # light every pixel; else every vertex, the pixel only shadowed (shaders/)
    shadow_map_px: int  # side of the sun's shadow map [px]; 0 = no shadows
    shadow_film_m: float  # [m] side of the square around the eye that shadows cover
    shadow_taps: int  # 1 (hardware 2×2 filter) or 4 (softer edges)
    box_shadows: bool  # actors cast their declared box's shadow (one draw call for all)
    multisamples: int  # MSAA samples per pixel; 0 = none
    headlights: int  # spotlights at the nearest vehicles whose low or high beams are on
    glare_lamps: int  # lit headlamps drawn as glowing sprites (nearest first)
    street_lights: bool  # poles along roads and their baked pools of light
    clouds: bool
    rain_streaks: int  # falling streaks around the eye at full precipitation


PRESETS: dict[str, Preset] = {
    "full": Preset("full", True, True, True, 2048, 160.0, 4, False, 4, 8, 48, True, True, 4000),
    "cpu": Preset("cpu", True, True, False, 512, 100.0, 1, True, 0, 1, 8, True, True, 1200),
    "flat": Preset("flat", False, False, False, 0, 0.0, 1, False, 0, 0, 0, False, False, 0),
}


def is_software(gl_renderer: str) -> bool:
    """Whether the GL renderer string names a CPU rasteriser."""
    text = gl_renderer.lower()
    return any(name in text for name in SOFTWARE_RENDERERS)


def resolve(quality: Quality, gl_renderer: str) -> Preset:
    """The preset a config's `quality` means on this GL renderer."""
    if quality == "auto":
        return PRESETS["cpu" if is_software(gl_renderer) else "full"]
    return PRESETS[quality]
