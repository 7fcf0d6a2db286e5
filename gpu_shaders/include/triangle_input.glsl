// Input triangles of the LBVH passes: world-space vertices as a flat float array (9 floats =
// 36 bytes per triangle, the (N, 3, 3) float32 layout of Geometry.triangles), optionally seen
// through an index list (the near-cube culler's compacted output).
//
// Host defines: TRI_INPUT_BINDING, TRI_INDEX_BINDING (binding points).
// Uniform u_use_indices: 1 -> element i is triangle tri_index[i]; 0 -> element i is triangle i.
#ifndef HYBRID_TRIANGLE_INPUT_GLSL
#define HYBRID_TRIANGLE_INPUT_GLSL

layout(std430, binding = TRI_INPUT_BINDING) readonly buffer TriangleInput {
    float tri_input[];
};

layout(std430, binding = TRI_INDEX_BINDING) readonly buffer TriangleIndex {
    uint tri_index[];
};

uniform int u_use_indices;

uint input_triangle(uint element) {
    return u_use_indices != 0 ? tri_index[element] : element;
}

vec3 input_vertex(uint prim, uint corner) {
    uint base = prim * 9u + corner * 3u;
    return vec3(tri_input[base], tri_input[base + 1u], tri_input[base + 2u]);
}

#endif
