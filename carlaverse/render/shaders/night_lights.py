"""The night's lights on a surface: the vehicles' headlamp beams (`headlights.py` hands over
the nearest lamps) and the street lights' pools, baked into a map (`street_lights.py`).

Compiled in only by night (`NIGHT`) and where the preset has them (`HEADLIGHTS`,
`STREET_LIGHTS`): by day they cost nothing. Parts of `COMMON` (`program.py`), after `OPTICS`.
"""

HEADLAMP_BEAMS = """
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
"""

STREET_LIGHT_POOLS = """
#if NIGHT && STREET_LIGHTS
uniform sampler2D street_map;  // irradiance on the ground from every street light
uniform vec4 street_rect;      // x0, y0 [m], 1/width, 1/height [1/m]
vec3 street_light(vec3 pos, vec3 N) {
    vec2 uv = (pos.xy - street_rect.xy) * street_rect.zw;
    float e = textureLod(street_map, uv, 0.0).r * max(N.z, 0.0) * smoothstep(3.0, 0.0, pos.z);
    return STREET_RGB * (e * night);
}
#endif
"""
