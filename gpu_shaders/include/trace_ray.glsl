// SPDX-License-Identifier: GPL-3.0-or-later
// One secondary ray of the hybrid tracer (paper §3.4) and the shading of what it meets: the
// code the megakernel (trace/hybrid_trace.comp.glsl) and the wave pipeline
// (trace/wave_*.comp.glsl, hybrid_engine/passes/trace/wave_trace.py) share, so that both
// trace, shade and spawn exactly alike. What they differ in is where a spawned ray waits:
// the including shader defines
//   bool ray_room();   // false: the ray takes the sky along its direction instead
//   void store_ray(vec3 origin, vec3 dir, vec3 weight, int depth, float blur, float reach);
// (the megakernel: its per-pixel stack; a wave: the parent's children, counted, then written
// into the next queues, wave_queue.glsl). The ray and
// work counters (CounterBuffer, tracer.COUNTER_KINDS x COUNTER_DEPTHS) go to the buffer at
// once, or, with WORKGROUP_COUNTERS, through shared memory (count, flush_workgroup_counts).
// With TRACE_SHADING_ONLY only the shading and spawning (no tracing, none of its storage
// blocks: the wave kernels that shade stay within the driver's block limit).
// With TRACE_ANY_HIT, trace_ray stops at the first BVH surface it finds: the occlusion
// rays' kernel (trace/wave_occlusion.comp.glsl).
// Host defines, storage blocks, uniforms and samplers: as trace/hybrid_trace.comp.glsl's
// contract lists them (the images are the entry shaders').
#define BVH_NODES
#define BVH_TRIANGLES
// Shadows seen in reflections and through glass are hard (lighting.glsl HARD_SHADOWS): every
// pixel shades up to max_depth hits there, and a penumbra's filter at each would cost more
// than the rest of their shading.
#define HARD_SHADOWS 1
#include "scene_layout.glsl"
#include "storage_blocks.glsl"
#include "shading.glsl"
#include "octahedral.glsl"
#include "float_order.glsl"

// The `blur` a diffuse path's rays (and the diffuse gather's) are traced with: none, so that
// what they meet is textured at the camera's footprint there, as pbrt-v4 approximates the
// differentials of rays past the camera's (Pharr, Jakob and Humphreys 2023, Approximate_dp_dxy),
// not at the cone of the whole cosine lobe. The path's samples over frames already integrate
// the lobe; its cone read levels so coarse that they averaged the empty texels outside a
// mesh's UV islands into the light bounced off it (Cycles filters no texture).
const float PATH_TEXTURE_BLUR = 0.0;

#ifndef TRACE_SHADING_ONLY
#ifdef ALPHA_TEST
#define BVH_ALPHA_TEST  // the traversal's any-hit alpha test: bvh_alpha_kept below
#endif
#include "bvh_traverse.glsl"
#endif  // TRACE_SHADING_ONLY


layout(std430) readonly buffer MaterialBuffer { Material materials[]; };
// The emissive objects' light linking (EMITTER_LINKING only; passes/emitters/emitter_links.py).
#include "emitter_links.glsl"

// The lit cube map's reads (lit_cube.glsl) locate hits in the faces: the shading kernels need the march's uniforms too.
#if !defined(TRACE_SHADING_ONLY) || defined(LIT_CUBE)
#include "cube_march.glsl"
#endif
#include "scene_bounds.glsl"

#ifndef TRACE_SHADING_ONLY
// Shading normals of triangle i, corners 0..2: floats 9 i .. 9 i + 8 of the scene's normal
// buffer (Geometry.normals as uploaded by hybrid_engine/passes/scene_upload/scene_buffers.py; ORIGINAL order, as
// the BVH reports). Past the storage-block limit (3.7 M triangles of 36 bytes on llvmpipe)
// it is bound as up to four ranges (storage_blocks.glsl): blocks TriangleNormals1..3.
#ifndef TRI_NORMAL_BLOCKS
#define TRI_NORMAL_BLOCKS 1
#define TRI_NORMAL_BLOCK_SIZE 1
#endif
layout(std430) readonly buffer TriangleNormals { float tri_normals[]; };
#if TRI_NORMAL_BLOCKS > 1
layout(std430) readonly buffer TriangleNormals1 { float tri_normals1[]; };
#endif
#if TRI_NORMAL_BLOCKS > 2
layout(std430) readonly buffer TriangleNormals2 { float tri_normals2[]; };
#endif
#if TRI_NORMAL_BLOCKS > 3
layout(std430) readonly buffer TriangleNormals3 { float tri_normals3[]; };
#endif
// Material index per triangle (Geometry.material_ids), original order.
layout(std430) readonly buffer TriangleMaterials { int tri_materials[]; };

#define TRI_NORMAL_AT(array, base) vec3(array[(base)], array[(base) + 1u], array[(base) + 2u])

// The shading normal of corner `corner` of original triangle `tri` (the block picked as in
// triangle_input.glsl input_vertex).
vec3 corner_normal(uint tri, uint corner) {
#if TRI_NORMAL_BLOCKS == 1
    return TRI_NORMAL_AT(tri_normals, tri * 9u + corner * 3u);
#else
    uint block = STORAGE_BLOCK_OF(tri, TRI_NORMAL_BLOCK_SIZE, TRI_NORMAL_BLOCKS);
    uint base = (tri - block * uint(TRI_NORMAL_BLOCK_SIZE)) * 9u + corner * 3u;
#if TRI_NORMAL_BLOCKS > 3
    if (block == 3u) return TRI_NORMAL_AT(tri_normals3, base);
#endif
#if TRI_NORMAL_BLOCKS > 2
    if (block == 2u) return TRI_NORMAL_AT(tri_normals2, base);
#endif
    if (block == 1u) return TRI_NORMAL_AT(tri_normals1, base);
    return TRI_NORMAL_AT(tri_normals, base);
#endif
}

// The shading normal interpolated at barycentrics (b1, b2) of original triangle `tri`.
vec3 interpolated_normal(int tri, vec2 bary) {
    uint i = uint(tri);
    return (1.0 - bary.x - bary.y) * corner_normal(i, 0u) + bary.x * corner_normal(i, 1u)
           + bary.y * corner_normal(i, 2u);
}
#endif  // TRACE_SHADING_ONLY

#include "textures.glsl"
// NODE_PROGRAMS (GPUScene.defines): materials with node programs are evaluated at every hit
// (hit_material), with the hit's triangle row for the inputs that read its object.
#ifdef NODE_PROGRAMS
#include "node_program.glsl"
#endif
// Whether the rays being traced are shadow rays: the emitters' next-event rays set it around
// their trace (emitter_light.glsl); the occlusion kernel's rays (TRACE_ANY_HIT) are shadow
// rays throughout, and the megakernel sets it around its occlusion rays of AO Distance
// (trace/hybrid_trace.comp.glsl trace_stack). A coverage program at their candidate hits
// then sees Is Shadow Ray, as Cycles' shadow rays test a blocker's transparency (an
// artist's glass that casts no shadow mixes in a Transparent BSDF by it).
bool trace_shadow_rays = false;
// The bounce a shadow ray leaves from (Light Path's Ray Depth is one more there, as Cycles
// counts it: 1 from a point the camera sees): the emitters' next-event rays set it per path
// vertex; the occlusion rays of a reflection's hit leave from bounce 1.
int trace_shadow_bounce = 1;

#ifndef TRACE_SHADING_ONLY
// struct TriangleUV (GPUScene.uv_rows; scene_upload/instance_transform.comp.glsl)   // total: 32 bytes
//   vec4 uv01;       xy = UV of corner 0, zw = UV of corner 1
//   vec4 uv2_scale;  xy = UV of corner 2, z = UV units per metre (sqrt of UV area over
//                    world area; 0 when degenerate), w unused
struct TriangleUV {
    vec4 uv01;
    vec4 uv2_scale;
};
layout(std430) readonly buffer TriangleUVBuffer { TriangleUV tri_uvs[]; };

#ifdef ALPHA_TEST
#include "alpha.glsl"
// The traversal's any-hit test (bvh_traverse.glsl): the triangle's coverage at the hit,
// its alpha image read at the finest level, against a number drawn from the ray (origin and
// direction change with every sample's jitter and lobe choice) and the triangle.
bool bvh_alpha_kept(int tri, vec2 bary, BVHRay ray, float t) {
    int material = tri_materials[tri];
    Material m = materials[material];
    if (!material_has_alpha(m)) return true;
    TriangleUV tuv = tri_uvs[tri];
    vec2 uv = (1.0 - bary.x - bary.y) * tuv.uv01.xy + bary.x * tuv.uv01.zw + bary.y * tuv.uv2_scale.xy;
    uvec3 o = floatBitsToUint(ray.origin) ^ (floatBitsToUint(ray.inv_dir) * 0x9e3779b9u);
    float alpha = material_alpha_lod(m, uv, 0.0);
    // -- closure alpha: the material's alpha program at the candidate hit (alpha.glsl), a
    // short program of the nodes the coverage reads (scene/closure_alpha.py); t is in units
    // of the ray's direction as bvh_make_ray was given it. A shadow ray's candidate is run
    // as one (trace_shadow_rays).
#ifdef NODE_CLOSURE_ALPHA
    if (material_has_closure_alpha(m)) {
#ifdef TRACE_ANY_HIT
        bool shadow = true;
#else
        bool shadow = trace_shadow_rays;
#endif
        vec3 dir = 1.0 / ray.inv_dir;
        vec3 towards = -node_unit(dir, vec3(0.0, 0.0, 1.0));
        vec3 n = node_unit(interpolated_normal(tri, bary), towards);
        alpha = material_closure_alpha(m, ray.origin + t * dir, n, towards, uv, vec2(0.0), vec2(0.0), 0.0, tri,
                                       material, shadow ? node_shadow_ray_depth(trace_shadow_bounce) : 1);
    }
#endif
    // -- end of closure alpha
    return alpha_kept(alpha, uvec4(o, uint(tri)));
}
#endif
#endif  // TRACE_SHADING_ONLY
uniform float u_pixel_width;   // a pixel's footprint at the camera (orthographic), metres
uniform float u_pixel_spread;  // its growth per metre of distance (perspective), radians
uniform float u_ao_distance;   // reach of the occlusion rays of the first bounce's hits (0: none)

#define COUNTER_DEPTHS 17
#define COUNT_TRACED 0
#define COUNT_CUBE_MAP 1
#define COUNT_SKY 2
#define COUNT_BVH_REENTRY 3
#define COUNT_BVH_HIT 4
#define COUNT_CUBE_HIT 5
#define COUNT_BVH_NODES 6   // nodes the rays of a depth visited, summed
#define COUNT_CUBE_STEPS 7  // march steps the rays of a depth took, summed
#ifndef TRACE_SHADING_ONLY
layout(std430) buffer CounterBuffer { uint counters[]; };
#endif  // TRACE_SHADING_ONLY

uniform sampler2D u_depth;
uniform sampler2D u_normal_material;
uniform sampler2D u_albedo;
uniform sampler2D u_emission_scale;
uniform sampler2D u_surface;         // primary roughness, metallic (gbuffer.frag.glsl)
uniform sampler2D u_cube_surface;    // xy UV, z UV density (cube_map.CubeFaceTargets)
uniform sampler2D u_cube_geometric;  // xy octahedral geometric normal
// The point a cube-map texel stores (its centre at its stored depth, either layer), and the
// texel's width there: where a cube hit's ray is measured against the stored surface.
#ifndef TRACE_SHADING_ONLY
vec3 cube_texel_point(ivec2 texel, out float width) {
    int face = cube_face_of_column(texel.x, u_cube_res);
    ivec2 local = ivec2(texel.x, texel.y >= u_cube_res ? texel.y - u_cube_res : texel.y);
    float z = texelFetch(u_cube_depth, texel, 0).r * 2.0 - 1.0;
    width = cube_linear_depth(z) * 2.0 * CUBE_TAN_HALF_FOV / float(u_cube_res);
    return cube_unproject(face, vec3(cube_texel_center(local, face), z));
}
#endif

#if defined(NODE_PROGRAMS) && !defined(TRACE_SHADING_ONLY)
// -- cube hits' tangent frame (issue 38) --
uniform sampler2D u_cube_tangent;    // the texels' UV directions (cube_map.CubeFaceTargets)
#include "cube_tangent.glsl"

// The UV's change from where the face interpolated the UV a cube-hit texel keeps (its centre,
// at its stored depth) to where the ray o + d t meets the plane through that point (the
// texel's geometric normal g), by the triangle's UV directions: the program reads the UV at
// the ray's own point, as a BVH hit does, not at the nearest texel's. None where the ray
// meets that plane more than a few texels away (grazing), as without the frame.
vec2 cube_hit_uv_offset(vec3 o, vec3 d, ivec2 texel, vec3 g, vec3 dp_du, vec3 dp_dv) {
    float texel_width;
    vec3 centre = cube_texel_point(texel, texel_width);
    float facing = dot(d, g);
    if (!(abs(facing) > 1e-6)) return vec2(0.0);
    vec3 step = d * (dot(centre - o, g) / facing) + (o - centre);
    if (!(dot(step, step) <= 16.0 * texel_width * texel_width)) return vec2(0.0);
    return node_uv_change(step, dp_du, dp_dv);
}

#ifdef ALPHA_TEST
// Whether material m's surface is there at all at uv, the UV a cube hit would move to. The
// faces kept the texel by its coverage at its own UV (gbuffer.frag.glsl: the alpha image, or
// the alpha program); the march may meet a texel at a cut edge a few texels from where the
// ray meets its plane, and that point can lie in the hole. A cube hit cannot pass through
// it (the march has ended), so the program shading that point would see a Transparent
// closure: a surface with no colour, where the faces said the card is. Its coverage read as
// the traversal's any-hit test reads it (the finest level; the alpha program at the hit).
bool cube_hit_covered_at(Material m, int material, vec2 uv, vec3 position, vec3 normal, int row, vec3 d) {
    if (!material_has_alpha(m)) return true;
    float alpha = material_alpha_lod(m, uv, 0.0);
#ifdef NODE_CLOSURE_ALPHA
    if (material_has_closure_alpha(m)) {
        vec3 towards = -node_unit(d, vec3(0.0, 0.0, 1.0));
        alpha = material_closure_alpha(m, position, node_unit(normal, towards), towards, uv, vec2(0.0), vec2(0.0),
                                       0.0, row, material, 1);
    }
#endif
    return alpha > 0.0;
}
#endif
#endif
uniform mat4 u_inv_view_proj;
uniform vec3 u_camera_position;
uniform vec3 u_camera_forward;
uniform int u_orthographic;
uniform ivec2 u_size;
uniform int u_mode;          // MODE_* below
uniform int u_max_depth;     // 0..MAX_DEPTH_LIMIT
uniform vec3 u_near_center;  // the near cube (camera position)
uniform float u_near_half;   // its half-size (near_size): decides where a ray starts
uniform float u_bvh_half;    // half-size of the culled region (near_size + overlap)

#define MODE_HYBRID 0
#define MODE_FULL_BVH 1
#define MODE_PROVENANCE 2

#define MAX_DEPTH_LIMIT 16
#define STACK_SIZE (MAX_DEPTH_LIMIT + 2)
// Segments (BVH <-> cube map hand-overs) one ray may take before it is given the sky.
#define MAX_SEGMENTS 12
// Spawned rays start this far off the surface (relative to the position's magnitude, plus
// a share of the scene's size: scene_offset_absolute), so that neither the BVH nor the cube
// map finds the surface they leave. RAY_OFFSET_ABSOLUTE: the share of a scene without bounds.
const float RAY_OFFSET_RELATIVE = 1e-4;
const float RAY_OFFSET_ABSOLUTE = 1e-4;

#define HIT_SKY 0
#define HIT_BVH 1
#define HIT_CUBE 2

struct Hit {
    int kind;
    vec3 position;
    vec3 normal;     // unit shading normal as modelled
    vec3 geometric;  // unit normal of the hit triangle's plane (either orientation)
    int material;
    vec2 uv;         // texture coordinate (BVH hits: interpolated; cube hits: the texel's)
    float lod;       // mip level of the ray cone's footprint (textured hits)
#ifdef NODE_PROGRAMS
    int row;         // world row of the surface's triangle (a cube hit: the face texel's), -1 none
    vec3 dp_du;      // the triangle's directions of increasing u and v (a node program's tangent
    vec3 dp_dv;      //   frame: Normal Map); zero where unknown (cube hits) or degenerate
    float footprint; // the ray cone's width at the hit, metres (a node program's dP: Bump)
#endif
};

struct PendingRay {
    vec3 origin;
    vec3 dir;
    vec3 weight;
    int depth;   // bounce; -1: an occlusion ray (push_occlusion)
    float blur;  // the roughest lobe on the ray's path (filters the lamp highlights it sees)
    float reach; // how far it looks (FLOAT_MAX but for occlusion rays)
};

vec3 unproject_primary(vec2 ndc_xy, float ndc_z) {
    vec4 world = u_inv_view_proj * vec4(ndc_xy, ndc_z, 1.0);
    return world.xyz / world.w;
}

bool inside_near_cube(vec3 p) {
    return all(lessThanEqual(abs(p - u_near_center), vec3(u_near_half)));
}

// [enter, exit] of the ray with the BVH region (the culled cube).
vec2 bvh_region_interval(vec3 o, vec3 d) {
    return box_interval(o, d, u_near_center - vec3(u_bvh_half), u_near_center + vec3(u_bvh_half));
}

vec3 offset_origin(vec3 p, vec3 towards) {
    float scale = scene_offset_absolute(RAY_OFFSET_ABSOLUTE) + RAY_OFFSET_RELATIVE * max(max(abs(p.x), abs(p.y)), abs(p.z));
    return p + towards * scale;
}

#ifndef TRACE_SHADING_ONLY
#ifdef WORKGROUP_COUNTERS
// A wave's rays all have one depth: the counts of a workgroup gather in shared memory, and
// flush_workgroup_counts adds them to CounterBuffer with one atomic per kind (every
// invocation of the workgroup calls it, in uniform control flow).
shared uint workgroup_counts[COUNT_CUBE_STEPS + 1];
void count(int kind, int depth) { atomicAdd(workgroup_counts[kind], 1u); }
void count_amount(int kind, int depth, uint amount) { atomicAdd(workgroup_counts[kind], amount); }
void clear_workgroup_counts() {
    if (gl_LocalInvocationIndex <= uint(COUNT_CUBE_STEPS)) workgroup_counts[gl_LocalInvocationIndex] = 0u;
    barrier();
}
void flush_workgroup_counts(int depth) {
    barrier();
    uint kind = gl_LocalInvocationIndex;
    if (kind <= uint(COUNT_CUBE_STEPS) && workgroup_counts[kind] != 0u)
        atomicAdd(counters[kind * uint(COUNTER_DEPTHS) + uint(clamp(depth, 0, COUNTER_DEPTHS - 1))],
                  workgroup_counts[kind]);
}
#else
void count(int kind, int depth) {
    atomicAdd(counters[kind * COUNTER_DEPTHS + clamp(depth, 0, COUNTER_DEPTHS - 1)], 1u);
}
void count_amount(int kind, int depth, uint amount) {
    atomicAdd(counters[kind * COUNTER_DEPTHS + clamp(depth, 0, COUNTER_DEPTHS - 1)], amount);
}
#endif

// Width in metres of a pixel's ray cone at distance t along a ray from o: the camera-to-
// origin distance plus t is a lower bound of the path length (textures.py). A ray drawn from
// a glossy lobe of roughness `blur` (the roughest on its path) stands for the lobe's spread
// of directions, about 2 alpha radians across (GGX, alpha = roughness^2), which widens its
// cone past its origin: what it meets is textured at the level the lobe would blur it to,
// so one sample of a rough reflection already shows the blurred texture.
float ray_cone_footprint(vec3 o, float t, float blur) {
    return u_pixel_width + u_pixel_spread * (distance(o, u_camera_position) + t) + 2.0 * blur * blur * t;
}

#ifdef NODE_PROGRAMS
// dP/du and dP/dv of a triangle with edges e1, e2 whose UVs change by d1, d2 along them;
// zero when its UVs are degenerate.
void triangle_uv_directions(vec3 e1, vec3 e2, vec2 d1, vec2 d2, out vec3 tu, out vec3 tv) {
    float r = d1.x * d2.y - d2.x * d1.y;
    bool ok = abs(r) > 1e-20;
    tu = ok ? (e1 * d2.y - e2 * d1.y) / r : vec3(0.0);
    tv = ok ? (e2 * d1.x - e1 * d2.x) / r : vec3(0.0);
}
#endif

Hit bvh_hit(vec3 o, vec3 d, float t, int leaf, vec2 bary, float blur) {
    Hit h;
    h.kind = HIT_BVH;
    h.position = o + d * t;
    int tri = bvh_leaf_original(leaf);
    h.geometric = safe_normalize(bvh_leaf_face_normal(leaf), -d);
    h.normal = safe_normalize(interpolated_normal(tri, bary), h.geometric);
    h.material = tri_materials[tri];
    h.uv = vec2(0.0);
    h.lod = 0.0;
    ivec4 tex = materials[h.material].textures;
#ifdef NODE_PROGRAMS
    h.row = tri;
    h.dp_du = vec3(0.0);
    h.dp_dv = vec3(0.0);
    h.footprint = ray_cone_footprint(o, t, blur);
    if (material_has_program(materials[h.material])) {
        tex.x = 0;  // a program may read the UV
        // The triangle's UV directions (its tangent frame, constant over it: a Normal Map's
        // tangent where Cycles interpolates MikkTSpace's per vertex).
        TriangleUV tuv = tri_uvs[tri];
        BVHTriangle tr = bvh_triangle(uint(leaf));
        triangle_uv_directions(bvh_xyz(tr.v1) - bvh_xyz(tr.v0), bvh_xyz(tr.v2) - bvh_xyz(tr.v0),
                               tuv.uv01.zw - tuv.uv01.xy, tuv.uv2_scale.xy - tuv.uv01.xy, h.dp_du, h.dp_dv);
    }
#endif
    if (max(max(tex.x, tex.y), tex.z) >= 0 || material_has_surface_maps(materials[h.material])) {
        // Texture coordinate by the hit's barycentrics.
        TriangleUV tuv = tri_uvs[tri];
        h.uv = (1.0 - bary.x - bary.y) * tuv.uv01.xy + bary.x * tuv.uv01.zw + bary.y * tuv.uv2_scale.xy;
        h.lod = texture_lod(ray_cone_footprint(o, t, blur), tuv.uv2_scale.z);
        if (tex.z >= 0) {
            // The triangle's UV directions dp/du, dp/dv from its corners.
            BVHTriangle tr = bvh_triangle(uint(leaf));
            vec3 e1 = bvh_xyz(tr.v1) - bvh_xyz(tr.v0);
            vec3 e2 = bvh_xyz(tr.v2) - bvh_xyz(tr.v0);
            vec2 d1 = tuv.uv01.zw - tuv.uv01.xy;
            vec2 d2 = tuv.uv2_scale.xy - tuv.uv01.xy;
            float r = d1.x * d2.y - d2.x * d1.y;
            if (abs(r) > 1e-20) {
                vec3 tu = (e1 * d2.y - e2 * d1.y) / r;
                vec3 tv = (e2 * d1.x - e1 * d2.x) / r;
                h.normal = material_normal_lod(materials[h.material], h.normal, tu, tv, h.uv, h.lod);
            }
        }
    }
    return h;
}

// Follow one ray through the BVH and the cube map until it hits something or the sky, or
// passes t_max (then it sees the sky); `blur`: the roughest lobe on its path
// (ray_cone_footprint). A depth below 0 marks an occlusion ray: it is left out of the ray
// counts and of the diagnostic views, which show the reflection and refraction rays.
#if CUBE_HIDDEN_SIDE
// How far from its texel's centre, across the line of sight and in texel widths, the ray
// o + d t may meet the plane of the surface a flagged cube hit stored, and still have met
// that surface there, without looking further (cube_stores_point). A ray meeting a surface
// seen at an angle enters the texels beyond the crossing behind A without piercing it there,
// but meets the plane within a texel or so: most flagged hits end here, one fetch each.
#define CUBE_HIDDEN_LATERAL 4.0

// Whether the map stores a surface at world point x: x's depth, from the map's centre, lies
// within the texel's own depth bias (twice: x is not at the texel's centre) of the depth
// stored where x projects.
// The texel of the face that sees world point x, and x's linear depth from the map's
// centre; false where x lies on no face's side (the map's centre).
bool cube_point_texel(vec3 x, out ivec2 texel, out float depth) {
    texel = ivec2(0);
    depth = 0.0;
    for (int face = 0; face < 6; ++face) {
        vec4 c = u_face_view_proj[face] * vec4(x, 1.0);
        if (!cube_face_contains(c)) continue;
        vec3 ndc = c.xyz / c.w;
        texel = cube_texel(face, ndc.xy);
        depth = cube_linear_depth(ndc.z);
        return true;
    }
    return false;
}

bool cube_stores_point(vec3 x) {
    ivec2 texel;
    float depth;
    if (!cube_point_texel(x, texel, depth) || texelFetch(u_cube_normal_material, texel, 0).w == 0.0) return false;
    float surface = cube_linear_depth(texelFetch(u_cube_depth, texel, 0).r * 2.0 - 1.0);
    int face = cube_face_of_column(texel.x, u_cube_res);
    ivec2 local = texel - ivec2(face * u_cube_res, 0);
    float bias = cube_linear_depth(texelFetch(u_cube_hiz, ivec2(face * u_cube_hiz_res, 0) + local, 0).r) - surface;
    return abs(depth - surface) <= 2.0 * bias;
}

// A flagged cube hit `cm` (geometric normal g; cube_march.glsl "Hidden sides") as the
// diffuse paths take it. Where the ray meets the plane of the stored surface near the
// texel, or where the map stores that plane (a ray from behind a thin surface, e.g. from
// the lamp's side of a partition, meets it there, far from where its march first met the
// surface's stretch): a hit on that plane, returned in `h`, and false. Otherwise the ray
// passed beside the surface into the space hidden behind it: true.
bool cube_hidden_side(CubeMarch cm, vec3 o, vec3 d, vec3 g, inout Hit h) {
    if (!cm.hidden) return false;
    float texel_width;
    vec3 centre = cube_texel_point(cm.texel, texel_width);
    float facing = dot(d, g);
    float t_plane = abs(facing) > 1e-6 ? dot(centre - o, g) / facing : -1.0;
    if (!(t_plane > 0.0)) return true;
    vec3 crossing = o + d * t_plane;
    vec3 sight = normalize(centre - u_cube_center);
    vec3 across = crossing - centre;
    across -= sight * dot(across, sight);
    if (dot(across, across) <= CUBE_HIDDEN_LATERAL * CUBE_HIDDEN_LATERAL * texel_width * texel_width)
        return false;
    if (!cube_stores_point(crossing)) return true;
    h.position = crossing;
    return false;
}

// Whether the side of the scene's bounds at `side` along `axis` is a wall the map sees: the
// map stores a surface at that plane's point nearest the map's centre (within 1 % of its
// depth, which takes in the bounds' padding). A closed room's six sides are; an open
// scene's sides and top are the sky.
bool cube_bounds_side_is_wall(int axis, float side) {
    vec3 foot = u_cube_center;
    foot[axis] = side;
    ivec2 texel;
    float depth;
    if (!cube_point_texel(foot, texel, depth) || texelFetch(u_cube_normal_material, texel, 0).w == 0.0) return false;
    float surface = cube_linear_depth(texelFetch(u_cube_depth, texel, 0).r * 2.0 - 1.0);
    return abs(depth - surface) <= 0.01 * depth;
}

// A ray that passed into the space hidden from the map's centre meets something the map
// does not hold. Where it leaves the bounds of all geometry through a side that is a wall
// (cube_bounds_side_is_wall), the diffuse paths take that point instead, facing back into
// the bounds: in a closed room the wall it really meets, lit by the lamps there, where the
// stored surface's camera-facing side (often the shadowed one: the partition in front of
// the lamp) darkened the bounced light. False (the stored surface's stretch stays the hit,
// as in the paper) where the side is open (the ray may reach the sky: the map cannot tell)
// or the ray leaves the bounds before the hit (a hit past them is the overshoot's).
bool cube_hidden_exit_point(vec3 o, vec3 d, float t_hit, inout Hit h) {
    if (u_scene_bounded == 0) return false;
    vec3 safe = mix(d, vec3(1e-30), lessThan(abs(d), vec3(1e-30)));
    vec3 t_far = max((u_scene_lo - o) / safe, (u_scene_hi - o) / safe);
    int axis = t_far.x <= t_far.y ? (t_far.x <= t_far.z ? 0 : 2) : (t_far.y <= t_far.z ? 1 : 2);
    if (!(t_far[axis] > t_hit)) return false;
    if (!cube_bounds_side_is_wall(axis, d[axis] > 0.0 ? u_scene_hi[axis] : u_scene_lo[axis])) return false;
    h.position = o + d * t_far[axis];
    vec3 n = vec3(0.0);
    n[axis] = d[axis] > 0.0 ? -1.0 : 1.0;
    h.normal = n;
    h.geometric = n;
    return true;
}
#endif

#if BVH_WHOLE_RAY && !defined(TRACE_ANY_HIT)
#include "grazing_leaves.glsl"
// The nearest of the near cube's grazing triangles (grazing_leaves.glsl) that the ray meets
// in (tmin, tmax]: the triangles beyond the near cube that the cube map sees edge-on. Every
// invocation reads the same short list, a few broadcast loads per ray. No traversal of the
// BVH: trace_ray keeps one (the segment inside the near cube), since a second in the diffuse
// kernel made a GPU's diffuse pass two to three times slower for the same work.
bool grazing_closest_leaf(vec3 o, vec3 d, float tmin, float tmax, out float t, out int leaf, out vec2 bary) {
    t = tmax;
    leaf = -1;
    bary = vec2(0.0);
    uint listed = grazing_listed();
    if (listed == 0u || !(all_finite(o) && all_finite(d))) return false;
    BVHRay ray = bvh_make_ray(o, d);
    for (uint i = 0u; i < listed; ++i) {
        int candidate = int(grazing_leaves[i]);
        if (bvh_intersect_leaf(ray, candidate, tmin, t, bary)) leaf = candidate;
    }
    return leaf >= 0;
}
#endif

Hit trace_ray(vec3 o, vec3 d, int depth, float blur, float t_max) {
    Hit h;
    h.kind = HIT_SKY;
    h.position = vec3(0.0);
    h.normal = vec3(0.0, 0.0, 1.0);
    h.geometric = h.normal;
    h.material = 0;
    h.uv = vec2(0.0);
    h.lod = 0.0;
#ifdef NODE_PROGRAMS
    h.row = -1;
    h.dp_du = vec3(0.0);
    h.dp_dv = vec3(0.0);
    h.footprint = 0.0;
#endif
    bool reached_cube = false;
    bool reentered = false;
    uint nodes_before = bvh_nodes_visited;
    uint steps_before = cube_march_steps;
    float t;
    int leaf;
    vec2 bary;
    // Whether the ray ended on the BVH leaf (t, leaf, bary): its hit is built once, after the
    // loop, so that the kernel holds one copy of that code however many ways reach it.
    bool met_leaf = false;
    // One traversal serves both modes: FULL_BVH is a single BVH segment over the whole
    // scene whose miss is the sky.
    bool full = u_mode == MODE_FULL_BVH;
    bool in_bvh = full || inside_near_cube(o);
    float t_cur = 0.0;
    for (int seg = 0; seg < MAX_SEGMENTS; ++seg) {
        if (in_bvh) {
            vec2 span = full ? vec2(0.0, FLOAT_MAX) : bvh_region_interval(o, d);
            float t0 = max(t_cur, span.x);
            float t1 = min(span.y, t_max);
#ifdef TRACE_ANY_HIT
            // An occlusion ray asks whether anything lies within its reach: the first
            // surface found ends it (no nearest-first search), and only its material matters.
            if (t0 <= t1 && bvh_any_leaf(o, d, t0, t1, leaf)) {
                h.kind = HIT_BVH;
                h.material = tri_materials[bvh_leaf_original(leaf)];
                break;
            }
#else
            if (t0 <= t1 && bvh_closest_leaf(o, d, t0, t1, t, leaf, bary)) {
                met_leaf = true;  // shaded once, below the loop
                break;
            }
#endif
            if (full) break;
            // Leave the near cube: continue in the cube map at the exit point.
            t_cur = max(t_cur, t1);
            in_bvh = false;
        } else {
            reached_cube = true;
            float t_limit = min(scene_exit(o, d), t_max);
#if BVH_WHOLE_RAY && !defined(TRACE_ANY_HIT)
            // (Beyond the paper; the diffuse paths only, diffuse_light.py.) The BVH holds the
            // whole triangles that reach into the near cube. A wall the camera stands close
            // to is one: beyond the near cube's faces the cube map sees it edge-on, a sliver
            // of texels that a march slips through. Such triangles (grazing_closest_leaf)
            // are met wherever the ray crosses them, the march ending there.
            float t_beyond;
            int leaf_beyond;
            vec2 bary_beyond;
            bool beyond = t_limit > t_cur && grazing_closest_leaf(o, d, t_cur, t_limit, t_beyond, leaf_beyond, bary_beyond);
            if (beyond) t_limit = t_beyond;
#endif
            CubeMarch cm = cube_march_limited(o, d, t_cur, t_limit);
#if BVH_WHOLE_RAY && !defined(TRACE_ANY_HIT)
            // Nothing in the map before the triangle: the march ran to it, or leaves into
            // the near cube no nearer.
            if (beyond && (cm.kind == CUBE_SKY || (cm.kind == CUBE_TO_BVH && cm.t >= t_beyond))) {
                t = t_beyond;
                leaf = leaf_beyond;
                bary = bary_beyond;
                met_leaf = true;
                break;
            }
#endif
            if (cm.kind == CUBE_HIT) {
                h.kind = HIT_CUBE;
                h.position = cm.position;
                h.normal = safe_normalize(cm.normal, -d);
                vec2 g_oct = texelFetch(u_cube_geometric, cm.texel, 0).xy;
                h.geometric = gbuffer_geometric(g_oct.x, g_oct.y, h.normal);
#if CUBE_HIDDEN_SIDE
                if (cube_hidden_side(cm, o, d, h.geometric, h) && cube_hidden_exit_point(o, d, cm.t, h)) {
                    h.material = cm.material;  // the stored surface's: the map holds no other
                    break;
                }
#endif
                h.material = cm.material;
                ivec4 tex = materials[h.material].textures;
#ifdef NODE_PROGRAMS
                // The face texel's triangle row (gbuffer.frag.glsl, CUBE_FACE; cube_row_encode).
                h.row = cube_row_decode(texelFetch(u_cube_surface, cm.texel, 0).w);
                h.footprint = ray_cone_footprint(o, distance(o, cm.position), blur);
                if (material_has_program(materials[h.material])) {
                    tex.x = 0;  // a program may read the UV
                    // -- cube hits' tangent frame (issue 38) --
                    // The triangle's UV directions as the face texel keeps them
                    // (cube_tangent.glsl), the frame bvh_hit builds from its corners: a
                    // tangent-space Normal Map and the Bump's UV offsets as at a BVH hit.
                    cube_tangent_decode(texelFetch(u_cube_tangent, cm.texel, 0), g_oct, h.dp_du, h.dp_dv);
                }
#endif
                if (max(max(tex.x, tex.y), tex.z) >= 0 || material_has_surface_maps(materials[h.material])) {
                    // The face keeps the texel's UV and UV density (gbuffer.frag.glsl,
                    // CUBE_FACE): textured like a BVH hit, with the same ray cone.
                    vec4 surface = texelFetch(u_cube_surface, cm.texel, 0);
                    h.uv = surface.xy;
                    h.lod = texture_lod(ray_cone_footprint(o, distance(o, cm.position), blur), surface.z);
                }
#ifdef NODE_PROGRAMS
                // -- cube hits' tangent frame (issue 38): the UV at the ray's point --
                if (material_has_program(materials[h.material])) {
                    vec2 moved = h.uv + cube_hit_uv_offset(o, d, cm.texel, h.geometric, h.dp_du, h.dp_dv);
#ifdef ALPHA_TEST
                    // Not into a cut-out's hole the faces never tested (cube_hit_covered_at).
                    if (cube_hit_covered_at(materials[h.material], h.material, moved, h.position, h.normal, h.row, d))
#endif
                    h.uv = moved;
                }
#endif
                break;
            }
            if (cm.kind == CUBE_SKY) break;
            // Back through a near plane into the near cube (paper: "using the original
            // ray r_w"); never step backwards along the ray.
            reentered = true;
            t_cur = max(t_cur, cm.t);
            in_bvh = true;
        }
    }
#ifndef TRACE_ANY_HIT
    if (met_leaf) h = bvh_hit(o, d, t, leaf, bary, blur);
#endif
    if (depth < 0) {
        bvh_nodes_visited = nodes_before;
        cube_march_steps = steps_before;
        return h;
    }
    count(COUNT_TRACED, depth);
    if (reached_cube) count(COUNT_CUBE_MAP, depth);
    if (reentered) count(COUNT_BVH_REENTRY, depth);
    if (h.kind == HIT_SKY) count(COUNT_SKY, depth);
    if (h.kind == HIT_BVH) count(COUNT_BVH_HIT, depth);
    if (h.kind == HIT_CUBE) count(COUNT_CUBE_HIT, depth);
    if (bvh_nodes_visited != nodes_before)
        count_amount(COUNT_BVH_NODES, depth, bvh_nodes_visited - nodes_before);
    if (cube_march_steps != steps_before)
        count_amount(COUNT_CUBE_STEPS, depth, cube_march_steps - steps_before);
    return h;
}


#endif  // TRACE_SHADING_ONLY
// What rays see that find no room: the sky along their direction (and the rays past the
// depth limit); the entry shader adds it to the pixel.
vec3 past_depth_limit = vec3(0.0);

bool ray_room();
void store_ray(vec3 origin, vec3 dir, vec3 weight, int depth, float blur, float reach);

// A ray one bounce past the depth limit (depth u_max_depth + 1) is still traced, through the
// BVH and the cube map, and the surface it meets is shaded without spawning rays: the depth
// limit then shows the environment along the last ray (as Cycles shades the last vertex of a
// path with its lamps and emission), not the sky through every wall. Depth 0 keeps its
// meaning, no secondary rays: there the sky is all a mirror shows.
void push(vec3 origin, vec3 dir, vec3 weight, int depth, float blur) {
    if (!(max(max(weight.r, weight.g), weight.b) > 0.0)) return;
#ifdef NO_DEPTH_LIMIT_RAY  // a measurement switch (benchmarks/picture_cost.py): the sky at once
    if (!ray_room() || depth > u_max_depth) {
#else
    if (!ray_room() || depth > u_max_depth + min(u_max_depth, 1)) {
#endif
        past_depth_limit += weight * sky_radiance(dir);
        return;
    }
    store_ray(origin, dir, weight, depth, blur, FLOAT_MAX);
}

// An occlusion ray from a hit: `weight` is the World's light that hit takes if it sees the
// sky along dir within `reach` (world_light_response times the path's weight); the ray
// adds it times what it finds there, 1 for the sky, a surface's transmission otherwise.
// It waits on the stack like the reflections: the megakernel's loop traces one ray per pixel and
// step, so a pixel's occlusion ray shares a step with its neighbours' rays instead of
// running a traversal of its own while they idle (8 pixels run in lockstep on a CPU
// driver's SIMD lanes, and in a GPU's warps). Room for it is always left: a pixel holds at
// most one, and the reflections' depth-first stack at most max_depth + 2 rays.
void push_occlusion(vec3 origin, vec3 dir, vec3 weight, float reach) {
    if (!(max(max(weight.r, weight.g), weight.b) > 0.0)) return;
    if (!ray_room()) {
#ifdef DIFFUSE_GATHER
        past_depth_limit += weight * sky_radiance(dir);  // never reached (above): the sky taken as seen
#else
        past_depth_limit += weight;  // never reached (above): the sky taken as seen
#endif
        return;
    }
#ifdef DIFFUSE_GATHER
    store_ray(origin, dir, weight, -1, PATH_TEXTURE_BLUR, reach);  // a gather ray brings light
#else
    store_ray(origin, dir, weight, -1, 1.0, reach);
#endif
}

// Spawn the reflected and refracted rays of a hit at p (offset off the surface). Outside the
// near cube a refraction is the paper's thin fallback (§3.4, Figure 8): the ray refracts
// once and looks the scene up in the cube map, whose faces hold what lies behind refractive
// surfaces (cube_map.py: they are left out of the faces), not the surfaces themselves.
// `blur`: the roughest lobe of the path up to and including this hit.
void spawn_children(SpecularSplit split, vec3 p, vec3 weight, int depth, float blur) {
    push(offset_origin(p, split.g_facing), split.reflect_dir, weight * split.reflect_weight, depth, blur);
    push(offset_origin(p, -split.g_facing), split.refract_dir, weight * split.refract_weight, depth, blur);
}

// This sample's numbers for the lobes of the hit at bounce `depth` of the pixel whose
// primary hit lies at pixel_key (position_key: a cropped view draws the same numbers).
uvec3 pixel_key;
#ifdef EMITTER_LINKING
// The receiver set whose linked emitters a traced ray may see (emitter_links.glsl): the
// light-linking set of the pixel's primary surface, set with pixel_key. Cycles checks the
// surface a ray leaves; for the first bounce, the reflections and refractions a pixel shows
// directly, that is this one.
int ray_receiver_set = 0;

int pixel_receiver_set(ivec2 pixel) {
    float w = texelFetch(u_normal_material, pixel, 0).w;
    return w == 0.0 ? 0 : row_light_set(int(abs(w) + 0.5) - 1);
}
#endif
vec2 lobe_random(int depth) {
    return random2(uvec4(pixel_key.x, pixel_key.y ^ pcg_hash(pixel_key.z), uint(u_sample), uint(depth)));
}

// The material of a primary pixel, with the roughness and metallic its images give there.
Material primary_material(int index, ivec2 pixel) {
    Material m = materials[index];
#ifdef NODE_PROGRAMS
    if (material_has_program(m)) return node_gbuffer_material(m, texelFetch(u_surface, pixel, 0));
#endif
    if (!material_has_surface_maps(m)) return m;
    vec2 surface = texelFetch(u_surface, pixel, 0).rg;
    return material_with_surface(m, surface.x, surface.y);
}

// A cosine-distributed direction around the shading normal n from two uniform numbers,
// kept above the true surface (g, the geometric normal on the same side).
vec3 cosine_direction(vec3 n, vec3 g, vec2 xi) {
    vec3 t, b;
    basis_around(n, t, b);
    float r = sqrt(xi.x);
    vec3 d = r * cos(2.0 * PI * xi.y) * t + r * sin(2.0 * PI * xi.y) * b + sqrt(max(0.0, 1.0 - xi.x)) * n;
    return keep_on_side(d, g, 0.01);
}


#ifdef LIT_CUBE
#include "lit_cube.glsl"
#endif

// The material at the hit h of a ray along d at bounce `depth`, with its images sampled at
// the ray cone's level; a material with a node program runs it (include/node_program.glsl),
// which may bend h.normal.
Material hit_material(inout Hit h, vec3 d, int depth) {
#ifdef NODE_PROGRAMS
    Material m = materials[h.material];
    if (material_has_program(m)) {
        ShadingPoint sp;
        sp.position = sp.surface = h.position;
        sp.incoming = -d;
        // BVH hits know the triangle's winding; cube hits only the stored shading normal.
        sp.backfacing = dot(d, h.kind == HIT_BVH ? h.geometric : h.normal) > 0.0;
        sp.normal = sp.backfacing ? -h.normal : h.normal;
        sp.geometric = dot(h.geometric, d) > 0.0 ? -h.geometric : h.geometric;
        sp.uv = h.uv;
        sp.duv_dx = vec2(0.0);
        sp.duv_dy = vec2(0.0);
        sp.lod = max(h.lod, 0.0);
        sp.dp_du = h.dp_du;
        sp.dp_dv = h.dp_dv;
        // The ray cone's width as the ray's dP, unfolded in the surface's plane as Cycles does.
        node_footprint_axes(sp.geometric, h.footprint, sp.dp_dx, sp.dp_dy);
        sp.uv_dx = node_uv_change(sp.dp_dx, h.dp_du, h.dp_dv);
        sp.uv_dy = node_uv_change(sp.dp_dy, h.dp_du, h.dp_dv);
        // Seen from behind, the tangent frame flips with the normal, so that a Normal Map's
        // colour maps to the mapped normal negated, as Cycles gives it (and as the G-buffer's
        // cotangent frame, which flips with the view); the UV's changes stay the surface's.
        if (sp.backfacing) {
            sp.dp_du = -sp.dp_du;
            sp.dp_dv = -sp.dp_dv;
        }
        sp.ray_depth = max(depth, 1);
        sp.row = h.row;
        sp.material = h.material;
        NodeClosure c = node_program_run(m.textures2.w, sp);
        h.normal = c.normal;
        return node_closure_material(m, c);
    }
#endif
    return material_at_lod(materials[h.material], h.uv, h.lod);
}

// What an occlusion ray finds (its weight is the World's light it may let in): 1 for the
// sky, the transmission of the surface it met.
float occlusion_seen(Hit h) {
    return h.kind == HIT_SKY ? 1.0 : material_transmission(materials[h.material]);
}

// The radiance a diffuse gather ray along d brings back from what it met (closest hit): the
// sky, or the surface's emission and lamp light (shadow maps; highlights filtered as the
// roughest lobe, the ray stands for a whole hemisphere), plus the sky through it by its
// transmission (as occlusion_seen). No further bounce: the one-ray gather of the first
// bounce's hits (DIFFUSE_GATHER, shade_hit). A linked emitter's emission counts only where it
// lights ray_receiver_set, as in shade_hit (the pixel's set stands for the surface the ray
// left, as it does for every ray of the pixel).
vec3 gather_light(Hit h, vec3 d) {
    if (h.kind == HIT_SKY) return sky_radiance(d);
    Material hm = hit_material(h, d, 1);
    vec3 h_emission = material_emission_lod(hm, h.uv, h.lod);
#ifdef EMITTER_LINKING
    if (!emission_lights_set(h.material, ray_receiver_set)) h_emission = vec3(0.0);
#endif
#ifdef LIT_CUBE
    if (h.kind == HIT_CUBE) {
        // The lit cube map's light; its texels hold no emission (cube_light_shade.comp.glsl),
        // which the hit adds as the surfaces the BVH finds do below.
        return cube_stored_radiance(h, 0.0) + h_emission;
    }
#endif
    vec3 h_albedo = material_albedo_lod(hm, h.uv, h.lod);
    SpecularSplit hs = specular_split_geometric(hm, h_albedo, d, h.normal, h.geometric);
    return lamp_light_response(hm, h_albedo, h_emission, h.position, d, hs, 1.0)
           + material_transmission(hm) * sky_radiance(d);
}

// What a ray of depth -1 (push_occlusion) adds, times its weight: with DIFFUSE_GATHER (the
// World Light setting Rays) the light it gathers at any distance, otherwise the share of the
// sky it sees within AO Distance.
vec3 occlusion_result(Hit h, vec3 d) {
#ifdef DIFFUSE_GATHER
    return gather_light(h, d);
#else
    return vec3(occlusion_seen(h));
#endif
}

// The light a ray of `ray.depth` brings from the surface h it met (not the sky), added to
// `traced`; spawns its reflected and refracted rays and, at the first bounce, its occlusion
// ray. A cube-map hit is shaded here from the face's G-buffer (normal, material, UV) at the
// reconstructed position, so only the texels rays hit are shaded and textured; reflection
// and refraction are traced from that position (no refractive surface is stored in the
// faces, paper Figure 8: refraction finds none there).
void shade_hit(PendingRay ray, Hit h, inout vec3 traced) {
    Material hm = hit_material(h, ray.dir, ray.depth);
    vec3 h_albedo = material_albedo_lod(hm, h.uv, h.lod);
    vec3 h_emission = material_emission_lod(hm, h.uv, h.lod);
#ifdef EMITTER_LINKING
    // A linked emitter shows in a reflection or refraction only where it lights the surface
    // the ray left (ray_receiver_set), as Cycles links what its indirect rays find; the
    // camera sees it whatever its linking (the deferred shading adds every emission).
    vec3 unlinked_emission = emission_lights_set(h.material, ray_receiver_set) ? vec3(0.0) : h_emission;
    h_emission -= unlinked_emission;
#endif
    SpecularSplit hs = specular_split_sampled(hm, h_albedo, ray.dir, h.normal, h.geometric,
                                              lobe_random(ray.depth));
    // Seen through a rough lobe, a sharp lamp highlight is a firefly: widen it to that
    // lobe's roughness (Cycles' Filter Glossy does the same).
#ifdef LIT_CUBE
    // A cube-map hit's diffuse light (lamps, World, bounces) is the lit cube map's
    // (lit_cube.glsl); its texels hold no emission (cube_light_shade.comp.glsl), so the ray
    // adds h_emission, with a linked emitter's already taken off above where it does not light.
    bool stored = h.kind == HIT_CUBE;
    if (stored) traced += ray.weight * (cube_hit_light(hm, h, ray.dir, hs, ray.blur) + h_emission);
    else traced += ray.weight * lamp_light_response(hm, h_albedo, h_emission, h.position, ray.dir, hs, ray.blur);
#else
    const bool stored = false;
    traced += ray.weight * lamp_light_response(hm, h_albedo, h_emission, h.position, ray.dir, hs, ray.blur);
#endif
    if (ray.depth <= u_max_depth)
        spawn_children(hs, h.position, ray.weight, ray.depth + 1, max(ray.blur, material_roughness(hm)));
#ifdef DIFFUSE_GATHER
    // World Light Rays (passes/diffuse_light/): the first bounce's hits, in the BVH and in
    // the cube map, gather their diffuse light with one cosine ray of unlimited reach (the
    // sky, or the lamp light of the surface it meets), so that a closed room's reflections
    // are as dark as the room; the rough reflections of the sky are left unoccluded.
    if (ray.depth == 1 && hs.diffuse_weight > 0.0) {
        traced += ray.weight * world_light_response(hm, h_albedo, hs, vec3(0.0), 1.0);
        if (stored) return;  // the lit cube map's light holds the World's, occluded and bounced
        vec3 d_gather = cosine_direction(hs.n_facing, hs.g_facing, lobe_random(0x5ca3));
        push_occlusion(offset_origin(h.position, hs.g_facing), d_gather, ray.weight * hs.diffuse_weight * h_albedo,
                       FLOAT_MAX);
        return;
    }
    // A rough metal (material_glossy_gathered) has no diffuse ray to hide the sky from its
    // reflection: one ray along its lobe (hs's sampled direction) of unlimited reach brings
    // what it reflects, the sky or the surfaces that hide it, as at primary pixels.
    if (ray.depth == 1 && !stored && material_glossy_gathered(hm)) {
        push_occlusion(offset_origin(h.position, hs.g_facing), hs.reflect_dir, ray.weight * hs.glossy_local,
                       FLOAT_MAX);
        return;
    }
#endif
    vec3 world = ray.weight * world_light_response(hm, h_albedo, hs, stored ? vec3(0.0) : sky_irradiance(hs.n_facing), 1.0);
    // The World's light at the first bounce's hits near the camera is hidden as at
    // primary pixels: one cosine ray within AO Distance through the BVH (hybrid ambient
    // occlusion, the paper's reference [14]), a fresh direction per sample. Hits in the
    // cube map take the whole sky: one more ray from each of them would be a march
    // through the cube map, which costs the trace far more than these short BVH rays.
    if (ray.depth == 1 && h.kind == HIT_BVH && u_ao_distance > 0.0 && hs.diffuse_weight > 0.0) {
        vec3 d_ao = cosine_direction(hs.n_facing, hs.g_facing, lobe_random(0x5ca3));
        push_occlusion(offset_origin(h.position, hs.g_facing), d_ao, world, u_ao_distance);
    } else {
        traced += world;
    }
}

// Whether the primary pixel spawns secondary rays: its G-buffer normal and material (nm)
// and its material m, with the roughness and metallic its images give there.
bool primary_specular(ivec2 pixel, out vec4 nm, out Material m) {
    nm = texelFetch(u_normal_material, pixel, 0);
    if (nm.w == 0.0) return false;
    m = primary_material(int(abs(nm.w) + 0.5) - 1, pixel);
    return material_is_specular(m);
}

// The position of the primary surface at the pixel (its depth unprojected).
vec3 primary_position(ivec2 pixel) {
    vec2 ndc_xy = (vec2(pixel) + 0.5) / vec2(u_size) * 2.0 - 1.0;
    float depth = texelFetch(u_depth, pixel, 0).r;
    return unproject_primary(ndc_xy, depth * 2.0 - 1.0);
}

// The key of the numbers every bounce of the pixel draws (pixel_key), from its primary
// surface alone: the wave tracer recomputes it per ray instead of queueing it.
// With EMITTER_LINKING it also sets ray_receiver_set, which the waves recompute alike.
uvec3 primary_key(ivec2 pixel) {
#ifdef EMITTER_LINKING
    ray_receiver_set = pixel_receiver_set(pixel);
#endif
    return position_key(primary_position(pixel));
}

// The primary surface at the pixel: its position p, the view direction and the shading
// normal n (nm: its G-buffer normal and material).
void primary_surface(ivec2 pixel, vec4 nm, out vec3 p, out vec3 view_dir, out vec3 n) {
    vec2 ndc_xy = (vec2(pixel) + 0.5) / vec2(u_size) * 2.0 - 1.0;
    vec3 near_point = unproject_primary(ndc_xy, -1.0);
    view_dir = u_orthographic != 0 ? normalize(u_camera_forward)
                                   : normalize(near_point - u_camera_position);
    p = primary_position(pixel);
    n = safe_normalize(nm.xyz, -view_dir);
}

// Spawn the first secondary rays (bounce 1) of the specular primary pixel (material m,
// surface p, view_dir, n); sets pixel_key, the numbers every later bounce of the pixel draws.
void spawn_primary(ivec2 pixel, Material m, vec3 p, vec3 view_dir, vec3 n) {
    vec4 albedo_g = texelFetch(u_albedo, pixel, 0);
    vec3 g = gbuffer_geometric(albedo_g.a, texelFetch(u_emission_scale, pixel, 0).a, n);
    pixel_key = position_key(p);
#ifdef EMITTER_LINKING
    ray_receiver_set = pixel_receiver_set(pixel);
#endif
    SpecularSplit split = specular_split_sampled(m, albedo_g.rgb, view_dir, n, g, lobe_random(0));
    spawn_children(split, p, vec3(1.0), 1, material_roughness(m));
}
