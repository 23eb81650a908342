"""What both surface programs share: the view and the material's start (`SURFACE_HEAD`), the
vertex inputs (`VERTEX_IN`), the sun's shadow-map lookup (`SHADOW_LOOKUP`) and lit windows
(`EMISSION`).

A node whose lights are all off (`set_light_off`: lamps, signal heads) is emissive: Panda3D
hands such a node an ambient of (1, 1, 1, 1), while the scene's own ambient light has alpha 0.
Vertex colours and textures are sRGB, linearised with γ = 2.2.
"""

# In every stage of both programs: the view, the material's start and the shadow map's inputs.
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
