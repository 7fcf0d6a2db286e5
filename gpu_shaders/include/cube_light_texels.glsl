// SPDX-License-Identifier: GPL-3.0-or-later
// The surfaces of the cube map's texels as the cube_light pass shades them
// (hybrid_engine/passes/cube_light/): a texel's position, normals and material, and the
// representative texel of each block of the World-light gather (one cosine ray per block of
// CUBE_GATHER_BLOCK x CUBE_GATHER_BLOCK texels per frame).
//
// Needs cube_march.glsl (its uniforms and samplers) and u_cube_geometric (the faces'
// octahedral geometric normals, cube_map.CubeFaceTargets).
#ifndef HYBRID_CUBE_LIGHT_TEXELS_GLSL
#define HYBRID_CUBE_LIGHT_TEXELS_GLSL
#include "octahedral.glsl"

#define CUBE_GATHER_BLOCK 4

uniform sampler2D u_cube_geometric;

// The width one texel of the map spans at point p: the footprint at which the faces' raster
// textures the surface there, and a node program's dP.
float cube_texel_footprint(vec3 p) {
    return distance(p, u_cube_center) * 2.0 * CUBE_TAN_HALF_FOV / float(u_cube_res);
}

// The map's texel at the centre of gather block `block` of a face (clamped into the face).
ivec2 cube_gather_texel(ivec2 block) {
    return min(block * CUBE_GATHER_BLOCK + CUBE_GATHER_BLOCK / 2, ivec2(u_cube_res - 1));
}

// The surface stored at atlas texel `atlas` of `face` (its normal/material `nm`, w != 0):
// its world position, reconstructed from the face's depth at the texel's centre.
vec3 cube_texel_position(int face, ivec2 atlas) {
    vec2 local = vec2(atlas - ivec2(face * u_cube_res, (atlas.y >= u_cube_res ? u_cube_res : 0))) + 0.5;
    vec2 ndc_xy = local / float(u_cube_res) * 2.0 - 1.0;
    return cube_unproject(face, vec3(ndc_xy, texelFetch(u_cube_depth, atlas, 0).r * 2.0 - 1.0));
}

// The shading and geometric normals of the surface at `atlas`, turned to the side the map's
// centre sees (the side the camera sees, lit and looked at); on the back layer
// (CUBE_BACK_LAYER, rows past the first) the far side of a closed object, turned away from it.
void cube_texel_normals(ivec2 atlas, vec4 nm, vec3 p, out vec3 n_facing, out vec3 g_facing) {
    vec3 to_center = atlas.y >= u_cube_res ? p - u_cube_center : u_cube_center - p;
    vec3 n = normalize(nm.xyz);
    vec2 g_oct = texelFetch(u_cube_geometric, atlas, 0).xy;
    vec3 g = gbuffer_geometric(g_oct.x, g_oct.y, n);
    g_facing = dot(g, to_center) >= 0.0 ? g : -g;
    n_facing = dot(n, g_facing) >= 0.0 ? n : -n;
}

#endif
