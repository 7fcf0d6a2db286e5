// SPDX-License-Identifier: GPL-3.0-or-later
// Level 0 of the cube map's hit-interval pyramid (include/cube_march.glsl, "Hierarchical
// march"): for each texel of each face the NDC depths (A, B) of the interval a ray must
// reach to hit the surface stored there; CUBE_HIZ_EMPTY where nothing is stored and in the
// padding up to the power-of-two face size u_cube_hiz_res.
//
// With CUBE_FOOTPRINT_BUILD, also the surface footprints' level 0 and planes
// (include/cube_march.glsl, "Surface footprints"): per texel the plane of the stored surface
// through its stored point, with the geometric normal the face keeps, as (the plane's depth
// plus its share of the bias at the texel's centre, its slopes d/dx, d/dy in NDC, the
// material index), and the least A(x, y) over the texel's square with B.
//
// Storage block MaterialBuffer (thickness in params.y); image u_level0, the pyramid's level 0
//   (rg32f); with CUBE_FOOTPRINT_BUILD, images u_footprint0 (rg32f: the footprints' level 0)
//   and u_planes (rgba32f, the atlas's size), and sampler u_cube_geometric (the faces'
//   octahedral geometric normals).
// Uniforms: those of cube_march.glsl.
#include "scene_layout.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430) readonly buffer MaterialBuffer { Material materials[]; };

#include "cube_march.glsl"

layout(rg32f) writeonly uniform image2D u_level0;

#ifdef CUBE_FOOTPRINT_BUILD
#include "octahedral.glsl"

layout(rg32f) writeonly uniform image2D u_footprint0;
layout(rgba32f) writeonly uniform image2D u_planes;
uniform sampler2D u_cube_geometric;

// The plane of the surface stored at `atlas_texel` of `face` (see the header).
vec4 texel_plane(ivec2 atlas_texel, int face) {
    vec4 nm = texelFetch(u_cube_normal_material, atlas_texel, 0);
    float stored_z = texelFetch(u_cube_depth, atlas_texel, 0).r * 2.0 - 1.0;
    vec3 ndc = vec3(cube_texel_center(atlas_texel, face), stored_z);
    vec3 normal = normalize(nm.xyz);
    vec2 g_oct = texelFetch(u_cube_geometric, atlas_texel, 0).xy;
    vec3 g = gbuffer_geometric(g_oct.x, g_oct.y, normal);
    float surface = cube_linear_depth(stored_z);
    // The plane through the stored point in NDC: (pi M^-1) . (x, y, z, 1) = 0 for the world
    // plane pi = (g, -g . p), so z = z_c + dz/dx (x - x_c) + dz/dy (y - y_c).
    vec3 p = cube_unproject(face, ndc);
    vec4 pi_ndc = vec4(g, -dot(g, p)) * u_face_inv_view_proj[face];
    // The slope -pi_ndc.xy / pi_ndc.z, capped at CUBE_FOOTPRINT_MAX_SLOPE texel angles of
    // linear depth per texel: (dz/dr) r slope tan(half fov) per NDC unit at depth r.
    float n = u_cube_near;
    float f = u_cube_far;
    float cap = 2.0 * f * n / ((f - n) * surface) * CUBE_TAN_HALF_FOV * CUBE_FOOTPRINT_MAX_SLOPE;
    float lateral = length(pi_ndc.xy);
    vec2 slope = lateral <= cap * abs(pi_ndc.z)
        ? -pi_ndc.xy / pi_ndc.z
        : -(pi_ndc.z < 0.0 ? -1.0 : 1.0) * cap / max(lateral, 1e-30) * pi_ndc.xy;
    float bias = cube_depth_bias(face, ndc, surface, normal);
    float relative = surface * CUBE_BIAS_RELATIVE;
    float a = cube_ndc_depth(surface + relative + CUBE_FOOTPRINT_BIAS * (bias - relative));
    return vec4(a, slope, float(int(abs(nm.w) + 0.5) - 1));
}
#endif

void main() {
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (texel.x >= 6 * u_cube_hiz_res || texel.y >= u_cube_hiz_res) return;
    int face = cube_face_of_column(texel.x, u_cube_hiz_res);
    ivec2 local = texel - ivec2(face * u_cube_hiz_res, 0);
    vec2 ab = CUBE_HIZ_EMPTY;
    bool in_face = all(lessThan(local, ivec2(u_cube_res)));
    if (in_face) {
        ab = cube_hit_interval(ivec2(face * u_cube_res, 0) + local);
    }
    imageStore(u_level0, texel, vec4(ab, 0.0, 0.0));
#ifdef CUBE_FOOTPRINT_BUILD
    vec2 span = CUBE_HIZ_EMPTY;
    if (in_face) {
        ivec2 atlas_texel = ivec2(face * u_cube_res, 0) + local;
        vec4 plane = vec4(CUBE_HIZ_EMPTY.x, 0.0, 0.0, -1.0);
        if (ab.x <= ab.y) {
            plane = texel_plane(atlas_texel, face);
            // The plane's nearest point over the texel's square (half a texel is 1 / res
            // in NDC); A(x, y) never lies past A, nor therefore past B.
            float reach = (abs(plane.y) + abs(plane.z)) / float(u_cube_res);
            span = vec2(min(ab.x, plane.x - reach), ab.y);
        }
        imageStore(u_planes, atlas_texel, plane);
    }
    imageStore(u_footprint0, texel, vec4(span, 0.0, 0.0));
#endif
}
