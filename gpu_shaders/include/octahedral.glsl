// SPDX-License-Identifier: GPL-3.0-or-later
// Unit vectors as two numbers in [-1, 1] (octahedral mapping), so that a direction fits the
// two spare half-float channels of the G-buffer (gbuffer/gbuffer.frag.glsl stores the
// triangle's geometric normal there). Half precision keeps it within about 1e-3 radians,
// which is all its one use needs: telling which side of the true surface a ray leaves on.
#ifndef HYBRID_OCTAHEDRAL_GLSL
#define HYBRID_OCTAHEDRAL_GLSL

vec2 octahedral_encode(vec3 n) {
    vec3 a = n / max(abs(n.x) + abs(n.y) + abs(n.z), 1e-30);
    if (a.z < 0.0) {
        vec2 s = vec2(a.x >= 0.0 ? 1.0 : -1.0, a.y >= 0.0 ? 1.0 : -1.0);
        a.xy = (1.0 - abs(a.yx)) * s;
    }
    return a.xy;
}

vec3 octahedral_decode(vec2 e) {
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    if (n.z < 0.0) {
        vec2 s = vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
        n.xy = (1.0 - abs(n.yx)) * s;
    }
    return normalize(n);
}

// The geometric normal a G-buffer texel keeps in the alphas of its albedo and emission
// targets (gbuffer/gbuffer.frag.glsl); `fallback` where they do not decode to a direction.
vec3 gbuffer_geometric(float albedo_alpha, float emission_alpha, vec3 fallback) {
    vec2 e = vec2(albedo_alpha, emission_alpha);
    if (any(isnan(e)) || any(greaterThan(abs(e), vec2(1.0 + 1e-3)))) return fallback;
    return octahedral_decode(clamp(e, -1.0, 1.0));
}

#endif
