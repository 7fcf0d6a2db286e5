// SPDX-License-Identifier: GPL-3.0-or-later
// Wave tracer, compaction offsets: one workgroup turns the per-workgroup child counts of a
// wave's parents (BlockSums, counted by wave_primary with WAVE_COUNT / wave_traverse) into
// their exclusive prefix sums, in place, and writes the next queues' counts and indirect
// dispatch arguments (WaveState). The counts never leave the GPU: the next wave's kernels
// are dispatched from them. Stable: children keep their parents' order, so a pixel's rays
// stay together in every queue (wave_resolve.comp.glsl adds them per pixel in that order).
// A queue holds at most its capacity; the most any wave wanted is kept in the frame's last
// slot and, across frames until the host reads and clears it, in WaveOverflow
// (wave_trace.py WaveTracer.note_overflow grows the queues from it).
// Storage blocks: WaveState, BlockSums, WaveOverflow. Uniforms: u_wave_slot (the parents'
//   slot), u_ray_slot, u_occlusion_slot (the children's), u_overflow_slot, u_ray_capacity,
//   u_occlusion_capacity, u_max_groups_x.
#include "wave_queue.glsl"

#define SCAN_LOCAL 256
layout(local_size_x = SCAN_LOCAL) in;

layout(std430) buffer BlockSums { uvec2 block_sums[]; };
uniform int u_ray_slot;
uniform int u_occlusion_slot;
uniform int u_overflow_slot;
layout(std430) buffer WaveOverflow { uvec4 wanted_since_read; };
uniform uint u_ray_capacity;
uniform uint u_occlusion_capacity;
uniform uint u_max_groups_x;

shared uvec2 partial[SCAN_LOCAL];
shared uvec2 total;

uvec4 dispatch_args(uint count) {
    uint groups = (count + uint(WAVE_LOCAL) - 1u) / uint(WAVE_LOCAL);
    uint gx = min(groups, u_max_groups_x);
    uint gy = gx == 0u ? 1u : (groups + gx - 1u) / gx;
    return uvec4(gx, gy, 1u, count);
}

void main() {
    uint t = gl_LocalInvocationIndex;
    uint blocks = (wave_count() + uint(WAVE_LOCAL) - 1u) / uint(WAVE_LOCAL);
    uint chunk = (blocks + uint(SCAN_LOCAL) - 1u) / uint(SCAN_LOCAL);
    uint begin = min(t * chunk, blocks);
    uint end = min(begin + chunk, blocks);
    uvec2 sum = uvec2(0u);
    for (uint b = begin; b < end; ++b) sum += block_sums[b];
    partial[t] = sum;
    barrier();
    if (t == 0u) {
        uvec2 running = uvec2(0u);
        for (uint k = 0u; k < uint(SCAN_LOCAL); ++k) {
            uvec2 v = partial[k];
            partial[k] = running;
            running += v;
        }
        total = running;
    }
    barrier();
    uvec2 offset = partial[t];
    for (uint b = begin; b < end; ++b) {
        uvec2 v = block_sums[b];
        block_sums[b] = offset;
        offset += v;
    }
    if (t == 0u) {
        wave_args[u_ray_slot] = dispatch_args(min(total.x, u_ray_capacity));
        wave_args[u_occlusion_slot] = dispatch_args(min(total.y, u_occlusion_capacity));
        uvec4 seen = wave_args[u_overflow_slot];
        wave_args[u_overflow_slot] = uvec4(max(seen.x, total.x), max(seen.y, total.y), seen.zw);
        wanted_since_read.xy = max(wanted_since_read.xy, total);
    }
}
