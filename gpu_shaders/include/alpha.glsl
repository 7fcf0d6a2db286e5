// SPDX-License-Identifier: GPL-3.0-or-later
// Alpha as Blender defines it: the fraction of a surface that is there (the Principled BSDF's
// Alpha, a Transparent BSDF mixed in by a factor; hybrid_engine/scene/data.py MaterialTable).
// Cycles treats it as coverage: a path meets the surface with probability alpha and passes
// through it otherwise. Every pass that sees surfaces does the same, stochastically: a
// fragment or a BVH hit is kept when alpha exceeds a uniform number drawn from a hash of where
// and when it is seen (pixel and sample in the G-buffer, the ray in the traversal), so one
// sample is a dithered cut-out and the accumulated samples converge to the fractional
// coverage. Alpha 1 is always kept (the number is below 1), alpha 0 never.
//
// Material fields (scene_layout.glsl): params2.x = alpha factor; textures2.z = alpha image,
// layer * 4 + channel (0..2 red, green, blue, 3 its alpha), -1 none; params2.y > 0: the
// image's value is clipped at that threshold first (glTF's MASK mode as Blender's importer
// builds it: 1 - (alpha < cutoff)).
//
// Compiled only into the variants a scene with alpha asks for (ALPHA_TEST, set by the passes
// when MaterialTable.has_alpha): a fragment shader that may discard loses the early depth
// test, and a traversal that fetches a texture per candidate hit costs the opaque scenes
// nothing only when it is not there at all.
#ifndef HYBRID_ALPHA_GLSL
#define HYBRID_ALPHA_GLSL
#include "scene_layout.glsl"
#include "textures.glsl"
#include "random.glsl"

bool material_has_alpha(Material m) { return m.params2.x < 1.0 || m.textures2.z >= 0; }

// The coverage given the alpha image's texel.
float material_alpha_of_texel(Material m, vec4 texel) {
    float value = texel[m.textures2.z & 3];
    if (m.params2.y > 0.0) value = value >= m.params2.y ? 1.0 : 0.0;
    return clamp(m.params2.x * value, 0.0, 1.0);
}

// The coverage at uv: with UV derivatives (fragment stages) or at a mip level (traversal).
float material_alpha_grad(Material m, vec2 uv, vec2 duv_dx, vec2 duv_dy) {
    if (m.textures2.z < 0) return m.params2.x;
    return material_alpha_of_texel(m, textureGrad(u_textures, vec3(uv, float(m.textures2.z >> 2)), duv_dx, duv_dy));
}
float material_alpha_lod(Material m, vec2 uv, float lod) {
    if (m.textures2.z < 0) return m.params2.x;
    return material_alpha_of_texel(m, textureLod(u_textures, vec3(uv, float(m.textures2.z >> 2)), lod));
}

// Whether a surface of coverage `alpha` is there for this draw: `key` names the pixel (or
// ray), the sample and the layer, so stacked surfaces and successive samples draw
// independent numbers.
bool alpha_kept(float alpha, uvec4 key) {
    return alpha > random2(key).x;
}

#endif
