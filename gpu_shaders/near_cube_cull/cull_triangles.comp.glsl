// Near-cube culling, step 2: per-triangle decision and per-chunk kept counts (paper §3.3: "the
// second pass performs per triangle culling").
//
// Invocation t walks chunk t of the elements in order: the triangles themselves, or (uniform
// u_use_indices = 1) an ascending list of candidate triangles -- the host leaves out the
// objects whose bounds miss the cube, so their triangles cost nothing here. Each triangle takes its object's class
// (objects are sorted by first triangle, so the object index only moves forward inside a
// chunk; a binary search finds the chunk's first object). Triangles of straddling objects, and
// triangles outside every object range, get the exact triangle/box SAT test (tri_box.glsl)
// against the cube grown by the overlap margin. A 0/1 flag per triangle and the chunk's kept
// count feed the prefix sum and compaction.
//
// Host defines: LOCAL_SIZE, (TriangleIndex: the candidates),
//   TRI_INPUT_BLOCKS, TRI_INPUT_BLOCK_SIZE (the last two only for a scene split over storage
//   blocks: triangle_input.glsl).
// Storage blocks: TriangleInput (read; TriangleInput1..3 for a split scene), ObjectRanges
//   (read: ivec2[K] first, count; sorted by first), ObjectClass (read), KeepFlags (write:
//   uint[N]), ChunkCounts (write: uint[T]).
// Uniforms: u_count (N), u_chunk_size, u_num_chunks (T), u_num_objects (K), u_center,
//   u_half_size.
#include "dispatch.glsl"
#include "chunks.glsl"
#include "float_order.glsl"
#include "triangle_input.glsl"
#include "tri_box.glsl"
#include "near_cube_class.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430) readonly buffer ObjectRanges {
    ivec2 object_ranges[];
};
layout(std430) readonly buffer ObjectClass {
    uint object_class[];
};
layout(std430) writeonly buffer KeepFlags {
    uint keep_flags[];
};
layout(std430) writeonly buffer ChunkCounts {
    uint chunk_counts[];
};

uniform uint u_num_objects;
uniform vec3 u_center;
uniform vec3 u_half_size;


void main() {
    uint chunk, begin, end;
    if (!chunk_items(chunk, begin, end)) {
        return;
    }
    uint first_triangle = begin < end ? input_triangle(begin) : 0u;
    // Last object whose first triangle is <= the chunk's first triangle (-1 if none).
    int lo = 0;
    int hi = int(u_num_objects) - 1;
    int object = -1;
    while (lo <= hi) {
        int mid = (lo + hi) / 2;
        if (uint(object_ranges[mid].x) <= first_triangle) {
            object = mid;
            lo = mid + 1;
        } else {
            hi = mid - 1;
        }
    }
    uint kept = 0u;
    for (uint i = begin; i < end; ++i) {
        uint t = input_triangle(i);  // ascending, so the object walk only moves forward
        while (object + 1 < int(u_num_objects) && uint(object_ranges[object + 1].x) <= t) {
            ++object;
        }
        uint cls = CLASS_STRADDLING;
        if (object >= 0 && t < uint(object_ranges[object].x + object_ranges[object].y)) {
            cls = object_class[object];
        }
        bool keep = cls == CLASS_INSIDE;
        if (cls == CLASS_STRADDLING) {
            keep = tri_box_overlap(input_vertex(t, 0u), input_vertex(t, 1u), input_vertex(t, 2u),
                                   u_center, u_half_size);
        }
        keep_flags[i] = keep ? 1u : 0u;
        kept += keep ? 1u : 0u;
    }
    chunk_counts[chunk] = kept;
}
