// SPDX-License-Identifier: GPL-3.0-or-later
// Cycles' light passes, written by the shaders that shade (compiled in with the host define
// LIGHT_PASSES only when a view layer asks for them: without it nothing here exists and the
// shading runs as it always did). hybrid_engine/passes/film/light_passes.py owns the
// images and says what each pass holds.
//
// One RGBA32F layer per quantity of this sample, in u_light_samples: the
// lobes' colours (their weights at the primary hit) and the light each lobe brought, the
// latter *times* its colour, as the image adds it up. The film pass divides the sums
// (light / colour), Cycles' convention, so that (Direct + Indirect) x Color gives the
// lobe's share of Combined again.
//
// Which lobe a light belongs to is decided at the primary hit, as Cycles does: the lamps on
// the diffuse layer are Diffuse Direct, the World's light on it (the sky and what the
// gathered rays bring back from surfaces, which the gather does not tell apart) Diffuse
// Indirect; the lamps' highlights are Glossy Direct; everything that arrives through the
// primary hit's reflection (the paper's recursive mirror rays, §3.4, and the prefiltered sky
// of reflections too rough to trace) Glossy Indirect, through its refraction Transmission
// Indirect (no lamp is seen straight through a refraction: Transmission Direct is 0).
#ifndef HYBRID_LIGHT_PASSES_GLSL
#define HYBRID_LIGHT_PASSES_GLSL

#define LP_DIFFUSE_COLOR 0   // rgb, a: the sky's visibility (the AO pass)
#define LP_GLOSSY_COLOR 1    // rgb, a: the Mist
#define LP_TRANSMISSION_COLOR 2
#define LP_DIFFUSE_DIRECT 3
#define LP_DIFFUSE_INDIRECT 4
#define LP_GLOSSY_DIRECT 5
#define LP_GLOSSY_INDIRECT 6
#define LP_TRANSMISSION_INDIRECT 7
#define LP_EMISSION 8
#define LP_ENVIRONMENT 9
#define LP_LAYERS 10

// The layers are tiles of one 2D image, LP_COLUMNS across (an image2DArray's unit cannot be
// set through the bindings, gpu/bindings.py), each the size of the view, u_light_view.
#define LP_COLUMNS 2
layout(rgba32f) uniform image2D u_light_samples;
uniform ivec2 u_light_view;

ivec2 light_texel(ivec2 pixel, int layer) {
    return pixel + ivec2(layer % LP_COLUMNS, layer / LP_COLUMNS) * u_light_view;
}

void light_store(ivec2 pixel, int layer, vec4 value) {
    imageStore(u_light_samples, light_texel(pixel, layer), value);
}

void light_store(ivec2 pixel, int layer, vec3 value) {
    imageStore(u_light_samples, light_texel(pixel, layer), vec4(value, 0.0));
}

// Add `value` to a layer this sample's shading wrote (the tracer's rays).
void light_add(ivec2 pixel, int layer, vec3 value) {
    vec4 before = imageLoad(u_light_samples, light_texel(pixel, layer));
    imageStore(u_light_samples, light_texel(pixel, layer), vec4(before.rgb + value, before.a));
}

#ifndef LIGHT_PASSES_FILM  // the film's resolve (film/light_passes.comp.glsl) shades nothing
// The light of a primary hit, lobe by lobe: shade_surface (shading.glsl) with its terms
// kept apart. `total` is computed with the very operations shade_surface performs, in its
// order, so the image is bit for bit the one a render without passes makes
// (tests/test_light_passes.py).
struct SurfaceLight {
    vec3 total;
    vec3 emission;
    vec3 diffuse_direct;
    vec3 diffuse_indirect;
    vec3 glossy_direct;
    vec3 glossy_indirect;
};

SurfaceLight shade_surface_parts(Material m, vec3 albedo, vec3 emission, vec3 p, vec3 view_dir, SpecularSplit split,
                                 vec3 world_irradiance, float sky_visibility, float highlight_blur) {
    SurfaceLight s;
    s.emission = emission;
    s.diffuse_direct = vec3(0.0);
    s.diffuse_indirect = vec3(0.0);
    s.glossy_indirect = vec3(0.0);
    // lamp_light_response
    vec3 lamp = emission;
    vec3 n = split.n_facing;
    float highlight_roughness = max(material_roughness(m), highlight_blur);
    DirectLight direct = direct_lighting(p, n, -view_dir, split.lamp_f0, split.lamp_f90, highlight_roughness,
                                         split.diffuse_weight > 0.0, material_light_set(m));  // light linking
    if (split.diffuse_weight > 0.0) {
        s.diffuse_direct = split.diffuse_weight * albedo / PI * direct.irradiance;
        lamp += s.diffuse_direct;
    }
    s.glossy_direct = direct.glossy;
    lamp = lamp + direct.glossy;
    // world_light_response
    vec3 world = vec3(0.0);
#ifndef NO_WORLD_LIGHT
    if (split.diffuse_weight > 0.0) {
        s.diffuse_indirect = split.diffuse_weight * albedo / PI * world_irradiance;
        world += s.diffuse_indirect;
    }
    if (max(max(split.glossy_local.r, split.glossy_local.g), split.glossy_local.b) > 0.0) {
        s.glossy_indirect = split.glossy_local * sky_radiance_rough(split.glossy_dir, material_roughness(m)) * sky_visibility;
        world += s.glossy_indirect;
    }
#endif
    s.total = lamp + world;
    return s;
}
#endif  // LIGHT_PASSES_FILM

#endif  // HYBRID_LIGHT_PASSES_GLSL
