// SPDX-License-Identifier: GPL-3.0-or-later
// Wave tracer, traversal: one invocation per ray of a wave (all of one bounce depth) finds
// its closest hit through the near-cube BVH and the cube-map march (paper §3.4;
// trace_ray.glsl, as the megakernel does for each of its rays) and stores it for the
// shading kernel (wave_hit.glsl). It also counts the children the hit will spawn, per
// workgroup (wave_queue.glsl WAVE_COUNT: the shading's own spawning, whose light is unused
// here and so compiled away), so that the shading kernel can write them straight into the
// next queue. The ray and work counters of the wave's depth gather per workgroup in shared
// memory before one atomic per kind reaches CounterBuffer.
// Host defines: those of trace/hybrid_trace.comp.glsl. Storage blocks: WaveState, Rays
//   (this wave's queue; the hit's position replaces the origin), Hits (written), BlockSums,
//   CounterBuffer and trace_ray.glsl's. Uniforms: u_wave_slot, u_ray_words, u_wave_depth
//   (the wave's bounce) and trace_ray.glsl's.
#define WORKGROUP_COUNTERS
#define WAVE_COUNT
#define WAVE_READ
#define WAVE_HIT_WRITE
#include "trace_ray.glsl"
#include "wave_queue.glsl"
#include "wave_hit.glsl"

layout(local_size_x = WAVE_LOCAL) in;

uniform int u_wave_depth;

void main() {
    clear_workgroup_counts();
    uint i = wave_index();
    if (i < wave_count()) {
        QueuedRay r = load_ray(i);
        Hit h = trace_ray(r.origin, r.dir, u_wave_depth, r.blur, FLOAT_MAX);
        store_hit(i, h);
        if (h.kind != HIT_SKY) {
            pixel_key = primary_key(ivec2(int(r.pixel % uint(u_size.x)), int(r.pixel / uint(u_size.x))));
            vec3 light = vec3(0.0);
            shade_hit(PendingRay(r.origin, r.dir, r.weight, u_wave_depth, r.blur, FLOAT_MAX), h, light);
        }
    }
    flush_workgroup_counts(u_wave_depth);
    emit_counts();
}
