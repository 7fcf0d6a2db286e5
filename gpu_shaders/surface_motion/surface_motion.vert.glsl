// SPDX-License-Identifier: GPL-3.0-or-later
// Surface motion, vertex stage (passes/surface_motion/surface_motion.py): the moved
// instances' world rows as the G-buffer draws them (vertex 3 * row + corner,
// gbuffer.vert.glsl), with the primary view's matrix, so that each fragment lands on the
// depth the G-buffer stored for it. MotionRows lists, sorted by first row, each moved
// instance's rows and entry (first row, end row, entry); the indirect draws cover only
// those rows, and the vertex finds its entry by a binary search (include/motion_rows.glsl).
in vec3 in_pos;

#include "motion_rows.glsl"

uniform mat4 u_view_proj;

flat out int v_entry;

void main() {
    int k = motion_entry(gl_VertexID / 3);
    v_entry = k >= 0 ? motion_rows[k].z : -1;
    gl_Position = u_view_proj * vec4(in_pos, 1.0);
}
