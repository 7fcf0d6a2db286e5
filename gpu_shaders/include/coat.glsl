// SPDX-License-Identifier: GPL-3.0-or-later
// The dielectric coat's directional albedo and its inverse, shared by the shading model
// (shading.glsl: how much light the diffuse layer's coat reflects) and by the node programs'
// closure (node_program.glsl: which coat reflects as much as a graph's Glossy layer weighs
// at the shading point, so that a Diffuse and a Glossy mixed by a Fresnel render as two
// lobes, the red diffuse under a white gloss).
#ifndef HYBRID_COAT_GLSL
#define HYBRID_COAT_GLSL

// The split-sum DFG term of Karis 2014's fit at cos_v and roughness: (scale, bias); the
// coat reflects f0 * scale + bias.
vec2 coat_dfg(float cos_v, float roughness) {
    const vec4 c0 = vec4(-1.0, -0.0275, -0.572, 0.022);
    const vec4 c1 = vec4(1.0, 0.0425, 1.04, -0.04);
    vec4 r = roughness * c0 + c1;
    float a004 = min(r.x * r.x, exp2(-9.28 * cos_v)) * r.x + r.y;
    return vec2(-1.04, 1.04) * a004 + r.zw;
}

// The specular coat's directional albedo: the share of light it reflects at cos_v and
// roughness. Reflectances below 2 % fade the grazing bias out with them (a coat of level 0
// reflects nothing).
float coat_reflectance(float f0, float cos_v, float roughness) {
    if (!(f0 > 0.0)) return 0.0;
    vec2 ab = coat_dfg(cos_v, roughness);
    return clamp(f0 * ab.x + clamp(50.0 * f0, 0.0, 1.0) * ab.y, 0.0, 1.0);
}

// The f0 whose coat reflects `reflectance` at cos_v and roughness (coat_reflectance's
// inverse; clamped to [0, 1] where no coat reflects that much).
float coat_f0_for(float reflectance, float cos_v, float roughness) {
    if (!(reflectance > 0.0)) return 0.0;
    vec2 ab = coat_dfg(cos_v, roughness);
    // Below f0 = 0.02 the bias fades in linearly with f0: reflectance = f0 (scale + 50 bias).
    float faded = ab.x + 50.0 * ab.y;
    if (faded > 0.0 && reflectance < 0.02 * faded) return reflectance / faded;
    return ab.x > 1e-6 ? clamp((reflectance - ab.y) / ab.x, 0.0, 1.0) : 1.0;
}

#endif
