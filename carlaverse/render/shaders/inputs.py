"""What every program is handed: the sun's and the sky's uniforms and the wetness (set on the
world node by `render/weather.py`; a dry day compiles the wetness in as 0), the surface's
material (`lighting.Material`) and clouds, and `flagged()`, which reads the surface's flags.

The first part of `COMMON` (`program.py`).
"""

SCENE_INPUTS = """
uniform vec3 sun_dir;         // towards the sun
uniform vec3 sun_color;       // irradiance facing the sun
uniform vec3 sun_glow;
uniform vec3 sky_zenith;
uniform vec3 sky_horizon;
uniform vec3 sky_ambient;
uniform vec3 ground_ambient;
uniform vec4 fog;             // rgb colour, a = extinction [1/m]
uniform float exposure;
uniform float night;
#if WET
uniform float wetness;
#else
// dry weather: a constant, so every wet term (the sun's highlight and the sky mirrored by a
// wet surface, lit per vertex) folds away when the program compiles. llvmpipe shades vertices
// on the thread that submits the scene: these terms were a third of the cpu preset's cost
// over flat there, and by a dry day they add exactly nothing.
const float wetness = 0.0;
#endif
uniform vec4 surface;         // x wet response, y roughness, z flags (POOLS...), w gloss
uniform vec4 clouds;          // x cover 0..1, y unused, zw drift of the pattern (sky)

// the surface's flags: headlight pools per pixel (roads), an emission stage (lit windows), no
// texture (its fetch skipped: Panda3D would stand in a white one). Lit per vertex, a program
// per set of flags has them compiled in (FLAGS): a software rasteriser runs both sides of a
// branch for every pixel, so a flag read from the input would make every pixel pay for the
// road's beam and the windows' glow.
#ifdef FLAGS
bool flagged(int flag) { return (FLAGS & flag) != 0; }
#else
bool flagged(int flag) { return (int(surface.z + 0.5) & flag) != 0; }
#endif
"""
