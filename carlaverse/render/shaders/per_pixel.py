"""The surface program lit per pixel (`full`, for a GPU): the fragment shader lights every
pixel, then fogs and tone maps it.
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
