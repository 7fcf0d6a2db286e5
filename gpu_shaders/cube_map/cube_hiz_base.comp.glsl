// SPDX-License-Identifier: GPL-3.0-or-later
// Level 0 of the cube map's hit-interval pyramid (include/cube_march.glsl, "Hierarchical
// march"): for each texel of each face the NDC depths (A, B) of the interval a ray must
// reach to hit the surface stored there; CUBE_HIZ_EMPTY where nothing is stored and in the
// padding up to the power-of-two face size u_cube_hiz_res.
//
// With CUBE_FOOTPRINT_BUILD, also the surface footprints (include/cube_march.glsl, "Surface
// footprints"): per texel the plane P of the stored surface through its stored point, with
// the geometric normal the face keeps; the footprints' level 0 holds the least A(x, y) over
// the texel's square and B, u_planes the plane's NDC slopes d/dx, d/dy and A less that least
// A(x, y).
//
// Storage block MaterialBuffer (thickness in params.y); image u_level0, the pyramid's level 0
//   (rg32f); with CUBE_FOOTPRINT_BUILD, images u_footprint0 (rg32f: the footprints' level 0)
//   and u_planes (rgba16f), and sampler u_cube_geometric (the faces' octahedral geometric
//   normals).
// Uniforms: those of cube_march.glsl.
#include "scene_layout.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430) readonly buffer MaterialBuffer { Material materials[]; };

#include "cube_march.glsl"

layout(rg32f) writeonly uniform image2D u_level0;

#ifdef CUBE_FOOTPRINT_BUILD
#include "octahedral.glsl"

layout(rg32f) writeonly uniform image2D u_footprint0;
layout(rgba16f) writeonly uniform image2D u_planes;
uniform sampler2D u_cube_geometric;

// The plane (see the header) of the surface stored at `atlas_texel` of `face`, at NDC point
// `ndc` and linear depth `surface`, with shading normal `nm` and hit interval starting at
// linear depth `a`: (P + e at the texel's centre, dP/dx, dP/dy), NDC. In the face's view
// axes (right, up, forward), the plane with normal n through the point seen at depth r along
// (u, v, 1), (u, v) = NDC xy tan(half fov), meets the line of sight through NDC (x, y) where
// 1 / w = (n.right x + n.up y) tan(half fov) / (r facing) + ..., facing = n . (u, v, 1), and
// the NDC depth (f + n) / (f - n) - 2 f n / ((f - n) w) is affine in 1 / w.
vec3 texel_plane(ivec2 atlas_texel, int face, vec3 ndc, float surface, vec4 nm, float a) {
    vec2 g_oct = texelFetch(u_cube_geometric, atlas_texel, 0).xy;
    vec3 g = gbuffer_geometric(g_oct.x, g_oct.y, normalize(nm.xyz));
    mat4 m = u_face_view_proj[face];
    vec3 right = normalize(vec3(m[0][0], m[1][0], m[2][0]));
    vec3 up = normalize(vec3(m[0][1], m[1][1], m[2][1]));
    vec3 forward = vec3(m[0][3], m[1][3], m[2][3]);
    vec2 lateral = vec2(dot(g, right), dot(g, up));
    float facing = dot(g, (ndc.x * right + ndc.y * up) * CUBE_TAN_HALF_FOV + forward);
    // |lateral| / |facing|: the linear depth's change across a texel in texel angles at its
    // depth (cube_depth_bias's slope), capped at CUBE_FOOTPRINT_MAX_SLOPE.
    float lateral_len = length(lateral);
    float steep = min(lateral_len / max(abs(facing), 1e-30), CUBE_FOOTPRINT_MAX_SLOPE);
    vec2 along = lateral_len > 0.0 ? lateral / lateral_len : vec2(0.0);
    float n = u_cube_near;
    float f = u_cube_far;
    vec2 slope = (facing < 0.0 ? 2.0 : -2.0) * f * n / ((f - n) * surface) * CUBE_TAN_HALF_FOV * steep * along;
    float relative = surface * CUBE_BIAS_RELATIVE;
    float start = cube_ndc_depth(surface + relative + CUBE_FOOTPRINT_BIAS * (a - surface - relative));
    return vec3(start, slope);
}
#endif

void main() {
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (texel.x >= 6 * u_cube_hiz_res || texel.y >= u_cube_hiz_res) return;
    int face = cube_face_of_column(texel.x, u_cube_hiz_res);
    ivec2 local = texel - ivec2(face * u_cube_hiz_res, 0);
    vec2 ab = CUBE_HIZ_EMPTY;
    bool in_face = all(lessThan(local, ivec2(u_cube_res)));
#ifndef CUBE_FOOTPRINT_BUILD
    if (in_face) {
        ab = cube_hit_interval(ivec2(face * u_cube_res, 0) + local);
    }
    imageStore(u_level0, texel, vec4(ab, 0.0, 0.0));
#else
    // cube_hit_interval's work, its fetches and linear interval kept for the plane.
    vec2 footprint = CUBE_HIZ_EMPTY;
    if (in_face) {
        ivec2 atlas_texel = ivec2(face * u_cube_res, 0) + local;
        vec4 nm = texelFetch(u_cube_normal_material, atlas_texel, 0);
        if (nm.w != 0.0) {
            float stored_z = texelFetch(u_cube_depth, atlas_texel, 0).r * 2.0 - 1.0;
            bool back;
            vec2 interval = cube_texel_interval(atlas_texel, nm, stored_z, back);
            ab = vec2(cube_ndc_depth(interval.x), cube_ndc_depth(interval.y));
            vec3 ndc = vec3(cube_texel_center(atlas_texel, face), stored_z);
            vec3 plane = texel_plane(atlas_texel, face, ndc, cube_linear_depth(stored_z), nm, interval.x);
            // The slopes as u_planes keeps them (float16), so that the march's plane, the
            // least A(x, y) plus what its slopes reach, is this one.
            plane.yz = unpackHalf2x16(packHalf2x16(plane.yz));
            // The plane's nearest point over the texel's square, never past A (P + e <= A at
            // the centre: e is a share of the bias).
            footprint = vec2(plane.x - cube_footprint_reach(plane.yz), ab.y);
            // A less the least A(x, y): small, so float16 keeps it to far below the bias.
            imageStore(u_planes, texel, vec4(plane.yz, ab.x - footprint.x, 0.0));
        }
    }
    imageStore(u_level0, texel, vec4(ab, 0.0, 0.0));
    imageStore(u_footprint0, texel, vec4(footprint, 0.0, 0.0));
#endif
}
