// Input triangles of the LBVH and culling passes: world-space vertices as a flat float array
// (9 floats = 36 bytes per triangle, the (N, 3, 3) float32 layout of Geometry.triangles),
// optionally seen through an index list (the near-cube culler's compacted output).
//
// A scene of more than 3.7M triangles exceeds one 128 MiB storage block; the host then binds
// the buffer as TRI_INPUT_BLOCKS ranges of TRI_INPUT_BLOCK_SIZE triangles each
// (storage_blocks.glsl) and input_vertex() picks the block.
//
// Host defines, for a split input: TRI_INPUT_BLOCKS (2..4, default 1), TRI_INPUT_BLOCK_SIZE
//   (triangles per block); block k > 0 is the storage block TriangleInput<k>.
// Uniform u_use_indices: 1 -> element i is triangle tri_index[i]; 0 -> element i is triangle i.
#ifndef HYBRID_TRIANGLE_INPUT_GLSL
#define HYBRID_TRIANGLE_INPUT_GLSL

#include "storage_blocks.glsl"

#ifndef TRI_INPUT_BLOCKS
#define TRI_INPUT_BLOCKS 1
#endif
#if TRI_INPUT_BLOCKS < 1 || TRI_INPUT_BLOCKS > STORAGE_MAX_BLOCKS
#error "TRI_INPUT_BLOCKS must be 1..4"
#endif

layout(std430) readonly buffer TriangleInput {
    float tri_input[];
};
#if TRI_INPUT_BLOCKS > 1
layout(std430) readonly buffer TriangleInput1 {
    float tri_input_1[];
};
#endif
#if TRI_INPUT_BLOCKS > 2
layout(std430) readonly buffer TriangleInput2 {
    float tri_input_2[];
};
#endif
#if TRI_INPUT_BLOCKS > 3
layout(std430) readonly buffer TriangleInput3 {
    float tri_input_3[];
};
#endif

layout(std430) readonly buffer TriangleIndex {
    uint tri_index[];
};

uniform int u_use_indices;

uint input_triangle(uint element) {
    return u_use_indices != 0 ? tri_index[element] : element;
}

#define TRI_INPUT_VEC3(array, base) vec3(array[base], array[(base) + 1u], array[(base) + 2u])

vec3 input_vertex(uint prim, uint corner) {
#if TRI_INPUT_BLOCKS == 1
    uint base = prim * 9u + corner * 3u;
    return TRI_INPUT_VEC3(tri_input, base);
#else
    uint block = STORAGE_BLOCK_OF(prim, TRI_INPUT_BLOCK_SIZE, TRI_INPUT_BLOCKS);
    uint base = (prim - block * uint(TRI_INPUT_BLOCK_SIZE)) * 9u + corner * 3u;
#if TRI_INPUT_BLOCKS > 3
    if (block == 3u) {
        return TRI_INPUT_VEC3(tri_input_3, base);
    }
#endif
#if TRI_INPUT_BLOCKS > 2
    if (block == 2u) {
        return TRI_INPUT_VEC3(tri_input_2, base);
    }
#endif
    if (block == 1u) {
        return TRI_INPUT_VEC3(tri_input_1, base);
    }
    return TRI_INPUT_VEC3(tri_input, base);
#endif
}

#endif
