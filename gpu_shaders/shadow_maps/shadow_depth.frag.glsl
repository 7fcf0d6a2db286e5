// SPDX-License-Identifier: GPL-3.0-or-later
// Shadow-map depth pass, fragment stage: depth only, no colour target.
// ALPHA_TEST defined (scenes with alpha only, MaterialTable.has_alpha): a fragment of a
// material with alpha is discarded with the probability it is not there (alpha.glsl), drawn
// per texel and depth, not per sample: the maps are cached across frames
// (shadow_cache.py), so a partly covering surface casts a fixed dithered shadow that the
// shadow filter averages. Opaque scenes compile no discard (the early depth test stays).
// NODE_PROGRAMS with it (GPUScene.defines: some material has a closure alpha): a material's
// alpha program (alpha.glsl) gives its coverage, evaluated as for a shadow ray.
#ifdef ALPHA_TEST
#ifdef NODE_PROGRAMS
#include "node_program.glsl"
#endif
#include "alpha.glsl"
layout(std430) readonly buffer MaterialBuffer { Material materials[]; };
#ifdef INSTANCED
layout(std430) readonly buffer TriangleMaterials { int triangle_materials[]; };
flat in int v_first_row;
#else
flat in int v_material;
#endif
in vec2 v_uv;
#ifdef NODE_PROGRAMS
in vec3 v_world;
in vec3 v_seen_along;  // away from the lamp: the shadow ray's Incoming (shadow_depth.vert.glsl)
#ifndef INSTANCED
flat in int v_row;
#endif
#endif
#endif

void main() {
#ifdef ALPHA_TEST
#ifdef INSTANCED
    int material = triangle_materials[v_first_row + gl_PrimitiveID];
#else
    int material = v_material;
#endif
    Material m = materials[material];
    // Derivatives outside any branch (undefined in non-uniform control flow).
    vec2 duv_dx = dFdx(v_uv);
    vec2 duv_dy = dFdy(v_uv);
#ifdef NODE_PROGRAMS
    vec3 plane = cross(dFdx(v_world), dFdy(v_world));
#endif
    if (material_has_alpha(m)) {
        // -- closure alpha: the alpha program at the texel's point, as a shadow ray from a
        // camera ray's point meets it (Incoming along the lamp's view, Is Shadow Ray, Ray
        // Depth 1)
#ifdef NODE_CLOSURE_ALPHA
#ifdef INSTANCED
        int row = v_first_row + gl_PrimitiveID;
#else
        int row = v_row;
#endif
        float alpha = material_fragment_alpha(m, v_uv, duv_dx, duv_dy, v_world, plane,
                                              node_unit(v_seen_along, vec3(0.0)), row, material,
                                              node_shadow_ray_depth(0));
#else
        float alpha = material_alpha_grad(m, v_uv, duv_dx, duv_dy);
#endif
        // -- end of closure alpha
        if (!alpha_kept(alpha, uvec4(uvec2(gl_FragCoord.xy), 0x5bd1e995u, floatBitsToUint(gl_FragCoord.z)))) {
            discard;
        }
    }
#endif
}
