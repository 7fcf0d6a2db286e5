// SPDX-License-Identifier: GPL-3.0-or-later
// Color Attribute and Attribute nodes: the value of one requested attribute at a shading
// point (hybrid_engine/scene/mesh_attributes.py; the store is written by
// hybrid_engine/passes/scene_upload/node_attributes.py). Included by node_program.glsl only
// under NODE_ATTRIBUTES, which the host defines when some program reads an attribute.
//
// Storage blocks:
//   NodeAttributeValues    vec4 per mesh corner and geometry slot: mesh m's triangle t,
//                          corner c, slot s at first(m) + (3 t + c) * slots + s (object space,
//                          the mesh's own corner order)
//   NodeAttributeInstances row 0: x = geometry slots, y = instance slots, z = instances (int
//                          bits); instance k (NodeObjects row k, from 1) at 1 + (k - 1) * (1 +
//                          instance slots): x = first(m) or -1, y = mirrored; then its instance
//                          slots' RGBA
//   NodeAttributePositions the world rows' corners (float[9 N], scene positions)
// The point's barycentrics come from its world position and its row's corners, so every
// caller (G-buffer, cube faces, BVH and cube-map hits) needs only the row and the position
// it already has (ShadingPoint).
#ifndef HYBRID_NODE_ATTRIBUTES_GLSL
#define HYBRID_NODE_ATTRIBUTES_GLSL

layout(std430) readonly buffer NodeAttributeValues { vec4 node_attr_values[]; };
layout(std430) readonly buffer NodeAttributeInstances { vec4 node_attr_instances[]; };
layout(std430) readonly buffer NodeAttributePositions { float node_attr_positions[]; };

vec3 node_attr_corner(int row, int c) {
    int base = row * 9 + c * 3;
    return vec3(node_attr_positions[base], node_attr_positions[base + 1], node_attr_positions[base + 2]);
}

// Barycentric weights of world corners 0, 1, 2 at p, projected onto the triangle's plane;
// (1, 0, 0) for a degenerate triangle.
vec3 node_attr_barycentrics(int row, vec3 p) {
    vec3 p0 = node_attr_corner(row, 0);
    vec3 e1 = node_attr_corner(row, 1) - p0, e2 = node_attr_corner(row, 2) - p0, v = p - p0;
    float d11 = dot(e1, e1), d12 = dot(e1, e2), d22 = dot(e2, e2);
    float d1 = dot(v, e1), d2 = dot(v, e2);
    float det = d11 * d22 - d12 * d12;
    if (!(abs(det) > 1e-30 * d11 * d22) || isinf(det)) return vec3(1.0, 0.0, 0.0);
    float b1 = (d22 * d1 - d12 * d2) / det;
    float b2 = (d11 * d2 - d12 * d1) / det;
    return vec3(1.0 - b1 - b2, b1, b2);
}

// The RGBA of attribute `slot` of `source` (node_codes.ATTRIBUTE_SOURCES: 0 geometry, else
// instance) at the shading point; (0, 0, 0, 0) where there is none (mesh_attributes.MISSING).
vec4 node_attribute(int source, int slot, int object_row, int row, vec3 position) {
    ivec4 header = floatBitsToInt(node_attr_instances[0]);
    if (slot < 0 || object_row < 1 || object_row > header.z) return vec4(0.0);
    int entry = 1 + (object_row - 1) * (1 + header.y);
    if (source != 0) {
        return slot < header.y ? node_attr_instances[entry + 1 + slot] : vec4(0.0);
    }
    ivec4 inst = floatBitsToInt(node_attr_instances[entry]);
    if (inst.x < 0 || slot >= header.x) return vec4(0.0);
    int local = row - node_objects[object_row].rows.x;
    vec3 b = node_attr_barycentrics(row, position);
    // World corners 1 and 2 are the mesh's 2 and 1 under a mirroring matrix
    // (scene_upload/instance_transform.comp.glsl).
    int c1 = inst.y != 0 ? 2 : 1;
    int base = inst.x + local * 3 * header.x + slot;
    return b.x * node_attr_values[base] + b.y * node_attr_values[base + c1 * header.x]
         + b.z * node_attr_values[base + (3 - c1) * header.x];
}

#endif
