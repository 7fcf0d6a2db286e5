// SPDX-License-Identifier: GPL-3.0-or-later
// The hybrid tracer (paper §3, steps 4 and 5; §3.4): secondary rays of every reflective or
// refractive primary hit, traced recursively through the near-cube BVH and the G-buffer
// cube map, added to the deferred-shaded primary image.
//
// One invocation per pixel runs a depth-first explicit stack of pending rays (weight,
// origin, direction, depth): a megakernel with no per-ray host work. Per ray:
//   * where it starts (§3.4): in the BVH when its origin lies inside the near cube
//     (half-size u_near_half around the camera), otherwise in the cube map; FULL_BVH traces
//     everything in one BVH over the whole scene and a miss is the sky;
//   * in the BVH: closest hit (bvh_traverse.glsl) up to the point where the ray leaves the
//     near cube (grown by the culling overlap), then the cube map from that point;
//   * in the cube map: cube_march.glsl; a hit, the sky, or back into the BVH (z < -1); the
//     march ends where the ray leaves the bounds of all geometry (u_scene_lo/hi, grown by
//     the march's depth bias): nothing lies past them, and sky-bound rays, most of a
//     scene's reflections, no longer walk the faces on to their far planes;
//   * a BVH hit is shaded like the deferred pass (shading.glsl: emission + diffuse with
//     shadow maps) and spawns the reflected ray (mirror lobe tinted by the base colour, plus
//     the Fresnel part of the glass lobe) and the refracted ray (Snell, total internal
//     reflection, Fresnel weight 1 - F, tinted);
//   * a cube-map hit is shaded the same way from the face's G-buffer (stored normal,
//     material and UV, position reconstructed from the face's depth; only hit texels are
//     shaded and textured, never whole faces) and spawns the reflected ray from that position; a refractive cube-map hit is thin
//     (§3.4, Figure 8): its refracted part is the sky seen in the refracted direction,
//     sky(refract(d, n, 1 / ior)) weighted by (1 - F) and the base colour. The same holds
//     for any refractive hit outside the near cube in HYBRID (a primary hit there: its
//     refracted ray would start in the cube map, inside the very object the map stores);
//   * a hit is shaded like the deferred pass (shading.glsl shade_surface: the lamps with
//     shadow maps, the World's irradiance, lamp highlights, too-rough reflections as the
//     prefiltered sky); its reflected and refracted directions come from the GGX lobe,
//     drawn per sample (random.glsl, u_sample) and exact when the roughness is 0;
//   * a ray that would pass max_depth is not traced: it takes the sky in its direction, so
//     glass and mirrors at the depth limit show the environment, not black
//     (tests/whitted_reference.py does the same).
// PROVENANCE mode writes, instead of tracing, blue (0, 0, 1) for specular pixels whose
// first secondary rays start in the BVH, red (1, 0, 0) for those starting in the cube map,
// and grey 0.5 elsewhere (paper Figure 4).
//
// Counters (CounterBuffer, uint[8][COUNTER_DEPTHS], index kind * COUNTER_DEPTHS + depth): rays
// traced, rays that entered the cube map, rays that ended in the sky, rays that went from
// the cube map back into the BVH, rays that ended at a BVH hit, at a cube-map hit, per
// bounce depth; each ray counts at most once per kind. Then the BVH nodes visited and the
// march steps taken by the rays of each depth, summed (tracer.COUNTER_KINDS).
//
// Uniform blocks LightBuffer, ShadowSlotBuffer; storage blocks: MaterialBuffer, the BVH's (bvh_storage.glsl,
//   bvh_traverse.glsl), TriangleNormals (float[9 N], the scene's normal buffer), CounterBuffer
//   (read/write), TriangleUVBuffer (TriangleUV[N]; read only for materials with image
//   textures), TriangleMaterials (int[N]), SkyIrradiance (world_light.glsl); all
//   per-triangle arrays in original triangle order. Image u_color: the primary colour
//   (RGBA32F, read and written). Textures: u_textures (textures.glsl; BVH hits sample it at the
//   interpolated UV, mip level from the ray cone u_pixel_width + u_pixel_spread * distance,
//   widened by the glossy lobes on the ray's path).
//   Cube-map hits sample it the same way at the UV their face texel stores.
//   Samplers: primary u_depth, u_normal_material, u_albedo, u_emission_scale; the cube atlas u_cube_depth,
//   u_cube_normal_material, u_cube_surface, u_cube_geometric, u_cube_hiz; u_shadow_atlas, u_shadow_dynamic; u_sky_env.
// Workgroup 8x8: neighbouring pixels' rays are coherent for the first bounce.
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
#include "bvh_traverse.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430) readonly buffer MaterialBuffer { Material materials[]; };

#include "cube_march.glsl"

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

#include "textures.glsl"
// struct TriangleUV (GPUScene.uv_rows; scene_upload/instance_transform.comp.glsl)   // total: 32 bytes
//   vec4 uv01;       xy = UV of corner 0, zw = UV of corner 1
//   vec4 uv2_scale;  xy = UV of corner 2, z = UV units per metre (sqrt of UV area over
//                    world area; 0 when degenerate), w unused
struct TriangleUV {
    vec4 uv01;
    vec4 uv2_scale;
};
layout(std430) readonly buffer TriangleUVBuffer { TriangleUV tri_uvs[]; };
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
layout(std430) buffer CounterBuffer { uint counters[]; };

layout(rgba32f) uniform image2D u_color;
#ifdef WORLD_LIGHT_PASS
layout(rgba32f) writeonly uniform image2D u_ambient;
#endif
#ifdef DIAGNOSTIC
// The diagnostic views (hybrid_engine/passes/trace/diagnostic_views.py): each pixel's value in r of
// u_diagnostic, its false colour in u_color.
#define DIAG_BOUNCES 1       // the deepest bounce any of the pixel's rays reached
#define DIAG_CUBE_STEPS 2    // march steps of all its rays (cube_march_steps)
#define DIAG_BVH_NODES 3     // BVH nodes all its rays visited (bvh_nodes_visited)
#define DIAG_BOUNCE_PATHS 4  // where its rays of bounce u_diag_bounce ended: 1 BVH, 2 cube map, 4 sky
layout(r32f) writeonly uniform image2D u_diagnostic;
uniform int u_diag_view;
uniform int u_diag_bounce;
uniform float u_diag_scale;    // the value shown in the ramp's last colour
uniform vec3 u_diag_ramp[5];   // colours of 0, 1/4, 1/2, 3/4 and 1 of the scale
uniform vec3 u_diag_paths[4];  // no ray at that bounce, BVH, cube map, sky
uniform vec3 u_diag_untraced;  // pixels that spawn no ray
uint diag_bounces = 0u;
uint diag_paths = 0u;
#endif

uniform sampler2D u_depth;
uniform sampler2D u_normal_material;
uniform sampler2D u_albedo;
uniform sampler2D u_emission_scale;
uniform sampler2D u_surface;         // primary roughness, metallic (gbuffer.frag.glsl)
uniform sampler2D u_cube_surface;    // xy UV, z UV density (cube_map.CubeFaceTargets)
uniform sampler2D u_cube_geometric;  // xy octahedral geometric normal
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
uniform int u_scene_bounded; // 1: u_scene_lo/hi bound all geometry (padded); 0: empty scene
uniform vec3 u_scene_lo;
uniform vec3 u_scene_hi;

#define MODE_HYBRID 0
#define MODE_FULL_BVH 1
#define MODE_PROVENANCE 2

#define MAX_DEPTH_LIMIT 16
#define STACK_SIZE (MAX_DEPTH_LIMIT + 2)
// Segments (BVH <-> cube map hand-overs) one ray may take before it is given the sky.
#define MAX_SEGMENTS 12
// Spawned rays start this far off the surface (relative to the position's magnitude), so
// that neither the BVH nor the cube map finds the surface they leave.
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

// [enter, exit] of the ray with the box [lo, hi]; enter > exit: no overlap.
vec2 box_interval(vec3 o, vec3 d, vec3 lo, vec3 hi) {
    vec3 safe = mix(d, vec3(1e-30), lessThan(abs(d), vec3(1e-30)));
    vec3 inv = 1.0 / safe;
    vec3 t0 = (lo - o) * inv;
    vec3 t1 = (hi - o) * inv;
    vec3 tn = min(t0, t1);
    vec3 tf = max(t0, t1);
    return vec2(max(max(tn.x, tn.y), tn.z), min(min(tf.x, tf.y), tf.z));
}

// [enter, exit] of the ray with the BVH region (the culled cube).
vec2 bvh_region_interval(vec3 o, vec3 d) {
    return box_interval(o, d, u_near_center - vec3(u_bvh_half), u_near_center + vec3(u_bvh_half));
}

vec3 offset_origin(vec3 p, vec3 towards) {
    float scale = RAY_OFFSET_ABSOLUTE + RAY_OFFSET_RELATIVE * max(max(abs(p.x), abs(p.y)), abs(p.z));
    return p + towards * scale;
}

void count(int kind, int depth) {
    atomicAdd(counters[kind * COUNTER_DEPTHS + clamp(depth, 0, COUNTER_DEPTHS - 1)], 1u);
}

// Width in metres of a pixel's ray cone at distance t along a ray from o: the camera-to-
// origin distance plus t is a lower bound of the path length (textures.py). A ray drawn from
// a glossy lobe of roughness `blur` (the roughest on its path) stands for the lobe's spread
// of directions, about 2 alpha radians across (GGX, alpha = roughness^2), which widens its
// cone past its origin: what it meets is textured at the level the lobe would blur it to,
// so one sample of a rough reflection already shows the blurred texture.
float ray_cone_footprint(vec3 o, float t, float blur) {
    return u_pixel_width + u_pixel_spread * (distance(o, u_camera_position) + t) + 2.0 * blur * blur * t;
}

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

// Where the ray leaves the bounds of all geometry (-1: it misses them; CUBE_NO_LIMIT: no
// bounds). Past them neither the BVH nor the cube map holds anything to hit, so the march
// stops there instead of walking the faces on to their far planes. The march takes a hit a
// little behind its surface (the depth bias), so the bounds grow away from the map's centre
// by that much (cube_max_hit_overshoot); a ray behind a thick object past them meets a
// stretch of it, not the object itself.
float scene_exit(vec3 o, vec3 d) {
    if (u_scene_bounded == 0) return CUBE_NO_LIMIT;
    float grow = 1.0 + cube_max_hit_overshoot();
    vec3 lo = u_scene_lo - u_cube_center;
    vec3 hi = u_scene_hi - u_cube_center;
    vec2 span = box_interval(o, d, u_cube_center + min(lo, lo * grow), u_cube_center + max(hi, hi * grow));
    return span.y < max(span.x, 0.0) ? -1.0 : span.y;
}

// Follow one ray through the BVH and the cube map until it hits something or the sky, or
// passes t_max (then it sees the sky); `blur`: the roughest lobe on its path
// (ray_cone_footprint). A depth below 0 marks an occlusion ray: it is left out of the ray
// counts and of the diagnostic views, which show the reflection and refraction rays.
Hit trace_ray(vec3 o, vec3 d, int depth, float blur, float t_max) {
    Hit h;
    h.kind = HIT_SKY;
    h.position = vec3(0.0);
    h.normal = vec3(0.0, 0.0, 1.0);
    h.geometric = h.normal;
    h.material = 0;
    h.uv = vec2(0.0);
    h.lod = 0.0;
    bool reached_cube = false;
    bool reentered = false;
    uint nodes_before = bvh_nodes_visited;
    uint steps_before = cube_march_steps;
    float t;
    int leaf;
    vec2 bary;
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
            if (t0 <= t1 && bvh_closest_leaf(o, d, t0, t1, t, leaf, bary)) {
                h = bvh_hit(o, d, t, leaf, bary, blur);
                break;
            }
            if (full) break;
            // Leave the near cube: continue in the cube map at the exit point.
            t_cur = max(t_cur, t1);
            in_bvh = false;
        } else {
            reached_cube = true;
            CubeMarch cm = cube_march_limited(o, d, t_cur, min(scene_exit(o, d), t_max));
            if (cm.kind == CUBE_HIT) {
                h.kind = HIT_CUBE;
                h.position = cm.position;
                h.normal = safe_normalize(cm.normal, -d);
                vec2 g_oct = texelFetch(u_cube_geometric, cm.texel, 0).xy;
                h.geometric = gbuffer_geometric(g_oct.x, g_oct.y, h.normal);
                h.material = cm.material;
                ivec4 tex = materials[h.material].textures;
                if (max(max(tex.x, tex.y), tex.z) >= 0 || material_has_surface_maps(materials[h.material])) {
                    // The face keeps the texel's UV and UV density (gbuffer.frag.glsl,
                    // CUBE_FACE): textured like a BVH hit, with the same ray cone.
                    vec4 surface = texelFetch(u_cube_surface, cm.texel, 0);
                    h.uv = surface.xy;
                    h.lod = texture_lod(ray_cone_footprint(o, distance(o, cm.position), blur), surface.z);
                }
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
    int slot = clamp(depth, 0, COUNTER_DEPTHS - 1);
    if (bvh_nodes_visited != nodes_before)
        atomicAdd(counters[COUNT_BVH_NODES * COUNTER_DEPTHS + slot], bvh_nodes_visited - nodes_before);
    if (cube_march_steps != steps_before)
        atomicAdd(counters[COUNT_CUBE_STEPS * COUNTER_DEPTHS + slot], cube_march_steps - steps_before);
    return h;
}

// The pending rays of this invocation (file-scope variables are private per invocation).
PendingRay stack[STACK_SIZE];
int stack_size = 0;
// What rays see that find no room on the stack: the sky along their direction.
vec3 past_depth_limit = vec3(0.0);

// Put a ray on the stack (the caller checked that there is room).
void store_ray(vec3 origin, vec3 dir, vec3 weight, int depth, float blur, float reach) {
    stack[stack_size] = PendingRay(origin, dir, weight, depth, blur, reach);
    stack_size += 1;
}

// A ray one bounce past the depth limit (depth u_max_depth + 1) is still traced, through the
// BVH and the cube map, and the surface it meets is shaded without spawning rays: the depth
// limit then shows the environment along the last ray (as Cycles shades the last vertex of a
// path with its lamps and emission), not the sky through every wall. Depth 0 keeps its
// meaning, no secondary rays: there the sky is all a mirror shows.
void push(vec3 origin, vec3 dir, vec3 weight, int depth, float blur) {
    if (!(max(max(weight.r, weight.g), weight.b) > 0.0)) return;
#ifdef NO_DEPTH_LIMIT_RAY  // a measurement switch (benchmarks/picture_cost.py): the sky at once
    if (stack_size >= STACK_SIZE || depth > u_max_depth) {
#else
    if (stack_size >= STACK_SIZE || depth > u_max_depth + min(u_max_depth, 1)) {
#endif
        past_depth_limit += weight * sky_radiance(dir);
        return;
    }
    store_ray(origin, dir, weight, depth, blur, FLOAT_MAX);
}

// An occlusion ray from a hit: `weight` is the World's light that hit takes if it sees the
// sky along dir within `reach` (world_light_response times the path's weight); the ray
// adds it times what it finds there, 1 for the sky, a surface's transmission otherwise.
// It waits on the stack like the reflections: the loop below traces one ray per pixel and
// step, so a pixel's occlusion ray shares a step with its neighbours' rays instead of
// running a traversal of its own while they idle (8 pixels run in lockstep on a CPU
// driver's SIMD lanes, and in a GPU's warps). Room for it is always left: a pixel holds at
// most one, and the reflections' depth-first stack at most max_depth + 2 rays.
void push_occlusion(vec3 origin, vec3 dir, vec3 weight, float reach) {
    if (!(max(max(weight.r, weight.g), weight.b) > 0.0)) return;
    if (stack_size >= STACK_SIZE) {
        past_depth_limit += weight;  // never reached (above): the sky taken as seen
        return;
    }
    store_ray(origin, dir, weight, -1, 1.0, reach);
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
vec2 lobe_random(int depth) {
    return random2(uvec4(pixel_key.x, pixel_key.y ^ pcg_hash(pixel_key.z), uint(u_sample), uint(depth)));
}

// The material of a primary pixel, with the roughness and metallic its images give there.
Material primary_material(int index, ivec2 pixel) {
    Material m = materials[index];
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

#ifdef WORLD_LIGHT_PASS
// The World's light on a diffuse primary pixel (tracer.WorldLightRays): one ray in a
// cosine-distributed direction, traced like a reflection through the BVH and the cube map.
// Escaping, it brings the sky's radiance; meeting a surface, that surface's light (lamps
// with shadows, emission, and the sky's irradiance if a second ray from there escapes: one
// bounce of diffuse light), plus the sky through glass by the glass's transmission. rgb = pi times that radiance (a cosine-
// distributed sample's irradiance estimate), a = the sky's visibility.
void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, u_size))) return;
    vec4 nm = texelFetch(u_normal_material, pixel, 0);
    vec4 ambient = vec4(0.0, 0.0, 0.0, 1.0);
    if (nm.w != 0.0 && material_diffuse(primary_material(int(abs(nm.w) + 0.5) - 1, pixel)) > 0.0) {
        vec2 ndc_xy = (vec2(pixel) + 0.5) / vec2(u_size) * 2.0 - 1.0;
        vec3 p = unproject_primary(ndc_xy, texelFetch(u_depth, pixel, 0).r * 2.0 - 1.0);
        vec3 view_dir = u_orthographic != 0 ? normalize(u_camera_forward) : normalize(p - u_camera_position);
        vec3 n = safe_normalize(nm.xyz, -view_dir);
        vec4 albedo_g = texelFetch(u_albedo, pixel, 0);
        vec3 g = gbuffer_geometric(albedo_g.a, texelFetch(u_emission_scale, pixel, 0).a, n);
        vec3 g_facing = dot(g, view_dir) < 0.0 ? g : -g;
        vec3 n_facing = dot(n, g_facing) >= 0.0 ? n : -n;
        pixel_key = position_key(p);
        vec3 d = cosine_direction(n_facing, g_facing, lobe_random(0x5ca1));
        Hit h = trace_ray(offset_origin(p, g_facing), d, 0, 0.0, FLOAT_MAX);
        if (h.kind == HIT_SKY) {
            ambient = vec4(PI * sky_radiance(d), 1.0);
        } else {
            Material hm = material_at_lod(materials[h.material], h.uv, h.lod);
            vec3 h_albedo = material_albedo_lod(hm, h.uv, h.lod);
            vec3 h_emission = material_emission_lod(hm, h.uv, h.lod);
            SpecularSplit hs = specular_split_geometric(hm, h_albedo, d, h.normal, h.geometric);
            // The surface met sees the sky only where nothing hides it either: a second
            // cosine ray from it decides (an enclosed space's walls lit by the whole sky
            // would bounce far too much light).
            vec3 d2 = cosine_direction(hs.n_facing, hs.g_facing, lobe_random(0x5ca2));
            Hit h2 = trace_ray(offset_origin(h.position, hs.g_facing), d2, 0, 0.0, FLOAT_MAX);
            float seen = h2.kind == HIT_SKY ? 1.0 : material_transmission(materials[h2.material]);
            vec3 bounce = shade_surface(hm, h_albedo, h_emission, h.position, d, hs,
                                        sky_irradiance(hs.n_facing) * seen, seen, 1.0);
            float through = material_transmission(hm);
            ambient = vec4(PI * (bounce + through * sky_radiance(d)), through);
        }
    }
    imageStore(u_ambient, pixel, ambient);
}
#else
#ifdef DIAGNOSTIC
vec3 diag_ramp(float x) {
    float f = clamp(x, 0.0, 1.0) * 4.0;
    int i = min(int(f), 3);
    return mix(u_diag_ramp[i], u_diag_ramp[i + 1], f - float(i));
}

// The pixel's value and false colour for the diagnostic view; `traced`: it spawned rays.
void write_diagnostic(ivec2 pixel, bool traced) {
    float value = 0.0;
    vec3 color = u_diag_untraced;
    if (u_diag_view == DIAG_BOUNCE_PATHS) {
        value = float(diag_paths);
        if (traced) {
            vec3 sum = vec3(0.0);
            float n = 0.0;
            for (int b = 0; b < 3; ++b) {
                if ((diag_paths & (1u << uint(b))) != 0u) { sum += u_diag_paths[b + 1]; n += 1.0; }
            }
            color = n > 0.0 ? sum / n : u_diag_paths[0];
        }
    } else {
        value = float(u_diag_view == DIAG_BOUNCES ? diag_bounces
                      : u_diag_view == DIAG_CUBE_STEPS ? cube_march_steps : bvh_nodes_visited);
        if (traced) color = diag_ramp(value / u_diag_scale);
    }
    imageStore(u_diagnostic, pixel, vec4(value, 0.0, 0.0, 1.0));
    imageStore(u_color, pixel, vec4(color, 1.0));
}
#endif

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, u_size))) return;

    vec4 nm = texelFetch(u_normal_material, pixel, 0);
    Material m;
    bool specular = false;
    int material_index = 0;
    if (nm.w != 0.0) {
        material_index = int(abs(nm.w) + 0.5) - 1;
        m = primary_material(material_index, pixel);
        specular = material_is_specular(m);
    }
    if (!specular) {
        if (u_mode == MODE_PROVENANCE) imageStore(u_color, pixel, vec4(vec3(0.5), 1.0));
#ifdef DIAGNOSTIC
        write_diagnostic(pixel, false);
#endif
        return;  // the deferred-shaded colour stands
    }

    vec2 ndc_xy = (vec2(pixel) + 0.5) / vec2(u_size) * 2.0 - 1.0;
    vec3 near_point = unproject_primary(ndc_xy, -1.0);
    vec3 view_dir = u_orthographic != 0 ? normalize(u_camera_forward)
                                        : normalize(near_point - u_camera_position);
    float depth = texelFetch(u_depth, pixel, 0).r;
    vec3 p = unproject_primary(ndc_xy, depth * 2.0 - 1.0);
    vec4 albedo_g = texelFetch(u_albedo, pixel, 0);
    vec3 albedo = albedo_g.rgb;
    vec3 n = safe_normalize(nm.xyz, -view_dir);

    if (u_mode == MODE_PROVENANCE) {
        vec3 where = inside_near_cube(p) ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0);
        imageStore(u_color, pixel, vec4(where, 1.0));
        return;
    }

    vec3 g = gbuffer_geometric(albedo_g.a, texelFetch(u_emission_scale, pixel, 0).a, n);
    pixel_key = position_key(p);
    SpecularSplit split = specular_split_sampled(m, albedo, view_dir, n, g, lobe_random(0));

    vec3 traced = vec3(0.0);
    spawn_children(split, p, vec3(1.0), 1, material_roughness(m));
    while (stack_size > 0) {
        stack_size -= 1;
        PendingRay ray = stack[stack_size];
        Hit h = trace_ray(ray.origin, ray.dir, ray.depth, ray.blur, ray.reach);
        if (ray.depth < 0) {
            traced += ray.weight * (h.kind == HIT_SKY ? 1.0 : material_transmission(materials[h.material]));
            continue;
        }
#ifdef DIAGNOSTIC
        diag_bounces = max(diag_bounces, uint(ray.depth));
        if (ray.depth == u_diag_bounce)
            diag_paths |= h.kind == HIT_BVH ? 1u : h.kind == HIT_CUBE ? 2u : 4u;
#endif
        if (h.kind == HIT_SKY) {
            traced += ray.weight * sky_radiance(ray.dir);
            continue;
        }
        // A cube-map hit is shaded here from the face's G-buffer (normal, material, UV) at
        // the reconstructed position, so only the texels rays hit are shaded and textured;
        // reflection and refraction are traced from that position (no refractive surface
        // is stored in the faces, paper Figure 8: refraction finds none there).
        Material hm = material_at_lod(materials[h.material], h.uv, h.lod);
        vec3 h_albedo = material_albedo_lod(hm, h.uv, h.lod);
        vec3 h_emission = material_emission_lod(hm, h.uv, h.lod);
        SpecularSplit hs = specular_split_sampled(hm, h_albedo, ray.dir, h.normal, h.geometric,
                                                  lobe_random(ray.depth));
        // Seen through a rough lobe, a sharp lamp highlight is a firefly: widen it to that
        // lobe's roughness (Cycles' Filter Glossy does the same).
        traced += ray.weight * lamp_light_response(hm, h_albedo, h_emission, h.position, ray.dir, hs, ray.blur);
        vec3 world = ray.weight * world_light_response(hm, h_albedo, hs, sky_irradiance(hs.n_facing), 1.0);
        if (ray.depth <= u_max_depth)
            spawn_children(hs, h.position, ray.weight, ray.depth + 1, max(ray.blur, material_roughness(hm)));
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
#ifdef DIAGNOSTIC
    write_diagnostic(pixel, true);
    return;
#endif
    vec4 base = imageLoad(u_color, pixel);
    vec3 color = base.rgb + traced + past_depth_limit;
    if (any(isnan(color)) || any(isinf(color))) color = base.rgb;
    if (any(isnan(color)) || any(isinf(color))) color = vec3(0.0);
    imageStore(u_color, pixel, vec4(color, 1.0));
}
#endif
