// SPDX-License-Identifier: GPL-3.0-or-later
// Light from the World on diffuse surfaces: the sky's irradiance as nine spherical-harmonic
// coefficients (Ramamoorthi and Hanrahan 2001), already convolved with the clamped cosine,
// written by lighting/sky_irradiance.comp.glsl whenever the World changes
// (hybrid_engine/sky_light.py). Evaluating them costs nine multiply-adds per hit, on every
// diffuse hit alike: primary pixels, BVH hits and cube-map hits.
//
// Binding: SSBO 9, vec4[9] (rgb used).
#ifndef SKY_SH_BINDING
#define SKY_SH_BINDING 9
#endif
layout(std430, binding = SKY_SH_BINDING) readonly buffer SkyIrradiance { vec4 sky_sh[9]; };
#include "sh9.glsl"

// Irradiance (W/m^2 per unit radiance) arriving at a surface of unit normal n from the whole
// unoccluded sky.
vec3 sky_irradiance(vec3 n) {
    float y[9];
    sh9_basis(n, y);
    vec3 e = vec3(0.0);
    for (int i = 0; i < 9; ++i) e += sky_sh[i].rgb * y[i];
    return max(e, vec3(0.0));
}
