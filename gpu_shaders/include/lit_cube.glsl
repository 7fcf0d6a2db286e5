// SPDX-License-Identifier: GPL-3.0-or-later
// A traced ray's hit in the cube map, lit from the lit cube map (LIT_CUBE;
// hybrid_engine/passes/cube_light/, cube_radiance.glsl) instead of shaded per ray: the
// diffuse, view-independent light the cube_light pass stored at the texel (emission, the
// lamps through their shadow maps, the World's light times the sky the texel sees, and the
// light bounced from the other texels), read at the mip level whose texels span the ray's
// cone, so that a rough reflection of the cube map reads it prefiltered to its roughness.
// What depends on the view stays per ray: the lamps' highlights (here) and the reflected and
// refracted rays (trace_ray.glsl shade_hit).
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
    return cube_radiance_at_level(face, cube_layer_of(face, local, axial), local, cube_radiance_level(cone));
}

// The light a ray along view_dir takes from cube-map hit h (material m, its specular split):
// the stored diffuse light over the ray's cone -- a pixel's spread, widened by the glossy
// lobes on its path as ray_cone_footprint widens it (about 2 alpha radians across, taken as
// seen from the map's centre, which is the camera) -- plus the lamps' highlights, widened to
// `blur` as lamp_light_response widens them.
vec3 cube_hit_light(Material m, Hit h, vec3 view_dir, SpecularSplit split, float blur) {
    float cone = u_pixel_spread + 2.0 * blur * blur;
    float highlight_roughness = max(material_roughness(m), blur);
    vec3 glossy = direct_lighting(h.position, split.n_facing, -view_dir, split.lamp_f0, split.lamp_f90,
                                  highlight_roughness, false).glossy;
    return cube_stored_radiance(h, cone) + glossy;
}

#endif
