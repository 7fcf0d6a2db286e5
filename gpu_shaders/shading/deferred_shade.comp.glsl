// SPDX-License-Identifier: GPL-3.0-or-later
// Deferred shading of primary hits (paper §3.5 and the first half of step 4 of §3).
//
// Reads a G-buffer and writes its shaded colour: everything of the surface that is not a
// traced ray (include/shading.glsl shade_surface: emission, the diffuse layer lit by the
// lamps with shadow maps and by the World, lamp highlights, too-rough reflections). With
// u_traced_specular = 0 (RASTER mode, and the default of an unset uniform) the traced lobes
// look the sky up in the reflected / refracted direction (the classic environment-map
// approximation); with 1 they are left out, because the hybrid tracer
// (trace/hybrid_trace.comp.glsl) adds them as traced rays.
//
// The World's light on primary pixels: the sky's irradiance times its visibility from
// screen_ao.comp.glsl, or what the tracer's sky rays gathered (WORLD_LIGHT_PASS: the sky,
// and the light of the surfaces that hide it, one bounce), smoothed here over the pixels of
// the same surface around each pixel, unless the denoiser filtered it already
// (u_ambient_filtered = 1, denoise/atrous.comp.glsl: its wavelet filter reaches much
// farther with the same edge tests, and a 3x3 average on top would only blur it). Background pixels get the sky, or
// (0, 0, 0, 0) with u_transparent_background = 1 (Blender's transparent film, film.py):
// alpha 0 there, and premultiplied colour 0; reflections still see the sky.
//
// Bindings: u_depth (DEPTH32F), u_normal_material (RGBA32F), u_albedo (RGBA16F),
//   u_emission_scale (RGBA16F: the emission texture's colour, multiplies the emission) read;
//   uniform blocks LightBuffer, ShadowSlotBuffer and storage blocks MaterialBuffer, SkyIrradiance read; image
//   u_output (RGBA32F) written. Host define LIGHT_PASSES: also image u_light_samples (RGBA32F,
//   written; uniforms u_light_view, u_mist_start, u_mist_inv_depth, u_mist_falloff).
// Workgroup 8x8: square tiles keep neighbouring pixels (and their G-buffer rows) together.
#include "scene_layout.glsl"
#include "shading.glsl"
#include "textures.glsl"
#include "octahedral.glsl"
// NODE_PROGRAMS defined: a material with a node program reads its closure from the G-buffer.
#ifdef NODE_PROGRAMS
#include "node_material.glsl"
#endif

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430) readonly buffer MaterialBuffer { Material materials[]; };
layout(rgba32f) writeonly uniform image2D u_output;

uniform sampler2D u_depth;
uniform sampler2D u_normal_material;
uniform sampler2D u_albedo;
uniform sampler2D u_emission_scale;
uniform sampler2D u_surface;  // roughness, metallic (gbuffer.frag.glsl location 3)
uniform mat4 u_inv_view_proj;
// per pixel: rgb the World's irradiance gathered by sky rays (a rough metal's: pi times the
// radiance its glossy lobe gathered), a the sky's visibility
uniform sampler2D u_ambient;
uniform int u_ambient_from_rays;     // 1: rgb holds the World's light (sky rays), 0: only a
uniform int u_sky_visibility_known;  // 0: no pass estimated it, the whole sky is seen
uniform int u_ambient_filtered;      // 1: the denoiser filtered u_ambient, take it as it is
uniform vec3 u_camera_position;
uniform vec3 u_camera_forward;
uniform int u_orthographic;
uniform ivec2 u_size;  // size of the view being shaded
uniform int u_traced_specular;  // 1: specular lobes are traced elsewhere, leave them out
uniform int u_transparent_background;  // 1: the background is transparent, not the sky
// LIGHT_PASSES defined (a view layer asks for Cycles' light passes): the shading also writes
// them, lobe by lobe (include/light_passes.glsl, passes/film/light_passes.py).
#ifdef LIGHT_PASSES
#include "light_passes.glsl"
uniform float u_mist_start;
uniform float u_mist_inv_depth;
uniform float u_mist_falloff;  // the exponent: 2 Quadratic, 1 Linear, 0.5 Inverse Quadratic

// Cycles' Mist (kernel/film/data_passes.h): 0 at Start, 1 at Start + Depth along the
// primary ray (the view axis for an orthographic camera), shaped by the falloff.
float mist_of(vec3 p) {
    float d = u_orthographic != 0 ? dot(p - u_camera_position, normalize(u_camera_forward))
                                  : distance(p, u_camera_position);
    float mist = clamp((d - u_mist_start) * u_mist_inv_depth, 0.0, 1.0);
    return u_mist_falloff == 1.0 ? mist : u_mist_falloff == 2.0 ? mist * mist
           : u_mist_falloff == 0.5 ? sqrt(mist) : pow(mist, u_mist_falloff);
}
#endif

vec3 unproject(vec2 ndc_xy, float ndc_z) {
    vec4 world = u_inv_view_proj * vec4(ndc_xy, ndc_z, 1.0);
    return world.xyz / world.w;
}

// The ambient estimate of screen_ao.comp.glsl or of the sky rays (rgb irradiance, a sky
// visibility), averaged over the 3x3 pixels around `local` that lie on p's surface (near
// its tangent plane, facing alike): each pixel's few points or its one ray are noisy, nine
// neighbours' together much less, and accumulated samples smooth the rest.
vec4 smoothed_ambient(ivec2 local, vec3 p, vec3 n) {
    float camera_dist = u_orthographic != 0 ? 1.0 : distance(p, u_camera_position);
    vec4 sum = vec4(0.0);
    float weight = 0.0;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = clamp(local + ivec2(dx, dy), ivec2(0), u_size - 1);
            vec4 nm = texelFetch(u_normal_material, q, 0);
            if (nm.w == 0.0) continue;
            float depth = texelFetch(u_depth, q, 0).r;
            vec3 pq = unproject((vec2(q) + 0.5) / vec2(u_size) * 2.0 - 1.0, depth * 2.0 - 1.0);
            bool same = abs(dot(pq - p, n)) < 0.02 * camera_dist && abs(dot(nm.xyz, n)) > 0.9;
            float w = same ? 1.0 : 0.0;
            sum += w * texelFetch(u_ambient, q, 0);
            weight += w;
        }
    }
    return weight > 0.0 ? sum / weight : vec4(0.0, 0.0, 0.0, 1.0);
}

void main() {
    ivec2 local = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(local, u_size))) return;
    ivec2 pixel = local;

    vec2 ndc_xy = (vec2(local) + 0.5) / vec2(u_size) * 2.0 - 1.0;
    vec3 near_point = unproject(ndc_xy, -1.0);
    vec3 view_dir = u_orthographic != 0 ? u_camera_forward : normalize(near_point - u_camera_position);

    vec4 nm = texelFetch(u_normal_material, pixel, 0);
    if (nm.w == 0.0) {
        imageStore(u_output, pixel, u_transparent_background != 0 ? vec4(0.0)
                                                                   : vec4(sky_radiance(view_dir), 1.0));
#ifdef LIGHT_PASSES
        for (int layer = 0; layer < LP_LAYERS; ++layer) light_store(pixel, layer, vec4(0.0));
        light_store(pixel, LP_GLOSSY_COLOR, vec4(0.0, 0.0, 0.0, 1.0));  // Mist: 1 where nothing was hit
        // The World as seen, transparent film or not: Cycles' Environment pass holds it either way.
        light_store(pixel, LP_ENVIRONMENT, sky_radiance(view_dir));
#endif
        return;
    }
    float depth = texelFetch(u_depth, pixel, 0).r;
    vec3 p = unproject(ndc_xy, depth * 2.0 - 1.0);
    int material_index = int(abs(nm.w) + 0.5) - 1;
    Material m = materials[material_index];
    if (material_has_surface_maps(m)) {
        vec2 surface = texelFetch(u_surface, pixel, 0).rg;
        m = material_with_surface(m, surface.x, surface.y);
    }
#ifdef NODE_PROGRAMS
    if (material_has_program(m)) m = node_gbuffer_material(m, texelFetch(u_surface, pixel, 0));
#endif
    vec4 albedo_g = texelFetch(u_albedo, pixel, 0);
    vec4 emission_g = texelFetch(u_emission_scale, pixel, 0);
    vec3 albedo = albedo_g.rgb;

    // The alphas hold the triangle's geometric normal (gbuffer.frag.glsl): it decides which
    // side the viewer is on, as in the tracer, so both shade a surface alike.
    vec3 n = nm.xyz;
    vec3 g = gbuffer_geometric(albedo_g.a, emission_g.a, n);
    SpecularSplit split = specular_split_geometric(m, albedo, view_dir, n, g);
    vec3 emission = m.emission_trans.rgb * emission_g.rgb;
    vec4 ambient = u_sky_visibility_known == 0 ? vec4(0.0, 0.0, 0.0, 1.0)
                   : u_ambient_filtered != 0 ? texelFetch(u_ambient, pixel, 0) : smoothed_ambient(local, p, split.n_facing);
    float visibility = ambient.a;
    vec3 world = u_ambient_from_rays != 0 ? ambient.rgb : sky_irradiance(split.n_facing) * visibility;
    // A rough metal's traced World light is what its glossy lobe gathered (pi times the
    // radiance along it: diffuse_gather.comp.glsl), the sky and the surfaces that hide it;
    // the prefiltered sky it would otherwise take is left out (visibility 0).
    bool glossy_gathered = u_ambient_from_rays != 0 && material_glossy_gathered(m);
    vec3 glossy_world = glossy_gathered ? split.glossy_local * ambient.rgb / PI : vec3(0.0);
    float sky_visibility = glossy_gathered ? 0.0 : visibility;
#ifdef LIGHT_PASSES
    SurfaceLight parts = shade_surface_parts(m, albedo, emission, p, view_dir, split, world, sky_visibility, 0.0);
    vec3 color = parts.total + glossy_world;
    vec3 glossy_indirect = parts.glossy_indirect + glossy_world;
    vec3 transmission_indirect = vec3(0.0);
#else
    vec3 color = shade_surface(m, albedo, emission, p, view_dir, split, world, sky_visibility, 0.0) + glossy_world;
#endif
    if (u_traced_specular == 0) {
        float roughness = material_roughness(m);
        vec3 reflected = split.reflect_weight * sky_radiance_rough(split.reflect_dir, roughness) * visibility;
        vec3 refracted = split.refract_weight * sky_radiance_rough(split.refract_dir, roughness);
        color += reflected;
        color += refracted;
#ifdef LIGHT_PASSES
        glossy_indirect += reflected;
        transmission_indirect = refracted;
#endif
    }
    bool finite = !(any(isnan(color)) || any(isinf(color)));
    if (!finite) color = vec3(0.0);
    imageStore(u_output, pixel, vec4(color, 1.0));
#ifdef LIGHT_PASSES
    // A lobe's colour: its weight at this hit (Cycles' Color passes), whether or not it is
    // traced; the film divides each lobe's light by it.
    light_store(pixel, LP_DIFFUSE_COLOR, vec4(split.diffuse_weight * albedo, visibility));
    light_store(pixel, LP_GLOSSY_COLOR, vec4(split.reflect_weight + split.glossy_local, mist_of(p)));
    light_store(pixel, LP_TRANSMISSION_COLOR, split.refract_weight);
    if (!finite) {  // a pixel the image zeroes adds no light to the passes either
        parts = SurfaceLight(vec3(0.0), vec3(0.0), vec3(0.0), vec3(0.0), vec3(0.0), vec3(0.0));
        glossy_indirect = transmission_indirect = vec3(0.0);
    }
    light_store(pixel, LP_DIFFUSE_DIRECT, parts.diffuse_direct);
    light_store(pixel, LP_DIFFUSE_INDIRECT, parts.diffuse_indirect);
    light_store(pixel, LP_GLOSSY_DIRECT, parts.glossy_direct);
    light_store(pixel, LP_GLOSSY_INDIRECT, glossy_indirect);
    light_store(pixel, LP_TRANSMISSION_INDIRECT, transmission_indirect);
    light_store(pixel, LP_EMISSION, parts.emission);
    light_store(pixel, LP_ENVIRONMENT, vec3(0.0));
#endif
}
