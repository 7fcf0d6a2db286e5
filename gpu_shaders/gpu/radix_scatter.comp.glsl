// Radix sort, step 3 of 3 per digit: stable scatter of (key, value) pairs to their offsets.
//
// Invocation t walks chunk t in order and bumps its own offset row, so equal digits keep
// their input order (required for LSD radix sort, and it makes ties in the Morton codes fall
// back to the element order that Karras' index tie-break assumes).
//
// Host defines: LOCAL_SIZE, RADIX_BITS.
// Storage blocks: KeysIn (read), Histograms (read/write: offsets from radix_scan, consumed),
//   ValuesIn (read), KeysOut (write), ValuesOut (write).
// Uniforms: u_count, u_chunk_size, u_num_chunks, u_shift.
#include "dispatch.glsl"
#include "chunks.glsl"

layout(local_size_x = LOCAL_SIZE) in;

#define RADIX (1u << RADIX_BITS)
#define DIGIT_MASK (RADIX - 1u)

layout(std430) readonly buffer KeysIn {
    uint keys_in[];
};
layout(std430) buffer Histograms {
    uint histograms[];
};
layout(std430) readonly buffer ValuesIn {
    uint values_in[];
};
layout(std430) writeonly buffer KeysOut {
    uint keys_out[];
};
layout(std430) writeonly buffer ValuesOut {
    uint values_out[];
};

uniform uint u_shift;

void main() {
    uint chunk, begin, end;
    if (!chunk_items(chunk, begin, end)) {
        return;
    }
    uint row = chunk * RADIX;
    for (uint i = begin; i < end; ++i) {
        uint key = keys_in[i];
        uint slot = row + ((key >> u_shift) & DIGIT_MASK);
        uint target = histograms[slot];
        histograms[slot] = target + 1u;
        keys_out[target] = key;
        values_out[target] = values_in[i];
    }
}
