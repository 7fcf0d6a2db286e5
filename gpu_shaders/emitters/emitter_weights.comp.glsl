// SPDX-License-Identifier: GPL-3.0-or-later
// Each emitter's integer weight, its power quantised against the frame's largest
// (emitter_power.comp.glsl): round(power / max x u_levels), at least 1 for any positive
// power (no light is ever left unsampled), 0 for none. The prefix scan of these weights
// (hybrid_engine/gpu/prefix_scan.py, in place, total at [u_count]) is the CDF
// emitter_light.glsl picks by: integer sums are exact in either scan shape, and the
// estimator divides by the weight's own share of the total, so the pick is unbiased however
// coarse the quantisation (it only makes the pick less proportional to the power).
// u_levels * u_count stays below 2^32 (the host sizes it).
//
// Host defines: LOCAL_SIZE.
// Storage blocks: EmitterTriangles, EmitterMax (read); EmitterCdf (written: uint per emitter).
// Uniforms: u_count, u_levels.
#include "dispatch.glsl"
#include "emitter_layout.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430) readonly buffer EmitterTriangles { Emitter emitters[]; };
layout(std430) readonly buffer EmitterMax { uint emitter_max_bits; };
layout(std430) writeonly buffer EmitterCdf { uint emitter_cdf[]; };

uniform uint u_count;
uniform uint u_levels;

void main() {
    uint i = flat_invocation_index();
    if (i >= u_count) return;
    float power = emitters[i].edge2.w;
    float largest = uintBitsToFloat(emitter_max_bits);
    uint weight = 0u;
    if (power > 0.0 && largest > 0.0) {
        float share = min(power / largest, 1.0);
        weight = clamp(uint(share * float(u_levels) + 0.5), 1u, u_levels);
    }
    emitter_cdf[i] = weight;
}
