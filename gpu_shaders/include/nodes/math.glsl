// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's Math node (ShaderNodeMath) as Cycles evaluates it: every operation is the "safe"
// variant, so a division by zero, the root or logarithm of a negative number and friends give 0
// instead of a NaN or an infinity that would poison the rest of the shading.
//
// node_math(op, a, b, c, use_clamp, out value)
//   inputs (socket identifier, Blender default): a = "Value" 0.5, b = "Value_001" 0.5,
//   c = "Value_002" 0.5 (only MULTIPLY_ADD, COMPARE, SMOOTH_MIN/MAX and WRAP read it);
//   use_clamp: the node's use_clamp (clamp the result to [0, 1]); output "Value".
//   op codes (Blender's `operation` enum, in its own order):
//     0 ADD           1 SUBTRACT      2 MULTIPLY      3 DIVIDE        4 MULTIPLY_ADD
//     5 POWER         6 LOGARITHM     7 SQRT          8 INVERSE_SQRT  9 ABSOLUTE
//    10 EXPONENT     11 MINIMUM      12 MAXIMUM      13 LESS_THAN    14 GREATER_THAN
//    15 SIGN         16 COMPARE      17 SMOOTH_MIN   18 SMOOTH_MAX   19 ROUND
//    20 FLOOR        21 CEIL         22 TRUNC        23 FRACT        24 MODULO
//    25 FLOORED_MODULO 26 WRAP       27 SNAP         28 PINGPONG     29 SINE
//    30 COSINE       31 TANGENT      32 ARCSINE      33 ARCCOSINE    34 ARCTANGENT
//    35 ARCTAN2      36 SINH         37 COSH         38 TANH         39 RADIANS
//    40 DEGREES
//   WRAP reads (value a, max b, min c); LOGARITHM is log of a in base b; POWER is a^b.
//   A negative base with an integer exponent keeps its sign rule ((-2)^3 = -8), with a
//   fractional exponent it gives 0; 0 to a negative power gives 0 (Cycles' GPU rule).
#ifndef HYBRID_NODES_MATH_GLSL
#define HYBRID_NODES_MATH_GLSL

const float NODE_MATH_PI = 3.14159265358979323846;
const float NODE_MATH_FLT_EPSILON = 1.192092896e-07;

float node_safe_divide(float a, float b) {
    return b != 0.0 ? a / b : 0.0;
}

// fmod with C's sign rule (the result has the sign of a); the division is exact where the
// quotient is an integer, so a multiple of b maps to 0 as in C.
float node_safe_fmod(float a, float b) {
    if (b == 0.0) return 0.0;
    return a - b * trunc(a / b);
}

float node_safe_pow(float a, float b) {
    if (a < 0.0 && b != trunc(b)) return 0.0;
    if (b == 0.0) return 1.0;
    if (a < 0.0) {
        float magnitude = pow(-a, b);
        return mod(-b, 2.0) == 0.0 ? magnitude : -magnitude;
    }
    if (a == 0.0) return 0.0;
    return pow(a, b);
}

float node_safe_log(float a, float base) {
    if (a <= 0.0 || base <= 0.0) return 0.0;
    return node_safe_divide(log(a), log(base));
}

float node_sign(float a) {
    return a > 0.0 ? 1.0 : (a < 0.0 ? -1.0 : 0.0);
}

float node_wrap(float value, float maximum, float minimum) {
    float range = maximum - minimum;
    return range != 0.0 ? value - range * floor((value - minimum) / range) : minimum;
}

float node_pingpong(float a, float scale) {
    if (scale == 0.0) return 0.0;
    float t = (a - scale) / (scale * 2.0);
    return abs((t - floor(t)) * scale * 2.0 - scale);
}

float node_smooth_min(float a, float b, float k) {
    if (k == 0.0) return min(a, b);
    float h = max(k - abs(a - b), 0.0) / k;
    return min(a, b) - h * h * h * k * (1.0 / 6.0);
}

// The hyperbolic functions from exponentials, bounded so that large arguments give the
// float limit (tanh -> +-1) rather than inf / inf.
float node_sinh(float a) { return 0.5 * (exp(a) - exp(-a)); }
float node_cosh(float a) { return 0.5 * (exp(a) + exp(-a)); }
float node_tanh(float a) {
    if (abs(a) > 10.0) return sign(a);
    if (abs(a) < 0.004) return a - a * a * a / 3.0;  // the exponentials cancel near 0
    float e = exp(2.0 * a);
    return (e - 1.0) / (e + 1.0);
}

float node_atan2(float y, float x) {
    if (x == 0.0 && y == 0.0) return 0.0;  // atan(y, x) is undefined there in GLSL
    return atan(y, x);
}

float node_math_op(int op, float a, float b, float c) {
    switch (op) {
        case 0: return a + b;
        case 1: return a - b;
        case 2: return a * b;
        case 3: return node_safe_divide(a, b);
        case 4: return a * b + c;
        case 5: return node_safe_pow(a, b);
        case 6: return node_safe_log(a, b);
        case 7: return a > 0.0 ? sqrt(a) : 0.0;
        case 8: return a > 0.0 ? 1.0 / sqrt(a) : 0.0;
        case 9: return abs(a);
        case 10: return exp(a);
        case 11: return min(a, b);
        case 12: return max(a, b);
        case 13: return a < b ? 1.0 : 0.0;
        case 14: return a > b ? 1.0 : 0.0;
        case 15: return node_sign(a);
        case 16: return (a == b || abs(a - b) <= max(c, NODE_MATH_FLT_EPSILON)) ? 1.0 : 0.0;
        case 17: return node_smooth_min(a, b, c);
        case 18: return -node_smooth_min(-a, -b, c);
        case 19: return floor(a + 0.5);
        case 20: return floor(a);
        case 21: return ceil(a);
        case 22: return trunc(a);
        case 23: return a - floor(a);
        case 24: return node_safe_fmod(a, b);
        case 25: return b != 0.0 ? a - floor(a / b) * b : 0.0;
        case 26: return node_wrap(a, b, c);
        case 27: return floor(node_safe_divide(a, b)) * b;
        case 28: return node_pingpong(a, b);
        case 29: return sin(a);
        case 30: return cos(a);
        case 31: return tan(a);
        case 32: return asin(clamp(a, -1.0, 1.0));
        case 33: return acos(clamp(a, -1.0, 1.0));
        case 34: return atan(a);
        case 35: return node_atan2(a, b);
        case 36: return node_sinh(a);
        case 37: return node_cosh(a);
        case 38: return node_tanh(a);
        case 39: return a * (NODE_MATH_PI / 180.0);
        case 40: return a * (180.0 / NODE_MATH_PI);
    }
    return 0.0;
}

void node_math(int op, float a, float b, float c, bool use_clamp, out float value) {
    value = node_math_op(op, a, b, c);
    if (use_clamp) value = clamp(value, 0.0, 1.0);
}

#endif
