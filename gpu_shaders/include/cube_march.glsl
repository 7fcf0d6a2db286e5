// SPDX-License-Identifier: GPL-3.0-or-later
// Ray marching through the G-buffer cube map (paper §3.4, "BVH and Cube Map Traversal").
//
//   CubeMarch cube_march(vec3 o, vec3 d, float t_start)
//   CubeMarch cube_march_limited(vec3 o, vec3 d, float t_start, float t_limit)
//
// follows the world ray r_w(t) = o + d t (|d| = 1) from r_w(t_start) (up to r_w(t_limit):
// past it the ray is given the sky; the tracer passes where the ray leaves the bounds of
// all geometry, grown by cube_max_hit_overshoot) through the six face
// G-buffers of hybrid_engine/passes/cube_map/cube_map.py (atlas, face i at texels [i res, (i+1) res) in x) and
// returns one of
//   CUBE_HIT     a stored surface: its face, atlas texel, position reconstructed from the
//                face's depth, stored normal and material;
//   CUBE_SKY     the ray left a face through its far plane (NDC z > 1), passed t_limit, or
//                never entered a face (an origin beyond the far planes), in sight of the
//                centre there (see "Hidden exits");
//   CUBE_TO_BVH  the ray left a face through its near plane (NDC z < -1): it re-enters the
//                near cube at world parameter t (the caller continues in the BVH).
//
// The map ray. The paper maps p0 = r_w(t_i) and p1 = r_w(t_i + eps) by the face's
// view-projection M_i and marches o_m = p0', d_m = (p1' - p0') / |p1' - p0'| in NDC. We use
// the limit eps -> 0, which is exact and has no cancellation: with clip c = M_i (p0, 1) and
// c' = M_i (d, 0), d NDC/dt is proportional to c'.xyz c.w - c.xyz c'.w.
//
// Sampling. A face is crossed from o_m to the exit of the NDC box [-1, 1]^3 in
// n = n_min + |d_m.z| (n_max - n_min) equal steps: the paper's n = n_min + N.r (n_max - n_min)
// with N.r the z component of the normalised NDC direction.
//
// Hit rule (per sample s_k on texel T, linear view depths along the face axis: r_k of the
// sample, S of the surface stored at T, F the far plane, b a small depth bias):
//   no surface stored at T                     -> no hit
//   r_k <= S + b   (sample in front)           -> no hit
//   r_{k-1} <= S + b  (the step pierced S)     -> hit (any thickness: a ray that crosses the
//                                                 stored depth within one step hits it)
//   r_k <= S + thickness (F - S)               -> hit (the sample lies inside the stretched
//                                                 object: thickness 0 = a sheet with nothing
//                                                 behind it, 1 = solid to the far plane)
//   otherwise                                  -> the ray passes behind the stored surface
// where thickness is the hit material's params.y. A piercing hit is refined by bisection
// between the two samples (CUBE_REFINE_STEPS) so that the texel is the first one behind.
// The bias b = S (CUBE_BIAS_RELATIVE + texel angle * min(slope, CUBE_MAX_SLOPE)) absorbs the
// quantisation of the depth to one value per texel, which otherwise makes a surface seen at
// an angle hit itself. The slope is that of the stored depth itself, the view depth along
// the face's axis, per unit of the face's tangent plane: for the plane with normal n through
// the point seen along w = u right + v up + forward ((u, v) the texel's tangent
// coordinates), |(n.right, n.up)| / |n.w|. It is not the tangent of the angle between n and
// the line of sight: off a face's centre the axial depth of a surface facing the centre
// still changes across a texel (by u / (1 + u^2) of it at v = 0), and with that tangent the
// rays a tessellated mirror ball reflects back where it faces the camera hit the ball
// itself (a ring of dashes around its centre of reflection; tests/test_cube_map.py).
//
// Back layer (CUBE_BACK_LAYER, cube_map.py). Where T holds a front face and the texel
// res rows above it a back face of the same material, seen from behind at depth K > S (the
// far side of the same closed object), the stretch S + thickness (F - S) is replaced by
// K - b_K (b_K the bias at the back face): the object ends there. A ray that reaches the
// object from behind (crossing K, or entering T nearer K than S) hits the back layer's
// texel: the hidden side, with its own normal, material and UV. A compile-time switch, not a
// uniform: its code, even switched off, slows the marches on llvmpipe (it adds to the loops'
// register pressure), so without it the shaders hold none of it.
//
// Hierarchical march (settings.cube_march HIERARCHICAL, the default). The same rule made
// continuous: the ray is followed through every texel T of the face it crosses, entering T
// at depth r_in and leaving at r_out, and hits T when its depth range [lo, hi] there reaches
// into T's hit interval (A, B]:
//   A = S + b                                  (b: the bias above, at T's centre)
//   B = max(A, S + thickness (F - S))
//   hit  <=>  hi > A  and  lo <= B
// (a ray crossing A within T pierces the surface whatever the thickness; thickness 0 is a
// sheet). The hit point is where the ray enters (A, B] inside T. Instead of sampling, the
// march walks a min/max pyramid of the intervals (u_cube_hiz, built by
// cube_map/cube_hiz_base.comp.glsl and cube_hiz_reduce.comp.glsl: level 0 holds (A, B) as NDC
// depths, level L the (min A, max B) of 2^L x 2^L texels): a cell whose interval the ray's
// depth range over the cell misses is skipped whole and the walk climbs a level; a cell it
// may hit is descended into. Every texel the ray crosses is accounted for, so unlike the
// sampled march no thin surface is stepped over, and an empty or unreachable region costs
// one fetch per pyramid cell instead of n samples. Depths compare in NDC, where the map
// ray's depth is linear in its parameter (perspective maps lines to lines).
//
// Hidden exits (CUBE_HIDDEN_EXIT, settings.cube_hidden_exit; beyond the paper, which gives
// every such ray the sky). A ray that leaves the map (through a far plane, or past t_limit,
// where it leaves the bounds of all geometry) at a point hidden from the centre -- behind
// the surface stored at that point's texel -- ran through space the map knows nothing
// about. The paper takes that space as empty and the ray sees the sky. It is mostly not
// empty: such a ray has gone under a floor, behind a board seen from above, under or behind
// an object, where the surface it really meets is hidden from the camera. Instead it hits
// the stored surface at its exit texel: the visible surface that covers the hidden point, so
// the nearest thing to what hides there that the map holds. "Behind" means past the start A
// of the texel's hit interval, not past its raw depth: a ray reflected off the top of an
// object leaves the bounds a little way above it, at points just behind the object's
// outline, within the depth bias that keeps any ray from hitting the surface it leaves;
// compared with the raw depth such rays hit the object (a dark dash on a mirror ball,
// tests/test_cube_map.py). It helps most with the back layer, whose rays pass behind
// objects instead of stopping at their stretch. It errs where a ray passes behind an object
// and leaves the scene still hidden by it (a camera below the top of the scene, a ray
// going up past the far side of a tall object): such a ray shows the object, not the sky.
//
// Hidden sides (CUBE_HIDDEN_SIDE; beyond the paper). A hit where the ray entered its texel
// already past A, without piercing A inside it (and not on the back layer), is flagged
// `hidden`: the ray may have passed beside the stored surface's silhouette into the space
// the centre cannot see behind it, and met the stretch there rather than the surface; or
// it met a surface seen at an angle, whose depth steps towards the ray from texel to texel.
// trace_ray.glsl tells the two apart from where the ray meets the texel's plane
// (cube_hidden_side). Only the hierarchical march flags hits. The diffuse light's kernel
// alone is compiled with it (diffuse_light.py, HYBRID): the stretch stands in for what hides
// behind a surface, right for a mirror's reflection of a solid object, but a diffuse path
// that passes over a partition to the lamp behind it takes the partition's camera-facing,
// shadowed side for the lit walls beyond.
//
// Surface footprints (CUBE_FOOTPRINT; beyond the paper). A texel stores one depth, that of
// the surface at its centre, and the hit rule holds it over the whole texel, within the
// bias. A surface seen edge-on -- a board frame's side wall receding from the centre --
// changes its depth across one texel by more than the bias, so a ray crossing it away from
// the texel's centre passes in front of A in every texel it crosses, and sees the sky
// through a wall one or two texels wide. With this rule the level-0 test follows the plane
// of the stored surface (its geometric normal, u_cube_geometric) across the texel: the hit
// interval at NDC point (x, y) of texel T is (A(x, y), B] with
//   A(x, y) = min(P(x, y) + e, A)
// where P is the plane through the stored point and e = S CUBE_BIAS_RELATIVE +
// CUBE_FOOTPRINT_BIAS (b - S CUBE_BIAS_RELATIVE), a share of the bias. Planes map to planes
// in NDC, so P is affine in (x, y); the ray's depth being linear in its parameter, where it
// gets behind P or A inside T is the first root of two linear functions. A(x, y) never lies
// past A: the plane only brings the surface nearer where it comes towards the ray (extended
// behind A, the tangent plane at a piece's outline would be a sheet stopping the rays that
// pass behind the piece). A ray that enters T already behind P but in front of A hits only
// if it was in front of P where it entered the face (its origin, in the first face) or, for
// the diffuse paths (CUBE_FOOTPRINT_OTHER_MATERIAL), leaves a surface of another material
// (cube_origin_material, which the caller sets): a ray leaving a curved surface starts
// behind its neighbours' tangent planes and would stop on its own surface, whereas one from
// the floor beside a frame passes under the frame's top, which the centre sees from above,
// without crossing its plane in sight. The mirror and glass rays keep the first condition
// alone: a reflection that leaves a piece beside another of its material passes behind the
// other's outline, where the tangent plane seen nearly edge-on would stop it short, and in
// Chess they part from FULL_BVH's least so (docs/BENCHMARKS.md, "Surface footprints for the
// mirror and glass rays"). The march walks a
// second pyramid (u_cube_footprint, built with the first: the least A(x, y) over each
// texel's square, and B), so that no cell whose plane comes nearer than A is skipped;
// u_cube_planes (float16) holds each texel's NDC slopes of P and A less the least A(x, y)
// (P + e at the centre is the least A(x, y) plus what the slopes reach over half a texel).
// The slope of P is capped at CUBE_FOOTPRINT_MAX_SLOPE (the depth change
// across a texel, in texel angles at its depth): a surface exactly edge-on has no finite
// plane in the map. Only the hierarchical march follows the planes. The diffuse light's
// kernel (diffuse_light.py) and the tracer's (trace/tracer.py) are compiled with it in
// HYBRID: a diffuse path that escapes through a wall takes the sky, and a mirror shows the
// sky through the walls of a board frame it reflects.
//
// Face switching (paper Figure 3). A ray starts in the FIRST face (order +X, -X, +Y, -Y, +Z,
// -Z) whose frustum contains its start point, and keeps that face for as long as it stays in
// the face's frustum (the 90.2-degree faces overlap, and being inside the overlap does not
// switch). On an x/y exit the exit point is carried into the other faces by the precomputed
// matrices M_j M_i^-1 (u_face_to_face) and the first face containing it is picked. A line
// leaves a convex frustum only once, so a ray never returns to a face it has left; the
// number of switches is bounded by CUBE_MAX_FACE_SWITCHES anyway (then: sky).
//
// Needs, declared by the including shader: `Material materials[]` (scene_layout.glsl).
// Uniforms: u_cube_depth, u_cube_normal_material (the atlas), u_face_view_proj[6],
// u_face_inv_view_proj[6], u_face_to_face[36] (index i * 6 + j), u_cube_center, u_cube_near,
// u_cube_far, u_cube_res, u_n_min, u_n_max; the pyramid u_cube_hiz (faces u_cube_hiz_res
// texels apart at level 0, a power of two >= u_cube_res) and u_cube_hiz_levels.
// Host defines (cube_map.CubeMapPass.march_defines): CUBE_SAMPLED (1: the sampled march;
// default 0: the hierarchical one), CUBE_BACK_LAYER (1: the atlas holds the back layer in
// its second row of faces; default 0); CUBE_HIDDEN_EXIT (1: the hidden-exit rule above;
// default 0). The march is a define, like the layer, for the same reason: the other march's
// code, even never run, slows the loops on llvmpipe. The including shader's define:
// CUBE_HIDDEN_SIDE (1: flag hidden sides, above; default 0); CUBE_FOOTPRINT (1: the surface
// footprints, above, with the samplers u_cube_footprint and u_cube_planes; default 0);
// CUBE_FOOTPRINT_OTHER_MATERIAL (with CUBE_FOOTPRINT; 1, the default: a ray entering behind a
// plane also hits where it leaves another material, cube_origin_material; 0: the tracer's
// rays, which do not carry the surface they leave).
#ifndef HYBRID_CUBE_MARCH_GLSL
#define HYBRID_CUBE_MARCH_GLSL

uniform sampler2D u_cube_depth;
uniform sampler2D u_cube_normal_material;
uniform mat4 u_face_view_proj[6];
uniform mat4 u_face_inv_view_proj[6];
uniform mat4 u_face_to_face[36];
uniform vec3 u_cube_center;
uniform float u_cube_near;
uniform float u_cube_far;
uniform int u_cube_res;
uniform int u_n_min;
uniform int u_n_max;
uniform sampler2D u_cube_hiz;
uniform int u_cube_hiz_res;
uniform int u_cube_hiz_levels;
#ifndef CUBE_SAMPLED
#define CUBE_SAMPLED 0
#endif
#ifndef CUBE_BACK_LAYER
#define CUBE_BACK_LAYER 0
#endif
#ifndef CUBE_HIDDEN_EXIT
#define CUBE_HIDDEN_EXIT 0
#endif
#ifndef CUBE_HIDDEN_SIDE
#define CUBE_HIDDEN_SIDE 0
#endif
#ifndef CUBE_FOOTPRINT
#define CUBE_FOOTPRINT 0
#endif
#ifndef CUBE_FOOTPRINT_OTHER_MATERIAL
#define CUBE_FOOTPRINT_OTHER_MATERIAL 1
#endif
#if CUBE_FOOTPRINT
uniform sampler2D u_cube_footprint;
uniform sampler2D u_cube_planes;
#if CUBE_FOOTPRINT_OTHER_MATERIAL
// The material of the surface the ray being traced leaves (-1: none), which its caller sets.
int cube_origin_material = -1;
#endif
#endif
#if CUBE_FOOTPRINT || defined(CUBE_FOOTPRINT_BUILD)
// The share of the depth bias that the footprints keep in front of the plane, and the
// steepest plane they follow (see "Surface footprints"). Chess, one sample against
// FULL_BVH (docs/BENCHMARKS.md, Chess with the traced light): the smaller the share, the
// fewer paths escape through edge-on walls and the more stop short on the outlines of
// curved pieces; a quarter measured best, an eighth or a half worse.
const float CUBE_FOOTPRINT_BIAS = 0.25;
const float CUBE_FOOTPRINT_MAX_SLOPE = 8.0;

// How far a plane of NDC slopes `slope` comes nearer than at its texel's centre, over the
// texel's square (half a texel is 1 / u_cube_res in NDC).
float cube_footprint_reach(vec2 slope) {
    return (abs(slope.x) + abs(slope.y)) / float(u_cube_res);
}
#endif

#define CUBE_SKY 0
#define CUBE_HIT 1
#define CUBE_TO_BVH 2

#define CUBE_MAX_FACE_SWITCHES 8
// cube_march_limited's t_limit meaning "no limit".
#define CUBE_NO_LIMIT 1e30
#define CUBE_REFINE_STEPS 6
// Fetches one face's hierarchical march may take before the ray is given the sky. A walk
// needs at most (levels + 1) fetches per texel crossed; real rays take a few dozen.
#define CUBE_HIZ_MAX_STEPS 4096
// Hit interval of an empty texel: nothing to hit at any depth.
#define CUBE_HIZ_EMPTY vec2(2.0, -2.0)
// A point on a face's frustum boundary belongs to it (relative NDC tolerance).
const float CUBE_CONTAINS_EPS = 1e-5;
// Depth bias: float32 depth rounding, plus the depth change across one texel of a surface
// seen at an angle (tan of the incidence angle, capped for surfaces seen edge-on).
const float CUBE_BIAS_RELATIVE = 1e-4;
const float CUBE_MAX_SLOPE = 8.0;
// Half the angular width of a face: tan(90.2 deg / 2).
const float CUBE_TAN_HALF_FOV = 1.0034970;

struct CubeMarch {
    int kind;        // CUBE_SKY, CUBE_HIT, CUBE_TO_BVH
    int face;        // face of the hit / of the exit
    ivec2 texel;     // atlas texel of the hit
    vec3 position;   // hit: reconstructed world position; TO_BVH: the re-entry point
    vec3 normal;     // hit: stored world normal (as modelled, unit)
    int material;    // hit: material index
    float t;         // TO_BVH: world ray parameter of the re-entry point
    int switches;    // face switches taken
#if CUBE_HIDDEN_SIDE
    bool hidden;     // hit: entered its texel behind A (see "Hidden sides")
#endif
};

// The face of atlas column x for faces `res` texels wide: x / res, in float arithmetic
// because a CPU driver has no vector integer division and divides lane by lane, and the
// pyramid's base pass divides once for every texel. Exact: x + 0.5 lies at least 0.5 / res
// from a multiple of res, far more than the rounding of a float division of numbers below
// 2^24.
// Steps the marches of this invocation took so far: pyramid cells visited (hierarchical
// march) or samples taken (sampled march; the bisection of a hit not counted). Diagnostics:
// the tracer's march-step view and counters, the probe's output.
uint cube_march_steps = 0u;
#if CUBE_HIDDEN_SIDE
// The last hierarchical hit entered its texel behind A (see "Hidden sides").
bool cube_entered_behind = false;
#endif

int cube_face_of_column(int x, int res) {
    return int((float(x) + 0.5) / float(res));
}

float cube_linear_depth(float z_ndc) {
    float n = u_cube_near;
    float f = u_cube_far;
    return 2.0 * f * n / max((f + n) - clamp(z_ndc, -1.0, 1.0) * (f - n), 1e-30);
}

bool cube_face_contains(vec4 clip) {
    return clip.w > 0.0 && all(lessThanEqual(abs(clip.xyz), vec3(clip.w * (1.0 + CUBE_CONTAINS_EPS))));
}

// How far outside the face's NDC box a clip point lies (0 inside; huge behind the camera).
float cube_face_violation(vec4 clip) {
    if (!(clip.w > 0.0)) return 1e30;
    vec3 ndc = abs(clip.xyz / clip.w);
    return max(max(ndc.x, ndc.y), ndc.z) - 1.0;
}

vec3 cube_unproject(int face, vec3 ndc) {
    vec4 w = u_face_inv_view_proj[face] * vec4(ndc, 1.0);
    return w.xyz / w.w;
}

ivec2 cube_texel(int face, vec2 ndc_xy) {
    ivec2 local = ivec2(floor((ndc_xy * 0.5 + 0.5) * float(u_cube_res)));
    return ivec2(face * u_cube_res, 0) + clamp(local, ivec2(0), ivec2(u_cube_res - 1));
}

// NDC depth of linear view depth r (the inverse of cube_linear_depth).
float cube_ndc_depth(float r) {
    float n = u_cube_near;
    float f = u_cube_far;
    return ((f + n) - 2.0 * f * n / max(r, 1e-30)) / (f - n);
}

// The depth bias b of a stored surface at linear depth `surface`, seen at NDC point `ndc` of
// `face`, with unit normal `normal`: one texel of its axial depth's slope (see the header).
float cube_depth_bias(int face, vec3 ndc, float surface, vec3 normal) {
    // The face's axes are the rows of its view-projection: x and y scaled by the focal
    // length, w the forward axis (w = the view depth).
    mat4 m = u_face_view_proj[face];
    vec3 right = normalize(vec3(m[0][0], m[1][0], m[2][0]));
    vec3 up = normalize(vec3(m[0][1], m[1][1], m[2][1]));
    vec3 forward = vec3(m[0][3], m[1][3], m[2][3]);
    vec2 uv = ndc.xy * CUBE_TAN_HALF_FOV;
    float facing = abs(dot(normal, uv.x * right + uv.y * up + forward));
    float lateral = length(vec2(dot(normal, right), dot(normal, up)));
    float slope = lateral < facing * CUBE_MAX_SLOPE ? lateral / facing : CUBE_MAX_SLOPE;
    float texel_angle = 2.0 * CUBE_TAN_HALF_FOV / float(u_cube_res);
    return surface * (CUBE_BIAS_RELATIVE + texel_angle * slope);
}

// How far past its surface a hit may lie, relative to the surface's depth: a ray is taken to
// hit where it reaches A = S + b (b at most S (bias + texel angle x max slope)), up to a
// texel diagonal to the side. A caller that clips rays to the bounds of the geometry scales
// them about u_cube_center by 1 + this, so that no such hit is cut off.
float cube_max_hit_overshoot() {
    float texel_angle = 2.0 * CUBE_TAN_HALF_FOV / float(u_cube_res);
    return CUBE_BIAS_RELATIVE + texel_angle * (CUBE_MAX_SLOPE + 1.5);
}

// NDC xy of the centre of atlas texel `atlas_texel` on `face`.
vec2 cube_texel_center(ivec2 atlas_texel, int face) {
    vec2 local = vec2(atlas_texel - ivec2(face * u_cube_res, 0)) + 0.5;
    return local / float(u_cube_res) * 2.0 - 1.0;
}

// Whether front-layer atlas texel `atlas_texel` of `face` (normal/material `nm`, linear depth
// `surface`) has a back-layer surface (CUBE_BACK_LAYER): a front face with a back face of
// the same material behind it, the two sides of one closed object (along a line of sight
// the nearest front face of a closed solid is followed by its own back face). Then
// `far_side` is that back face's linear depth less its own bias, so that a ray leaving that
// face does not hit it.
bool cube_back_surface(ivec2 atlas_texel, int face, vec4 nm, float surface, out float far_side) {
    far_side = surface;
#if CUBE_BACK_LAYER
    if (nm.w > 0.0) {
        ivec2 back_texel = atlas_texel + ivec2(0, u_cube_res);
        vec4 back_nm = texelFetch(u_cube_normal_material, back_texel, 0);
        if (back_nm.w == -nm.w) {
            float back_z = texelFetch(u_cube_depth, back_texel, 0).r * 2.0 - 1.0;
            float k = cube_linear_depth(back_z);
            if (k > surface) {
                vec3 ndc = vec3(cube_texel_center(atlas_texel, face), back_z);
                far_side = k - cube_depth_bias(face, ndc, k, normalize(back_nm.xyz));
                return true;
            }
        }
    }
#endif
    return false;
}

// The hit interval (A, B] of front-layer atlas texel `atlas_texel` as linear depths (see the
// header), whose stored normal/material `nm` (w != 0) and NDC depth `stored_z` the caller
// fetched. `back` says whether B is the texel's back-layer surface (CUBE_BACK_LAYER)
// rather than the thickness rule's stretch: its atlas texel is atlas_texel + (0, res).
vec2 cube_texel_interval(ivec2 atlas_texel, vec4 nm, float stored_z, out bool back) {
    int face = cube_face_of_column(atlas_texel.x, u_cube_res);
    vec3 ndc = vec3(cube_texel_center(atlas_texel, face), stored_z);
    float surface = cube_linear_depth(stored_z);
    float a = surface + cube_depth_bias(face, ndc, surface, normalize(nm.xyz));
    // The ray hits a closed object where it is inside it: from A to its back layer's surface.
    float far_side;
    back = cube_back_surface(atlas_texel, face, nm, surface, far_side);
    if (back) return vec2(a, max(a, far_side));
    int material = int(abs(nm.w) + 0.5) - 1;
    float thickness = clamp(materials[material].params.y, 0.0, 1.0);
    return vec2(a, max(a, surface + thickness * (u_cube_far - surface)));
}

// The hit interval (A, B] of an atlas texel as NDC depths (see the header), or
// CUBE_HIZ_EMPTY where no surface is stored. Level 0 of the pyramid.
vec2 cube_hit_interval(ivec2 atlas_texel) {
    vec4 nm = texelFetch(u_cube_normal_material, atlas_texel, 0);
    if (nm.w == 0.0) return CUBE_HIZ_EMPTY;
    float stored_z = texelFetch(u_cube_depth, atlas_texel, 0).r * 2.0 - 1.0;
    bool back;
    vec2 ab = cube_texel_interval(atlas_texel, nm, stored_z, back);
    return vec2(cube_ndc_depth(ab.x), cube_ndc_depth(ab.y));
}

// The atlas texel that a ray hitting front-layer texel `front_texel` meets: its back layer
// when the ray comes `from_behind` and the texel has a back-layer surface (see
// cube_texel_interval), otherwise the texel itself.
ivec2 cube_layer_hit(ivec2 front_texel, bool from_behind) {
#if CUBE_BACK_LAYER
    if (!from_behind) return front_texel;
    vec4 nm = texelFetch(u_cube_normal_material, front_texel, 0);
    float surface = cube_linear_depth(texelFetch(u_cube_depth, front_texel, 0).r * 2.0 - 1.0);
    int face = cube_face_of_column(front_texel.x, u_cube_res);
    float far_side;  // unused here: only whether there is a back-layer surface
    bool back = cube_back_surface(front_texel, face, nm, surface, far_side);
    return back ? front_texel + ivec2(0, u_cube_res) : front_texel;
#else
    return front_texel;
#endif
}

#if CUBE_FOOTPRINT
// The level-0 test of the surface footprints (see the header) on texel `cell` of `face`, for
// the map ray a + dm t over [t0, t1] inside it, whose level-0 footprint is `footprint` (the
// least A(x, y), B): whether the ray enters (A(x, y), B] there, `t_hit` where it does and
// `from_behind` whether it comes from behind B (the back layer's side). g: the ray's depth
// less P + e, h: less A.
bool cube_footprint_hit(int face, ivec2 cell, vec3 a, vec3 dm, float t0, float t1, vec2 footprint,
                        out float t_hit, out bool from_behind) {
    float b_far = footprint.y;
    vec3 stored = texelFetch(u_cube_planes, ivec2(face * u_cube_hiz_res, 0) + cell, 0).rgb;
    vec3 plane = vec3(footprint.x + cube_footprint_reach(stored.xy), stored.xy);
    float a_const = footprint.x + stored.z;
    vec2 centre = (vec2(cell) + 0.5) / float(u_cube_res) * 2.0 - 1.0;
    vec3 p0 = a + dm * t0;
    vec3 p1 = a + dm * t1;
    float g0 = p0.z - (plane.x + dot(plane.yz, p0.xy - centre));
    float g1 = p1.z - (plane.x + dot(plane.yz, p1.xy - centre));
    float h0 = p0.z - a_const;
    float h1 = p1.z - a_const;
    // Behind the plane at entry counts only for a ray that was in front of it where it
    // entered this face (its origin, in the first face), or (the diffuse paths) that leaves
    // another material: a ray leaving a curved surface starts behind its neighbours' tangent
    // planes, whereas one from the floor beside a board's frame passes under the frame's
    // top, seen from above, without crossing the plane in sight.
    bool behind = h0 > 0.0;
    if (!behind && g0 > 0.0) {
        float ga = a.z - (plane.x + dot(plane.yz, a.xy - centre));
        behind = ga <= 0.0;
#if CUBE_FOOTPRINT_OTHER_MATERIAL
        float material = texelFetch(u_cube_normal_material, ivec2(face * u_cube_res, 0) + cell, 0).w;
        behind = behind || int(abs(material) + 0.5) - 1 != cube_origin_material;
#endif
    }
    t_hit = t0;
    // Entering nearer B than A(x, y): the ray meets the far side (the back layer) first.
    float a0 = min(a_const, p0.z - g0);
    from_behind = behind && p0.z - a0 > b_far - p0.z;
#if CUBE_HIDDEN_SIDE
    cube_entered_behind = behind;
#endif
    if (behind) {
        if (p0.z <= b_far) return true;  // entered inside the interval
        // Entered behind B: a hit where the falling depth reaches B (B >= A(x, y)).
        if (!(p1.z <= b_far)) return false;
        t_hit = clamp(t0 + (b_far - p0.z) / dm.z, t0, t1);
        return true;
    }
    // In front of A at entry: where the ray crosses the plane or A.
    float t_root = t1 + 1.0;
    if (g0 <= 0.0 && g1 > 0.0) t_root = t0 + (t1 - t0) * (g0 / (g0 - g1));
    if (h1 > 0.0) t_root = min(t_root, t0 + (t1 - t0) * (h0 / (h0 - h1)));
    t_hit = min(t_root, t1);
    return t_root <= t1;
}
#endif

// The hierarchical march of one face (see the header) along the map ray a + dm t,
// t in [0, t_exit]. On a hit returns true with the atlas texel and the NDC xy where the ray
// enters the texel's hit interval.
bool cube_march_face_hierarchical(int face, vec3 a, vec3 dm, float t_exit,
                                  out ivec2 hit_texel, out vec2 hit_xy) {
    hit_texel = ivec2(-1);
    hit_xy = vec2(0.0);
    float res = float(u_cube_res);
    // Texel coordinates along the ray: u(t) = u0 + du t.
    vec2 u0 = (a.xy * 0.5 + 0.5) * res;
    vec2 du = dm.xy * (0.5 * res);
    bvec2 moving = greaterThan(abs(du), vec2(1e-30));
    vec2 inv_du = 1.0 / mix(vec2(1.0), du, moving);
    ivec2 positive = ivec2(greaterThan(du, vec2(0.0)));
    ivec2 cell = clamp(ivec2(floor(u0)), ivec2(0), ivec2(u_cube_res - 1));  // level-0 texel
    int top = u_cube_hiz_levels - 1;
    int level = 0;
    float t = 0.0;
    bool found = false;
    bool hit_from_behind = false;
    for (int step = 0; step < CUBE_HIZ_MAX_STEPS; ++step) {
        cube_march_steps += 1u;
        int size = 1 << level;
        ivec2 c = cell >> level;
        vec2 t_bound = mix(vec2(1e30), (vec2((c + positive) * size) - u0) * inv_du, moving);
        float t_end = min(min(t_bound.x, t_bound.y), t_exit);
#if CUBE_FOOTPRINT
        vec2 ab = texelFetch(u_cube_footprint, ivec2(face * (u_cube_hiz_res >> level), 0) + c, level).rg;
#else
        vec2 ab = texelFetch(u_cube_hiz, ivec2(face * (u_cube_hiz_res >> level), 0) + c, level).rg;
#endif
        float z0 = a.z + dm.z * t;
        float z1 = a.z + dm.z * t_end;
#if CUBE_FOOTPRINT
        bool may_hit = max(z0, z1) > ab.x && min(z0, z1) <= ab.y;
        if (may_hit && level > 0) {
            level -= 1;  // the cell may hold a hit: look at its children
            continue;
        }
        float t_hit;
        bool from_behind;
        if (may_hit && cube_footprint_hit(face, cell, a, dm, t, t_end, ab, t_hit, from_behind)) {
            hit_texel = ivec2(face * u_cube_res, 0) + cell;
            hit_xy = a.xy + dm.xy * t_hit;
            hit_from_behind = from_behind;
            found = true;
            break;
        }
#else
        if (max(z0, z1) > ab.x && min(z0, z1) <= ab.y) {
            if (level > 0) {
                level -= 1;  // the cell may hold a hit: look at its children
                continue;
            }
            float t_hit = t;
            // Entering nearer B than A: the ray meets the far side (the back layer) first.
            bool from_behind = z0 - ab.x > ab.y - z0;
            if (!(z0 > ab.x && z0 <= ab.y)) {
                // Entered the texel in front of A (or behind B): where the depth crosses it.
                float target = z0 <= ab.x ? ab.x : ab.y;
                t_hit = clamp(t + (target - z0) / dm.z, t, t_end);
            }
            hit_texel = ivec2(face * u_cube_res, 0) + cell;
            hit_xy = a.xy + dm.xy * t_hit;
            hit_from_behind = from_behind;
#if CUBE_HIDDEN_SIDE
            cube_entered_behind = z0 > ab.x;
#endif
            found = true;
            break;
        }
#endif
        if (t_end >= t_exit) return false;
        // Step into the neighbouring cell of this level; the coordinate that does not step
        // follows the ray, kept inside the cell's span.
        t = t_end;
        ivec2 stepped = c * size - 1 + positive * (size + 1);  // (c + 1) size or c size - 1
        ivec2 followed = clamp(ivec2(floor(u0 + du * t)), c * size, c * size + size - 1);
        cell.x = t_bound.x <= t_bound.y ? stepped.x : followed.x;
        cell.y = t_bound.y <= t_bound.x ? stepped.y : followed.y;
        if (any(lessThan(cell, ivec2(0))) || any(greaterThanEqual(cell, ivec2(u_cube_res)))) return false;
        level = min(level + 1, top);
    }
    // The back layer's choice once, after the loop (out of the loop's registers).
    if (found) hit_texel = cube_layer_hit(hit_texel, hit_from_behind);
#if CUBE_HIDDEN_SIDE && CUBE_BACK_LAYER
    // A ray that met the back layer met the far side the map holds: no hidden side.
    if (found && hit_texel.y >= u_cube_res) cube_entered_behind = false;
#endif
    return found;
}

// The hit test of one sample (see the header). prev_lin: linear depth of the previous sample.
// `piercing` says that the step crossed the surface it hit (A from in front, or the back
// layer's B from behind); on a hit `texel`, `nm` and `stored_z` are those of the surface
// met (the back layer's for a ray from behind).
bool cube_sample_hits(int face, vec3 s, float prev_lin, out ivec2 texel, out vec4 nm,
                      out float stored_z, out bool piercing) {
    texel = cube_texel(face, s.xy);
    nm = texelFetch(u_cube_normal_material, texel, 0);
    piercing = false;
    stored_z = 1.0;
    if (nm.w == 0.0) return false;
    stored_z = texelFetch(u_cube_depth, texel, 0).r * 2.0 - 1.0;
    float r = cube_linear_depth(s.z);
    bool back;
    vec2 ab = cube_texel_interval(texel, nm, stored_z, back);
    if (back && prev_lin > ab.y && r <= ab.y) {
        piercing = true;  // came from behind through the far side: the back layer's surface
        texel += ivec2(0, u_cube_res);
        nm = texelFetch(u_cube_normal_material, texel, 0);
        stored_z = texelFetch(u_cube_depth, texel, 0).r * 2.0 - 1.0;
        return true;
    }
    if (r <= ab.x) return false;
    if (prev_lin <= ab.x) {
        piercing = true;
        return true;
    }
    return r <= ab.y;
}

// Makes `res` a hit of the ray o + d t on atlas texel `texel` of `face`, whose stored
// normal/material is `nm`, at NDC point `ndc` (xy where the ray met it, z the stored depth).
void cube_set_hit(inout CubeMarch res, int face, ivec2 texel, vec4 nm, vec3 ndc, vec3 o, vec3 d) {
    res.kind = CUBE_HIT;
    res.texel = texel;
    res.position = cube_unproject(face, ndc);
    res.normal = normalize(nm.xyz);
    res.material = int(abs(nm.w) + 0.5) - 1;
    res.t = dot(res.position - o, d);
}

// The hidden-exit rule (see the header): a ray leaving `face` at NDC point `e` behind the
// surface stored at its texel (past A) hits that surface; makes `res` that hit and returns
// true then.
bool cube_hidden_exit(int face, vec3 e, vec3 o, vec3 d, inout CubeMarch res) {
    ivec2 texel = cube_texel(face, e.xy);
    vec4 nm;
    float stored_z;
#if CUBE_SAMPLED
    nm = texelFetch(u_cube_normal_material, texel, 0);
    if (nm.w == 0.0) return false;  // nothing stored: the point is in sight, the sky
    stored_z = texelFetch(u_cube_depth, texel, 0).r * 2.0 - 1.0;
    bool back;
    vec2 ab = cube_texel_interval(texel, nm, stored_z, back);
    if (!(cube_linear_depth(e.z) > ab.x)) return false;
#else
    // A as the pyramid's level 0 holds it, in NDC (an empty texel's compares greater than
    // any point): one fetch instead of the interval's.
    ivec2 local = texel - ivec2(face * u_cube_res, 0);
    float a = texelFetch(u_cube_hiz, ivec2(face * u_cube_hiz_res, 0) + local, 0).r;
    if (!(e.z > a)) return false;
    nm = texelFetch(u_cube_normal_material, texel, 0);
    stored_z = texelFetch(u_cube_depth, texel, 0).r * 2.0 - 1.0;
#endif
    cube_set_hit(res, face, texel, nm, vec3(e.xy, stored_z), o, d);
    return true;
}

CubeMarch cube_march_limited(vec3 o, vec3 d, float t_start, float t_limit) {
    CubeMarch res;
    res.kind = CUBE_SKY;
    res.face = -1;
    res.texel = ivec2(-1);
    res.position = vec3(0.0);
    res.normal = vec3(0.0, 0.0, 1.0);
    res.material = 0;
    res.t = t_start;
    res.switches = 0;
#if CUBE_HIDDEN_SIDE
    res.hidden = false;
#endif

    if (!(t_start < t_limit)) return res;  // nothing left to march: the sky

    // The first face whose frustum contains the start point.
    vec3 q = o + d * t_start;
    int face = -1;
    vec4 clip = vec4(0.0);
    for (int i = 0; i < 6; ++i) {
        vec4 c = u_face_view_proj[i] * vec4(q, 1.0);
        if (cube_face_contains(c)) {
            face = i;
            clip = c;
            break;
        }
    }
    if (face < 0) return res;  // beyond every far plane: only the sky is left

    for (int sw = 0; sw <= CUBE_MAX_FACE_SWITCHES; ++sw) {
        res.face = face;
        // The map ray o_m + d_m t in this face's NDC.
        vec4 clip_dir = u_face_view_proj[face] * vec4(d, 0.0);
        vec3 a = clamp(clip.xyz / clip.w, vec3(-1.0), vec3(1.0));
        vec3 dm_raw = clip_dir.xyz * clip.w - clip.xyz * clip_dir.w;
        float dm_len2 = dot(dm_raw, dm_raw);
        if (!(dm_len2 > 0.0) || isinf(dm_len2)) return res;  // degenerate: give up to the sky
        vec3 dm = dm_raw * inversesqrt(dm_len2);

        // Exit of the NDC box.
        vec3 bound = mix(vec3(-1.0), vec3(1.0), greaterThan(dm, vec3(0.0)));
        vec3 safe = mix(dm, vec3(1e-30), lessThan(abs(dm), vec3(1e-30)));
        vec3 t_axes = mix((bound - a) / safe, vec3(1e30), lessThan(abs(dm), vec3(1e-30)));
        int axis = t_axes.x <= t_axes.y ? (t_axes.x <= t_axes.z ? 0 : 2) : (t_axes.y <= t_axes.z ? 1 : 2);
        float t_exit = max(t_axes[axis], 0.0);
        // The world limit in map units: r_w(t_limit) projects onto the map ray (a line
        // maps to a line while w > 0, and w, linear in t, is positive at both ends).
        bool limited = false;
        if (t_limit < CUBE_NO_LIMIT) {
            vec4 lc = u_face_view_proj[face] * vec4(o + d * t_limit, 1.0);
            if (lc.w > 0.0) {
                float s_limit = dot(lc.xyz / lc.w - a, dm);
                if (s_limit < t_exit) {
                    t_exit = max(s_limit, 0.0);
                    limited = true;
                }
            }
        }

#if !CUBE_SAMPLED
        ivec2 texel;
        vec2 hit_xy;
        if (cube_march_face_hierarchical(face, a, dm, t_exit, texel, hit_xy)) {
            vec4 nm = texelFetch(u_cube_normal_material, texel, 0);
            float stored_z = texelFetch(u_cube_depth, texel, 0).r * 2.0 - 1.0;
            cube_set_hit(res, face, texel, nm, vec3(hit_xy, stored_z), o, d);
#if CUBE_HIDDEN_SIDE
            res.hidden = cube_entered_behind;
#endif
            return res;
        }
#else
        {
            // March (n samples, the paper's sampling rate).
            int n = max(1, int(float(u_n_min) + abs(dm.z) * float(u_n_max - u_n_min) + 0.5));
            float prev_lin = cube_linear_depth(a.z);
            float t_prev = 0.0;
            for (int k = 1; k <= n; ++k) {
                cube_march_steps += 1u;
                float t_k = t_exit * float(k) / float(n);
                vec3 s = a + dm * t_k;
                ivec2 texel;
                vec4 nm;
                float stored_z;
                bool piercing;
                if (cube_sample_hits(face, s, prev_lin, texel, nm, stored_z, piercing)) {
                    vec3 hit_s = s;
                    if (piercing) {
                        // Bisect between the last sample in front and this one.
                        float lo = t_prev;
                        float hi = t_k;
                        float lo_lin = prev_lin;
                        for (int r = 0; r < CUBE_REFINE_STEPS; ++r) {
                            float mid = 0.5 * (lo + hi);
                            vec3 sm = a + dm * mid;
                            ivec2 texel_m;
                            vec4 nm_m;
                            float z_m;
                            bool p_m;
                            if (cube_sample_hits(face, sm, lo_lin, texel_m, nm_m, z_m, p_m)) {
                                hi = mid;
                                hit_s = sm;
                                texel = texel_m;
                                nm = nm_m;
                                stored_z = z_m;
                            } else {
                                lo = mid;
                                lo_lin = cube_linear_depth(sm.z);
                            }
                        }
                    }
                    cube_set_hit(res, face, texel, nm, vec3(hit_s.xy, stored_z), o, d);
                    return res;
                }
                prev_lin = cube_linear_depth(s.z);
                t_prev = t_k;
            }
        }
#endif

        vec3 e = a + dm * t_exit;
        bool leaves = limited || (axis == 2 && dm.z > 0.0);
#if CUBE_HIDDEN_EXIT
        if (leaves && cube_hidden_exit(face, e, o, d, res)) return res;
#endif
        if (leaves) return res;  // past the limit or the far plane: nothing more to hit, the sky
        if (axis == 2) {
            res.kind = CUBE_TO_BVH;      // near plane: back into the near cube
            res.position = cube_unproject(face, e);
            res.t = dot(res.position - o, d);
            return res;
        }
        // x/y exit: the first other face that contains the exit point.
        int next = -1;
        vec4 next_clip = vec4(0.0);
        float best = 1e30;
        for (int j = 0; j < 6; ++j) {
            if (j == face) continue;
            vec4 c = u_face_to_face[face * 6 + j] * vec4(e, 1.0);
            if (cube_face_contains(c)) {
                next = j;
                next_clip = c;
                break;
            }
            float v = cube_face_violation(c);
            if (v < best) {  // fallback for a point that rounding put outside every face
                best = v;
                next = j;
                next_clip = c;
            }
        }
        if (next < 0 || !(next_clip.w > 0.0)) return res;
        face = next;
        clip = next_clip;
        res.switches += 1;
    }
    return res;  // too many switches: the sky
}

CubeMarch cube_march(vec3 o, vec3 d, float t_start) {
    return cube_march_limited(o, d, t_start, CUBE_NO_LIMIT);
}

#endif
