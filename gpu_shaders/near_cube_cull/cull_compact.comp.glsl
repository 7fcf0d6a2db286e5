// Near-cube culling, step 3: stream compaction. Invocation t writes the indices of chunk t's
// kept triangles, in order, from its exclusive-prefix offset (scan.comp.glsl), so the output
// list is sorted by triangle index. Element i is triangle i, or candidates[i] when the host
// passed a candidate list (u_use_indices = 1, cull_triangles.comp.glsl).
//
// Host defines: LOCAL_SIZE.
// Storage blocks: KeepFlags (read), ChunkOffsets (read: uint[T + 1], scanned counts),
//   KeptIndices (write: uint[kept]), Candidates (read: uint[N], with u_use_indices).
// Uniforms: u_count (N), u_chunk_size, u_num_chunks (T), u_use_indices.
#include "dispatch.glsl"
#include "chunks.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430) readonly buffer KeepFlags {
    uint keep_flags[];
};
layout(std430) readonly buffer ChunkOffsets {
    uint chunk_offsets[];
};
layout(std430) writeonly buffer KeptIndices {
    uint kept_indices[];
};
layout(std430) readonly buffer Candidates {
    uint candidates[];
};

uniform int u_use_indices;


void main() {
    uint chunk, begin, end;
    if (!chunk_items(chunk, begin, end)) {
        return;
    }
    uint target = chunk_offsets[chunk];
    for (uint i = begin; i < end; ++i) {
        if (keep_flags[i] != 0u) {
            kept_indices[target] = u_use_indices != 0 ? candidates[i] : i;
            ++target;
        }
    }
}
