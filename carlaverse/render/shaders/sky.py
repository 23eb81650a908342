"""The sky's GLSL: the dome drawn around the eye (`sky_dome.py`) and, where the sky is lit
per vertex, the sun's disc on a card of its own. Built with `program.program`, so the sky
shares the surfaces' colour space, tone mapping, sky radiance and fog (`program.COMMON`).
"""

from __future__ import annotations

from carlaverse.render.quality import Preset
from carlaverse.render.shaders.program import program

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


def sky_sources(preset: Preset) -> tuple[str, str]:
    """Vertex and fragment source of the sky dome for this preset."""
    return program(preset, SKY_COMMON, SKY_VS), program(preset, SKY_COMMON, SKY_FS)


def sun_sources(preset: Preset) -> tuple[str, str]:
    """Vertex and fragment source of the sun's card (presets lighting the sky per vertex)."""
    return program(preset, SKY_COMMON, SUN_VS), program(preset, SKY_COMMON, SUN_FS)
