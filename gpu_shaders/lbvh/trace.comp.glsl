// Closest-hit queries against a built LBVH: one ray per invocation (the engine behind
// hybrid_engine.trace_closest and the embreex comparison; the hybrid tracer calls the same
// bvh_closest_hit() from its own shader).
//
// Host defines: LOCAL_SIZE, BVH_NODE_BLOCKS, BVH_NODE_BLOCK_SIZE, BVH_TRIANGLE_BLOCKS,
//   BVH_TRIANGLE_BLOCK_SIZE (all but the first only for a BVH split over storage blocks:
//   BuiltLBVH.traversal_defines()); RAY_ORDER (optional): invocation i traces ray
//   ray_order[i] (the rays sorted by ray_keys.comp.glsl) instead of ray i.
// Storage blocks: the BVH's (bvh_traverse.glsl; BuiltLBVH.storage), Origins (read:
//   float[3 M]), Directions (read: float[3 M]), HitT (write: float[M], +inf on a miss), HitTri
//   (write: int[M], original triangle index, -1 on a miss), RayOrder (read: uint[M], a
//   permutation of the rays; only with RAY_ORDER). Hits are stored by ray index.
// Uniforms: u_count (rays M), u_tmin, u_tmax.
#include "dispatch.glsl"
#include "float_order.glsl"
#include "bvh_traverse.glsl"

layout(local_size_x = LOCAL_SIZE) in;

layout(std430) readonly buffer Origins {
    float origins[];
};
layout(std430) readonly buffer Directions {
    float directions[];
};
layout(std430) writeonly buffer HitT {
    float hit_t[];
};
layout(std430) writeonly buffer HitTri {
    int hit_tri[];
};

#ifdef RAY_ORDER
layout(std430) readonly buffer RayOrder {
    uint ray_order[];
};
#endif

uniform uint u_count;
uniform float u_tmin;
uniform float u_tmax;

void main() {
    uint slot = flat_invocation_index();
    if (slot >= u_count) {
        return;
    }
#ifdef RAY_ORDER
    uint ray = ray_order[slot];
#else
    uint ray = slot;
#endif
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
