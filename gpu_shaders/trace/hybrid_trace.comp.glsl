// SPDX-License-Identifier: GPL-3.0-or-later
// The hybrid tracer (paper §3, steps 4 and 5; §3.4): secondary rays of every reflective or
// refractive primary hit, traced recursively through the near-cube BVH and the G-buffer
// cube map, added to the deferred-shaded primary image.
//
// One invocation per pixel runs a depth-first explicit stack of pending rays (weight,
// origin, direction, depth): a megakernel with no per-ray host work. Per ray:
//   * where it starts (§3.4): in the BVH when its origin lies inside the near cube
//     (half-size u_near_half around the camera), otherwise in the cube map; FULL_BVH traces
//     everything in one BVH over the whole scene and a miss is the sky;
//   * in the BVH: closest hit (bvh_traverse.glsl) up to the point where the ray leaves the
//     near cube (grown by the culling overlap), then the cube map from that point;
//   * in the cube map: cube_march.glsl; a hit, the sky, or back into the BVH (z < -1); the
//     march ends where the ray leaves the bounds of all geometry (u_scene_lo/hi, grown by
//     the march's depth bias): nothing lies past them, and sky-bound rays, most of a
//     scene's reflections, no longer walk the faces on to their far planes;
//   * a BVH hit is shaded like the deferred pass (shading.glsl: emission + diffuse with
//     shadow maps) and spawns the reflected ray (mirror lobe tinted by the base colour, plus
//     the Fresnel part of the glass lobe) and the refracted ray (Snell, total internal
//     reflection, Fresnel weight 1 - F, tinted);
//   * a cube-map hit is shaded the same way from the face's G-buffer (stored normal,
//     material and UV, position reconstructed from the face's depth; only hit texels are
//     shaded and textured, never whole faces) and spawns the reflected ray from that position; a refractive cube-map hit is thin
//     (§3.4, Figure 8): its refracted part is the sky seen in the refracted direction,
//     sky(refract(d, n, 1 / ior)) weighted by (1 - F) and the base colour. The same holds
//     for any refractive hit outside the near cube in HYBRID (a primary hit there: its
//     refracted ray would start in the cube map, inside the very object the map stores);
//   * a hit is shaded like the deferred pass (shading.glsl shade_surface: the lamps with
//     shadow maps, the World's irradiance, lamp highlights, too-rough reflections as the
//     prefiltered sky); its reflected and refracted directions come from the GGX lobe,
//     drawn per sample (random.glsl, u_sample) and exact when the roughness is 0; the
//     World's irradiance at the first bounce's hits is hidden by one occlusion ray within
//     AO Distance (near BVH hits), or with the host define DIFFUSE_GATHER (World Light
//     Rays) gathered by one cosine ray of unlimited reach, BVH and cube-map hits alike
//     (trace_ray.glsl shade_hit, gather_light);
//   * a ray that would pass max_depth is not traced: it takes the sky in its direction, so
//     glass and mirrors at the depth limit show the environment, not black
//     (tests/whitted_reference.py does the same).
// PROVENANCE mode writes, instead of tracing, blue (0, 0, 1) for specular pixels whose
// first secondary rays start in the BVH, red (1, 0, 0) for those starting in the cube map,
// and grey 0.5 elsewhere (paper Figure 4).
//
// Counters (CounterBuffer, uint[8][COUNTER_DEPTHS], index kind * COUNTER_DEPTHS + depth): rays
// traced, rays that entered the cube map, rays that ended in the sky, rays that went from
// the cube map back into the BVH, rays that ended at a BVH hit, at a cube-map hit, per
// bounce depth; each ray counts at most once per kind. Then the BVH nodes visited and the
// march steps taken by the rays of each depth, summed (tracer.COUNTER_KINDS).
//
// Uniform blocks LightBuffer, ShadowSlotBuffer; storage blocks: MaterialBuffer, the BVH's (bvh_storage.glsl,
//   bvh_traverse.glsl), TriangleNormals (float[9 N], the scene's normal buffer), CounterBuffer
//   (read/write), TriangleUVBuffer (TriangleUV[N]; read only for materials with image
//   textures), TriangleMaterials (int[N]), SkyIrradiance (world_light.glsl); all
//   per-triangle arrays in original triangle order. Image u_color: the primary colour
//   (RGBA32F, read and written); with LIGHT_PASSES u_light_samples (include/light_passes.glsl,
//   read and written). Textures: u_textures (textures.glsl; BVH hits sample it at the
//   interpolated UV, mip level from the ray cone u_pixel_width + u_pixel_spread * distance,
//   widened by the glossy lobes on the ray's path).
//   Cube-map hits sample it the same way at the UV their face texel stores.
//   Samplers: primary u_depth, u_normal_material, u_albedo, u_emission_scale; the cube atlas u_cube_depth,
//   u_cube_normal_material, u_cube_surface, u_cube_geometric, u_cube_hiz; u_shadow_atlas, u_shadow_dynamic; u_sky_env.
// Workgroup 8x8: neighbouring pixels' rays are coherent for the first bounce.
#include "trace_ray.glsl"
// LIGHT_PASSES (a view layer asks for Cycles' light passes; never with DIAGNOSTIC): the
// light of the primary hit's reflection and refraction also goes to Glossy and Transmission
// Indirect (include/light_passes.glsl).
#ifdef LIGHT_PASSES
#include "light_passes.glsl"
#endif

layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f) uniform image2D u_color;
#ifdef DIAGNOSTIC
// The diagnostic views (hybrid_engine/passes/trace/diagnostic_views.py): each pixel's value in r of
// u_diagnostic, its false colour in u_color.
#define DIAG_BOUNCES 1       // the deepest bounce any of the pixel's rays reached
#define DIAG_CUBE_STEPS 2    // march steps of all its rays (cube_march_steps)
#define DIAG_BVH_NODES 3     // BVH nodes all its rays visited (bvh_nodes_visited)
#define DIAG_BOUNCE_PATHS 4  // where its rays of bounce u_diag_bounce ended: 1 BVH, 2 cube map, 4 sky
layout(r32f) writeonly uniform image2D u_diagnostic;
uniform int u_diag_view;
uniform int u_diag_bounce;
uniform float u_diag_scale;    // the value shown in the ramp's last colour
uniform vec3 u_diag_ramp[5];   // colours of 0, 1/4, 1/2, 3/4 and 1 of the scale
uniform vec3 u_diag_paths[4];  // no ray at that bounce, BVH, cube map, sky
uniform vec3 u_diag_untraced;  // pixels that spawn no ray
uint diag_bounces = 0u;
uint diag_paths = 0u;
#endif

// The pending rays of this invocation (file-scope variables are private per invocation).
PendingRay stack[STACK_SIZE];
int stack_size = 0;

// Put a ray on the stack (the caller checked that there is room).
void store_ray(vec3 origin, vec3 dir, vec3 weight, int depth, float blur, float reach) {
    stack[stack_size] = PendingRay(origin, dir, weight, depth, blur, reach);
    stack_size += 1;
}


bool ray_room() { return stack_size < STACK_SIZE; }

#ifdef DIAGNOSTIC
vec3 diag_ramp(float x) {
    float f = clamp(x, 0.0, 1.0) * 4.0;
    int i = min(int(f), 3);
    return mix(u_diag_ramp[i], u_diag_ramp[i + 1], f - float(i));
}

// The pixel's value and false colour for the diagnostic view; `traced`: it spawned rays.
void write_diagnostic(ivec2 pixel, bool traced) {
    float value = 0.0;
    vec3 color = u_diag_untraced;
    if (u_diag_view == DIAG_BOUNCE_PATHS) {
        value = float(diag_paths);
        if (traced) {
            vec3 sum = vec3(0.0);
            float n = 0.0;
            for (int b = 0; b < 3; ++b) {
                if ((diag_paths & (1u << uint(b))) != 0u) { sum += u_diag_paths[b + 1]; n += 1.0; }
            }
            color = n > 0.0 ? sum / n : u_diag_paths[0];
        }
    } else {
        value = float(u_diag_view == DIAG_BOUNCES ? diag_bounces
                      : u_diag_view == DIAG_CUBE_STEPS ? cube_march_steps : bvh_nodes_visited);
        if (traced) color = diag_ramp(value / u_diag_scale);
    }
    imageStore(u_diagnostic, pixel, vec4(value, 0.0, 0.0, 1.0));
    imageStore(u_color, pixel, vec4(color, 1.0));
}
#endif

// Trace the rays on the stack, and every ray they spawn, adding their light to `traced`.
void trace_stack(inout vec3 traced) {
    while (stack_size > 0) {
        stack_size -= 1;
        PendingRay ray = stack[stack_size];
#ifndef DIFFUSE_GATHER
        // An occlusion ray (depth < 0, push_occlusion) asks only whether a blocker hides the
        // World within AO Distance: a shadow ray, whose candidate hits run a coverage with Is
        // Shadow Ray set, as the waves' any-hit kernel runs them (trace_ray.glsl TRACE_ANY_HIT).
        // With DIFFUSE_GATHER it is a gather ray that brings light back: no shadow ray.
        trace_shadow_rays = ray.depth < 0;
#endif
        Hit h = trace_ray(ray.origin, ray.dir, ray.depth, ray.blur, ray.reach);
        trace_shadow_rays = false;
        if (ray.depth < 0) {
            traced += ray.weight * occlusion_result(h, ray.dir);
            continue;
        }
#ifdef DIAGNOSTIC
        diag_bounces = max(diag_bounces, uint(ray.depth));
        if (ray.depth == u_diag_bounce)
            diag_paths |= h.kind == HIT_BVH ? 1u : h.kind == HIT_CUBE ? 2u : 4u;
#endif
        if (h.kind == HIT_SKY) {
            traced += ray.weight * sky_radiance(ray.dir);
            continue;
        }
        shade_hit(ray, h, traced);
    }
}

#ifdef LIGHT_PASSES
// spawn_primary (trace_ray.glsl) for one lobe: the refracted ray, or the reflected one.
void spawn_primary_lobe(ivec2 pixel, Material m, vec3 p, vec3 view_dir, vec3 n, bool refraction) {
    vec4 albedo_g = texelFetch(u_albedo, pixel, 0);
    vec3 g = gbuffer_geometric(albedo_g.a, texelFetch(u_emission_scale, pixel, 0).a, n);
    pixel_key = position_key(p);
#ifdef EMITTER_LINKING
    ray_receiver_set = pixel_receiver_set(pixel);
#endif
    SpecularSplit split = specular_split_sampled(m, albedo_g.rgb, view_dir, n, g, lobe_random(0));
    float blur = material_roughness(m);
    if (refraction) push(offset_origin(p, -split.g_facing), split.refract_dir, vec3(1.0) * split.refract_weight, 1, blur);
    else push(offset_origin(p, split.g_facing), split.reflect_dir, vec3(1.0) * split.reflect_weight, 1, blur);
}
#endif

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, u_size))) return;

    vec4 nm;
    Material m;
    if (!primary_specular(pixel, nm, m)) {
        if (u_mode == MODE_PROVENANCE) imageStore(u_color, pixel, vec4(vec3(0.5), 1.0));
#ifdef DIAGNOSTIC
        write_diagnostic(pixel, false);
#endif
        return;  // the deferred-shaded colour stands
    }

    vec3 p, view_dir, n;
    primary_surface(pixel, nm, p, view_dir, n);
    if (u_mode == MODE_PROVENANCE) {
        vec3 where = inside_near_cube(p) ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0);
        imageStore(u_color, pixel, vec4(where, 1.0));
        return;
    }

    vec3 traced = vec3(0.0);
#ifdef LIGHT_PASSES
    // The primary hit's two lobes one after the other, the refraction first: the stack pops
    // it first too, so `traced` sums the same terms in the same order as below, and the
    // image stays bit for bit what it is without passes.
    spawn_primary_lobe(pixel, m, p, view_dir, n, true);
    trace_stack(traced);
    vec3 through_refraction = traced + past_depth_limit;
    spawn_primary_lobe(pixel, m, p, view_dir, n, false);
    trace_stack(traced);
    vec3 through_reflection = (traced + past_depth_limit) - through_refraction;
#else
    spawn_primary(pixel, m, p, view_dir, n);
    trace_stack(traced);
#endif
#ifdef DIAGNOSTIC
    write_diagnostic(pixel, true);
    return;
#endif
    vec4 base = imageLoad(u_color, pixel);
    vec3 color = base.rgb + traced + past_depth_limit;
#ifdef LIGHT_PASSES
    if (!(any(isnan(color)) || any(isinf(color)))) {  // else the image drops the rays' light: so do the passes
        light_add(pixel, LP_GLOSSY_INDIRECT, through_reflection);
        light_add(pixel, LP_TRANSMISSION_INDIRECT, through_refraction);
    }
#endif
    if (any(isnan(color)) || any(isinf(color))) color = base.rgb;
    if (any(isnan(color)) || any(isinf(color))) color = vec3(0.0);
    imageStore(u_color, pixel, vec4(color, 1.0));
}
