// SPDX-License-Identifier: GPL-3.0-or-later
// An instance's object-to-world map, shared by the two places that apply it: the instance
// transform, which writes the world-space rows (scene_upload/instance_transform.comp.glsl),
// and the raster passes' indexed draws of object-space meshes (gbuffer/gbuffer.vert.glsl
// with INSTANCED). One source for both keeps their arithmetic the same operation for
// operation, so that a vertex transformed in the vertex stage is bit for bit the row the
// transform wrote, and the G-buffers of the two draw paths are identical (tests/test_gbuffer.py).
//
// struct Instance mirrors INSTANCE_DTYPE (hybrid_engine/passes/scene_upload/instance_transform.py).
#ifndef HYBRID_INSTANCE_SPACE_GLSL
#define HYBRID_INSTANCE_SPACE_GLSL

struct Instance {
    mat4 matrix;          // object to world
    vec4 normal_cols[3];  // columns of the normal matrix (xyz)
    ivec4 mesh;           // first vertex, first normal, first triangle, first UV corner (-1: none)
    ivec4 info;           // first world row, triangles, first slot material, slots
    ivec4 flags;          // x: mirrored
};

// An object-space point in world space.
vec3 instance_point(Instance inst, vec3 p) {
    return (inst.matrix * vec4(p, 1.0)).xyz;
}

mat3 instance_normal_matrix(Instance inst) {
    return mat3(inst.normal_cols[0].xyz, inst.normal_cols[1].xyz, inst.normal_cols[2].xyz);
}

// A unit world-space normal through the normal matrix; 0 when it has no direction (the
// G-buffer then takes the geometric normal).
vec3 instance_normal(mat3 normal_matrix, vec3 object_normal) {
    vec3 n = normal_matrix * object_normal;
    float len = length(n);
    return (len > 0.0 && !isinf(len) && !isnan(len)) ? n / len : vec3(0.0);
}

#endif
