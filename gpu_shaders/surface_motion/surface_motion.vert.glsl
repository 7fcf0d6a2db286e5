// SPDX-License-Identifier: GPL-3.0-or-later
// Surface motion, vertex stage (passes/surface_motion/surface_motion.py): the moved
// instances' world rows as the G-buffer draws them (vertex 3 * row + corner,
// gbuffer.vert.glsl), with the primary view's matrix, so that each fragment lands on the
// depth the G-buffer stored for it. MotionRows lists, sorted by first row, each moved
// instance's rows and entry (first row, end row, entry); the indirect draws cover only
// those rows, and the vertex finds its entry by a binary search.
in vec3 in_pos;

uniform mat4 u_view_proj;
uniform int u_entries;  // MotionRows' length

layout(std430) readonly buffer MotionRows { ivec4 motion_rows[]; };

flat out int v_entry;

// The entry of the moved instance whose rows hold `row`, or -1.
int motion_entry(int row) {
    int lo = 0, hi = u_entries - 1;
    while (lo < hi) {
        int mid = (lo + hi + 1) >> 1;
        if (motion_rows[mid].x <= row) lo = mid; else hi = mid - 1;
    }
    ivec4 entry = motion_rows[max(lo, 0)];
    return u_entries > 0 && row >= entry.x && row < entry.y ? entry.z : -1;
}

void main() {
    v_entry = motion_entry(gl_VertexID / 3);
    gl_Position = u_view_proj * vec4(in_pos, 1.0);
}
