// The LBVH in GPU memory, byte for byte (std430). Mirrored by NODE_DTYPE and TRIANGLE_DTYPE in
// hybrid_engine/passes/lbvh/lbvh.py, whose itemsize asserts and read-back test catch any drift.
//
// A binary tree over N leaves has N - 1 inner nodes (Karras 2012); node 0 is the root. Each
// inner node stores the boxes of BOTH children, so traversal decides which children to visit
// from one 64-byte fetch without touching the children themselves (paper §3.3 builds the
// boxes bottom-up; §3.4 traverses them).
//
// Child references: ref >= 0 is inner node `ref`; ref < 0 is leaf `~ref`, i.e. triangle
// `~ref` of the reordered triangle array (leaves hold one triangle each, in Morton order).
// Special trees: N = 0 -> node 0 with two empty boxes (every ray misses); N = 1 -> node 0
// with the triangle's box on the left and an empty box on the right. An empty box has
// min = +FLT_MAX and max = -FLT_MAX (min > max) and is never entered.
//
// BVHNode (64 bytes = 4 rows of uvec4; floats stored as their bits so that the integer
// fields never pass through a float register, where a driver could canonicalise NaN patterns):
//   offset  0: float left_min[3]   ; 12: int left_child
//   offset 16: float left_max[3]   ; 28: int right_child
//   offset 32: float right_min[3]  ; 44: int parent      (-1 at the root)
//   offset 48: float right_max[3]  ; 60: int leaf_count  (leaves under this node)
// Rows rather than 16 scalars because a CPU driver (llvmpipe) loads or stores one row with a
// single per-lane loop but pays a loop per scalar field.
//
// BVHTriangle (48 bytes = 3 rows): the vertices of leaf j in Morton order with the ORIGINAL
// triangle index, so a hit reports the caller's index without another lookup.
//   offset  0: float v0[3] ; 12: int prim   (original triangle index)
//   offset 16: float v1[3] ; 28: int 0      (reserved)
//   offset 32: float v2[3] ; 44: int 0      (reserved)
//
// The arrays themselves are declared, and split over several storage blocks when they exceed
// one, by bvh_storage.glsl; passes reach them only through its accessors.
#ifndef HYBRID_BVH_LAYOUT_GLSL
#define HYBRID_BVH_LAYOUT_GLSL

struct BVHNode {
    uvec4 left_min;   // xyz: left child box min (float bits); w: left child ref
    uvec4 left_max;   // xyz: left child box max;              w: right child ref
    uvec4 right_min;  // xyz: right child box min;             w: parent node (-1: root)
    uvec4 right_max;  // xyz: right child box max;             w: leaf count
};  // total: 64 bytes

struct BVHTriangle {
    uvec4 v0;  // xyz: vertex 0 (float bits); w: original triangle index
    uvec4 v1;  // xyz: vertex 1;              w: 0
    uvec4 v2;  // xyz: vertex 2;              w: 0
};  // total: 48 bytes

#define BVH_NODE_BYTES 64
#define BVH_TRIANGLE_BYTES 48
#define BVH_NO_PARENT (-1)

bool bvh_is_leaf(int ref) {
    return ref < 0;
}

uvec4 bvh_pack(vec3 xyz, int w) {
    return uvec4(floatBitsToUint(xyz), uint(w));
}

vec3 bvh_xyz(uvec4 row) {
    return uintBitsToFloat(row.xyz);
}

#endif
