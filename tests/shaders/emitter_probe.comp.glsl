// SPDX-License-Identifier: GPL-3.0-or-later
// The emitters' next-event estimate at given points (include/emitter_light.glsl), for
// tests/test_emitter_light.py: invocation i sums u_samples one-sample estimates of
// emitter_irradiance at points[i / u_chunks] with normal normals[i / u_chunks] (shading and
// geometric alike), samples (i % u_chunks) * u_samples onwards, through the BVH of the whole
// scene (u_mode FULL_BVH); results[i] = (the sum, shadow rays traced). A point's samples are
// spread over u_chunks invocations: llvmpipe ends a loop after 65,535 iterations of its
// SIMD lanes. With PICK_PROBE, invocation i instead draws one emitter_pick and
// writes (index, probability) to picks[i].
// Host defines: PICK_PROBE (optional); the BVH's traversal defines.
// Storage blocks: as trace/hybrid_trace.comp.glsl's, EmitterTable.bindings(), Points,
//   Normals (read: vec4, xyz used), Results / Picks (written).
// Uniforms: u_count, u_samples, u_chunks, u_seed, u_mode, u_receiver_set (the points' light
//   linking set: read with EMITTER_LINKING), EmitterTable.bindings()'s.
#define EMITTER_LIGHT
#include "trace_ray.glsl"
#include "emitter_light.glsl"

layout(local_size_x = 64) in;

uniform uint u_count;
uniform uint u_samples;
uniform uint u_chunks;
uniform uint u_seed;
uniform int u_receiver_set;

bool ray_room() { return false; }
void store_ray(vec3 origin, vec3 dir, vec3 weight, int depth, float blur, float reach) {}

#ifdef PICK_PROBE
layout(std430) writeonly buffer Picks { vec2 picks[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    float probability;
    int picked = emitter_pick(random2(uvec4(i, u_seed, 7u, 0u)).x, probability);
    picks[i] = vec2(float(picked), probability);
}
#else
layout(std430) readonly buffer Points { vec4 points[]; };
layout(std430) readonly buffer Normals { vec4 normals[]; };
layout(std430) writeonly buffer Results { vec4 results[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    uint point = i / u_chunks;
    vec3 p = points[point].xyz;
    vec3 n = normalize(normals[point].xyz);
    vec3 sum = vec3(0.0);
    for (uint k = 0u; k < u_samples; ++k) {
        uint s = (i % u_chunks) * u_samples + k;
        vec2 a = random2(uvec4(point, s, u_seed, 1u));
        vec2 b = random2(uvec4(point, s, u_seed, 2u));
        sum += emitter_irradiance(p, n, n, vec3(a, b.x), u_receiver_set, 0);
    }
    results[i] = vec4(sum, float(emitter_shadow_rays));
}
#endif
