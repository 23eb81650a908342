"""The renderer's GLSL, as text: what every program shares, and the surfaces' shader (the
sky dome, the sun's disc, rain and glare are in `sky_shaders.py`).

Every program starts with the preset's `#define`s and `COMMON`: colour space, tone mapping,
the sky's radiance in a direction, fog, and `light()` — what a surface point sends to the
eye, split into the part the sun adds (which a shadow removes) and the rest (sky, street
lights, headlights, reflections). The sky seen directly, the sky mirrored in a wet road and
the fog that swallows a distant house are one function.

Two ways to run `light()`, by preset (`quality.Preset.per_pixel`):

- per pixel (`full`, for a GPU): the fragment shader lights every pixel, then fogs and tone
  maps it;
- per vertex (`cpu`, for llvmpipe, whose fragment work is the frame): the vertex shader lights,
  fogs and tone maps each vertex twice — in shadow and in sun — and the fragment shader only
  mixes the two by the shadow map and multiplies the texture, as fixed-function drawing
  modulates a texture. Smooth terms come out the same; highlights are left to wet ground.
  By night the vertex hands over linear light instead and the fragment adds the nearest
  vehicle's headlights — the camera's own: a beam's pool on a road cut every 5 m needs
  pixels — and tone-maps; other vehicles' beams light the vertices.

Programs come in a day and a night variant (`NIGHT`): street lights, headlights and lit
windows cost nothing by day.

Conventions: world frame (x east, y north, z up) [m]; colours linear RGB in the units of
`sky.py` (1.0 = a clear zenith sun on a surface facing it); vertex colours and textures are
sRGB, linearised with γ = 2.2.
A node whose lights are all off (`set_light_off`: lamps, signal heads) is emissive: Panda3D
hands such a node an ambient of (1, 1, 1, 1), while the scene's own ambient light has alpha 0.
"""

from __future__ import annotations

from typing import Any

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

COMMON = """
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

vec3 to_linear(vec3 c) { return pow(max(c, vec3(0.0)), vec3(2.2)); }
vec3 to_display(vec3 c) { return pow(clamp(c, 0.0, 1.0), vec3(1.0 / 2.2)); }

// Narkowicz's fit of the ACES filmic curve: a soft toe, a shoulder that keeps highlights
vec3 tone_map(vec3 x) {
    x *= exposure;
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

float pow4(float x) { x *= x; return x * x; }

// radiance of the clear sky seen along unit direction d (no sun disc, no clouds)
vec3 sky_radiance(vec3 d) {
    float up = max(d.z, 0.0);
    // a band of horizon colour some 10° deep (white haze by day, red at dusk), then zenith
    float t = smoothstep(0.02, 0.45, up);
    vec3 c = mix(sky_horizon, sky_zenith, pow(t, 0.7));
    float mu = max(dot(d, sun_dir), 0.0);
    float mu16 = pow4(pow4(mu));
    c += sun_glow * (0.45 * pow4(mu) + 1.6 * mu16 * mu16 * mu16);
    return c * mix(1.0, 0.45, smoothstep(0.0, -0.25, d.z));  // below the horizon: ground haze
}

vec3 fogged(vec3 c, float dist) { return mix(fog.rgb, c, exp(-fog.a * dist)); }

// Cook-Torrance per unit of irradiance: GGX distribution, Schlick's Fresnel at the half
// vector (a lamp beside the eye meets the road near normal incidence there: F ≈ f0, however
// grazing the view), Smith-Schlick shadowing. Times π, as the diffuse term here is albedo × E.
float specular(vec3 N, vec3 L, vec3 V, float rough, float f0) {
    vec3 h = normalize(L + V);
    float a2 = pow4(rough);
    float nh = max(dot(N, h), 0.0);
    float nl = max(dot(N, L), 1e-3);
    float nv = max(dot(N, V), 1e-3);
    float dd = nh * nh * (a2 - 1.0) + 1.0;
    float vh = 1.0 - max(dot(V, h), 0.0);
    float fresnel = f0 + (1.0 - f0) * pow4(vh) * vh;
    float k = (rough + 1.0) * (rough + 1.0) / 8.0;
    float g = nl / (nl * (1.0 - k) + k) * nv / (nv * (1.0 - k) + k);
    return a2 / (dd * dd) * fresnel * g / (4.0 * nl * nv);
}

#if NIGHT && HEADLIGHTS > 0
uniform vec4 lamp_pos[HEADLIGHTS];  // xyz [m], w intensity (0: none)
uniform vec4 lamp_dir[HEADLIGHTS];  // xyz beam axis (unit, horizontal), w cut-off (tan, up +)
// the lamps first .. last - 1 (nearest first: the camera's own car is lamp 0)
vec3 headlights(vec3 pos, vec3 N, vec3 V, vec3 albedo, float rough, float f0, int first,
                int last) {
    vec3 sum = vec3(0.0);
#if !PER_PIXEL
    // lit per vertex, a wall or a pole (one quad, metres tall) would glow all over from its
    // foot, and every vertex of every car would pay: only level ground takes a beam here
    if (N.z < 0.5) return sum;
#endif
    for (int i = first; i < last; ++i) {
        vec4 p = lamp_pos[i];
        vec3 L = p.xyz - pos;
        vec3 axis = lamp_dir[i].xyz;
        float ahead = -dot(L, axis);  // [m] along the beam
        float d2 = dot(L, L);
        // most pixels are behind a lamp, beyond its reach or facing away: skip them early
        if (p.w <= 0.0 || ahead < 0.3 || d2 > HEAD_REACH_M * HEAD_REACH_M) continue;
        float ndl = dot(N, L);
        if (ndl <= 0.0) continue;
        float inv = inversesqrt(d2);
        float per = 1.0 / ahead;
        float across = abs(dot(L, vec3(axis.y, -axis.x, 0.0))) * per;  // tan, sideways
        float below = lamp_dir[i].w + L.z * per;  // tan under the cut-off (rise is −L.z/ahead)
        float beam = clamp((0.85 - across) * 1.8, 0.0, 1.0)  // fading out by ±40°
                   * clamp(below * 60.0 + 0.5, 0.0, 1.0)      // the cut-off, ±0.5°
                   // brightest just under the cut-off, falling by e every 3.4° below it:
                   // aimed at the road 20–60 m ahead, not at the bonnet
                   * exp2(-max(below, 0.0) * (1.4427 / 0.06));
        vec3 e = HEAD_RGB * (p.w * beam * ndl * inv * inv * inv);
#if PER_PIXEL
        sum += e * (albedo + specular(N, L * inv, V, rough, f0));
#else
        sum += e * albedo;  // a headlamp's highlight is left to the GPU preset
#endif
    }
    return sum;
}
#endif

#if NIGHT && HEADLIGHTS > 0 && !PER_PIXEL
// Lamp 0 (the nearest vehicle's) seen from a point: metres ahead along its beam, sideways and
// how far the lamp stands above it. All three are linear in the point, so a vertex's values,
// interpolated, are a pixel's own exactly: the pixel pays only for the beam's shape.
vec3 beam_coords(vec3 pos) {
    vec3 L = lamp_pos[0].xyz - pos;
    vec3 axis = lamp_dir[0].xyz;
    return vec3(-dot(L, axis), dot(L, vec3(axis.y, -axis.x, 0.0)), L.z);
}
// The irradiance lamp 0 puts on level ground at beam coordinates b: headlights() for N up,
// without branches (a software rasteriser runs both sides of one for every pixel)
vec3 own_beam(vec3 b) {
    float per = 1.0 / max(b.x, 0.3);
    float across = abs(b.y) * per;
    float below = lamp_dir[0].w + b.z * per;
    float d2 = dot(b, b);
    float inv = inversesqrt(d2);
    float on = lamp_pos[0].w * step(0.3, b.x) * step(d2, HEAD_REACH_M * HEAD_REACH_M);
    float beam = clamp((0.85 - across) * 1.8, 0.0, 1.0)
               * clamp(below * 60.0 + 0.5, 0.0, 1.0)
               * exp2(-max(below, 0.0) * (1.4427 / 0.06));
    return HEAD_RGB * (max(on, 0.0) * beam * max(b.z, 0.0) * inv * inv * inv);
}
#endif

#if NIGHT && STREET_LIGHTS
uniform sampler2D street_map;  // irradiance on the ground from every street light
uniform vec4 street_rect;      // x0, y0 [m], 1/width, 1/height [1/m]
vec3 street_light(vec3 pos, vec3 N) {
    vec2 uv = (pos.xy - street_rect.xy) * street_rect.zw;
    float e = textureLod(street_map, uv, 0.0).r * max(N.z, 0.0) * smoothstep(3.0, 0.0, pos.z);
    return STREET_RGB * (e * night);
}
#endif

// How a point answers light: its albedo (wet surfaces darken), roughness, Fresnel towards V
struct Surface { vec3 albedo; float wet; float rough; float f0; float fresnel; };
Surface surface_at(vec3 N, vec3 V, vec3 albedo) {
    Surface s;
    // water stands on level ground (roads, roofs), not on a tree's crown or a wall
    s.wet = wetness * surface.x * smoothstep(0.9, 0.98, N.z);
    s.albedo = albedo * (1.0 - WET_DARKENING * s.wet);
    s.rough = mix(surface.y, 0.05, s.wet);
    s.f0 = mix(0.04, WATER_F0, s.wet);
    float nv = 1.0 - max(dot(N, V), 1e-3);
    s.fresnel = s.f0 + (1.0 - s.f0) * pow4(nv) * nv;  // a mirror's, towards V
    return s;
}

// What a point sends towards the eye: `sunlit` is what the sun adds (a shadow takes it away),
// `rest` everything else. base: sRGB colour; V: unit vector to the eye. Lit per vertex, the
// headlights are left to the fragment shader (a pool on a road cut every 5 m needs pixels).
void light(vec3 pos, vec3 N, vec3 V, vec3 base, out vec3 rest, out vec3 sunlit) {
    Surface s = surface_at(N, V, to_linear(base));
    float ndl = max(dot(N, sun_dir), 0.0);
#if PER_PIXEL
    float gloss = max(s.wet, surface.w);
#else
    // per vertex, a highlight or a reflection on a big face (a van's back is two triangles)
    // smears into a diagonal streak: only a wet surface, finely cut, mirrors the sky
    float gloss = s.wet;
#endif
    // a sun behind clouds leaves no sharp highlight: the clearer the sky the likelier a gap
    // in front of its disc, and from 80 % cover on the disc is hidden (a wet road under rain
    // clouds mirrors the grey sky, not a sun)
    float gap = max(1.0 - clouds.x / 0.8, 0.0);
    float clear = gap * gap;
    float spec = gloss * clear * specular(N, sun_dir, V, s.rough, s.f0);
    sunlit = sun_color * ndl * (s.albedo + spec);
    rest = s.albedo * mix(ground_ambient, sky_ambient, 0.5 + 0.5 * N.z);
    rest += sky_radiance(reflect(-V, N)) * (s.fresnel * gloss * (1.0 - s.rough));
#if NIGHT && HEADLIGHTS > 0
    // per pixel all lamps; lit per vertex, a road leaves the nearest to the fragment shader
    int first = PER_PIXEL == 0 && flagged(POOLS) ? 1 : 0;
    rest += headlights(pos, N, V, s.albedo, s.rough, s.f0, first, HEADLIGHTS);
#endif
#if NIGHT && STREET_LIGHTS
    rest += s.albedo * street_light(pos, N);
#endif
}
"""

# Shared by both surface programs: the view, the material's start and the shadow map.
SURFACE_HEAD = """
uniform struct p3d_LightModelParameters { vec4 ambient; } p3d_LightModel;
uniform mat4 p3d_ViewMatrixInverse;
uniform vec4 p3d_ColorScale;
#if SHADOW_TAPS > 0
uniform mat4 shadow_mat;
uniform float shadow_texel;  // [m] one shadow-map texel on the ground
uniform sampler2DShadow shadow_map;
uniform float shadow_on;
#endif
bool emissive() { return p3d_LightModel.ambient.a > 0.5; }  // lights off: a lamp
vec3 eye_position() { return p3d_ViewMatrixInverse[3].xyz; }
"""

VERTEX_IN = """
uniform mat4 p3d_ModelViewProjectionMatrix;
uniform mat4 p3d_ModelMatrix;
uniform mat3 p3d_NormalMatrix;
in vec4 p3d_Vertex;
in vec3 p3d_Normal;
in vec4 p3d_Color;
in vec2 p3d_MultiTexCoord0;
out vec2 v_uv;
out vec4 v_shadow;
// the inverse-transpose in view space, back to world: right for scaled actors too
vec3 world_normal() {
    return normalize(mat3(p3d_ViewMatrixInverse) * (p3d_NormalMatrix * p3d_Normal));
}
vec4 shadow_coord(vec3 world, vec3 N) {
#if SHADOW_TAPS > 0
    // normal offset: look the depth up a texel and a half off the surface, no acne
    return shadow_mat * vec4(world + N * 1.5 * shadow_texel, 1.0);
#else
    return vec4(0.0);
#endif
}
"""

SHADOW_LOOKUP = """
in vec4 v_shadow;
float sun_visible() {
#if SHADOW_TAPS > 0
    vec3 p = v_shadow.xyz;  // orthographic: w is 1
#if SHADOW_TAPS > 1
    vec2 t = vec2(0.6 / SHADOW_PX);
    float s = 0.25 * (texture(shadow_map, p + vec3(-t.x, -t.y, 0.0))
                    + texture(shadow_map, p + vec3(t.x, -t.y, 0.0))
                    + texture(shadow_map, p + vec3(-t.x, t.y, 0.0))
                    + texture(shadow_map, p + vec3(t.x, t.y, 0.0)));
#else
    float s = texture(shadow_map, p);
#endif
    vec2 edge = min(p.xy, 1.0 - p.xy);  // fade out at the film's border
    return mix(1.0, s, shadow_on * smoothstep(0.0, 0.05, min(edge.x, edge.y)));
#else
    return 1.0;
#endif
}
"""

EMISSION = """
uniform sampler2D p3d_TextureEmission;  // lit windows: black but for the lit ones
// Panda3D hands a node without an emission stage a white texture: pure white means none
vec3 emission(vec2 uv) {
#if NIGHT
    vec3 e = texture(p3d_TextureEmission, uv).rgb;
#if PER_PIXEL
    vec3 lin = to_linear(e);
#else
    vec3 lin = e * e;  // γ 2: a pixel's pow is dear on llvmpipe
#endif
    return min(e.r, min(e.g, e.b)) > 0.99 ? vec3(0.0) : lin * (WINDOW_RADIANCE * night);
#else
    return vec3(0.0);
#endif
}
"""

PIXEL_VS = """
out vec3 v_pos;
out vec3 v_normal;
out vec4 v_color;
void main() {
    vec4 world = p3d_ModelMatrix * p3d_Vertex;
    gl_Position = p3d_ModelViewProjectionMatrix * p3d_Vertex;
    v_normal = world_normal();
    v_pos = world.xyz;
    v_color = p3d_Color * p3d_ColorScale;
    v_uv = p3d_MultiTexCoord0;
    v_shadow = shadow_coord(world.xyz, v_normal);
}
"""

PIXEL_FS = """
uniform sampler2D p3d_TextureModulate;
in vec3 v_pos;
in vec3 v_normal;
in vec4 v_color;
in vec2 v_uv;
out vec4 frag;
void main() {
    vec4 base = v_color * texture(p3d_TextureModulate, v_uv);
    float dist = length(eye_position() - v_pos);
    if (emissive()) {
        frag = vec4(mix(to_display(tone_map(fog.rgb)), base.rgb, exp(-fog.a * dist)), base.a);
        return;
    }
    vec3 rest, sunlit;
    light(v_pos, normalize(v_normal), (eye_position() - v_pos) / max(dist, 1e-4), base.rgb,
          rest, sunlit);
    vec3 c = rest + sunlit * sun_visible() + emission(v_uv);
    frag = vec4(to_display(tone_map(fogged(c, dist))), base.a);
}
"""

VERTEX_LIT_VS = """
out vec3 v_shade;   // the display colour in shadow; a road's by night: linear radiance × fog
out vec3 v_sun;     // the same in sun
out float v_alpha;
#if NIGHT && HEADLIGHTS > 0
out vec4 v_albedo;  // what a road's headlights meet: linear albedo, a = fog transmittance
out vec3 v_beam;    // the nearest vehicle's beam coordinates (beam_coords)
#endif
void main() {
    vec4 world = p3d_ModelMatrix * p3d_Vertex;
    gl_Position = p3d_ModelViewProjectionMatrix * p3d_Vertex;
    vec4 base = p3d_Color * p3d_ColorScale;
    v_uv = p3d_MultiTexCoord0;
    v_alpha = base.a;
    vec3 to_eye = eye_position() - world.xyz;
    float dist = length(to_eye);
    vec3 N = world_normal();
    vec3 V = to_eye / max(dist, 1e-4);
    v_shadow = shadow_coord(world.xyz, N);
    float through = exp(-fog.a * dist);
#if NIGHT && HEADLIGHTS > 0
    v_beam = beam_coords(world.xyz);
    v_albedo = vec4(surface_at(N, V, to_linear(base.rgb)).albedo, through);
#endif
    // a lamp's program has LAMP compiled in: the lighting below is dead code there, where
    // llvmpipe would otherwise run it for every lamp vertex (it runs both sides of a branch)
    if (flagged(LAMP) || emissive()) {
        v_shade = v_sun = mix(to_display(tone_map(fog.rgb)), base.rgb, through);
        return;
    }
    vec3 rest, sunlit;
    light(world.xyz, N, V, base.rgb, rest, sunlit);
#if NIGHT && HEADLIGHTS > 0
    if (flagged(POOLS)) {  // the fragment adds the beam and tone-maps
        v_shade = rest * through;
        v_sun = (rest + sunlit) * through;
        return;
    }
#endif
    v_shade = to_display(tone_map(mix(fog.rgb, rest, through)));
    v_sun = to_display(tone_map(mix(fog.rgb, rest + sunlit, through)));
}
"""

VERTEX_LIT_FS = """
uniform sampler2D p3d_TextureModulate;
in vec3 v_shade;
in vec3 v_sun;
in float v_alpha;
in vec2 v_uv;
#if NIGHT && HEADLIGHTS > 0
in vec4 v_albedo;
in vec3 v_beam;
#endif
out vec4 frag;
void main() {
    vec4 tex = flagged(UNTEXTURED) ? vec4(1.0) : texture(p3d_TextureModulate, v_uv);
#if NIGHT && HEADLIGHTS > 0
    // a road by night: the nearest vehicle's beam pool per pixel, then tone-mapped (γ 2); a
    // road is level (N up) and lit, never a lamp (few varyings: each costs every pixel)
    if (flagged(POOLS)) {
        vec3 t = tex.rgb * tex.rgb;
        vec3 c = mix(v_shade, v_sun, sun_visible()) * t + fog.rgb * (1.0 - v_albedo.a);
        c += own_beam(v_beam) * (v_albedo.rgb * t * v_albedo.a);
        frag = vec4(sqrt(tone_map(c)), v_alpha * tex.a);
        return;
    }
#endif
    vec3 c = mix(v_shade, v_sun, sun_visible()) * tex.rgb;
#if NIGHT
    if (flagged(WINDOWS)) {
        c += sqrt(tone_map(emission(v_uv)));  // γ 2 here: a pixel's pow is dear on llvmpipe
    }
#endif
    frag = vec4(c, v_alpha * tex.a);
}
"""


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


def program(preset: Preset, *stages: str, night: bool = False, sun_up: bool = True,
            flags: int | None = None, wet: bool = True) -> str:  # fmt: skip
    """One stage's full source: version, the preset's switches, the common part, the stage."""
    defines = shader_defines(preset, night, sun_up, flags, wet)
    return "\n".join(("#version 330", defines, COMMON, *stages))


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
