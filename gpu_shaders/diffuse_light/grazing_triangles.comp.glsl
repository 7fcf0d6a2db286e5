// SPDX-License-Identifier: GPL-3.0-or-later
// The near cube's grazing triangles (beyond the paper; hybrid_engine/passes/diffuse_light/
// grazing.py): the frame's BVH leaves that reach far beyond the near cube in a plane passing
// close to its centre. The cube map, centred there, sees such a surface edge-on beyond its
// near planes, a sliver of texels that a march slips through: a camera against a wall lets
// the sky in through it. The diffuse paths that leave from outside the near cube test these
// triangles along the whole ray (trace_ray.glsl BVH_WHOLE_RAY).
//
// A leaf grazes where its triangle lies more than u_beyond outside the near cube (half-size
// u_near_half around u_near_center) along some axis and its plane passes within
// u_plane_reach of the centre; its bin is that distance in GRAZING_BINS steps of
// u_plane_reach. Two dispatches, one invocation per leaf (the host dispatches the build's
// capacity; BuildCount holds the leaves N):
//   GRAZING_COUNT: every grazing leaf counts itself in its bin;
//   otherwise:     the leaves of the leading bins that fit the list together are listed, and
//                  those of the next bin while room remains (any of them: they graze alike).
//
// Host defines: LOCAL_SIZE, GRAZING_CAPACITY, GRAZING_BINS, (GRAZING_COUNT),
//   BVH_TRIANGLE_BLOCKS, BVH_TRIANGLE_BLOCK_SIZE (a split array only: bvh_storage.glsl).
// Storage blocks: BVHTriangles (read; BVHTriangles1..3 when split), BuildCount (read),
//   GrazingLeaves (counts and bins zeroed by the host, then atomic; leaves written).
#include "build_count.glsl"
#include "dispatch.glsl"
#define BVH_TRIANGLES
#include "bvh_storage.glsl"
#define GRAZING_LEAVES_ACCESS coherent
#include "grazing_leaves.glsl"

layout(local_size_x = LOCAL_SIZE) in;

uniform vec3 u_near_center;
uniform float u_near_half;
uniform float u_beyond;
uniform float u_plane_reach;

// The leaf's bin, or -1 where it does not graze.
int grazing_bin(uint leaf) {
    BVHTriangle tr = bvh_triangle(leaf);
    vec3 a = bvh_xyz(tr.v0), b = bvh_xyz(tr.v1), c = bvh_xyz(tr.v2);
    vec3 lo = min(a, min(b, c)) - u_near_center;
    vec3 hi = max(a, max(b, c)) - u_near_center;
    vec3 outside = max(hi - vec3(u_near_half), vec3(-u_near_half) - lo);
    if (!(max(outside.x, max(outside.y, outside.z)) > u_beyond)) return -1;
    vec3 n = cross(b - a, c - a);
    float len = length(n);
    // A degenerate triangle is never met (the watertight test rejects it).
    if (!(len > 0.0)) return -1;
    float reach = abs(dot(n, a - u_near_center)) / len;
    if (!(reach <= u_plane_reach)) return -1;
    return min(int(reach / u_plane_reach * float(GRAZING_BINS)), GRAZING_BINS - 1);
}

void main() {
    uint leaf = flat_invocation_index();
    if (leaf >= build_count()) return;
    int bin = grazing_bin(leaf);
    if (bin < 0) return;
#ifdef GRAZING_COUNT
    atomicAdd(grazing_bins[bin], 1u);
    atomicAdd(grazing_seen, 1u);
#else
    // The leading bins that fit the list together, and how many leaves they hold.
    uint whole = 0u;
    int fitting = 0;
    while (fitting < GRAZING_BINS && whole + grazing_bins[fitting] <= uint(GRAZING_CAPACITY)) {
        whole += grazing_bins[fitting];
        fitting += 1;
    }
    if (bin < fitting) {
        grazing_leaves[atomicAdd(grazing_whole, 1u)] = leaf;
    } else if (bin == fitting) {
        uint slot = whole + atomicAdd(grazing_partial, 1u);
        if (slot < uint(GRAZING_CAPACITY)) grazing_leaves[slot] = leaf;
    }
#endif
}
