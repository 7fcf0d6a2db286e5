// SPDX-License-Identifier: GPL-3.0-or-later
// Wave tracer, shading: one invocation per ray of a wave shades the hit the traversal kernel
// found (trace_ray.glsl shade_hit, as the megakernel does), writes the light the ray brings
// over its record (wave_queue.glsl words 0-2; wave_resolve.comp.glsl adds the records to
// their pixels in queue order) and writes its children (reflection, refraction, the first
// bounce's occlusion ray) straight into the next wave's queues, at the offsets
// wave_scan.comp.glsl made of the traversal's counts (wave_queue.glsl WAVE_SPAWN).
// Host defines: those of trace/hybrid_trace.comp.glsl. Storage blocks: WaveState, Rays,
//   Hits (read), BlockSums, NextRays, NextOcclusions and trace_ray.glsl's. Uniforms:
//   u_wave_slot, u_ray_words, u_wave_depth, u_ray_capacity, u_occlusion_capacity and
//   trace_ray.glsl's.
#define WAVE_SPAWN
#define WAVE_READ
#define TRACE_SHADING_ONLY
#include "trace_ray.glsl"
#include "wave_queue.glsl"
#include "wave_hit.glsl"

layout(local_size_x = WAVE_LOCAL) in;

uniform int u_wave_depth;

void main() {
    uint i = wave_index();
    bool live = i < wave_count();
    vec3 traced = vec3(0.0);
    if (live) {
        QueuedRay r = load_ray(i);
        wave_pixel = r.pixel;
        pixel_key = primary_key(ivec2(int(r.pixel % uint(u_size.x)), int(r.pixel / uint(u_size.x))));
        // The origin is spent (its words hold the hit's position): shade_hit never reads it.
        PendingRay ray = PendingRay(vec3(0.0), r.dir, r.weight, u_wave_depth, r.blur, FLOAT_MAX);
        Hit h = load_hit(i);
        if (h.kind == HIT_SKY) {
            traced += ray.weight * sky_radiance(ray.dir);
        } else {
            shade_hit(ray, h, traced);
        }
    }
    vec3 untraced = emit_children();
    if (live) store_ray_words_vec3(i, traced + past_depth_limit + untraced);
}
