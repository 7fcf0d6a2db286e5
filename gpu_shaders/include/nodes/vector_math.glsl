// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's Vector Math node (ShaderNodeVectorMath) as Cycles evaluates it, with the same safe
// rules as the Math node (nodes/math.glsl): a zero divisor, a zero-length normal or projection
// axis gives 0 rather than a NaN.
//
// node_vector_math(op, a, b, c, scale, out vector, out value)
//   inputs (socket identifier, Blender default): a = "Vector" (0,0,0), b = "Vector_001"
//   (0,0,0), c = "Vector_002" (0,0,0) (MULTIPLY_ADD, FACEFORWARD, WRAP), scale = "Scale" 1.0
//   (SCALE, and the index of refraction of REFRACT); outputs "Vector" and "Value": an
//   operation fills the one it produces and leaves the other 0.
//   op codes (Blender's `operation` enum, in its own order):
//     0 ADD          1 SUBTRACT     2 MULTIPLY     3 DIVIDE       4 MULTIPLY_ADD
//     5 CROSS_PRODUCT 6 PROJECT     7 REFLECT      8 REFRACT      9 FACEFORWARD
//    10 DOT_PRODUCT 11 DISTANCE    12 LENGTH      13 SCALE       14 NORMALIZE
//    15 ABSOLUTE    16 POWER       17 SIGN        18 MINIMUM     19 MAXIMUM
//    20 FLOOR       21 CEIL        22 FRACTION    23 MODULO      24 WRAP
//    25 SNAP        26 SINE        27 COSINE      28 TANGENT
//   DOT_PRODUCT, DISTANCE and LENGTH produce Value; every other operation produces Vector.
//   REFLECT and REFRACT take b as the normal (normalised first); FACEFORWARD keeps a where
//   dot(c, b) < 0, else flips it; WRAP reads (value a, max b, min c) per axis.
#ifndef HYBRID_NODES_VECTOR_MATH_GLSL
#define HYBRID_NODES_VECTOR_MATH_GLSL
#include "include/nodes/math.glsl"

vec3 node_safe_divide3(vec3 a, vec3 b) {
    return vec3(node_safe_divide(a.x, b.x), node_safe_divide(a.y, b.y), node_safe_divide(a.z, b.z));
}

vec3 node_safe_normalize(vec3 a) {
    float len = length(a);
    return len != 0.0 ? a / len : vec3(0.0);
}

vec3 node_vector_project(vec3 a, vec3 onto) {
    float len_sq = dot(onto, onto);
    return len_sq != 0.0 ? (dot(a, onto) / len_sq) * onto : vec3(0.0);
}

vec3 node_vector_refract(vec3 incident, vec3 normal, float eta) {
    float d = dot(normal, incident);
    float k = 1.0 - eta * eta * (1.0 - d * d);
    return k < 0.0 ? vec3(0.0) : eta * incident - (eta * d + sqrt(k)) * normal;
}

void node_vector_math(int op, vec3 a, vec3 b, vec3 c, float scale, out vec3 vector, out float value) {
    vector = vec3(0.0);
    value = 0.0;
    switch (op) {
        case 0: vector = a + b; break;
        case 1: vector = a - b; break;
        case 2: vector = a * b; break;
        case 3: vector = node_safe_divide3(a, b); break;
        case 4: vector = a * b + c; break;
        case 5: vector = cross(a, b); break;
        case 6: vector = node_vector_project(a, b); break;
        case 7: {
            vec3 n = node_safe_normalize(b);
            vector = a - 2.0 * dot(n, a) * n;
            break;
        }
        case 8: vector = node_vector_refract(a, node_safe_normalize(b), scale); break;
        case 9: vector = dot(c, b) < 0.0 ? a : -a; break;
        case 10: value = dot(a, b); break;
        case 11: value = length(a - b); break;
        case 12: value = length(a); break;
        case 13: vector = a * scale; break;
        case 14: vector = node_safe_normalize(a); break;
        case 15: vector = abs(a); break;
        case 16: vector = vec3(node_safe_pow(a.x, b.x), node_safe_pow(a.y, b.y), node_safe_pow(a.z, b.z)); break;
        case 17: vector = vec3(node_sign(a.x), node_sign(a.y), node_sign(a.z)); break;
        case 18: vector = min(a, b); break;
        case 19: vector = max(a, b); break;
        case 20: vector = floor(a); break;
        case 21: vector = ceil(a); break;
        case 22: vector = a - floor(a); break;
        case 23: vector = vec3(node_safe_fmod(a.x, b.x), node_safe_fmod(a.y, b.y), node_safe_fmod(a.z, b.z)); break;
        case 24: vector = vec3(node_wrap(a.x, b.x, c.x), node_wrap(a.y, b.y, c.y), node_wrap(a.z, b.z, c.z)); break;
        case 25: vector = floor(node_safe_divide3(a, b)) * b; break;
        case 26: vector = sin(a); break;
        case 27: vector = cos(a); break;
        case 28: vector = tan(a); break;
    }
}

#endif
