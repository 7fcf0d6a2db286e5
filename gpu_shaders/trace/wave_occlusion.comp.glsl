// SPDX-License-Identifier: GPL-3.0-or-later
// Wave tracer, occlusion rays: one invocation per occlusion ray (the first bounce's hits
// near the camera, trace_ray.glsl shade_hit) traces it any-hit (TRACE_ANY_HIT: the first
// BVH surface found ends it, no nearest-first search) within AO Distance and writes weight
// times what it found (1 for the sky, the surface's transmission) over its record
// (wave_queue.glsl words 0-2). With DIFFUSE_GATHER (World Light Rays) the ray is a diffuse
// gather of unlimited reach instead: closest hit, and weight times the light it brings
// (trace_ray.glsl gather_light). Occlusion rays are left out of the counters, as in the
// megakernel.
// Host defines: those of trace/hybrid_trace.comp.glsl. Storage blocks: WaveState, Rays (the
//   occlusion queue) and trace_ray.glsl's. Uniforms: u_wave_slot, u_ray_words and
//   trace_ray.glsl's.
#ifndef DIFFUSE_GATHER
#define TRACE_ANY_HIT
#endif
#define WAVE_READ
#include "trace_ray.glsl"
#include "wave_queue.glsl"

layout(local_size_x = WAVE_LOCAL) in;

bool ray_room() { return true; }
void store_ray(vec3 origin, vec3 dir, vec3 weight, int depth, float blur, float reach) {}

void main() {
    uint i = wave_index();
    if (i >= wave_count()) return;
    QueuedRay r = load_ray(i);
#ifdef DIFFUSE_GATHER
    Hit h = trace_ray(r.origin, r.dir, -1, r.blur, FLOAT_MAX);
#else
    Hit h = trace_ray(r.origin, r.dir, -1, r.blur, u_ao_distance);
#endif
    store_ray_words_vec3(i, r.weight * occlusion_result(h, r.dir));
}
