// GPU-shaped LSD radix sort ("gpu" variant of hybrid_engine/gpu/radix_sort.py), step 1 of 3
// per digit: the digit histogram of each tile of TILE_KEYS = LOCAL_SIZE * KEYS_PER_INVOCATION
// keys, counted in shared memory and written digit-major.
//
// Digit-major (histograms[d * u_num_tiles + t]) makes the one exclusive scan of the whole
// array (prefix_scan.py, any variant) the global scatter offsets: the keys of all smaller
// digits, then those of digit d in earlier tiles (Satish, Harris & Garland 2009). Keys are read
// striped across the lanes (coalesced); the shared counters take atomic increments, whose
// order does not matter for a count. Keys at and past u_count are not counted.
//
// Host defines: LOCAL_SIZE, KEYS_PER_INVOCATION, RADIX_BITS (digit width; 8 -> 256 buckets).
// Storage blocks: Keys (read: uint[u_count]), Histograms (write: uint[RADIX * u_num_tiles]).
// Uniforms: u_count, u_num_tiles, u_shift (bit position of the digit).
#include "dispatch.glsl"

layout(local_size_x = LOCAL_SIZE) in;

#define RADIX (1u << RADIX_BITS)
#define DIGIT_MASK (RADIX - 1u)
#define TILE_KEYS (uint(LOCAL_SIZE) * uint(KEYS_PER_INVOCATION))

layout(std430) readonly buffer Keys {
    uint keys[];
};
layout(std430) writeonly buffer Histograms {
    uint histograms[];
};

uniform uint u_count;
uniform uint u_num_tiles;
uniform uint u_shift;

shared uint tile_histogram[RADIX];

void main() {
    uint tile = flat_workgroup_index();
    if (tile >= u_num_tiles) {
        return;  // the whole group: the grid overshoots by whole groups
    }
    uint lane = gl_LocalInvocationID.x;
    for (uint d = lane; d < RADIX; d += uint(LOCAL_SIZE)) {
        tile_histogram[d] = 0u;
    }
    barrier();
    uint base = tile * TILE_KEYS;
    for (uint k = 0u; k < uint(KEYS_PER_INVOCATION); ++k) {
        uint i = base + k * uint(LOCAL_SIZE) + lane;
        if (i < u_count) {
            atomicAdd(tile_histogram[(keys[i] >> u_shift) & DIGIT_MASK], 1u);
        }
    }
    barrier();
    for (uint d = lane; d < RADIX; d += uint(LOCAL_SIZE)) {
        histograms[d * u_num_tiles + tile] = tile_histogram[d];
    }
}
