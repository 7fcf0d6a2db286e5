// SPDX-License-Identifier: GPL-3.0-or-later
// The tangent frame a cube-map texel keeps where node programs run (issue 38): its triangle's
// UV directions dP/du and dP/dv, the frame a BVH hit builds from the triangle's corners
// (trace_ray.glsl bvh_hit), so that a tangent-space Normal Map and a Bump whose Height reads
// the UV shade a cube hit as they shade a BVH hit of the same triangle (paper §3.4: the cube
// map stands in for the BVH beyond the near cube).
//
// Why a texel keeps it rather than the hit reading the corners of the triangle its row names:
// the corners would be one more storage block in every kernel that builds hits, and the wave
// traversal kernel is at the driver's limit of blocks per stage already. Both vectors lie in
// the triangle's plane, so four numbers hold them: their coordinates on two axes around the
// geometric normal, as the faces store that normal (RG16F octahedral): the face's fragment
// stage and the tracer build the same axes from the same two half floats.
#ifndef HYBRID_CUBE_TANGENT_GLSL
#define HYBRID_CUBE_TANGENT_GLSL

#include "octahedral.glsl"

// A triangle's world row in a float channel of the faces (location 1's w): its bits with bit
// 30 set, so that the float is a normal number (no denormal, which GLSL lets a driver flush
// to zero on the way to a float target, and no NaN or infinity), for rows below 2^30. A
// stored 0.0 (no row written) reads as row 0.
float cube_row_encode(int row) {
    return intBitsToFloat(row | 0x40000000);
}

int cube_row_decode(float stored) {
    return floatBitsToInt(stored) & 0x3FFFFFFF;
}

// Largest magnitude a coordinate keeps (a half float's range; a near-degenerate UV mapping
// would otherwise store infinities).
const float CUBE_TANGENT_MAX = 65000.0;

// Two unit axes orthogonal to the normal that octahedral coordinates g_oct decode to (Duff et
// al. 2017, "Building an Orthonormal Basis, Revisited": continuous but at n.z = 0's sign).
void cube_tangent_axes(vec2 g_oct, out vec3 a, out vec3 b) {
    vec3 n = octahedral_decode(clamp(g_oct, -1.0, 1.0));
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float k = -1.0 / (s + n.z);
    float m = n.x * n.y * k;
    a = vec3(1.0 + s * n.x * n.x * k, s * m, -s * n.x);
    b = vec3(m, s + n.y * n.y * k, -n.y);
}

// The texel's stored frame: dp_du, dp_dv on the axes of the geometric normal whose octahedral
// coordinates the face stores as g_oct_stored (the half floats it reads back).
vec4 cube_tangent_encode(vec3 dp_du, vec3 dp_dv, vec2 g_oct_stored) {
    vec3 a, b;
    cube_tangent_axes(g_oct_stored, a, b);
    vec4 c = vec4(dot(dp_du, a), dot(dp_du, b), dot(dp_dv, a), dot(dp_dv, b));
    return any(isnan(c)) ? vec4(0.0) : clamp(c, -CUBE_TANGENT_MAX, CUBE_TANGENT_MAX);
}

// dP/du and dP/dv from a texel's stored frame and its stored geometric normal.
void cube_tangent_decode(vec4 stored, vec2 g_oct_stored, out vec3 dp_du, out vec3 dp_dv) {
    vec3 a, b;
    cube_tangent_axes(g_oct_stored, a, b);
    dp_du = stored.x * a + stored.y * b;
    dp_dv = stored.z * a + stored.w * b;
}

// dP/du and dP/dv of a fragment from the screen derivatives of its position and UV (exact for
// a triangle, over which both are affine in each other); zero where the UVs are degenerate.
void cube_tangent_of_fragment(vec3 dp_dx, vec3 dp_dy, vec2 duv_dx, vec2 duv_dy, out vec3 dp_du, out vec3 dp_dv) {
    float det = duv_dx.x * duv_dy.y - duv_dy.x * duv_dx.y;
    bool ok = abs(det) > 1e-30;
    float inv = ok ? 1.0 / det : 0.0;
    dp_du = (dp_dx * duv_dy.y - dp_dy * duv_dx.y) * inv;
    dp_dv = (dp_dy * duv_dx.x - dp_dx * duv_dy.x) * inv;
}

#endif
