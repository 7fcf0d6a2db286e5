// SPDX-License-Identifier: GPL-3.0-or-later
// A traced ray's hit in the cube map, lit from the lit cube map (LIT_CUBE;
// hybrid_engine/passes/cube_light/, cube_radiance.glsl) instead of shaded per ray: the
// diffuse, view-independent light the cube_light pass stored at the texel (the lamps through
// their shadow maps, the World's light times the sky the texel sees, and the light bounced
// from the other texels), read at the mip level whose texels span the ray's cone, so that a
// rough reflection of the cube map reads it prefiltered to its roughness. What depends on the
// view stays per ray: the lamps' highlights (here) and the reflected and refracted rays
// (trace_ray.glsl shade_hit), and so does the hit's emission, which the texels do not hold
// (cube_light_shade.comp.glsl): a rough reflection takes it at the point its sampled ray
// meets, as it does a surface in the BVH, and the film's samples average it.
//
// Included by trace_ray.glsl after its Hit struct and u_pixel_spread; needs shading.glsl.
#ifndef HYBRID_LIT_CUBE_GLSL
#define HYBRID_LIT_CUBE_GLSL
#include "cube_radiance.glsl"

// The light stored for cube-map hit h, averaged over a cone of `cone` radians seen from the
// map's centre (0: the texel itself). The texel is found again from the hit's position, so
// that a hit carries nothing more than it does without the lit cube map (the wave tracer's
// hit records, wave_hit.glsl, stay as they are).
vec3 cube_stored_radiance(Hit h, float cone) {
    int face;
    ivec2 local;
    float axial;
    cube_locate(h.position, u_cube_center, face, local, axial);
    int row = cube_layer_of(face, local, axial);
    // A hit the march found where the ray entered a texel (a surface stretched by its
    // thickness, met from the side) lies on that texel's edge, and its position may round
    // into the neighbour: the nearest texel around that holds the hit's material is its own.
    ivec2 base = ivec2(face * u_cube_res, row * u_cube_res);
    if (int(abs(texelFetch(u_cube_normal_material, base + local, 0).w) + 0.5) - 1 != h.material) {
        for (int k = 0; k < 8; ++k) {
            ivec2 step = ivec2(k < 3 ? k - 1 : k < 5 ? (k == 3 ? -1 : 1) : k - 6, k < 3 ? -1 : k < 5 ? 0 : 1);
            ivec2 near_texel = clamp(local + step, ivec2(0), ivec2(u_cube_res - 1));
            if (int(abs(texelFetch(u_cube_normal_material, base + near_texel, 0).w) + 0.5) - 1 == h.material) {
                local = near_texel;
                break;
            }
        }
    }
    return cube_radiance_at_level(face, row, local, cube_radiance_level(cone));
}

// The light a ray along view_dir takes from cube-map hit h (material m, its specular split):
// the stored diffuse light over the cone of the glossy lobes on the ray's path (about
// 2 alpha radians across, as ray_cone_footprint widens a ray's cone, taken as seen from the
// map's centre, the camera), plus the lamps' highlights, widened to `blur` as
// lamp_light_response widens them. A pixel's own footprint is left out of the cone: the
// film's jittered samples filter it (antialias.py), and a mirror reads each texel sharp, as
// a ray shaded per hit would see it, rather than blending a silhouette into what lies
// behind it.
vec3 cube_hit_light(Material m, Hit h, vec3 view_dir, SpecularSplit split, float blur) {
    float cone = 2.0 * blur * blur;
    float highlight_roughness = max(material_roughness(m), blur);
    vec3 glossy = direct_lighting(h.position, split.n_facing, -view_dir, split.lamp_f0, split.lamp_f90,
                                  highlight_roughness, false, material_light_set(m)).glossy;  // light linking
    return cube_stored_radiance(h, cone) + glossy;
}

#endif
