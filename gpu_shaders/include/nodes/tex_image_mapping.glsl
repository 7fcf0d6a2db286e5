// SPDX-License-Identifier: GPL-3.0-or-later
// The coordinate side of Blender's Image Texture node: where on the image a shading point
// looks (projection), what happens outside the image (extension), and which texels a lookup
// reads with which weights (interpolation). The texel fetch itself belongs to the caller (the
// node interpreter owns the image table), so every function here is plain arithmetic on
// coordinates and image sizes; texel (0, 0) is the image's bottom-left pixel, as in Blender.
//
// Blender node "Image Texture" (ShaderNodeTexImage). Settings and their int codes:
//   projection (Blender default FLAT):    0 FLAT, 1 BOX, 2 SPHERE, 3 TUBE
//   extension (Blender default REPEAT):   0 REPEAT, 1 EXTEND, 2 CLIP, 3 MIRROR
//   interpolation (Blender default Linear): 0 Linear, 1 Closest, 2 Cubic, 3 Smart
//     (Cycles renders Smart as Cubic)
//   projection_blend (Box only): a plain float, Blender default 0.0
// Inputs (socket identifier: Blender default):
//   Vector: the active UV map when unlinked (the caller supplies it)
// Outputs Color and Alpha come from the caller's fetch; CLIP outside the image is
// transparent black (0, 0, 0, 0).
//
// node_tex_image_project(projection, vector, normal, blend, out uv0, out uv1, out uv2, out weights)
//   The image coordinates a point reads. FLAT, SPHERE and TUBE give one (uv0, weights (1,0,0)).
//   BOX gives one per cube side, uv0 seen along x, uv1 along y, uv2 along z, and their
//   weights from the object-space shading normal `normal`: one side alone near an axis, and
//   with Blend > 0 a blend of two or three sides where the normal lies between axes. Only
//   sides of non-zero weight need a fetch.
// node_tex_image_closest(extension, uv, size, out texel, out centre) -> inside
//   Closest: the texel holding uv after the extension, and that texel's centre in [0, 1]^2
//   (for a sampler-based fetch). Returns false where CLIP leaves the image (no fetch: the
//   result is transparent black).
// node_tex_image_linear(extension, uv, size, out lo, out hi) -> weights
//   Linear: the 2x2 texels around uv (texel centres at half-integers), as the corner texels
//   lo and hi, already wrapped by the extension, and the weights of the taps
//   (lo.x, lo.y), (hi.x, lo.y), (lo.x, hi.y), (hi.x, hi.y). Under CLIP a tap outside the image
//   has weight 0, so the image fades to transparent black over its border half-texel.
// node_tex_image_cubic(extension, uv, size, out xs, out ys, out wx, out wy)
//   Cubic (and Smart): the 4x4 texels around uv as columns xs and rows ys (wrapped), read
//   with the separable weights wx[i] * wy[j] of the uniform cubic B-spline, as Cycles
//   filters; under CLIP a column or row outside the image has weight 0.
#ifndef HYBRID_NODES_TEX_IMAGE_MAPPING_GLSL
#define HYBRID_NODES_TEX_IMAGE_MAPPING_GLSL

const float IMAGE_MAPPING_PI = 3.14159265358979;

// Sphere and Tube read the vector as a point in the box [0, 1]^3 whose centre is the pole.
vec2 node_tex_image_sphere_uv(vec3 co) {
    vec3 d = (co - vec3(0.5)) * 2.0;
    float l = length(d);
    if (!(l > 0.0)) return vec2(0.0);
    // Longitude from the +y axis, increasing clockwise seen from +z, seam at -y.
    float u = (d.x == 0.0 && d.y == 0.0) ? 0.0 : (1.0 - atan(d.x, d.y) / IMAGE_MAPPING_PI) * 0.5;
    float v = 1.0 - acos(clamp(d.z / l, -1.0, 1.0)) / IMAGE_MAPPING_PI;
    return vec2(u, v);
}

vec2 node_tex_image_tube_uv(vec3 co) {
    vec3 d = (co - vec3(0.5)) * 2.0;
    float r = sqrt(d.x * d.x + d.y * d.y);
    if (!(r > 0.0)) return vec2(0.0);
    return vec2((1.0 - atan(d.x / r, d.y / r) / IMAGE_MAPPING_PI) * 0.5, (d.z + 1.0) * 0.5);
}

// Weight of side a against side b on the edge between their single-side zones: 0.5 on the
// diagonal, reaching 0 and 1 where the single-side zones begin.
float node_tex_image_box_pair(float a, float b, float blend) {
    return clamp((a / (a + b) - 0.5 * (1.0 - blend)) / blend, 0.0, 1.0);
}

// The normal's absolute components normalised to sum 1 are barycentric coordinates on a
// triangle whose corners are the x, y and z sides. Near a corner (within `limit` of it
// against each other side) one side shows; along an edge two blend; in the middle three.
vec3 node_tex_image_box_weights(vec3 normal, float blend) {
    vec3 n = abs(normal);
    n /= n.x + n.y + n.z;
    float limit = 0.5 * (1.0 + blend);
    if (n.x > limit * (n.x + n.y) && n.x > limit * (n.x + n.z)) return vec3(1.0, 0.0, 0.0);
    if (n.y > limit * (n.x + n.y) && n.y > limit * (n.y + n.z)) return vec3(0.0, 1.0, 0.0);
    if (n.z > limit * (n.x + n.z) && n.z > limit * (n.y + n.z)) return vec3(0.0, 0.0, 1.0);
    if (!(blend > 0.0)) return vec3(1.0, 0.0, 0.0);  // no zone claims the point: one side
    float rest = 1.0 - limit;
    if (n.z < rest * (n.x + n.y)) {
        float w = node_tex_image_box_pair(n.x, n.y, blend);
        return vec3(w, 1.0 - w, 0.0);
    }
    if (n.x < rest * (n.y + n.z)) {
        float w = node_tex_image_box_pair(n.y, n.z, blend);
        return vec3(0.0, w, 1.0 - w);
    }
    if (n.y < rest * (n.x + n.z)) {
        float w = node_tex_image_box_pair(n.x, n.z, blend);
        return vec3(w, 0.0, 1.0 - w);
    }
    return ((2.0 - limit) * n + vec3(limit - 1.0)) / (2.0 * limit - 1.0);
}

void node_tex_image_project(int projection, vec3 vector, vec3 normal, float blend,
                            out vec2 uv0, out vec2 uv1, out vec2 uv2, out vec3 weights) {
    if (projection == 1) {
        weights = node_tex_image_box_weights(normal, blend);
        // Each side is mirrored where it faces away, so the image reads the same way round
        // seen from outside the box on either face of an axis.
        uv0 = vec2(normal.x < 0.0 ? 1.0 - vector.y : vector.y, vector.z);
        uv1 = vec2(normal.y > 0.0 ? 1.0 - vector.x : vector.x, vector.z);
        uv2 = vec2(normal.z > 0.0 ? 1.0 - vector.y : vector.y, vector.x);
        return;
    }
    if (projection == 2) uv0 = node_tex_image_sphere_uv(vector);
    else if (projection == 3) uv0 = node_tex_image_tube_uv(vector);
    else uv0 = vector.xy;
    uv1 = uv0;
    uv2 = uv0;
    weights = vec3(1.0, 0.0, 0.0);
}

// One texel index under an extension mode (CLIP clamps here; the caller tests inside-ness).
int node_tex_image_wrap(int extension, int i, int n) {
    if (extension == 0) return i >= 0 ? i % n : n - 1 - (-i - 1) % n;  // % only on i >= 0
    if (extension == 3) {
        int a = i >= 0 ? i : -i - 1;  // texel -1 mirrors texel 0
        int m = a % (2 * n);
        return m < n ? m : 2 * n - 1 - m;
    }
    return clamp(i, 0, n - 1);
}

ivec2 node_tex_image_wrap2(int extension, ivec2 i, ivec2 size) {
    return ivec2(node_tex_image_wrap(extension, i.x, size.x), node_tex_image_wrap(extension, i.y, size.y));
}

bool node_tex_image_closest(int extension, vec2 uv, ivec2 size, out ivec2 texel, out vec2 centre) {
    ivec2 i = ivec2(floor(uv * vec2(size)));
    texel = node_tex_image_wrap2(extension, i, size);
    centre = (vec2(texel) + 0.5) / vec2(size);
    return extension != 2 || (all(greaterThanEqual(i, ivec2(0))) && all(lessThan(i, size)));
}

vec4 node_tex_image_linear(int extension, vec2 uv, ivec2 size, out ivec2 lo, out ivec2 hi) {
    vec2 f = uv * vec2(size) - 0.5;
    vec2 base = floor(f);
    vec2 t = f - base;
    ivec2 i = ivec2(base);
    vec4 weights = vec4((1.0 - t.x) * (1.0 - t.y), t.x * (1.0 - t.y), (1.0 - t.x) * t.y, t.x * t.y);
    if (extension == 2) {
        // A tap outside the image reads transparent black: drop its weight.
        bvec2 lo_in = bvec2(i.x >= 0 && i.x < size.x, i.y >= 0 && i.y < size.y);
        bvec2 hi_in = bvec2(i.x + 1 >= 0 && i.x + 1 < size.x, i.y + 1 >= 0 && i.y + 1 < size.y);
        weights *= vec4(float(lo_in.x && lo_in.y), float(hi_in.x && lo_in.y),
                        float(lo_in.x && hi_in.y), float(hi_in.x && hi_in.y));
    }
    lo = node_tex_image_wrap2(extension, i, size);
    hi = node_tex_image_wrap2(extension, i + 1, size);
    return weights;
}

// Uniform cubic B-spline weights of the four taps around a point t in [0, 1) past the second:
// (1-t)^3/6, (3t^3 - 6t^2 + 4)/6, (-3t^3 + 3t^2 + 3t + 1)/6, t^3/6. They sum to 1 and do not
// pass through the texel values: the filter smooths as well as interpolates.
vec4 node_tex_image_bspline(float t) {
    float s = 1.0 - t, t2 = t * t, t3 = t2 * t;
    return vec4(s * s * s, 3.0 * t3 - 6.0 * t2 + 4.0, -3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0, t3) * (1.0 / 6.0);
}

void node_tex_image_cubic(int extension, vec2 uv, ivec2 size, out ivec4 xs, out ivec4 ys,
                          out vec4 wx, out vec4 wy) {
    vec2 f = uv * vec2(size) - 0.5;
    vec2 base = floor(f);
    vec2 t = f - base;
    ivec4 cx = ivec4(base.x) + ivec4(-1, 0, 1, 2);
    ivec4 cy = ivec4(base.y) + ivec4(-1, 0, 1, 2);
    wx = node_tex_image_bspline(t.x);
    wy = node_tex_image_bspline(t.y);
    if (extension == 2) {
        wx *= vec4(greaterThanEqual(cx, ivec4(0))) * vec4(lessThan(cx, ivec4(size.x)));
        wy *= vec4(greaterThanEqual(cy, ivec4(0))) * vec4(lessThan(cy, ivec4(size.y)));
    }
    for (int k = 0; k < 4; ++k) {
        xs[k] = node_tex_image_wrap(extension, cx[k], size.x);
        ys[k] = node_tex_image_wrap(extension, cy[k], size.y);
    }
}

#endif
