// SPDX-License-Identifier: GPL-3.0-or-later
// The table of moving instances' world rows that the passes of motion read
// (film/vector.comp.glsl, surface_motion/surface_motion.comp.glsl): MotionRows lists, sorted
// by first row, one ivec4 per instance (first row, end row, and two indices of the pass's
// own), u_entries its length.
#ifndef HYBRID_MOTION_ROWS_GLSL
#define HYBRID_MOTION_ROWS_GLSL

uniform int u_entries;  // MotionRows' length
layout(std430) readonly buffer MotionRows { ivec4 motion_rows[]; };

// The MotionRows entry whose rows hold `row` (a binary search), or -1.
int motion_entry(int row) {
    int lo = 0, hi = u_entries - 1;
    while (lo < hi) {
        int mid = (lo + hi + 1) >> 1;
        if (motion_rows[mid].x <= row) lo = mid; else hi = mid - 1;
    }
    ivec4 entry = motion_rows[max(lo, 0)];
    return u_entries > 0 && row >= entry.x && row < entry.y ? lo : -1;
}

#endif
