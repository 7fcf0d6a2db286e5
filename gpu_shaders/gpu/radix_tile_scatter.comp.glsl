// GPU-shaped LSD radix sort ("gpu" variant of hybrid_engine/gpu/radix_sort.py), step 3 of 3
// per digit: each workgroup re-reads its tile, sorts it by the digit in shared memory, stably,
// and writes every key to its digit's global offset plus its rank within the tile.
//
// The tile-local sort is a sequence of 2-bit splits (Satish, Harris & Garland 2009, with
// two bits per split): each lane holds KEYS_PER_INVOCATION consecutive keys, counts its keys
// of each of the four 2-bit values in 16-bit fields of a uvec2, one workgroup scan of those
// counters gives every lane where its keys of each value go, and the keys move there in
// shared memory. A split keeps the order of equal values, so after RADIX_BITS / 2 splits
// (low bits first) the tile is ordered by the digit and, within a digit, by input index: the
// sort is stable, as LSD radix sort needs and as Karras' index tie-break for equal Morton
// codes assumes. The keys of digit d then sit contiguously from digit_start[d]; the one in
// local position i goes to offsets[d, tile] + i - digit_start[d], and neighbouring lanes
// write neighbouring addresses (coalesced).
//
// The last tile is padded with 0xFFFFFFFF keys: their digit is the largest at every shift and
// they come after every real key, so they sort to the tile's end and are never written.
//
// Host defines: LOCAL_SIZE, KEYS_PER_INVOCATION (LOCAL_SIZE * KEYS_PER_INVOCATION < 65536),
//   RADIX_BITS (even).
// Storage blocks: KeysIn, ValuesIn (read: uint[u_count]), Histograms (read: the exclusive scan
//   of radix_tile_count's digit-major counts), KeysOut, ValuesOut (write: uint[u_count]).
// Uniforms: u_count, u_num_tiles, u_shift.
#include "dispatch.glsl"
#define WORKGROUP_SCAN_TYPE uvec2
#include "workgroup_scan.glsl"

layout(local_size_x = LOCAL_SIZE) in;

#define RADIX (1u << RADIX_BITS)
#define DIGIT_MASK (RADIX - 1u)
#define TILE_KEYS (uint(LOCAL_SIZE) * uint(KEYS_PER_INVOCATION))
#define KEYS_PER_LANE uint(KEYS_PER_INVOCATION)

layout(std430) readonly buffer KeysIn {
    uint keys_in[];
};
layout(std430) readonly buffer ValuesIn {
    uint values_in[];
};
layout(std430) readonly buffer Histograms {
    uint histograms[];
};
layout(std430) writeonly buffer KeysOut {
    uint keys_out[];
};
layout(std430) writeonly buffer ValuesOut {
    uint values_out[];
};

uniform uint u_count;
uniform uint u_num_tiles;
uniform uint u_shift;

shared uint tile_keys[TILE_KEYS];
shared uint tile_values[TILE_KEYS];
shared uint digit_offset[RADIX];  // where the tile's first key of each digit goes globally
shared uint digit_start[RADIX];   // local position of the tile's first key of each digit

uint digit_of(uint key) {
    return (key >> u_shift) & DIGIT_MASK;
}

void main() {
    uint tile = flat_workgroup_index();
    if (tile >= u_num_tiles) {
        return;  // the whole group: the grid overshoots by whole groups
    }
    uint lane = gl_LocalInvocationID.x;
    uint base = tile * TILE_KEYS;
    uint valid = min(TILE_KEYS, u_count - base);
    for (uint d = lane; d < RADIX; d += uint(LOCAL_SIZE)) {
        digit_offset[d] = histograms[d * u_num_tiles + tile];
    }
    for (uint k = 0u; k < KEYS_PER_LANE; ++k) {
        uint i = k * uint(LOCAL_SIZE) + lane;
        bool real = i < valid;
        tile_keys[i] = real ? keys_in[base + i] : 0xFFFFFFFFu;
        tile_values[i] = real ? values_in[base + i] : 0u;
    }
    barrier();

    uint first = lane * KEYS_PER_LANE;
    uint key[KEYS_PER_INVOCATION];
    uint value[KEYS_PER_INVOCATION];
    for (uint k = 0u; k < KEYS_PER_LANE; ++k) {
        key[k] = tile_keys[first + k];
        value[k] = tile_values[first + k];
    }
    for (uint bit = 0u; bit < uint(RADIX_BITS); bit += 2u) {
        uint shift = u_shift + bit;
        // Counts of the values 0, 1 (x) and 2, 3 (y), 16 bits each: a tile holds < 65536 keys.
        uvec2 counts = uvec2(0u);
        for (uint k = 0u; k < KEYS_PER_LANE; ++k) {
            uint v = (key[k] >> shift) & 3u;
            uint one = 1u << ((v & 1u) * 16u);
            counts += v < 2u ? uvec2(one, 0u) : uvec2(0u, one);
        }
        uvec2 totals;
        uvec2 below = workgroup_exclusive_scan(counts, totals);
        // The scan's barriers also mean every lane has read its keys: the tile may be rewritten.
        uint total0 = totals.x & 0xFFFFu;
        uint total1 = totals.x >> 16u;
        uint total2 = totals.y & 0xFFFFu;
        uvec4 next = uvec4(below.x & 0xFFFFu, below.x >> 16u, below.y & 0xFFFFu, below.y >> 16u)
                   + uvec4(0u, total0, total0 + total1, total0 + total1 + total2);
        for (uint k = 0u; k < KEYS_PER_LANE; ++k) {
            uint v = (key[k] >> shift) & 3u;
            uint slot = next[v];
            next[v] = slot + 1u;
            tile_keys[slot] = key[k];
            tile_values[slot] = value[k];
        }
        barrier();
        for (uint k = 0u; k < KEYS_PER_LANE; ++k) {
            key[k] = tile_keys[first + k];
            value[k] = tile_values[first + k];
        }
    }

    // Where each digit's run starts: at a position whose left neighbour has another digit.
    for (uint k = 0u; k < KEYS_PER_LANE; ++k) {
        uint position = first + k;
        uint digit = digit_of(key[k]);
        if (position == 0u || digit_of(tile_keys[position - 1u]) != digit) {
            digit_start[digit] = position;
        }
    }
    barrier();
    for (uint k = 0u; k < KEYS_PER_LANE; ++k) {
        uint i = k * uint(LOCAL_SIZE) + lane;
        if (i < valid) {
            uint sorted_key = tile_keys[i];
            uint digit = digit_of(sorted_key);
            uint target = digit_offset[digit] + (i - digit_start[digit]);
            keys_out[target] = sorted_key;
            values_out[target] = tile_values[i];
        }
    }
}
