// Multi-workgroup exclusive prefix sum ("gpu" variant of hybrid_engine/gpu/prefix_scan.py),
// step 3 of 3 (and the whole scan when the values fit one block): each workgroup scans its
// block of BLOCK_ITEMS = LOCAL_SIZE * ITEMS_PER_INVOCATION values in shared memory and adds the
// block's offset, the scanned sum of the blocks before it (scan_reduce.comp.glsl, then the
// host's scan of the block sums).
//
// The block is loaded and stored striped (lane-adjacent words: coalesced), scanned blocked
// (each lane its ITEMS_PER_INVOCATION consecutive values, then one workgroup scan of the lanes'
// sums), so a value is read and written once in global memory.
//
// Host defines: LOCAL_SIZE (a power of two), ITEMS_PER_INVOCATION.
// Storage blocks: Data (read/write: uint[u_count + 1]; exclusive sums in place, the total at
//   data[u_count]), BlockSums (read: uint[u_num_blocks + 1], the scanned block sums and their
//   total; unused with u_use_block_sums = 0).
// Uniforms: u_count, u_num_blocks, u_use_block_sums (0: one block, offset 0, its own total).
#include "dispatch.glsl"
#include "workgroup_scan.glsl"

layout(local_size_x = LOCAL_SIZE) in;

#define BLOCK_ITEMS (uint(LOCAL_SIZE) * uint(ITEMS_PER_INVOCATION))

layout(std430) buffer Data {
    uint data[];
};
layout(std430) readonly buffer BlockSums {
    uint block_sums[];
};

uniform uint u_count;
uniform uint u_num_blocks;
uniform uint u_use_block_sums;

shared uint items[BLOCK_ITEMS];

void main() {
    uint block = flat_workgroup_index();
    if (block >= u_num_blocks) {
        return;
    }
    uint lane = gl_LocalInvocationID.x;
    uint base = block * BLOCK_ITEMS;
    for (uint k = 0u; k < uint(ITEMS_PER_INVOCATION); ++k) {
        uint i = k * uint(LOCAL_SIZE) + lane;
        items[i] = base + i < u_count ? data[base + i] : 0u;
    }
    barrier();
    uint first = lane * uint(ITEMS_PER_INVOCATION);
    uint sum = 0u;
    for (uint k = 0u; k < uint(ITEMS_PER_INVOCATION); ++k) {
        sum += items[first + k];
    }
    uint block_total;
    uint running = workgroup_exclusive_scan(sum, block_total);
    if (u_use_block_sums != 0u) {
        running += block_sums[block];
    }
    for (uint k = 0u; k < uint(ITEMS_PER_INVOCATION); ++k) {
        uint value = items[first + k];
        items[first + k] = running;
        running += value;
    }
    barrier();
    for (uint k = 0u; k < uint(ITEMS_PER_INVOCATION); ++k) {
        uint i = k * uint(LOCAL_SIZE) + lane;
        if (base + i < u_count) {
            data[base + i] = items[i];
        }
    }
    if (block == 0u && lane == 0u) {
        data[u_count] = u_use_block_sums != 0u ? block_sums[u_num_blocks] : block_total;
    }
}
