// SPDX-License-Identifier: GPL-3.0-or-later
// Shadow-map depth pass, fragment stage: depth only, no colour target.
// ALPHA_TEST defined (scenes with alpha only, MaterialTable.has_alpha): a fragment of a
// material with alpha is discarded with the probability it is not there (alpha.glsl), drawn
// per texel and depth, not per sample: the maps are cached across frames
// (shadow_cache.py), so a partly covering surface casts a fixed dithered shadow that the
// shadow filter averages. Opaque scenes compile no discard (the early depth test stays).
#ifdef ALPHA_TEST
#include "alpha.glsl"
layout(std430) readonly buffer MaterialBuffer { Material materials[]; };
#ifdef INSTANCED
layout(std430) readonly buffer TriangleMaterials { int triangle_materials[]; };
flat in int v_first_row;
#else
flat in int v_material;
#endif
in vec2 v_uv;
#endif

void main() {
#ifdef ALPHA_TEST
#ifdef INSTANCED
    Material m = materials[triangle_materials[v_first_row + gl_PrimitiveID]];
#else
    Material m = materials[v_material];
#endif
    // Derivatives outside any branch (undefined in non-uniform control flow).
    vec2 duv_dx = dFdx(v_uv);
    vec2 duv_dy = dFdy(v_uv);
    if (material_has_alpha(m) && !alpha_kept(material_alpha_grad(m, v_uv, duv_dx, duv_dy),
            uvec4(uvec2(gl_FragCoord.xy), 0x5bd1e995u, floatBitsToUint(gl_FragCoord.z)))) {
        discard;
    }
#endif
}
