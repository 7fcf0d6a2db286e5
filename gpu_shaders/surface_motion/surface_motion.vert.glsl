// SPDX-License-Identifier: GPL-3.0-or-later
// Surface motion, vertex stage (passes/surface_motion/surface_motion.py): the moved
// instances' world rows as the G-buffer draws them (vertex 3 * row + corner,
// gbuffer.vert.glsl), with the primary view's matrix, so that each fragment lands on the
// depth the G-buffer stored for it. MotionRows lists, sorted by first row, each moved
// instance's rows, its entry and where last frame's rows of a deformed instance lie in
// PreviousPositions and PreviousNormals (first row, end row, entry, packed first row or -1);
// the indirect draws cover only those rows, and the vertex finds its entry by a binary
// search (include/motion_rows.glsl). Where the vertex stood last frame: its captured row for
// a deformed instance (scene_upload/previous_rows.py), else the entry's world-to-world move
// (u_motion_matrices, RGBA32F, row e the move's columns), the normal by its inverse
// transpose.
in vec3 in_pos;
in vec3 in_normal;

#include "motion_rows.glsl"

layout(std430) readonly buffer PreviousPositions { float previous_positions[]; };
layout(std430) readonly buffer PreviousNormals { float previous_normals[]; };

uniform mat4 u_view_proj;
uniform sampler2D u_motion_matrices;

flat out int v_entry;
out vec3 v_previous;
out vec3 v_normal;
out vec3 v_previous_normal;

vec3 previous_corner(int at, bool normal) {
    return normal ? vec3(previous_normals[at], previous_normals[at + 1], previous_normals[at + 2])
                  : vec3(previous_positions[at], previous_positions[at + 1], previous_positions[at + 2]);
}

void main() {
    int row = gl_VertexID / 3;
    int k = motion_entry(row);
    v_entry = k >= 0 ? motion_rows[k].z : -1;
    v_normal = in_normal;
    v_previous = in_pos;
    v_previous_normal = in_normal;
    if (k >= 0) {
        ivec4 entry = motion_rows[k];
        if (entry.w >= 0) {
            int at = (entry.w + row - entry.x) * 9 + (gl_VertexID - 3 * row) * 3;
            v_previous = previous_corner(at, false);
            v_previous_normal = previous_corner(at, true);
        } else {
            mat4 move = mat4(texelFetch(u_motion_matrices, ivec2(0, entry.z), 0),
                             texelFetch(u_motion_matrices, ivec2(1, entry.z), 0),
                             texelFetch(u_motion_matrices, ivec2(2, entry.z), 0),
                             texelFetch(u_motion_matrices, ivec2(3, entry.z), 0));
            v_previous = (move * vec4(in_pos, 1.0)).xyz;
            v_previous_normal = transpose(inverse(mat3(move))) * in_normal;
        }
    }
    gl_Position = u_view_proj * vec4(in_pos, 1.0);
}
