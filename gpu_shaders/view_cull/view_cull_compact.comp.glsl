// SPDX-License-Identifier: GPL-3.0-or-later
// Per-triangle culling of raster draws, step 2: compaction into an index buffer and one
// indirect draw command per view (see view_cull.comp.glsl).
//
// Invocation c writes the kept items of chunk c, in order, from its exclusive-prefix offset
// (gpu/scan.comp.glsl over the chunk counts): triangle t becomes the three vertex indices
// 3t, 3t+1, 3t+2 of the scene's vertex buffer (three vertices per triangle, scene_upload/scene_buffers.py).
// The output keeps the work list's order -- view by view, each in triangle order -- so the
// depth test resolves ties exactly as the direct draws did. The invocation of a view's first
// chunk writes that view's DrawElementsIndirectCommand {count, 1, first index, 0, 0}.
//
// Host defines: LOCAL_SIZE, MAX_VIEWS.
// Storage blocks: Segments (read, view_cull_segments.glsl), ChunkMasks (read: uint[C]),
//   ChunkOffsets (read: uint[C + 1], scanned counts), Indices (write: uint[3 kept]), Commands
//   (write: uint[5 V]).
// Uniforms: u_num_chunks (C), u_num_segments, u_num_views (V), u_view_chunks[MAX_VIEWS + 1]
//   (view v owns chunks [u_view_chunks[v], u_view_chunks[v + 1]) ).
#include "dispatch.glsl"
#include "view_cull_segments.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430) readonly buffer ChunkMasks {
    uint chunk_masks[];
};
layout(std430) readonly buffer ChunkOffsets {
    uint chunk_offsets[];
};
layout(std430) writeonly buffer Indices {
    uint indices[];
};
layout(std430) writeonly buffer Commands {
    uint commands[];
};

uniform uint u_num_chunks;
uniform uint u_num_views;
uniform uint u_view_chunks[MAX_VIEWS + 1];

void main() {
    uint chunk = flat_invocation_index();
    if (chunk >= u_num_chunks) {
        return;
    }
    for (uint v = 0u; v < u_num_views; ++v) {
        if (u_view_chunks[v] == chunk && u_view_chunks[v + 1u] > chunk) {
            uint first = chunk_offsets[chunk];
            uint end = chunk_offsets[u_view_chunks[v + 1u]];
            commands[5u * v + 0u] = 3u * (end - first);
            commands[5u * v + 1u] = 1u;
            commands[5u * v + 2u] = 3u * first;
            commands[5u * v + 3u] = 0u;
            commands[5u * v + 4u] = 0u;
        }
    }
    uint mask = chunk_masks[chunk];
    if (mask == 0u) {
        return;
    }
    uint begin = chunk * 32u;
    int seg = segment_of(begin);
    uint target = chunk_offsets[chunk];
    for (uint b = 0u; b < 32u; ++b) {
        if ((mask & (1u << b)) == 0u) {
            continue;
        }
        uint item = begin + b;
        while (seg + 1 < int(u_num_segments) && segments[seg + 1].z <= item) {
            ++seg;
        }
        uint tri = segments[seg].x + (item - segments[seg].z);
        indices[3u * target + 0u] = 3u * tri;
        indices[3u * target + 1u] = 3u * tri + 1u;
        indices[3u * target + 2u] = 3u * tri + 2u;
        ++target;
    }
}
