// Order-preserving float <-> uint mapping, so that atomicMin/atomicMax on uint reduce floats.
//
//   sign=0: set the sign bit      ( +0.0 -> 0x80000000, +inf -> 0xFF800000 )
//   sign=1: flip every bit        ( -0.0 -> 0x7FFFFFFF, -inf -> 0x007FFFFF )
// so unsigned comparison of the results matches the float order of finite values and infinities.
#ifndef HYBRID_FLOAT_ORDER_GLSL
#define HYBRID_FLOAT_ORDER_GLSL

#define FLOAT_MAX 3.4028234663852886e38

uint float_to_ordered(float value) {
    uint bits = floatBitsToUint(value);
    return (bits & 0x80000000u) != 0u ? ~bits : (bits | 0x80000000u);
}

float ordered_to_float(uint key) {
    return uintBitsToFloat((key & 0x80000000u) != 0u ? (key & 0x7FFFFFFFu) : ~key);
}

// True for finite values (false for NaN and +-inf). Tested on the exponent bits: a float
// comparison such as abs(x) <= FLOAT_MAX may be rewritten by the compiler in a way that is
// not NaN-safe (observed on llvmpipe).
bool is_finite(float value) {
    return (floatBitsToUint(value) & 0x7F800000u) != 0x7F800000u;
}

bool all_finite(vec3 value) {
    return is_finite(value.x) && is_finite(value.y) && is_finite(value.z);
}

#endif
