// SPDX-License-Identifier: GPL-3.0-or-later
// The near cube's grazing triangles as a list of the frame's BVH leaves (beyond the paper;
// hybrid_engine/passes/diffuse_light/grazing.py): written by
// diffuse_light/grazing_triangles.comp.glsl, read by trace_ray.glsl's whole-ray test
// (BVH_WHOLE_RAY). The leaves are binned by how close their planes pass to the near cube's
// centre, nearest first: where more graze than the list holds, it keeps the nearest planes,
// the surfaces the cube map sees most nearly edge-on.
//
// Host defines: GRAZING_CAPACITY, GRAZING_BINS; GRAZING_LEAVES_ACCESS (default readonly).
#ifndef HYBRID_GRAZING_LEAVES_GLSL
#define HYBRID_GRAZING_LEAVES_GLSL

#ifndef GRAZING_LEAVES_ACCESS
#define GRAZING_LEAVES_ACCESS readonly
#endif

layout(std430) GRAZING_LEAVES_ACCESS buffer GrazingLeaves {
    uint grazing_seen;     // every grazing leaf
    uint grazing_whole;    // the listed leaves of the bins that fit whole
    uint grazing_partial;  // the leaves of the first bin that does not, counted past the room left
    uint grazing_bins[GRAZING_BINS];
    uint grazing_leaves[GRAZING_CAPACITY];
};

// How many leaves the list holds.
uint grazing_listed() {
    return min(grazing_whole + grazing_partial, uint(GRAZING_CAPACITY));
}

#endif
