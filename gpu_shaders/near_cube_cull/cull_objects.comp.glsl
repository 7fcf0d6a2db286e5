// Near-cube culling, step 1: classify each object's world AABB against the near cube
// (paper §3.3: "a per object culling pass is performed").
//
// Classes: 0 = outside (its triangles are dropped without a test), 1 = inside (all kept
// without a test), 2 = straddling (each triangle gets the exact SAT test). A box with a
// non-finite coordinate straddles, so its triangles are judged one by one.
//
// Host defines: LOCAL_SIZE.
// Storage blocks: ObjectBounds (read: float[6 K], min xyz then max xyz per object),
//   ObjectClass (write: uint[K]), ClassCounts (atomic: uint[3], objects per class, zeroed by
//   the host: the frame's statistics, read after the frame, never by the cull).
// Uniforms: u_num_objects (K), u_center, u_half_size (near-cube half-size + overlap margin).
#include "dispatch.glsl"
#include "float_order.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430) readonly buffer ObjectBounds {
    float object_bounds[];
};
layout(std430) writeonly buffer ObjectClass {
    uint object_class[];
};
layout(std430) buffer ClassCounts {
    uint class_counts[3];
};

uniform uint u_num_objects;
uniform vec3 u_center;
uniform vec3 u_half_size;

#include "near_cube_class.glsl"

void main() {
    uint object = flat_invocation_index();
    if (object >= u_num_objects) {
        return;
    }
    uint base = 6u * object;
    vec3 lo = vec3(object_bounds[base], object_bounds[base + 1u], object_bounds[base + 2u]);
    vec3 hi = vec3(object_bounds[base + 3u], object_bounds[base + 4u], object_bounds[base + 5u]);
    vec3 cube_lo = u_center - u_half_size;
    vec3 cube_hi = u_center + u_half_size;
    uint result;
    if (!(all_finite(lo) && all_finite(hi))) {
        result = CLASS_STRADDLING;
    } else if (any(greaterThan(lo, cube_hi)) || any(lessThan(hi, cube_lo))) {
        result = CLASS_OUTSIDE;
    } else if (all(greaterThanEqual(lo, cube_lo)) && all(lessThanEqual(hi, cube_hi))) {
        result = CLASS_INSIDE;
    } else {
        result = CLASS_STRADDLING;
    }
    object_class[object] = result;
    atomicAdd(class_counts[result], 1u);
}
