"""The surface program lit per vertex (`cpu`, for llvmpipe, whose fragment work is the frame).

The vertex shader lights, fogs and tone maps each vertex twice — in shadow and in sun — and
the fragment shader only mixes the two by the shadow map and multiplies the texture, as
fixed-function drawing modulates a texture. Smooth terms come out the same as per pixel;
highlights are left to wet ground. By night a road's vertex hands over linear light instead
and the fragment adds the nearest vehicle's headlights — the camera's own: a beam's pool on a
road cut every 5 m needs pixels — and tone-maps; other vehicles' beams light the vertices.
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
