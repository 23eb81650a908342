"""The optics every program shares: colour space (sRGB γ 2.2 to linear and back), tone
mapping, the clear sky's radiance in a direction, fog, and a rough surface's specular
reflection (Cook-Torrance).

The second part of `COMMON` (`program.py`): these read `SCENE_INPUTS`.
"""

OPTICS = """
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
"""
