// SPDX-License-Identifier: GPL-3.0-or-later
// Where a surface point lies in its triangle, for the passes that take a pixel's point to
// the same point of the triangle at another time (surface_motion/surface_motion.comp.glsl,
// film/vector.comp.glsl): the triangle's corners then, weighted as here, place it.
#ifndef HYBRID_TRIANGLE_WEIGHTS_GLSL
#define HYBRID_TRIANGLE_WEIGHTS_GLSL

// The weights of p's projection onto the plane of triangle (a, b, c), by its corners (a's
// first); a's alone where the triangle has no area.
vec3 triangle_weights(vec3 p, vec3 a, vec3 b, vec3 c) {
    vec3 e1 = b - a, e2 = c - a, v = p - a;
    float d00 = dot(e1, e1), d01 = dot(e1, e2), d11 = dot(e2, e2);
    float d20 = dot(v, e1), d21 = dot(v, e2);
    float det = d00 * d11 - d01 * d01;
    if (!(abs(det) > 1e-30 * max(d00 * d11, 1e-30))) return vec3(1.0, 0.0, 0.0);
    float wb = (d11 * d20 - d01 * d21) / det;
    float wc = (d00 * d21 - d01 * d20) / det;
    return vec3(1.0 - wb - wc, wb, wc);
}

#endif
