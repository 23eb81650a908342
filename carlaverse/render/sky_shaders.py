"""The GLSL of what is drawn around the eye rather than lit: the sky dome, the sun's disc,
rain streaks and headlamp glare. Each program is built with `shaders.program`, so it shares
the surfaces' colour space, tone mapping, sky radiance and fog (`shaders.COMMON`).
"""

from __future__ import annotations

from carlaverse.render.quality import Preset
from carlaverse.render.shaders import program

# The sky: the clear sky through the fog layer, clouds, and the sun's disc in front unless a
# cloud hides it. `sky_at` gives the clear sky and the lit cloud colour for a direction; the
# per-pixel sky calls it per pixel, the vertex-lit one per dome vertex (colours and cloud
# cover interpolated, only the disc per pixel).
SKY_COMMON = """
uniform sampler2D cloud_map;
float fog_through(vec3 d) { return exp(-fog.a * min(FOG_LAYER_M / max(d.z, 1e-3), FAR_SKY_M)); }
vec2 cloud_uv(vec3 d) { return d.xy / (max(d.z, 0.0) + 0.12) * 0.35 + clouds.zw; }
void sky_at(vec3 d, out vec3 clear, out vec3 cloud) {
    float through = fog_through(d);
    float glow = pow4(pow4(max(dot(d, sun_dir), 0.0)));
    clear = mix(fog.rgb, sky_radiance(d), through);
    cloud = sky_horizon * 1.1 + sun_color * (0.2 + 0.4 * glow) * (1.0 - 0.8 * clouds.x);
    cloud = mix(fog.rgb, cloud * (1.0 - 0.3 * clouds.x), through);
}
float cloud_density(float pattern, vec3 d) {
    float cover = clouds.x;
    return smoothstep(1.0 - cover, 1.3 - cover, pattern) * smoothstep(0.0, 0.1, d.z)
         * step(0.001, cover);
}
float sun_disc(vec3 d) {
    return smoothstep(cos(SUN_DISC_RAD * 1.3), cos(SUN_DISC_RAD), dot(d, sun_dir));
}
"""

SKY_VS = """
uniform mat4 p3d_ModelViewProjectionMatrix;
in vec4 p3d_Vertex;
out vec3 v_dir;
out vec3 v_colour;  // display colour (vertex-lit presets)
float cover_at(vec3 d) {
#if CLOUDS
    // per vertex on a finely cut dome, from the pattern's coarser levels: soft-edged clouds
    return cloud_density(textureLod(cloud_map, cloud_uv(d), 2.0).r, d);
#else
    return 0.0;
#endif
}
void main() {
    // on the far plane: drawn after the scene, it only fills pixels nothing else covered
    gl_Position = (p3d_ModelViewProjectionMatrix * p3d_Vertex).xyww;
    v_dir = p3d_Vertex.xyz;  // the dome is centred on the eye and never rotated
#if !PER_PIXEL
    vec3 d = normalize(v_dir), clear, cloud;
    sky_at(d, clear, cloud);
    v_colour = to_display(tone_map(mix(clear, cloud, cover_at(d))));
#endif
}
"""

SKY_FS = """
in vec3 v_dir;
in vec3 v_colour;
out vec4 frag;
void main() {
#if PER_PIXEL
    vec3 d = normalize(v_dir), clear, cloud;
    sky_at(d, clear, cloud);
    vec3 c = clear + sun_color * (SUN_DISC_GAIN * fog_through(d) * sun_disc(d));
#if CLOUDS
    c = mix(c, cloud, cloud_density(texture(cloud_map, cloud_uv(d)).r, d));
#endif
    frag = vec4(to_display(tone_map(c)), 1.0);
#else
    frag = vec4(v_colour, 1.0);  // the sun's disc is a sprite of its own (SUN_*)
#endif
}
"""

# The sun's disc where the sky is lit per vertex: a small card at the sun's direction on the
# far plane, added to the sky behind it, dimmed by the cloud in front and the fog.
SUN_VS = """
uniform mat4 p3d_ModelViewProjectionMatrix;
in vec4 p3d_Vertex;
in vec2 p3d_MultiTexCoord0;
out vec2 v_uv;
out vec3 v_colour;
void main() {
    gl_Position = (p3d_ModelViewProjectionMatrix * p3d_Vertex).xyww;
    v_uv = p3d_MultiTexCoord0 * 2.0 - 1.0;
#if CLOUDS
    float cover = cloud_density(textureLod(cloud_map, cloud_uv(sun_dir), 2.0).r, sun_dir);
#else
    float cover = 0.0;
#endif
    vec3 disc = sun_color * (SUN_DISC_GAIN * fog_through(sun_dir) * (1.0 - cover));
    v_colour = to_display(tone_map(disc));
}
"""

SUN_FS = """
in vec2 v_uv;
in vec3 v_colour;
out vec4 frag;
void main() {
    frag = vec4(v_colour * smoothstep(1.0, 1.0 / 1.3, length(v_uv)), 1.0);
}
"""

RAIN_VS = """
uniform mat4 p3d_ViewProjectionMatrix;
uniform mat4 p3d_ViewMatrixInverse;
uniform vec3 rain_box;    // [m] the streaks fill this box around the eye
uniform vec4 rain_fall;   // xyz travelled by a drop since t = 0 [m], w share of drops shown
uniform vec3 rain_step;   // [m] a streak's length and direction (the drop's motion blur)
in vec4 p3d_Vertex;       // a drop's place in the unit box
in vec4 p3d_Color;        // r: the drop's rank (shown when < rain_fall.w), g: 0 head, 1 tail
out float v_alpha;

void main() {
    vec3 eye = p3d_ViewMatrixInverse[3].xyz;
    vec3 p = p3d_Vertex.xyz * rain_box + rain_fall.xyz;
    p = eye + (fract((p - eye) / rain_box + 0.5) - 0.5) * rain_box;  // wrap around the eye
    p += rain_step * p3d_Color.g;
    v_alpha = step(p3d_Color.r, rain_fall.w) * (1.0 - 0.7 * p3d_Color.g);
    gl_Position = p3d_ViewProjectionMatrix * vec4(p, 1.0);
}
"""

RAIN_FS = """
in float v_alpha;
out vec4 frag;
void main() {
    // a drop shows the world around it squeezed (bright sky, dark ground): about its mean
    vec3 c = sky_horizon * 0.55 + sky_ambient * 0.25;
    frag = vec4(to_display(tone_map(c)), RAIN_ALPHA * v_alpha);
}
"""

GLARE_VS = """
uniform mat4 p3d_ModelViewProjectionMatrix;
uniform mat4 p3d_ModelMatrix;
in vec4 p3d_Vertex;
in vec4 p3d_Color;
in vec2 p3d_MultiTexCoord0;
out vec2 v_uv;
out vec3 v_pos;
out float v_level;
void main() {
    gl_Position = p3d_ModelViewProjectionMatrix * p3d_Vertex;
    v_pos = (p3d_ModelMatrix * p3d_Vertex).xyz;
    v_uv = p3d_MultiTexCoord0;
    v_level = p3d_Color.r;
}
"""

GLARE_FS = """
uniform mat4 p3d_ViewMatrixInverse;
in vec2 v_uv;
in vec3 v_pos;
in float v_level;
out vec4 frag;
void main() {
    float r2 = dot(v_uv - 0.5, v_uv - 0.5) * 4.0;
    float glow = exp(-r2 * 9.0) + 0.25 * exp(-r2 * 2.5);
    float through = exp(-fog.a * length(p3d_ViewMatrixInverse[3].xyz - v_pos));
    frag = vec4(HEAD_RGB * (glow * v_level * through), 1.0);  // added to what lies behind
}
"""


def sky_sources(preset: Preset) -> tuple[str, str]:
    return program(preset, SKY_COMMON, SKY_VS), program(preset, SKY_COMMON, SKY_FS)


def sun_sources(preset: Preset) -> tuple[str, str]:
    return program(preset, SKY_COMMON, SUN_VS), program(preset, SKY_COMMON, SUN_FS)
