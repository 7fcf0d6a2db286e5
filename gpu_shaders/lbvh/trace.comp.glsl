// Closest-hit queries against a built LBVH: one ray per invocation (the engine behind
// hybrid_engine.trace_closest and the embreex comparison; the hybrid tracer calls the same
// bvh_closest_hit() from its own shader).
//
// Host defines: LOCAL_SIZE, BVH_NODE_BLOCKS, BVH_NODE_BLOCK_SIZE, BVH_TRIANGLE_BLOCKS,
//   BVH_TRIANGLE_BLOCK_SIZE (all but the first only for a BVH split over storage blocks:
//   BuiltLBVH.traversal_defines()).
// Bindings: 0 BVH nodes (read; blocks 1..3 at 43..45), 1 BVH triangles (read; 46..48), 2 origins (read: float[3 M]),
//   3 directions (read: float[3 M]), 4 hit_t (write: float[M], +inf on a miss),
//   5 hit_tri (write: int[M], original triangle index, -1 on a miss).
// Uniforms: u_count (rays M), u_tmin, u_tmax.
#include "dispatch.glsl"
#include "float_order.glsl"
#include "bvh_traverse.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430, binding = 2) readonly buffer Origins {
    float origins[];
};
layout(std430, binding = 3) readonly buffer Directions {
    float directions[];
};
layout(std430, binding = 4) writeonly buffer HitT {
    float hit_t[];
};
layout(std430, binding = 5) writeonly buffer HitTri {
    int hit_tri[];
};

uniform uint u_count;
uniform float u_tmin;
uniform float u_tmax;

void main() {
    uint ray = flat_invocation_index();
    if (ray >= u_count) {
        return;
    }
    vec3 origin = vec3(origins[3u * ray], origins[3u * ray + 1u], origins[3u * ray + 2u]);
    vec3 dir = vec3(directions[3u * ray], directions[3u * ray + 1u], directions[3u * ray + 2u]);
    float t;
    int tri;
    vec2 bary;
    if (bvh_closest_hit(origin, dir, u_tmin, u_tmax, t, tri, bary)) {
        hit_t[ray] = t;
        hit_tri[ray] = tri;
    } else {
        hit_t[ray] = uintBitsToFloat(0x7F800000u);  // +inf
        hit_tri[ray] = -1;
    }
}
