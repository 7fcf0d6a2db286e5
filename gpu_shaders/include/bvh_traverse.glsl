// Closest-hit traversal of the LBVH (paper §3.4: rays inside the near cube are traced against
// the BVH first), callable from any compute or fragment shader:
//
//   bool bvh_closest_hit(vec3 origin, vec3 dir, float tmin, float tmax,
//                        out float t, out int tri, out vec2 bary);
//
// returns true on a hit with t in (tmin, tmax], tri the ORIGINAL triangle index and bary the
// barycentric (u, v) of vertices 1 and 2 (hit = (1-u-v) v0 + u v1 + v v2). A ray with a
// non-finite origin or direction misses (t = tmax, tri = -1). bvh_closest_leaf reports the
// hit leaf instead, from which bvh_leaf_original and bvh_leaf_face_normal read the rest.
//
// Stack-based: each fetched node carries both child boxes (bvh_layout.glsl); leaf children are
// intersected at once, the nearer inner child is visited next and the farther one pushed.
// The stack holds at most the tree depth, which is <= 30 Morton bits + 32 index bits of
// Karras' tie-break, so BVH_STACK_SIZE = 64 cannot overflow.
//
// Node fetch: two 32-byte loads. A CPU driver (llvmpipe) loads a storage-buffer value whose
// address differs per lane with one scalar loop over the 8 lanes per load instruction, so the
// cost of a fetch is the number of loads, not of bytes. bvh_fetch_node() reads the 64-byte node
// as two dvec4 of an aliasing view of the node array and takes their bits back with
// unpackDouble2x32 (no arithmetic touches them, so every bit pattern survives): two lane loops
// where the four uvec4 rows of bvh_node() take four. The triangles keep their three rows: the
// 48-byte stride leaves every other triangle 16 bytes off a dvec4.
//
// Kept simple on purpose: while-while traversal (Aila & Laine 2009), postponed leaf tests, a
// register short stack, a shorter stack and an FMA slab test on a precomputed origin *
// inverse direction (which would void Ize's bound) each add code to the loop without touching
// what takes the time on llvmpipe: the node fetch's cache misses, the per-lane load loops and
// the triangle tests.
//
// Ray-triangle test: the watertight algorithm of Woop, Benthin and Wald, "Watertight
// Ray/Triangle Intersection", JCGT 2(1), 2013: shear the triangle into ray space, decide
// inside/outside from the signs of the 2D edge functions, with a double-precision fallback
// when an edge function is exactly zero; no ray slips through a shared edge.
// Ray-box test: slabs with the near/far planes picked by the ray direction's sign (so an empty
// box, min > max, is never entered) and the far distance widened by 2 ulp-ish (Ize 2013,
// "Robust BVH Ray Traversal") so a box is never missed by rounding.
//
// BVH_ALPHA_TEST defined (trace_ray.glsl, for scenes with alpha: ALPHA_TEST): a triangle the
// ray meets is a hit only if its material's coverage keeps it (an any-hit test during the
// traversal, for closest and occlusion rays alike): the including shader defines
//   bool bvh_alpha_kept(int original_tri, vec2 bary, BVHRay ray, float t);
// Without it the leaf test is the plain one, so opaque scenes trace exactly as before.
// Host defines (optional): for a BVH whose arrays exceed one storage block, the split defines of bvh_storage.glsl
// (BVH_NODE_BLOCKS, BVH_NODE_BLOCK_SIZE, BVH_TRIANGLE_BLOCKS, BVH_TRIANGLE_BLOCK_SIZE; the host
// takes them from BuiltLBVH.traversal_defines() and binds BuiltLBVH.storage()).
#ifndef HYBRID_BVH_TRAVERSE_GLSL
#define HYBRID_BVH_TRAVERSE_GLSL

#ifndef BVH_NODES
#define BVH_NODES
#endif
#ifndef BVH_TRIANGLES
#define BVH_TRIANGLES
#endif

#include "bvh_layout.glsl"
#include "bvh_storage.glsl"
#include "float_order.glsl"

#define BVH_STACK_SIZE 64

// The node array seen as dvec4 halves (two per node), block by block like bvh_storage.glsl.
layout(std430) readonly buffer BVHNodeHalves {
    dvec4 bvh_node_halves[];
};
#if BVH_NODE_BLOCKS > 1
layout(std430) readonly buffer BVHNodeHalves1 {
    dvec4 bvh_node_halves_1[];
};
#endif
#if BVH_NODE_BLOCKS > 2
layout(std430) readonly buffer BVHNodeHalves2 {
    dvec4 bvh_node_halves_2[];
};
#endif
#if BVH_NODE_BLOCKS > 3
layout(std430) readonly buffer BVHNodeHalves3 {
    dvec4 bvh_node_halves_3[];
};
#endif

// Two rows of a node from the bits of a dvec2 (no arithmetic: every bit pattern survives).
uvec4 bvh_rows_bits(dvec2 rows) {
    return uvec4(unpackDouble2x32(rows.x), unpackDouble2x32(rows.y));
}

// Node i, as bvh_node(i) of bvh_storage.glsl but in two loads (see the header).
BVHNode bvh_fetch_node(uint i) {
    dvec4 lo;
    dvec4 hi;
#if BVH_NODE_BLOCKS == 1
    lo = bvh_node_halves[2u * i];
    hi = bvh_node_halves[2u * i + 1u];
#else
    uint block = STORAGE_BLOCK_OF(i, BVH_NODE_BLOCK_SIZE, BVH_NODE_BLOCKS);
    uint first_half = 2u * (i - block * uint(BVH_NODE_BLOCK_SIZE));
    if (block == 0u) {
        lo = bvh_node_halves[first_half];
        hi = bvh_node_halves[first_half + 1u];
    }
#if BVH_NODE_BLOCKS > 2
    else if (block == 1u) {
        lo = bvh_node_halves_1[first_half];
        hi = bvh_node_halves_1[first_half + 1u];
    }
#endif
#if BVH_NODE_BLOCKS > 3
    else if (block == 2u) {
        lo = bvh_node_halves_2[first_half];
        hi = bvh_node_halves_2[first_half + 1u];
    }
#endif
    else {
#if BVH_NODE_BLOCKS == 2
        lo = bvh_node_halves_1[first_half];
        hi = bvh_node_halves_1[first_half + 1u];
#elif BVH_NODE_BLOCKS == 3
        lo = bvh_node_halves_2[first_half];
        hi = bvh_node_halves_2[first_half + 1u];
#else
        lo = bvh_node_halves_3[first_half];
        hi = bvh_node_halves_3[first_half + 1u];
#endif
    }
#endif
    BVHNode n;
    n.left_min = bvh_rows_bits(lo.xy);
    n.left_max = bvh_rows_bits(lo.zw);
    n.right_min = bvh_rows_bits(hi.xy);
    n.right_max = bvh_rows_bits(hi.zw);
    return n;
}

// 1 + 2 * gamma(3) with gamma(n) = n eps / (1 - n eps), eps = 2^-24 (Ize 2013, pbrt-v3 §3.9).
#define BVH_BOX_FAR_SCALE 1.0000003576

// Per-ray constants of the watertight test (Woop et al. 2013, §3).
struct BVHRay {
    vec3 origin;
    vec3 inv_dir;
    bvec3 negative;  // direction sign per axis: picks the near slab plane
    ivec3 axes;      // kx, ky, kz: kz is the dominant axis, kx/ky keep the winding
    vec3 shear;      // Sx, Sy, Sz
};

BVHRay bvh_make_ray(vec3 origin, vec3 dir) {
    BVHRay ray;
    ray.origin = origin;
    // A zero component must not yield NaN in (plane - origin) * inv_dir; use a huge reciprocal
    // with the component's sign instead of inf.
    vec3 tiny = mix(vec3(1e-30), vec3(-1e-30), lessThan(dir, vec3(0.0)));
    vec3 safe = mix(dir, tiny, lessThan(abs(dir), vec3(1e-30)));
    ray.inv_dir = 1.0 / safe;
    ray.negative = lessThan(ray.inv_dir, vec3(0.0));
    vec3 a = abs(dir);
    int kz = (a.x > a.y) ? ((a.x > a.z) ? 0 : 2) : ((a.y > a.z) ? 1 : 2);
    int kx = (kz + 1) % 3;
    int ky = (kx + 1) % 3;
    if (dir[kz] < 0.0) {
        int swap = kx;
        kx = ky;
        ky = swap;
    }
    ray.axes = ivec3(kx, ky, kz);
    ray.shear = vec3(dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]);
    return ray;
}

// Entry distance of the ray into [lo, hi] if it overlaps (tmin, tmax), else +inf-ish.
float bvh_box_entry(BVHRay ray, vec3 lo, vec3 hi, float tmin, float tmax) {
    vec3 near_plane = mix(lo, hi, ray.negative);
    vec3 far_plane = mix(hi, lo, ray.negative);
    vec3 t_near = (near_plane - ray.origin) * ray.inv_dir;
    vec3 t_far = (far_plane - ray.origin) * ray.inv_dir;
    float enter = max(max(t_near.x, t_near.y), max(t_near.z, tmin));
    float leave = min(min(t_far.x, t_far.y), t_far.z) * BVH_BOX_FAR_SCALE;
    leave = min(leave, tmax);
    return enter <= leave ? enter : FLOAT_MAX;
}

vec3 bvh_permute(vec3 v, ivec3 axes) {
    return vec3(v[axes.x], v[axes.y], v[axes.z]);
}

// Watertight ray-triangle test (Woop et al. 2013, Fig. 2). Updates t_best/bary on a closer hit.
bool bvh_intersect_triangle(BVHRay ray, vec3 p0, vec3 p1, vec3 p2, float tmin,
                            inout float t_best, inout vec2 bary) {
    vec3 a = bvh_permute(p0 - ray.origin, ray.axes);
    vec3 b = bvh_permute(p1 - ray.origin, ray.axes);
    vec3 c = bvh_permute(p2 - ray.origin, ray.axes);
    float ax = a.x - ray.shear.x * a.z;
    float ay = a.y - ray.shear.y * a.z;
    float bx = b.x - ray.shear.x * b.z;
    float by = b.y - ray.shear.y * b.z;
    float cx = c.x - ray.shear.x * c.z;
    float cy = c.y - ray.shear.y * c.z;
    float u = cx * by - cy * bx;
    float v = ax * cy - ay * cx;
    float w = bx * ay - by * ax;
    if (u == 0.0 || v == 0.0 || w == 0.0) {
        // An edge function is exactly zero: redo the 2D test in double so that the edge is
        // owned by exactly one of the triangles sharing it.
        u = float(double(cx) * double(by) - double(cy) * double(bx));
        v = float(double(ax) * double(cy) - double(ay) * double(cx));
        w = float(double(bx) * double(ay) - double(by) * double(ax));
    }
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) {
        return false;
    }
    float det = u + v + w;
    if (det == 0.0) {
        return false;
    }
    float az = ray.shear.z * a.z;
    float bz = ray.shear.z * b.z;
    float cz = ray.shear.z * c.z;
    float t_scaled = u * az + v * bz + w * cz;
    // Compare t = t_scaled / det against (tmin, t_best) without dividing.
    float det_sign = det < 0.0 ? -1.0 : 1.0;
    float t_signed = t_scaled * det_sign;
    float det_abs = abs(det);
    if (t_signed <= tmin * det_abs || t_signed > t_best * det_abs) {
        return false;
    }
    float inv_det = 1.0 / det;
    t_best = t_scaled * inv_det;
    bary = vec2(v * inv_det, w * inv_det);
    return true;
}

#ifdef BVH_ALPHA_TEST
bool bvh_alpha_kept(int original_tri, vec2 bary, BVHRay ray, float t);
#endif

// Intersect leaf `leaf` (a triangle of the reordered array); updates t_best/bary on a closer hit.
bool bvh_intersect_leaf(BVHRay ray, int leaf, float tmin, inout float t_best, inout vec2 bary) {
    BVHTriangle tr = bvh_triangle(uint(leaf));
#ifdef BVH_ALPHA_TEST
    float t = t_best;
    vec2 b = bary;
    if (!bvh_intersect_triangle(ray, bvh_xyz(tr.v0), bvh_xyz(tr.v1), bvh_xyz(tr.v2), tmin, t, b)
        || !bvh_alpha_kept(int(tr.v0.w), b, ray, t)) {
        return false;
    }
    t_best = t;
    bary = b;
    return true;
#else
    return bvh_intersect_triangle(ray, bvh_xyz(tr.v0), bvh_xyz(tr.v1), bvh_xyz(tr.v2), tmin,
                                  t_best, bary);
#endif
}

// Nodes fetched by the traversals of this invocation so far (diagnostics: the tracer's
// node-visit view and counters).
uint bvh_nodes_visited = 0u;

bool bvh_closest_leaf(vec3 origin, vec3 dir, float tmin, float tmax,
                      out float t, out int leaf, out vec2 bary) {
    t = tmax;
    leaf = -1;
    bary = vec2(0.0);
    // A ray with a NaN or infinite component has no meaningful hit (and float comparisons
    // with NaN may be reordered by the compiler): it misses.
    if (!(all_finite(origin) && all_finite(dir))) {
        return false;
    }
    BVHRay ray = bvh_make_ray(origin, dir);
    float t_best = tmax;
    int hit_leaf = -1;
    vec2 hit_bary = vec2(0.0);
    int stack[BVH_STACK_SIZE];
    int stack_size = 0;
    int node = 0;
    for (;;) {
        BVHNode n = bvh_fetch_node(uint(node));
        bvh_nodes_visited += 1u;
        float t_left = bvh_box_entry(ray, bvh_xyz(n.left_min), bvh_xyz(n.left_max), tmin, t_best);
        float t_right = bvh_box_entry(ray, bvh_xyz(n.right_min), bvh_xyz(n.right_max), tmin,
                                      t_best);
        int left = int(n.left_min.w);
        int right = int(n.left_max.w);
        // Leaf children: intersect now (one triangle per leaf).
        if (t_left < FLOAT_MAX && bvh_is_leaf(left)) {
            if (bvh_intersect_leaf(ray, ~left, tmin, t_best, hit_bary)) {
                hit_leaf = ~left;
            }
            t_left = FLOAT_MAX;
        }
        if (t_right < FLOAT_MAX && bvh_is_leaf(right)) {
            if (bvh_intersect_leaf(ray, ~right, tmin, t_best, hit_bary)) {
                hit_leaf = ~right;
            }
            t_right = FLOAT_MAX;
        }
        // Inner children: nearer first, the other onto the stack.
        bool go_left = t_left < FLOAT_MAX;
        bool go_right = t_right < FLOAT_MAX;
        if (go_left && go_right) {
            bool left_first = t_left <= t_right;
            int far_child = left_first ? right : left;
            node = left_first ? left : right;
            if (stack_size < BVH_STACK_SIZE) {
                stack[stack_size++] = far_child;
            }
        } else if (go_left || go_right) {
            node = go_left ? left : right;
        } else {
            if (stack_size == 0) {
                break;
            }
            node = stack[--stack_size];
        }
    }
    t = t_best;
    bary = hit_bary;
    leaf = hit_leaf;
    return hit_leaf >= 0;
}

// Any-hit traversal for occlusion rays: true as soon as some leaf is hit with t in
// (tmin, tmax], which one unspecified (the first the walk meets). No child is visited
// nearer-first and no hit shortens the search: an occlusion ray asks only whether anything
// lies within its reach, so the first hit ends it.
bool bvh_any_leaf(vec3 origin, vec3 dir, float tmin, float tmax, out int leaf) {
    leaf = -1;
    if (!(all_finite(origin) && all_finite(dir))) {
        return false;
    }
    BVHRay ray = bvh_make_ray(origin, dir);
    vec2 bary = vec2(0.0);
    int stack[BVH_STACK_SIZE];
    int stack_size = 0;
    int node = 0;
    for (;;) {
        BVHNode n = bvh_fetch_node(uint(node));
        bvh_nodes_visited += 1u;
        float t_left = bvh_box_entry(ray, bvh_xyz(n.left_min), bvh_xyz(n.left_max), tmin, tmax);
        float t_right = bvh_box_entry(ray, bvh_xyz(n.right_min), bvh_xyz(n.right_max), tmin, tmax);
        int left = int(n.left_min.w);
        int right = int(n.left_max.w);
        float t_best = tmax;
        if (t_left < FLOAT_MAX && bvh_is_leaf(left)) {
            if (bvh_intersect_leaf(ray, ~left, tmin, t_best, bary)) {
                leaf = ~left;
                return true;
            }
            t_left = FLOAT_MAX;
        }
        if (t_right < FLOAT_MAX && bvh_is_leaf(right)) {
            if (bvh_intersect_leaf(ray, ~right, tmin, t_best, bary)) {
                leaf = ~right;
                return true;
            }
            t_right = FLOAT_MAX;
        }
        bool go_left = t_left < FLOAT_MAX;
        bool go_right = t_right < FLOAT_MAX;
        if (go_left && go_right) {
            node = left;
            if (stack_size < BVH_STACK_SIZE) {
                stack[stack_size++] = right;
            }
        } else if (go_left || go_right) {
            node = go_left ? left : right;
        } else {
            if (stack_size == 0) {
                return false;
            }
            node = stack[--stack_size];
        }
    }
    return false;
}

// The original triangle index of leaf `leaf`.
int bvh_leaf_original(int leaf) {
    return int(bvh_triangle(uint(leaf)).v0.w);
}

// The unit face normal of leaf `leaf` (winding order: (v1 - v0) x (v2 - v0)), zero for a
// degenerate triangle. The cross product is scaled by its largest component first, so that
// tiny triangles (edges of 1e-8) keep their direction instead of underflowing.
vec3 bvh_leaf_face_normal(int leaf) {
    BVHTriangle tr = bvh_triangle(uint(leaf));
    vec3 p0 = bvh_xyz(tr.v0);
    vec3 c = cross(bvh_xyz(tr.v1) - p0, bvh_xyz(tr.v2) - p0);
    float m = max(max(abs(c.x), abs(c.y)), abs(c.z));
    if (!(m > 0.0) || isinf(m)) return vec3(0.0);
    c /= m;
    return c * inversesqrt(dot(c, c));
}

bool bvh_closest_hit(vec3 origin, vec3 dir, float tmin, float tmax,
                     out float t, out int tri, out vec2 bary) {
    int leaf;
    bool hit = bvh_closest_leaf(origin, dir, tmin, tmax, t, leaf, bary);
    tri = hit ? bvh_leaf_original(leaf) : -1;
    return hit;
}

#endif
