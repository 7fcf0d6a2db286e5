// SPDX-License-Identifier: GPL-3.0-or-later
// Wave tracer, traversal: one invocation per ray of a wave (all of one bounce depth) finds
// its closest hit through the near-cube BVH and the cube-map march (paper §3.4;
// trace_ray.glsl, as the megakernel does for each of its rays) and stores it for the
// shading kernel. The ray and work counters of the wave's depth gather per workgroup in
// shared memory before one atomic per kind reaches CounterBuffer.
// Host defines: those of trace/hybrid_trace.comp.glsl. Storage blocks: WaveState, Rays
//   (WaveRay[], this wave's queue), Hits (WaveHit[], written), CounterBuffer and
//   trace_ray.glsl's. Uniforms: u_wave_slot, u_wave_depth (the wave's bounce) and trace_ray.glsl's.
#define WORKGROUP_COUNTERS
#include "trace_ray.glsl"
#include "wave_queue.glsl"
#include "wave_hit.glsl"

layout(local_size_x = WAVE_LOCAL) in;

layout(std430) readonly buffer Rays { WaveRay rays[]; };
layout(std430) writeonly buffer Hits { WaveHit hits[]; };
uniform int u_wave_depth;

bool ray_room() { return true; }
void store_ray(vec3 origin, vec3 dir, vec3 weight, int depth, float blur, float reach) {}

void main() {
    clear_workgroup_counts();
    uint i = wave_index();
    if (i < wave_count()) {
        WaveRay r = rays[i];
        hits[i] = pack_hit(trace_ray(r.origin, r.dir, r.depth, r.blur, r.reach));
    }
    flush_workgroup_counts(u_wave_depth);
}
