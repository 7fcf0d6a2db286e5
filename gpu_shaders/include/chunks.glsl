// SPDX-License-Identifier: GPL-3.0-or-later
// Chunked passes: the items are cut into u_num_chunks contiguous chunks of u_chunk_size, and
// invocation c walks chunk c in order. llvmpipe gives each thread one contiguous part of a
// dispatch, so a pass that keeps per-chunk state (a histogram, a count for a prefix sum)
// reads its items sequentially instead of striding through memory.
//
//   bool chunk_items(out uint chunk, out uint begin, out uint end)
//
// false for an invocation past the last chunk; otherwise its chunk and items [begin, end).
// Uniforms: u_count (items), u_chunk_size, u_num_chunks. Needs dispatch.glsl.
#ifndef HYBRID_CHUNKS_GLSL
#define HYBRID_CHUNKS_GLSL

uniform uint u_count;
uniform uint u_chunk_size;
uniform uint u_num_chunks;

bool chunk_items(out uint chunk, out uint begin, out uint end) {
    chunk = flat_invocation_index();
    begin = chunk * u_chunk_size;
    end = min(begin + u_chunk_size, u_count);
    return chunk < u_num_chunks;
}

#endif
