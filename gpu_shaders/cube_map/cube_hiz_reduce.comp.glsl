// SPDX-License-Identifier: GPL-3.0-or-later
// One coarser level of the cube map's hit-interval pyramid (include/cube_march.glsl,
// "Hierarchical march"): each cell keeps the smallest A and the largest B of its 2 x 2
// children, so a ray whose depth range misses (min A, max B] misses every texel below.
// Faces are power-of-two squares, so no cell straddles two faces.
//
// Images: u_finer, the finer level (read), u_coarser, this level (write), both rg32f; with
// CUBE_FOOTPRINT_BUILD the surface footprints' pyramid (include/cube_march.glsl) alike in the
// same dispatch, u_footprint_finer and u_footprint_coarser.
// Uniforms: u_size, this level's atlas size in cells.
layout(local_size_x = 8, local_size_y = 8) in;

layout(rg32f) readonly uniform image2D u_finer;
layout(rg32f) writeonly uniform image2D u_coarser;

uniform ivec2 u_size;

#ifdef CUBE_FOOTPRINT_BUILD
layout(rg32f) readonly uniform image2D u_footprint_finer;
layout(rg32f) writeonly uniform image2D u_footprint_coarser;
#endif

void main() {
    ivec2 cell = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(cell, u_size))) return;
    ivec2 child = cell * 2;
    vec2 a = imageLoad(u_finer, child).rg;
    vec2 b = imageLoad(u_finer, child + ivec2(1, 0)).rg;
    vec2 c = imageLoad(u_finer, child + ivec2(0, 1)).rg;
    vec2 d = imageLoad(u_finer, child + ivec2(1, 1)).rg;
    imageStore(u_coarser, cell, vec4(min(min(a.x, b.x), min(c.x, d.x)),
                                     max(max(a.y, b.y), max(c.y, d.y)), 0.0, 0.0));
#ifdef CUBE_FOOTPRINT_BUILD
    a = imageLoad(u_footprint_finer, child).rg;
    b = imageLoad(u_footprint_finer, child + ivec2(1, 0)).rg;
    c = imageLoad(u_footprint_finer, child + ivec2(0, 1)).rg;
    d = imageLoad(u_footprint_finer, child + ivec2(1, 1)).rg;
    imageStore(u_footprint_coarser, cell, vec4(min(min(a.x, b.x), min(c.x, d.x)),
                                               max(max(a.y, b.y), max(c.y, d.y)), 0.0, 0.0));
#endif
}
