"""The values a program is compiled with: the physical constants its GLSL reads as
`#define`s, and the switches a quality preset, the time of day, the sun and the weather set.

Conventions: colours linear RGB in the units of `render/sky.py` (1.0 = a clear zenith sun on a
surface facing it).
"""

from __future__ import annotations

from carlaverse.render.quality import Preset

FOG_LAYER_M = 60.0  # [m] thickness of the fog layer the sky is seen through
FAR_SKY_M = 400.0  # [m] the longest path through fog towards the horizon
SUN_DISC_RAD = 0.0093  # [rad] the sun's disc radius drawn (about twice the true 0.27°)
SUN_DISC_GAIN = 60.0  # disc radiance per unit of sun irradiance: it tone-maps to white
WET_DARKENING = 0.5  # diffuse albedo lost on a fully wet surface (Lekner & Dorf 1988: ~½)
WATER_F0 = 0.02  # normal-incidence reflectance of water
HEAD_RGB = (1.0, 0.93, 0.82)  # halogen-ish headlamp colour
HEAD_REACH_M = 50.0  # [m] beyond this a low beam lights the road with under 1 % of its pool
STREET_RGB = (1.0, 0.82, 0.6)  # warm-white LED street lamps
# An emission texture (a texture stage in mode M_emission: a facade's lit windows, black
# elsewhere) glows at night with this radiance per unit of its linear colour; the sky's
# radiance at night is ~0.002. It must not be pure white: Panda3D stands in white for a
# missing stage, which the shader takes as "no emission".
WINDOW_RADIANCE = 0.12


def shader_defines(preset: Preset, night: bool, sun_up: bool = True,
                   flags: int | None = None, wet: bool = True) -> str:  # fmt: skip
    """The `#define`s that switch a program's features for one preset: by day or night, with
    shadows only while the sun is up, with the surface's flags compiled in when given, and
    with the wet terms only where the weather is wet (`wet`)."""
    values = {
        "PER_PIXEL": int(preset.per_pixel),
        "NIGHT": int(night),
        "WET": int(wet),
        "SHADOW_TAPS": preset.shadow_taps if preset.shadow_map_px and sun_up else 0,
        "SHADOW_PX": f"{max(preset.shadow_map_px, 1)}.0",
        "HEADLIGHTS": preset.headlights,
        "STREET_LIGHTS": int(preset.street_lights),
        "CLOUDS": int(preset.clouds),
        "FOG_LAYER_M": f"{FOG_LAYER_M}",
        "FAR_SKY_M": f"{FAR_SKY_M}",
        "SUN_DISC_RAD": f"{SUN_DISC_RAD}",
        "SUN_DISC_GAIN": f"{SUN_DISC_GAIN}",
        "WET_DARKENING": f"{WET_DARKENING}",
        "WATER_F0": f"{WATER_F0}",
        "HEAD_RGB": "vec3({}, {}, {})".format(*HEAD_RGB),
        "STREET_RGB": "vec3({}, {}, {})".format(*STREET_RGB),
        "WINDOW_RADIANCE": f"{WINDOW_RADIANCE}",
        "RAIN_ALPHA": "0.55",
        "POOLS": "1",
        "WINDOWS": "2",
        "UNTEXTURED": "4",
        "LAMP": "8",
        "HEAD_REACH_M": f"{HEAD_REACH_M}",
    }
    if flags is not None:
        values["FLAGS"] = str(flags)
    return "\n".join(f"#define {name} {value}" for name, value in values.items())
