// SPDX-License-Identifier: GPL-3.0-or-later
// The work list of the raster triangle culler (view_cull/view_cull.comp.glsl and
// view_cull_compact.comp.glsl): segments of consecutive triangles, each tagged with its view,
// sorted by their first work item.
//
// Storage block Segments: uvec4 segments[S]: x first triangle, y count, z first work item,
//   w view | closed << 8. Uniform u_num_segments (S).
#ifndef HYBRID_VIEW_CULL_SEGMENTS_GLSL
#define HYBRID_VIEW_CULL_SEGMENTS_GLSL

layout(std430) readonly buffer Segments {
    uvec4 segments[];
};

uniform uint u_num_segments;

// The last segment whose first work item is <= item (0 if none).
int segment_of(uint item) {
    int lo = 0;
    int hi = int(u_num_segments) - 1;
    int found = 0;
    while (lo <= hi) {
        int mid = (lo + hi) / 2;
        if (segments[mid].z <= item) {
            found = mid;
            lo = mid + 1;
        } else {
            hi = mid - 1;
        }
    }
    return found;
}

#endif
