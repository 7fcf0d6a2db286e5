// LBVH pass 1: bounds of the triangle centroids (paper §3.3: the Morton grid spans the culled
// set, not the whole scene).
//
// Centroids are kept as vertex sums ((v0 + v1) + v2), 3x the centroid, so no division enters
// the Morton quantisation (see morton.glsl). Non-finite sums are skipped: such triangles get
// the invalid Morton code and an empty box later, and never stretch the grid.
//
// Host defines: LOCAL_SIZE (64; llvmpipe runs 8 lanes per SIMD op, 64 keeps a group short),
//   ITEMS_PER_INVOCATION (elements each invocation folds before its atomics),
//   TRI_INPUT_BLOCKS, TRI_INPUT_BLOCK_SIZE (the
//   last two only for an input split over storage blocks).
// Storage blocks: TriangleInput (read; TriangleInput1..3 when split), TriangleIndex (read, if
//   u_use_indices), Bounds (read/write: 6 uints, ordered-float min xyz then max xyz; the host
//   resets them), BuildCount (read: the element count, build_count.glsl).
// Uniforms: u_use_indices. The host dispatches for the build's capacity (an upper bound of
//   the count); invocations past the count fold nothing.
#include "build_count.glsl"
#include "dispatch.glsl"
#include "float_order.glsl"
#include "triangle_input.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430) buffer Bounds {
    uint bounds[6];
};

void main() {
    uint count = build_count();
    // Block-strided: lane l of group g reads g*B + l, g*B + l + LOCAL_SIZE, ... so that the
    // lanes of one SIMD op touch neighbouring triangles.
    uint block = flat_workgroup_index() * uint(LOCAL_SIZE * ITEMS_PER_INVOCATION);
    vec3 lo = vec3(FLOAT_MAX);
    vec3 hi = vec3(-FLOAT_MAX);
    bool any_valid = false;
    for (uint k = 0u; k < uint(ITEMS_PER_INVOCATION); ++k) {
        uint element = block + k * uint(LOCAL_SIZE) + gl_LocalInvocationID.x;
        if (element >= count) {
            break;
        }
        uint prim = input_triangle(element);
        precise vec3 sum = (input_vertex(prim, 0u) + input_vertex(prim, 1u)) + input_vertex(prim, 2u);
        if (all_finite(sum)) {
            lo = min(lo, sum);
            hi = max(hi, sum);
            any_valid = true;
        }
    }
    if (any_valid) {
        atomicMin(bounds[0], float_to_ordered(lo.x));
        atomicMin(bounds[1], float_to_ordered(lo.y));
        atomicMin(bounds[2], float_to_ordered(lo.z));
        atomicMax(bounds[3], float_to_ordered(hi.x));
        atomicMax(bounds[4], float_to_ordered(hi.y));
        atomicMax(bounds[5], float_to_ordered(hi.z));
    }
}
