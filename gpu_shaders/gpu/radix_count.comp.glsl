// Radix sort, step 1 of 3 per digit: per-chunk digit histograms (LSD radix sort of the Morton
// codes, paper §3.3 "tree construction is reduced to a sorting problem").
//
// The keys are cut into u_num_chunks contiguous chunks of u_chunk_size keys; invocation t
// counts the digits of chunk t serially. No shared memory and no barriers: llvmpipe runs a
// workgroup's lanes as SIMD vectors on one CPU thread and pays for every barrier with a
// coroutine switch, while a serial loop per lane costs nothing extra. On a discrete GPU the
// host picks many short chunks instead.
//
// Host defines: LOCAL_SIZE, RADIX_BITS (digit width; 8 -> 256 buckets).
// Storage blocks: Keys (read), Histograms (write: uint[u_num_chunks * RADIX], chunk-major:
//   histograms[t * RADIX + d] = keys of chunk t whose digit is d).
// Uniforms: u_count (keys), u_chunk_size, u_num_chunks, u_shift (bit position of the digit).
#include "dispatch.glsl"
#include "chunks.glsl"

layout(local_size_x = LOCAL_SIZE) in;

#define RADIX (1u << RADIX_BITS)
#define DIGIT_MASK (RADIX - 1u)

layout(std430) readonly buffer Keys {
    uint keys[];
};
layout(std430) buffer Histograms {
    uint histograms[];
};

uniform uint u_shift;

void main() {
    uint chunk, begin, end;
    if (!chunk_items(chunk, begin, end)) {
        return;
    }
    uint row = chunk * RADIX;
    for (uint d = 0u; d < RADIX; ++d) {
        histograms[row + d] = 0u;
    }
    for (uint i = begin; i < end; ++i) {
        uint digit = (keys[i] >> u_shift) & DIGIT_MASK;
        histograms[row + digit] += 1u;
    }
}
