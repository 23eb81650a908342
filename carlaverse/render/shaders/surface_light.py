"""What a surface point sends towards the eye: `light()`, split into the part the sun adds
(a shadow removes it) and the rest (sky, street lights, headlights, the sky's reflection);
`surface_at()`, how a wet surface darkens, smooths and mirrors.

The last part of `COMMON` (`program.py`): it calls the optics and the night's lights.
"""

SURFACE_LIGHT = """
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
