// SPDX-License-Identifier: GPL-3.0-or-later
// Wave tracer, shading: one invocation per ray of a wave shades the hit the traversal kernel
// found (trace_ray.glsl shade_hit, as the megakernel does), leaves the light the ray brings
// in its contribution slot (Contributions, rgb; wave_resolve.comp.glsl adds the slots to
// their pixels in queue order) and spawns its children (reflection, refraction, the
// first bounce's occlusion ray) into its child slots for the next wave (wave_queue.glsl).
// Host defines: those of trace/hybrid_trace.comp.glsl. Storage blocks: WaveState, Rays,
//   Hits (read), Contributions (vec4[], written), Children, ChildMasks, BlockSums and
//   trace_ray.glsl's. Uniforms: u_wave_slot and trace_ray.glsl's.
#define WAVE_EMIT
#define TRACE_SHADING_ONLY
#include "trace_ray.glsl"
#include "wave_queue.glsl"
#include "wave_hit.glsl"

layout(local_size_x = WAVE_LOCAL) in;

layout(std430) readonly buffer Rays { WaveRay rays[]; };
layout(std430) readonly buffer Hits { WaveHit hits[]; };
layout(std430) writeonly buffer Contributions { vec4 contributions[]; };

void main() {
    uint i = wave_index();
    bool live = i < wave_count();
    if (live) {
        WaveRay r = rays[i];
        wave_parent = i;
        wave_key = r.key;
        pixel_key = r.key.xyz;
        PendingRay ray = PendingRay(r.origin, r.dir, r.weight, r.depth, r.blur, r.reach);
        Hit h = unpack_hit(hits[i]);
        vec3 traced = vec3(0.0);
        if (h.kind == HIT_SKY) {
            traced += ray.weight * sky_radiance(ray.dir);
        } else {
            shade_hit(ray, h, traced);
        }
        contributions[i] = vec4(traced + past_depth_limit, 0.0);
    }
    emit_children(live);
}
