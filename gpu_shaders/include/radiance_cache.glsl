// SPDX-License-Identifier: GPL-3.0-or-later
// The diffuse paths' world-space radiance cache (hybrid_engine/passes/diffuse_light/
// radiance_cache.py): a hash table of cells, each the mean irradiance that the paths
// leaving the surfaces in it have brought back over the last frames.
//
// A cell is a cube of the world, times the bucket of the surface's facing normal (its
// dominant axis and sign: the two sides of a wall, the floor and the wall at a corner never
// share one). Its size is a fixed share of the view's height at its distance from the camera
// (u_radiance_cell_pixels pixel footprints), in powers of two of the scene's typical object
// size (random.glsl's position_key): so the table holds about as many cells at any resolution
// (more pixels leave more paths in each), and one scene in millimetres or kilometres is
// cached alike.
//
// Slots are found by a hash of the cell and checked by a second hash of it (never 0: 0 marks
// a free slot), probing RADIANCE_PROBES slots from the first. Lookups compare every probed
// slot (a slot freed by the resolve may sit before the one that holds a cell). Deposits add
// in 64-bit fixed point (two words and a carry), so that their sum does not depend on the
// order the invocations add in: the same frame gives the same image.
//
// Host defines: RADIANCE_CACHE_SLOTS (a power of two), RADIANCE_PROBES, RADIANCE_FIXED_BITS
// (the fixed point's fraction bits).
#ifndef HYBRID_RADIANCE_CACHE_GLSL
#define HYBRID_RADIANCE_CACHE_GLSL
#include "random.glsl"

struct RadianceSlot {
    uint key;       // the cell's check hash; 0: free
    uint count;     // paths deposited this frame
    uint age;       // frames since the last deposit (radiance_cache_resolve.comp.glsl)
    uint pad;
    uvec4 low;      // this frame's deposits' sum (rgb), fixed point: the low words
    uvec4 high;     // and the high words
    vec4 mean;      // rgb the mean irradiance so far, a the deposits it holds
};

layout(std430) buffer RadianceCache { RadianceSlot radiance_slots[]; };

// A cell's size in pixel footprints at its distance (radiance_cache.py cell_pixels).
uniform float u_radiance_cell_pixels;

// The cell of point p (facing geometric normal g): its hash (which slot to start from) and
// its check hash (never 0).
uvec2 radiance_cell(vec3 p, vec3 g) {
    float unit, level;
    level = footprint_level(p, u_radiance_cell_pixels, unit, level) ? clamp(level, -100.0, 100.0) : -8.0;
    vec3 q = p / (unit * exp2(level));
    ivec3 c = ivec3(floor(clamp(q, vec3(-2.0e9), vec3(2.0e9))));
    vec3 a = abs(g);
    uint axis = a.x >= a.y && a.x >= a.z ? 0u : (a.y >= a.z ? 1u : 2u);
    uint bucket = axis * 2u + ((axis == 0u ? g.x : axis == 1u ? g.y : g.z) < 0.0 ? 1u : 0u);
    uint h = hash_key(uvec4(uvec3(c), uint(level + 128.0) * 8u + bucket));
    uint check = pcg_hash(h ^ 0x68bc21ebu) | 1u;
    return uvec2(h, check);
}

// The slot that holds `cell`, or -1.
int radiance_find(uvec2 cell) {
    for (uint i = 0u; i < uint(RADIANCE_PROBES); ++i) {
        uint slot = (cell.x + i) & uint(RADIANCE_CACHE_SLOTS - 1);
        if (radiance_slots[slot].key == cell.y) return int(slot);
    }
    return -1;
}

// The cell's mean irradiance so far (rgb) and the deposits it holds (a); 0 where it has none.
vec4 radiance_lookup(uvec2 cell) {
    int slot = radiance_find(cell);
    return slot >= 0 ? radiance_slots[slot].mean : vec4(0.0);
}

// One path's irradiance sample at `cell`: claims a slot for the cell where none holds it
// (none where every probed slot holds another cell: the sample is dropped).
void radiance_deposit(uvec2 cell, vec3 irradiance) {
    if (any(isnan(irradiance)) || any(isinf(irradiance))) return;
    int slot = radiance_find(cell);
    for (uint i = 0u; slot < 0 && i < uint(RADIANCE_PROBES); ++i) {
        uint s = (cell.x + i) & uint(RADIANCE_CACHE_SLOTS - 1);
        uint was = atomicCompSwap(radiance_slots[s].key, 0u, cell.y);
        if (was == 0u || was == cell.y) slot = int(s);
    }
    if (slot < 0) return;
    atomicAdd(radiance_slots[slot].count, 1u);
    for (int c = 0; c < 3; ++c) {
        // value * 2^RADIANCE_FIXED_BITS as high * 2^32 + low.
        float scaled = clamp(irradiance[c], 0.0, 1.0e9) * exp2(float(RADIANCE_FIXED_BITS));
        float high = floor(scaled * exp2(-32.0));
        uint low = uint(clamp(scaled - high * exp2(32.0), 0.0, 4294967040.0));
        uint carry = 0u;
        if (low != 0u) {
            uint was = atomicAdd(radiance_slots[slot].low[c], low);
            carry = was > 0xffffffffu - low ? 1u : 0u;
        }
        if (high > 0.0 || carry != 0u) atomicAdd(radiance_slots[slot].high[c], uint(high) + carry);
    }
}

// A slot's deposits' sum, from its fixed-point words.
vec3 radiance_sum(uvec4 low, uvec4 high) {
    return (vec3(high.xyz) * exp2(32.0) + vec3(low.xyz)) * exp2(-float(RADIANCE_FIXED_BITS));
}
#endif
