// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's Mix node (ShaderNodeMix) for its Float, Vector and Color data types, and the legacy
// MixRGB node (ShaderNodeMixRGB), which is the Color mix with the factor clamped.
//
// node_mix_float(clamp_factor, factor, a, b, out result)
//   Float: "Factor_Float" 0.5, "A_Float" 0.0, "B_Float" 0.0 -> "Result_Float".
// node_mix_vector(clamp_factor, factor, a, b, out result)
//   Vector, factor_mode UNIFORM: "Factor_Float" 0.5, "A_Vector" (0,0,0), "B_Vector" (0,0,0)
//   -> "Result_Vector".
// node_mix_vector_non_uniform(clamp_factor, factor, a, b, out result)
//   Vector, factor_mode NON_UNIFORM: "Factor_Vector" (0.5,0.5,0.5), a component per axis.
// node_mix_color(blend, clamp_factor, clamp_result, factor, a, b, out result)
//   Color: "Factor_Float" 0.5, "A_Color" (0.5,0.5,0.5,1), "B_Color" (0.5,0.5,0.5,1)
//   -> "Result_Color" (alpha is not mixed: the result's alpha is 1, as in Cycles).
//   MixRGB: "Fac" 0.5, "Color1", "Color2" (both (0.5,0.5,0.5,1)) -> "Color", use_clamp is
//   clamp_result and the factor is always clamped.
//   blend codes (Blender's `blend_type` enum, in its own order):
//     0 MIX        1 DARKEN     2 MULTIPLY   3 BURN       4 LIGHTEN    5 SCREEN
//     6 DODGE      7 ADD        8 OVERLAY    9 SOFT_LIGHT 10 LINEAR_LIGHT 11 DIFFERENCE
//    12 EXCLUSION 13 SUBTRACT  14 DIVIDE    15 HUE       16 SATURATION 17 COLOR 18 VALUE
//   The blends are Blender's layer formulas with a the lower layer and b the upper one, mixed
//   in by the factor t (not clamped unless clamp_factor, so t outside [0, 1] extrapolates).
#ifndef HYBRID_NODES_COLOR_MIX_GLSL
#define HYBRID_NODES_COLOR_MIX_GLSL
#include "include/nodes/color_space.glsl"

void node_mix_float(bool clamp_factor, float factor, float a, float b, out float result) {
    float t = clamp_factor ? clamp(factor, 0.0, 1.0) : factor;
    result = a * (1.0 - t) + b * t;
}

void node_mix_vector(bool clamp_factor, float factor, vec3 a, vec3 b, out vec3 result) {
    float t = clamp_factor ? clamp(factor, 0.0, 1.0) : factor;
    result = a * (1.0 - t) + b * t;
}

void node_mix_vector_non_uniform(bool clamp_factor, vec3 factor, vec3 a, vec3 b, out vec3 result) {
    vec3 t = clamp_factor ? clamp(factor, 0.0, 1.0) : factor;
    result = a * (vec3(1.0) - t) + b * t;
}

vec3 node_mix_lerp(vec3 a, vec3 b, float t) {
    return (1.0 - t) * a + t * b;
}

float node_mix_burn_channel(float a, float b, float t) {
    float d = (1.0 - t) + t * b;
    if (d <= 0.0) return 0.0;
    float r = 1.0 - (1.0 - a) / d;
    return r < 0.0 ? 0.0 : (r > 1.0 ? 1.0 : r);
}

float node_mix_dodge_channel(float a, float b, float t) {
    if (a == 0.0) return a;
    float d = 1.0 - t * b;
    if (d <= 0.0) return 1.0;
    float r = a / d;
    return r > 1.0 ? 1.0 : r;
}

float node_mix_overlay_channel(float a, float b, float t) {
    float tm = 1.0 - t;
    return a < 0.5 ? a * (tm + 2.0 * t * b) : 1.0 - (tm + 2.0 * t * (1.0 - b)) * (1.0 - a);
}

float node_mix_divide_channel(float a, float b, float t) {
    return b != 0.0 ? (1.0 - t) * a + t * a / b : a;
}

vec3 node_mix_blend(int blend, float t, vec3 a, vec3 b) {
    float tm = 1.0 - t;
    switch (blend) {
        case 0: return node_mix_lerp(a, b, t);
        case 1: return node_mix_lerp(a, min(a, b), t);
        case 2: return node_mix_lerp(a, a * b, t);
        case 3: return vec3(node_mix_burn_channel(a.r, b.r, t), node_mix_burn_channel(a.g, b.g, t),
                            node_mix_burn_channel(a.b, b.b, t));
        case 4: return node_mix_lerp(a, max(a, b), t);
        case 5: return vec3(1.0) - (vec3(tm) + t * (vec3(1.0) - b)) * (vec3(1.0) - a);
        case 6: return vec3(node_mix_dodge_channel(a.r, b.r, t), node_mix_dodge_channel(a.g, b.g, t),
                            node_mix_dodge_channel(a.b, b.b, t));
        case 7: return node_mix_lerp(a, a + b, t);
        case 8: return vec3(node_mix_overlay_channel(a.r, b.r, t), node_mix_overlay_channel(a.g, b.g, t),
                            node_mix_overlay_channel(a.b, b.b, t));
        case 9: {
            vec3 screen = vec3(1.0) - (vec3(1.0) - b) * (vec3(1.0) - a);
            return tm * a + t * ((vec3(1.0) - a) * b * a + a * screen);
        }
        case 10: return a + t * (2.0 * b - vec3(1.0));
        case 11: return node_mix_lerp(a, abs(a - b), t);
        case 12: return max(node_mix_lerp(a, a + b - 2.0 * a * b, t), vec3(0.0));
        case 13: return node_mix_lerp(a, a - b, t);
        case 14: return vec3(node_mix_divide_channel(a.r, b.r, t), node_mix_divide_channel(a.g, b.g, t),
                             node_mix_divide_channel(a.b, b.b, t));
        case 15: {  // the lower layer with the upper one's hue
            vec3 hsv_b = node_rgb_to_hsv(b);
            if (hsv_b.y == 0.0) return a;
            vec3 hsv = node_rgb_to_hsv(a);
            hsv.x = hsv_b.x;
            return node_mix_lerp(a, node_hsv_to_rgb(hsv), t);
        }
        case 16: {  // a grey lower layer stays grey
            vec3 hsv = node_rgb_to_hsv(a);
            if (hsv.y == 0.0) return a;
            vec3 hsv_b = node_rgb_to_hsv(b);
            hsv.y = tm * hsv.y + t * hsv_b.y;
            return node_hsv_to_rgb(hsv);
        }
        case 17: {  // hue and saturation from the upper layer
            vec3 hsv_b = node_rgb_to_hsv(b);
            if (hsv_b.y == 0.0) return a;
            vec3 hsv = node_rgb_to_hsv(a);
            hsv.xy = hsv_b.xy;
            return node_mix_lerp(a, node_hsv_to_rgb(hsv), t);
        }
        case 18: {
            vec3 hsv = node_rgb_to_hsv(a);
            vec3 hsv_b = node_rgb_to_hsv(b);
            hsv.z = tm * hsv.z + t * hsv_b.z;
            return node_hsv_to_rgb(hsv);
        }
    }
    return a;
}

void node_mix_color(int blend, bool clamp_factor, bool clamp_result, float factor, vec3 a, vec3 b,
                    out vec3 result) {
    float t = clamp_factor ? clamp(factor, 0.0, 1.0) : factor;
    result = node_mix_blend(blend, t, a, b);
    if (clamp_result) result = clamp(result, 0.0, 1.0);
}

#endif
