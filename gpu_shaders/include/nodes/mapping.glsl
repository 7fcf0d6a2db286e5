// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's Mapping (ShaderNodeMapping) and Vector Rotate (ShaderNodeVectorRotate) nodes.
// Rotations are Blender's XYZ Euler angles in radians: X first, then Y, then Z, about the
// fixed axes (the matrix Rz * Ry * Rx).
//
// node_mapping(vector_type, vector, location, rotation, scale, out result)
//   "Vector" (0,0,0), "Location" (0,0,0), "Rotation" (0,0,0), "Scale" (1,1,1) -> "Vector".
//   vector_type codes (Blender's `vector_type` enum, in its own order):
//     0 POINT    R (v * scale) + location
//     1 TEXTURE  the inverse of POINT: R^T (v - location) / scale (a zero scale axis gives 0)
//     2 VECTOR   R (v * scale), no translation
//     3 NORMAL   normalize(R (v / scale)), the inverse transpose for a normal (0 if degenerate)
//   Location is ignored by VECTOR and NORMAL, as the node hides it there.
//
// node_vector_rotate(rotation_type, invert, vector, center, axis, angle, rotation, out result)
//   "Vector" (0,0,0), "Center" (0,0,0), "Axis" (0,0,1) (AXIS_ANGLE only), "Angle" 0.0,
//   "Rotation" (0,0,0) (EULER_XYZ only) -> "Vector"; invert is the node's `invert` (rotate
//   the other way).
//   rotation_type codes (Blender's `rotation_type` enum, in its own order):
//     0 AXIS_ANGLE  1 X_AXIS  2 Y_AXIS  3 Z_AXIS  4 EULER_XYZ
//   A zero axis leaves the vector as it is.
#ifndef HYBRID_NODES_MAPPING_GLSL
#define HYBRID_NODES_MAPPING_GLSL

// Columns of Rz * Ry * Rx (GLSL matrices are column-major).
mat3 node_euler_to_mat3(vec3 euler) {
    float cx = cos(euler.x), sx = sin(euler.x);
    float cy = cos(euler.y), sy = sin(euler.y);
    float cz = cos(euler.z), sz = sin(euler.z);
    return mat3(
        vec3(cy * cz, cy * sz, -sy),
        vec3(sy * sx * cz - cx * sz, sy * sx * sz + cx * cz, cy * sx),
        vec3(sy * cx * cz + sx * sz, sy * cx * sz - sx * cz, cy * cx));
}

vec3 node_mapping_safe_divide(vec3 a, vec3 b) {
    return vec3(b.x != 0.0 ? a.x / b.x : 0.0, b.y != 0.0 ? a.y / b.y : 0.0, b.z != 0.0 ? a.z / b.z : 0.0);
}

vec3 node_mapping_safe_normalize(vec3 a) {
    float len = length(a);
    return len != 0.0 ? a / len : vec3(0.0);
}

void node_mapping(int vector_type, vec3 vector, vec3 location, vec3 rotation, vec3 scale, out vec3 result) {
    mat3 r = node_euler_to_mat3(rotation);
    if (vector_type == 0) result = r * (vector * scale) + location;
    else if (vector_type == 1) result = node_mapping_safe_divide(transpose(r) * (vector - location), scale);
    else if (vector_type == 2) result = r * (vector * scale);
    else result = node_mapping_safe_normalize(r * node_mapping_safe_divide(vector, scale));
}

// Rodrigues' rotation of p about the unit axis by angle (right-handed).
vec3 node_rotate_around_axis(vec3 p, vec3 axis, float angle) {
    float c = cos(angle), s = sin(angle);
    return p * c + cross(axis, p) * s + axis * (dot(axis, p) * (1.0 - c));
}

void node_vector_rotate(int rotation_type, bool invert, vec3 vector, vec3 center, vec3 axis, float angle,
                        vec3 rotation, out vec3 result) {
    if (rotation_type == 4) {
        mat3 r = node_euler_to_mat3(rotation);
        if (invert) r = transpose(r);
        result = r * (vector - center) + center;
        return;
    }
    vec3 a = rotation_type == 1 ? vec3(1.0, 0.0, 0.0)
           : rotation_type == 2 ? vec3(0.0, 1.0, 0.0)
           : rotation_type == 3 ? vec3(0.0, 0.0, 1.0) : axis;
    float len = length(a);
    if (len == 0.0) {
        result = vector;
        return;
    }
    result = node_rotate_around_axis(vector - center, a / len, invert ? -angle : angle) + center;
}

#endif
