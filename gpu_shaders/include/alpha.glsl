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
// A material with a node graph whose closure has an alpha (a Transparent BSDF mixed in, a
// Principled Alpha the graph computes: scene/closure_alpha.py) has its own short alpha
// program instead: textures2.z = -2 - its first word (NODE_PROGRAMS only), params2.xy = 1, 0;
// material_closure_alpha runs it at the point the caller describes.
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

bool material_has_alpha(Material m) { return m.params2.x < 1.0 || m.textures2.z != -1; }

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

// -- closure alpha
// The includer includes node_program.glsl (under NODE_PROGRAMS) before this file; the
// code is compiled only where some material's coverage is a program (NODE_CLOSURE_ALPHA,
// GPUScene.defines), since a call into the programs weighs on every shader it is in.
#ifdef NODE_CLOSURE_ALPHA
bool material_has_closure_alpha(Material m) { return m.textures2.z <= -2; }

// The coverage the material's alpha program gives at a point: world position, unit shading
// normal as modelled, unit direction towards where the point is seen from (the camera, a
// shadow ray's receiver; the normal where no viewer is known: the cube faces), UV with its derivatives
// (fragment stages) or a mip level (lod >= 0: traversal), world row and material, and the
// ray depth (0: the camera's). The footprint and UV directions are left out: Bump and
// tangent-space Normal Maps do not reach a coverage.
float material_closure_alpha(Material m, vec3 position, vec3 normal, vec3 incoming, vec2 uv, vec2 duv_dx,
                             vec2 duv_dy, float lod, int row, int material, int depth) {
    ShadingPoint sp = node_plain_point(position, normal, normal, incoming, uv, lod, depth, row, material);
    sp.duv_dx = duv_dx;
    sp.duv_dy = duv_dy;
    return node_program_run(-2 - m.textures2.z, sp).alpha;
}

// A fragment's coverage: its alpha image's (or factor's), or its alpha program's where it has
// one, at `position` whose normal is `plane` (the shading normal, or the plane's from
// cross(dFdx(p), dFdy(p)) taken outside any branch; any length), seen from `incoming`, or
// along that normal where `incoming` is zero (no viewer at hand).
float material_fragment_alpha(Material m, vec2 uv, vec2 duv_dx, vec2 duv_dy, vec3 position, vec3 plane,
                              vec3 incoming, int row, int material, int depth) {
    if (!material_has_closure_alpha(m)) return material_alpha_grad(m, uv, duv_dx, duv_dy);
    bool viewer = dot(incoming, incoming) > 0.0;
    vec3 n = node_unit(plane, viewer ? incoming : vec3(0.0, 0.0, 1.0));
    return material_closure_alpha(m, position, n, viewer ? incoming : n, uv, duv_dx, duv_dy, -1.0, row, material,
                                  depth);
}
#endif
// -- end of closure alpha

// Whether a surface of coverage `alpha` is there for this draw: `key` names the pixel (or
// ray), the sample and the layer, so stacked surfaces and successive samples draw
// independent numbers.
bool alpha_kept(float alpha, uvec4 key) {
    return alpha > random2(key).x;
}

#endif
