// SPDX-License-Identifier: GPL-3.0-or-later
// A ray weight through the wave queues' packing and back (include/wave_queue.glsl
// pack_weight, unpack_weight), for tests/test_wave_trace.py.
// Storage blocks: Weights (read: vec4 per weight, rgb), Unpacked (write: vec4 per weight).
// Uniforms: u_count.
#include "wave_queue.glsl"

layout(local_size_x = 64) in;

layout(std430) readonly buffer Weights { vec4 weights[]; };
layout(std430) writeonly buffer Unpacked { vec4 unpacked[]; };
uniform uint u_count;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    unpacked[i] = vec4(unpack_weight(pack_weight(weights[i].rgb)), 0.0);
}
