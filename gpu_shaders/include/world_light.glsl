// SPDX-License-Identifier: GPL-3.0-or-later
// Light from the World on diffuse surfaces: the sky's irradiance as nine spherical-harmonic
// coefficients (Ramamoorthi and Hanrahan 2001), already convolved with the clamped cosine,
// written by lighting/sky_irradiance.comp.glsl whenever the World changes
// (hybrid_engine/passes/lighting/sky_light.py). Evaluating them costs nine multiply-adds per hit, on every
// diffuse hit alike: primary pixels, BVH hits and cube-map hits.
//
// Storage block SkyIrradiance: vec4[9] (rgb used).
layout(std430) readonly buffer SkyIrradiance { vec4 sky_sh[9]; };

// Irradiance (W/m^2 per unit radiance) arriving at a surface of unit normal n from the whole
// unoccluded sky.
vec3 sky_irradiance(vec3 n) {
    // sh9_basis written out: an indexed array would live in memory on a software GL.
    vec3 e = 0.282095 * sky_sh[0].rgb
           + 0.488603 * (n.y * sky_sh[1].rgb + n.z * sky_sh[2].rgb + n.x * sky_sh[3].rgb)
           + 1.092548 * (n.x * n.y * sky_sh[4].rgb + n.y * n.z * sky_sh[5].rgb + n.x * n.z * sky_sh[7].rgb)
           + 0.315392 * (3.0 * n.z * n.z - 1.0) * sky_sh[6].rgb
           + 0.546274 * (n.x * n.x - n.y * n.y) * sky_sh[8].rgb;
    return max(e, vec3(0.0));
}
