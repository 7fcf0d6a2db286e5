// SPDX-License-Identifier: GPL-3.0-or-later
// Color Attribute and Attribute nodes: the value of one requested attribute at a shading
// point (hybrid_engine/scene/mesh_attributes.py; the block is written by
// hybrid_engine/passes/scene_upload/node_attributes.py). Included by node_program.glsl only
// under NODE_ATTRIBUTES, which the host defines when some program reads an attribute.
//
// Storage block NodeAttributes (vec4s; one block: the waves' kernels are at the driver's
// limit of blocks per stage):
//   [0]            x = geometry slots G, y = instance slots I, z = instances, w = the
//                  instance table's first vec4 (int bits)
//   mesh blocks    per triangle t of a mesh whose block starts at f: f + t (3 + 3 G) holds
//                  its corners' object-space positions, then corner c's slot s at
//                  + 3 + c G + s (the mesh's own corner order)
//   instance table instance k (NodeObjects row k, from 1) at w + (k - 1)(1 + I): x = its
//                  mesh's f or -1 (int bits); then its instance slots' RGBA
// The barycentrics come from the point taken to object space and the triangle's corners
// there, so a mirroring instance needs nothing of its own and every caller (G-buffer, cube
// faces, BVH and cube-map hits) needs only the row and position it already has.
#ifndef HYBRID_NODE_ATTRIBUTES_GLSL
#define HYBRID_NODE_ATTRIBUTES_GLSL

layout(std430) readonly buffer NodeAttributes { vec4 node_attr[]; };

// Barycentric weights of corners p0, p1, p2 at p, projected onto their plane; (1, 0, 0) for
// a degenerate triangle.
vec3 node_attr_barycentrics(vec3 p0, vec3 p1, vec3 p2, vec3 p) {
    vec3 e1 = p1 - p0, e2 = p2 - p0, v = p - p0;
    float d11 = dot(e1, e1), d12 = dot(e1, e2), d22 = dot(e2, e2);
    float d1 = dot(v, e1), d2 = dot(v, e2);
    float det = d11 * d22 - d12 * d12;
    if (!(abs(det) > 1e-12 * d11 * d22) || isinf(det)) return vec3(1.0, 0.0, 0.0);
    float b1 = (d22 * d1 - d12 * d2) / det;
    float b2 = (d11 * d2 - d12 * d1) / det;
    return vec3(1.0 - b1 - b2, b1, b2);
}

// The RGBA of attribute `slot` of `source` (node_codes.ATTRIBUTE_SOURCES: 0 geometry, else
// instance) at the world point `position` of world row `row` of instance `object_row`;
// (0, 0, 0, 0) where there is none (mesh_attributes.MISSING).
vec4 node_attribute(int source, int slot, int object_row, int row, vec3 position) {
    ivec4 header = floatBitsToInt(node_attr[0]);
    if (slot < 0 || object_row < 1 || object_row > header.z) return vec4(0.0);
    int entry = header.w + (object_row - 1) * (1 + header.y);
    if (source != 0) {
        return slot < header.y ? node_attr[entry + 1 + slot] : vec4(0.0);
    }
    int first = floatBitsToInt(node_attr[entry].x);
    if (first < 0 || slot >= header.x) return vec4(0.0);
    int local = row - node_objects[object_row].rows.x;
    int base = first + local * (3 + 3 * header.x);
    vec3 b = node_attr_barycentrics(node_attr[base].xyz, node_attr[base + 1].xyz, node_attr[base + 2].xyz,
                                    node_to_object(object_row, position, 1.0));
    int at = base + 3 + slot;
    return b.x * node_attr[at] + b.y * node_attr[at + header.x] + b.z * node_attr[at + 2 * header.x];
}

#endif
