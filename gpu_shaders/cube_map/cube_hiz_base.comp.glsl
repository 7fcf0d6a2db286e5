// SPDX-License-Identifier: GPL-3.0-or-later
// Level 0 of the cube map's hit-interval pyramid (include/cube_march.glsl, "Hierarchical
// march"): for each texel of each face the NDC depths (A, B) of the interval a ray must
// reach to hit the surface stored there; CUBE_HIZ_EMPTY where nothing is stored and in the
// padding up to the power-of-two face size u_cube_hiz_res.
//
// Storage block MaterialBuffer (thickness in params.y); image u_level0, the pyramid's level 0
//   (rg32f).
// Uniforms: those of cube_march.glsl.
#include "scene_layout.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430) readonly buffer MaterialBuffer { Material materials[]; };

#include "cube_march.glsl"

layout(rg32f) writeonly uniform image2D u_level0;

void main() {
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (texel.x >= 6 * u_cube_hiz_res || texel.y >= u_cube_hiz_res) return;
    int face = cube_face_of_column(texel.x, u_cube_hiz_res);
    ivec2 local = texel - ivec2(face * u_cube_hiz_res, 0);
    vec2 ab = CUBE_HIZ_EMPTY;
    if (all(lessThan(local, ivec2(u_cube_res)))) {
        ab = cube_hit_interval(ivec2(face * u_cube_res, 0) + local);
    }
    imageStore(u_level0, texel, vec4(ab, 0.0, 0.0));
}
