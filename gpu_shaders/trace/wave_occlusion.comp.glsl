// SPDX-License-Identifier: GPL-3.0-or-later
// Wave tracer, occlusion rays: one invocation per occlusion ray (the first bounce's hits
// near the camera, trace_ray.glsl shade_hit) traces it any-hit (TRACE_ANY_HIT: the first
// BVH surface found ends it, no nearest-first search) and leaves weight times what it found
// (1 for the sky, the surface's transmission) in its contribution slot. Occlusion rays are
// left out of the counters, as in the megakernel.
// Host defines: those of trace/hybrid_trace.comp.glsl. Storage blocks: WaveState, Rays (the
//   occlusion queue), Contributions (vec4[], written) and trace_ray.glsl's. Uniforms:
//   u_wave_slot and trace_ray.glsl's.
#define TRACE_ANY_HIT
#include "trace_ray.glsl"
#include "wave_queue.glsl"

layout(local_size_x = WAVE_LOCAL) in;

layout(std430) readonly buffer Rays { WaveRay rays[]; };
layout(std430) writeonly buffer Contributions { vec4 contributions[]; };

bool ray_room() { return true; }
void store_ray(vec3 origin, vec3 dir, vec3 weight, int depth, float blur, float reach) {}

void main() {
    uint i = wave_index();
    if (i >= wave_count()) return;
    WaveRay r = rays[i];
    Hit h = trace_ray(r.origin, r.dir, -1, r.blur, r.reach);
    contributions[i] = vec4(r.weight * occlusion_seen(h), 0.0);
}
