// SPDX-License-Identifier: GPL-3.0-or-later
// Sort keys of the rays given to LBVHBuilder.trace_buffers: a 24-bit Morton code of each
// ray's origin in the BVH's root box, so that the radix sort (hybrid_engine/gpu/radix_sort.py)
// lines up rays that start close together, and trace.comp.glsl then traces them in that order.
//
// Why: llvmpipe runs 8 invocations per SIMD vector and a vector loops until its slowest lane
// is done, and each lane fetches its own nodes. Rays that start close together (and, for
// reflection rays off a smooth surface, leave in similar directions) visit similar nodes: the
// vector's lanes finish together and share cached nodes.
// 8 bits per axis order the rays about as well as 10 at three sort passes instead of four.
// The key holds no direction: rays that start close together off one surface already leave
// in similar directions, so the direction's octant or a coarse direction code would add key
// bits without ordering them better.
//
// Host defines: LOCAL_SIZE (the root is node 0, always in the first block of a split node
//   array, so the split defines are not needed).
// Storage blocks: BVHNodes (read: the root's two child boxes), Origins (read: float[3 M]),
//   Keys (write: uint[M]), Values (write: uint[M], the ray index carried by the sort).
// Uniforms: u_count (rays M).
#define BVH_NODES
#include "dispatch.glsl"
#include "float_order.glsl"
#include "bvh_storage.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430) readonly buffer Origins {
    float origins[];
};
layout(std430) writeonly buffer Keys {
    uint keys[];
};
layout(std430) writeonly buffer Values {
    uint values[];
};

uniform uint u_count;

#define RAY_KEY_CELLS 256.0  // per axis: 3 x 8 bits

// Spread the low 8 bits of v so that two zero bits separate each pair.
uint ray_key_expand(uint v) {
    v &= 0xFFu;
    v = (v | (v << 8)) & 0x0000F00Fu;
    v = (v | (v << 4)) & 0x000C30C3u;
    v = (v | (v << 2)) & 0x00249249u;
    return v;
}

void main() {
    uint ray = flat_invocation_index();
    if (ray >= u_count) {
        return;
    }
    // Root box = union of the root's child boxes (an empty child box, min > max, drops out;
    // an empty tree gives an empty box and every key 0).
    BVHNode root = bvh_node(0u);
    vec3 lo = min(bvh_xyz(root.left_min), bvh_xyz(root.right_min));
    vec3 hi = max(bvh_xyz(root.left_max), bvh_xyz(root.right_max));
    vec3 extent = hi - lo;
    // A flat, empty or overflowing axis gets scale 0: every ray's cell 0 on that axis.
    vec3 scale = vec3(0.0);
    for (int axis = 0; axis < 3; ++axis) {
        float cells_per_unit = RAY_KEY_CELLS / extent[axis];
        if (extent[axis] > 0.0 && is_finite(cells_per_unit)) {
            scale[axis] = cells_per_unit;
        }
    }
    vec3 origin = vec3(origins[3u * ray], origins[3u * ray + 1u], origins[3u * ray + 2u]);
    uint key = 0u;
    if (all_finite(origin)) {
        // Origins outside the box (the rays may start anywhere) clamp to its faces.
        uvec3 q = uvec3(clamp((origin - lo) * scale, vec3(0.0), vec3(RAY_KEY_CELLS - 1.0)));
        key = (ray_key_expand(q.x) << 2) | (ray_key_expand(q.y) << 1) | ray_key_expand(q.z);
    }
    keys[ray] = key;
    values[ray] = ray;
}
