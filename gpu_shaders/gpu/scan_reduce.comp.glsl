// Multi-workgroup exclusive prefix sum ("gpu" variant of hybrid_engine/gpu/prefix_scan.py),
// step 1 of 3: the sum of each block of BLOCK_ITEMS = LOCAL_SIZE * ITEMS_PER_INVOCATION values.
//
// Reduce-then-scan (Merrill & Grimshaw 2009): the block sums are scanned next (recursively by
// the host, one workgroup once they fit one block) and scan_blocks.comp.glsl adds them back.
// One workgroup per block, loads striped across the lanes so that neighbouring lanes read
// neighbouring words; the lanes' partial sums are folded in shared memory.
//
// Host defines: LOCAL_SIZE (a power of two), ITEMS_PER_INVOCATION.
// Storage blocks: Data (read: uint[u_count]), BlockSums (write: uint[u_num_blocks]).
// Uniforms: u_count, u_num_blocks.
#include "dispatch.glsl"

layout(local_size_x = LOCAL_SIZE) in;

#define BLOCK_ITEMS (uint(LOCAL_SIZE) * uint(ITEMS_PER_INVOCATION))

layout(std430) readonly buffer Data {
    uint data[];
};
layout(std430) writeonly buffer BlockSums {
    uint block_sums[];
};

uniform uint u_count;
uniform uint u_num_blocks;

shared uint partial[LOCAL_SIZE];

void main() {
    uint block = flat_workgroup_index();
    if (block >= u_num_blocks) {
        return;  // the whole group: the grid overshoots by whole groups
    }
    uint lane = gl_LocalInvocationID.x;
    uint base = block * BLOCK_ITEMS;
    uint sum = 0u;
    for (uint k = 0u; k < uint(ITEMS_PER_INVOCATION); ++k) {
        uint i = base + k * uint(LOCAL_SIZE) + lane;
        if (i < u_count) {
            sum += data[i];
        }
    }
    partial[lane] = sum;
    barrier();
    for (uint stride = uint(LOCAL_SIZE) / 2u; stride > 0u; stride >>= 1u) {
        if (lane < stride) {
            partial[lane] += partial[lane + stride];
        }
        barrier();
    }
    if (lane == 0u) {
        block_sums[block] = partial[0];
    }
}
