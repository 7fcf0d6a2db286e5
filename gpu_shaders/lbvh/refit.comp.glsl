// LBVH pass 5: reorder the triangles into leaf order and build the boxes bottom-up
// (paper §3.3 "tree and AABB construction similar to Karras"; Karras 2012 §4).
//
// One invocation per leaf j: it copies triangle values[j] into slot j of the BVH triangle
// array, computes its box and walks towards the root. At every inner node it stores the box it
// carries into the node's left or right child slot (child boxes live in the parent, see
// bvh_layout.glsl), then increments the node's atomic flag: the first arrival stops, the second
// knows that both child boxes are written, merges them and continues upwards. Every node is
// thus finished by exactly one invocation, O(N) work in all.
//
// Degenerate input: a triangle with a NaN or infinite coordinate gets an empty box
// (min = +FLOAT_MAX, max = -FLOAT_MAX), so no ray ever reaches it and it cannot stretch its
// ancestors' boxes. Zero-area triangles keep their (flat) boxes; the watertight test rejects
// them (determinant 0).
//
// Host defines: LOCAL_SIZE, (triangle_input.glsl's index list unused here),
//   TRI_INPUT_BLOCKS, TRI_INPUT_BLOCK_SIZE, BVH_NODE_BLOCKS, BVH_NODE_BLOCK_SIZE,
//   BVH_TRIANGLE_BLOCKS, BVH_TRIANGLE_BLOCK_SIZE (the last six only for arrays split over
//   storage blocks: triangle_input.glsl, bvh_storage.glsl).
// Storage blocks: TriangleInput (read; TriangleInput1..3 when split), Values (read: original
//   triangle index per leaf), BVHNodes (read/write, coherent; BVHNodes1..3 when split),
//   LeafParent (read), RefitFlags (atomic), BVHTriangles (write; BVHTriangles1..3 when split),
//   BuildCount (read: the leaves N, build_count.glsl).
// The host dispatches at least N invocations (for its upper bound of N, or indirectly N).
#include "build_count.glsl"
#include "dispatch.glsl"
#include "float_order.glsl"
#include "bvh_layout.glsl"
#include "triangle_input.glsl"

#define BVH_NODES
#define BVH_NODES_ACCESS coherent
#define BVH_TRIANGLES
#define BVH_TRIANGLES_ACCESS writeonly
#define BVH_TRIANGLES_WRITEONLY
#include "bvh_storage.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430) readonly buffer Values {
    uint values[];
};
layout(std430) readonly buffer LeafParent {
    int leaf_parent[];
};
layout(std430) coherent buffer RefitFlags {
    uint refit_flags[];
};

void main() {
    uint leaf = flat_invocation_index();
    if (leaf >= build_count()) {
        return;
    }
    uint prim = values[leaf];
    vec3 v0 = input_vertex(prim, 0u);
    vec3 v1 = input_vertex(prim, 1u);
    vec3 v2 = input_vertex(prim, 2u);
    bvh_triangle_store(leaf, BVHTriangle(bvh_pack(v0, int(prim)), bvh_pack(v1, 0), bvh_pack(v2, 0)));

    vec3 lo = vec3(FLOAT_MAX);
    vec3 hi = vec3(-FLOAT_MAX);
    if (all_finite(v0) && all_finite(v1) && all_finite(v2)) {
        lo = min(v0, min(v1, v2));
        hi = max(v0, max(v1, v2));
    }

    int child = ~int(leaf);
    int node = leaf_parent[leaf];
    while (node >= 0) {
        uint at = uint(node);
        bool is_left = int(bvh_node_row(at, BVH_ROW_LEFT_MIN).w) == child;
        if (is_left) {
            bvh_node_set_xyz(at, BVH_ROW_LEFT_MIN, floatBitsToUint(lo));
            bvh_node_set_xyz(at, BVH_ROW_LEFT_MAX, floatBitsToUint(hi));
        } else {
            bvh_node_set_xyz(at, BVH_ROW_RIGHT_MIN, floatBitsToUint(lo));
            bvh_node_set_xyz(at, BVH_ROW_RIGHT_MAX, floatBitsToUint(hi));
        }
        memoryBarrierBuffer();
        if (atomicAdd(refit_flags[node], 1u) == 0u) {
            return;  // the sibling's invocation is still on its way; it finishes this node
        }
        memoryBarrierBuffer();
        // Second arrival: the sibling's box is in the other slot; merge it with ours.
        if (is_left) {
            lo = min(lo, bvh_xyz(bvh_node_row(at, BVH_ROW_RIGHT_MIN)));
            hi = max(hi, bvh_xyz(bvh_node_row(at, BVH_ROW_RIGHT_MAX)));
        } else {
            lo = min(lo, bvh_xyz(bvh_node_row(at, BVH_ROW_LEFT_MIN)));
            hi = max(hi, bvh_xyz(bvh_node_row(at, BVH_ROW_LEFT_MAX)));
        }
        child = node;
        node = int(bvh_node_row(at, BVH_ROW_RIGHT_MIN).w);
    }
}
