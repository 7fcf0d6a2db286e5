// The arrays of a built LBVH (layout: bvh_layout.glsl) and their accessors, possibly split over
// several storage blocks (storage_blocks.glsl): the node array exceeds one 128 MiB block
// beyond 2^21 nodes (2.1M leaves), the triangle array beyond 2.8M leaves.
//
// Declares the node array if BVH_NODES is defined and the triangle array if BVH_TRIANGLES
// is defined, so each pass gets only what it binds. Passes touch them
// only through the functions below; with one block each compiles to a plain array access.
//
// Host defines (all optional except the choice of arrays):
//   BVH_NODES, BVH_NODES_ACCESS (memory qualifier; default readonly, and then no
//     setters are compiled),
//   BVH_NODE_BLOCKS (1..4, default 1), BVH_NODE_BLOCK_SIZE (nodes per block);
//   BVH_TRIANGLES, BVH_TRIANGLES_ACCESS (default readonly; a pass that defines it as
//     writeonly also defines BVH_TRIANGLES_WRITEONLY, which drops the getter),
//   BVH_TRIANGLE_BLOCKS, BVH_TRIANGLE_BLOCK_SIZE.
// Block k > 0 of a split array is the block named with suffix k (BVHNodes1, BVHTriangles2).
#ifndef HYBRID_BVH_STORAGE_GLSL
#define HYBRID_BVH_STORAGE_GLSL

#include "bvh_layout.glsl"
#include "storage_blocks.glsl"

// Rows of a BVHNode (bvh_layout.glsl), for the row accessors.
#define BVH_ROW_LEFT_MIN 0
#define BVH_ROW_LEFT_MAX 1
#define BVH_ROW_RIGHT_MIN 2
#define BVH_ROW_RIGHT_MAX 3

// Row `row` (a constant after inlining, so the chains fold) of a node lvalue.
#define BVH_NODE_ROW(n, row) \
    ((row) == 0 ? (n).left_min : (row) == 1 ? (n).left_max : \
     (row) == 2 ? (n).right_min : (n).right_max)
#define BVH_NODE_SET_W(n, row, value) \
    if ((row) == 0) { (n).left_min.w = (value); } \
    else if ((row) == 1) { (n).left_max.w = (value); } \
    else if ((row) == 2) { (n).right_min.w = (value); } \
    else { (n).right_max.w = (value); }
#define BVH_NODE_SET_XYZ(n, row, value) \
    if ((row) == 0) { (n).left_min.xyz = (value); } \
    else if ((row) == 1) { (n).left_max.xyz = (value); } \
    else if ((row) == 2) { (n).right_min.xyz = (value); } \
    else { (n).right_max.xyz = (value); }

// ---- nodes --------------------------------------------------------------------------------
#ifdef BVH_NODES

#ifndef BVH_NODES_ACCESS
#define BVH_NODES_ACCESS readonly
#define BVH_NODES_READONLY
#endif
#ifndef BVH_NODE_BLOCKS
#define BVH_NODE_BLOCKS 1
#endif
#if BVH_NODE_BLOCKS < 1 || BVH_NODE_BLOCKS > STORAGE_MAX_BLOCKS
#error "BVH_NODE_BLOCKS must be 1..4"
#endif

layout(std430) BVH_NODES_ACCESS buffer BVHNodes {
    BVHNode bvh_nodes[];
};
#if BVH_NODE_BLOCKS > 1
layout(std430) BVH_NODES_ACCESS buffer BVHNodes1 {
    BVHNode bvh_nodes_1[];
};
#endif
#if BVH_NODE_BLOCKS > 2
layout(std430) BVH_NODES_ACCESS buffer BVHNodes2 {
    BVHNode bvh_nodes_2[];
};
#endif
#if BVH_NODE_BLOCKS > 3
layout(std430) BVH_NODES_ACCESS buffer BVHNodes3 {
    BVHNode bvh_nodes_3[];
};
#endif

// Apply STMT (a statement using `n`, the node lvalue) to node i: STMT is spelled out per
// block because GLSL cannot return a reference into a buffer.
#if BVH_NODE_BLOCKS == 1
#define BVH_NODE_APPLY(i, STMT) { uint bvh_j = (i); STMT(bvh_nodes[bvh_j]) }
#else
#define BVH_NODE_LOCATE(i) \
    uint bvh_b = STORAGE_BLOCK_OF(i, BVH_NODE_BLOCK_SIZE, BVH_NODE_BLOCKS); \
    uint bvh_j = (i) - bvh_b * uint(BVH_NODE_BLOCK_SIZE);
#if BVH_NODE_BLOCKS == 2
#define BVH_NODE_APPLY(i, STMT) { BVH_NODE_LOCATE(i) \
    if (bvh_b == 0u) { STMT(bvh_nodes[bvh_j]) } else { STMT(bvh_nodes_1[bvh_j]) } }
#elif BVH_NODE_BLOCKS == 3
#define BVH_NODE_APPLY(i, STMT) { BVH_NODE_LOCATE(i) \
    if (bvh_b == 0u) { STMT(bvh_nodes[bvh_j]) } else if (bvh_b == 1u) { STMT(bvh_nodes_1[bvh_j]) } \
    else { STMT(bvh_nodes_2[bvh_j]) } }
#else
#define BVH_NODE_APPLY(i, STMT) { BVH_NODE_LOCATE(i) \
    if (bvh_b == 0u) { STMT(bvh_nodes[bvh_j]) } else if (bvh_b == 1u) { STMT(bvh_nodes_1[bvh_j]) } \
    else if (bvh_b == 2u) { STMT(bvh_nodes_2[bvh_j]) } else { STMT(bvh_nodes_3[bvh_j]) } }
#endif
#endif

#define BVH_GET_NODE_(n) result = (n);
#define BVH_GET_ROW_(n) result = BVH_NODE_ROW(n, row);
#define BVH_SET_W_(n) BVH_NODE_SET_W(n, row, value)
#define BVH_SET_XYZ_(n) BVH_NODE_SET_XYZ(n, row, value)

// Node i (the traversal's one 64-byte fetch).
BVHNode bvh_node(uint i) {
    BVHNode result;
    BVH_NODE_APPLY(i, BVH_GET_NODE_)
    return result;
}

// Row `row` (BVH_ROW_*) of node i.
uvec4 bvh_node_row(uint i, int row) {
    uvec4 result;
    BVH_NODE_APPLY(i, BVH_GET_ROW_)
    return result;
}

#if !defined(BVH_NODES_READONLY)
// Set the w word (child ref, parent or leaf count) of one row of node i.
void bvh_node_set_w(uint i, int row, uint value) {
    BVH_NODE_APPLY(i, BVH_SET_W_)
}

// Set the xyz words (a box corner's float bits) of one row of node i.
void bvh_node_set_xyz(uint i, int row, uvec3 value) {
    BVH_NODE_APPLY(i, BVH_SET_XYZ_)
}
#endif

#endif  // BVH_NODES

// ---- triangles ----------------------------------------------------------------------------
#ifdef BVH_TRIANGLES

#ifndef BVH_TRIANGLES_ACCESS
#define BVH_TRIANGLES_ACCESS readonly
#define BVH_TRIANGLES_READONLY
#endif
#ifndef BVH_TRIANGLE_BLOCKS
#define BVH_TRIANGLE_BLOCKS 1
#endif
#if BVH_TRIANGLE_BLOCKS < 1 || BVH_TRIANGLE_BLOCKS > STORAGE_MAX_BLOCKS
#error "BVH_TRIANGLE_BLOCKS must be 1..4"
#endif

layout(std430) BVH_TRIANGLES_ACCESS buffer BVHTriangles {
    BVHTriangle bvh_triangles[];
};
#if BVH_TRIANGLE_BLOCKS > 1
layout(std430) BVH_TRIANGLES_ACCESS buffer BVHTriangles1 {
    BVHTriangle bvh_triangles_1[];
};
#endif
#if BVH_TRIANGLE_BLOCKS > 2
layout(std430) BVH_TRIANGLES_ACCESS buffer BVHTriangles2 {
    BVHTriangle bvh_triangles_2[];
};
#endif
#if BVH_TRIANGLE_BLOCKS > 3
layout(std430) BVH_TRIANGLES_ACCESS buffer BVHTriangles3 {
    BVHTriangle bvh_triangles_3[];
};
#endif

#if BVH_TRIANGLE_BLOCKS == 1
#define BVH_TRIANGLE_APPLY(i, STMT) { uint bvh_j = (i); STMT(bvh_triangles[bvh_j]) }
#else
#define BVH_TRIANGLE_LOCATE(i) \
    uint bvh_b = STORAGE_BLOCK_OF(i, BVH_TRIANGLE_BLOCK_SIZE, BVH_TRIANGLE_BLOCKS); \
    uint bvh_j = (i) - bvh_b * uint(BVH_TRIANGLE_BLOCK_SIZE);
#if BVH_TRIANGLE_BLOCKS == 2
#define BVH_TRIANGLE_APPLY(i, STMT) { BVH_TRIANGLE_LOCATE(i) \
    if (bvh_b == 0u) { STMT(bvh_triangles[bvh_j]) } else { STMT(bvh_triangles_1[bvh_j]) } }
#elif BVH_TRIANGLE_BLOCKS == 3
#define BVH_TRIANGLE_APPLY(i, STMT) { BVH_TRIANGLE_LOCATE(i) \
    if (bvh_b == 0u) { STMT(bvh_triangles[bvh_j]) } \
    else if (bvh_b == 1u) { STMT(bvh_triangles_1[bvh_j]) } else { STMT(bvh_triangles_2[bvh_j]) } }
#else
#define BVH_TRIANGLE_APPLY(i, STMT) { BVH_TRIANGLE_LOCATE(i) \
    if (bvh_b == 0u) { STMT(bvh_triangles[bvh_j]) } \
    else if (bvh_b == 1u) { STMT(bvh_triangles_1[bvh_j]) } \
    else if (bvh_b == 2u) { STMT(bvh_triangles_2[bvh_j]) } else { STMT(bvh_triangles_3[bvh_j]) } }
#endif
#endif

#define BVH_GET_TRIANGLE_(t) result = (t);
#define BVH_SET_TRIANGLE_(t) (t) = value;

#if !defined(BVH_TRIANGLES_WRITEONLY)
// Leaf i's triangle (Morton order).
BVHTriangle bvh_triangle(uint i) {
    BVHTriangle result;
    BVH_TRIANGLE_APPLY(i, BVH_GET_TRIANGLE_)
    return result;
}
#endif

#if !defined(BVH_TRIANGLES_READONLY)
void bvh_triangle_store(uint i, BVHTriangle value) {
    BVH_TRIANGLE_APPLY(i, BVH_SET_TRIANGLE_)
}
#endif

#endif  // BVH_TRIANGLES

#endif
