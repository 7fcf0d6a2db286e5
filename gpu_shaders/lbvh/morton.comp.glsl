// LBVH pass 2: one 30-bit Morton code per triangle centroid (paper §3.3; Karras 2012 §4).
//
// Host defines: LOCAL_SIZE, TRI_INPUT_BLOCKS,
//   TRI_INPUT_BLOCK_SIZE (the last two only for an input split over storage blocks).
// Storage blocks: TriangleInput (read; TriangleInput1..3 when split), TriangleIndex (read, if
//   u_use_indices), Bounds (read: the ordered-float centroid-sum bounds of
//   centroid_bounds.comp.glsl), Keys (write: codes), Values (write: the ORIGINAL triangle
//   index of each element, carried through the sort), BuildCount (read: the element count N,
//   build_count.glsl).
// Uniforms: u_capacity (keys the sort orders: the host's upper bound of N), u_use_indices.
// One element per invocation over the capacity; the dispatch may be split over x and y
// (dispatch.glsl). Elements N .. capacity - 1 get the padding key 0xFFFFFFFF, above every
// code (MORTON_INVALID included): the stable sort of all capacity keys leaves the N real ones
// first, in the order a sort of N keys gives them.
#include "build_count.glsl"
#include "dispatch.glsl"
#include "float_order.glsl"
#include "morton.glsl"
#include "triangle_input.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430) readonly buffer Bounds {
    uint bounds[6];
};
layout(std430) writeonly buffer Keys {
    uint keys[];
};
layout(std430) writeonly buffer Values {
    uint values[];
};

uniform uint u_capacity;

#define PADDING_KEY 0xFFFFFFFFu

void main() {
    uint element = flat_invocation_index();
    if (element >= u_capacity) {
        return;
    }
    if (element >= build_count()) {
        keys[element] = PADDING_KEY;
        values[element] = PADDING_KEY;
        return;
    }
    vec3 lo = vec3(ordered_to_float(bounds[0]), ordered_to_float(bounds[1]),
                   ordered_to_float(bounds[2]));
    vec3 hi = vec3(ordered_to_float(bounds[3]), ordered_to_float(bounds[4]),
                   ordered_to_float(bounds[5]));
    precise vec3 extent = hi - lo;
    vec3 scale = vec3(morton_axis_scale(extent.x), morton_axis_scale(extent.y),
                      morton_axis_scale(extent.z));

    uint prim = input_triangle(element);
    precise vec3 sum = (input_vertex(prim, 0u) + input_vertex(prim, 1u)) + input_vertex(prim, 2u);
    // A non-finite centroid (NaN/inf vertex, or a finite triangle whose sum overflows) sorts
    // last; its leaf box decides whether it can ever be hit.
    keys[element] = all_finite(sum) ? morton_code(sum, lo, scale) : MORTON_INVALID;
    values[element] = prim;
}
