// 30-bit Morton codes (paper §3.3, after Lauterbach et al. 2009 and Karras 2012).
//
// The quantisation uses only operations that IEEE 754 rounds exactly (add, subtract, multiply
// by a power of two, frexp/ldexp, truncation), so the numpy reference in
// benchmarks/lbvh_reference.py reproduces every code bit for bit on any conforming driver.
// The price: the scale is a power of two, so each axis uses between 512 and 1024 of its 1024
// cells.
//
// Bit layout of a code (x, y, z quantised to 10 bits each):
//   bit 29 28 27 ... 2  1  0
//       x9 y9 z9 ... x0 y0 z0
#ifndef HYBRID_MORTON_GLSL
#define HYBRID_MORTON_GLSL

#include "float_order.glsl"

#define MORTON_BITS_PER_AXIS 10
#define MORTON_CELLS 1024.0
#define MORTON_INVALID 0x3FFFFFFFu  // code of a non-finite centroid: sorts last

// Spread the low 10 bits of v so that two zero bits separate each pair:
// ---- ---- ---- ---- ---- --98 7654 3210  ->  ---- 9--8 --7- -6-- 5--4 --3- -2-- 1--0
uint morton_expand_bits(uint v) {
    v &= 0x3FFu;
    v = (v * 0x00010001u) & 0xFF0000FFu;
    v = (v * 0x00000101u) & 0x0F00F00Fu;
    v = (v * 0x00000011u) & 0xC30C30C3u;
    v = (v * 0x00000005u) & 0x49249249u;
    return v;
}

// Power-of-two scale that maps an extent into [0, 1024): 1024 * 2^-e with extent = m * 2^e,
// m in [0.5, 1). A zero extent gives 1024 (every code 0 on that axis); an infinite one 0.
float morton_axis_scale(float extent) {
    if (!is_finite(extent)) {
        return 0.0;
    }
    int exponent;
    frexp(extent, exponent);
    return ldexp(MORTON_CELLS, -exponent);
}

// centroid3 is the sum of the three vertices ((v0 + v1) + v2); lo the minimum of those sums
// over the set, scale from morton_axis_scale(hi - lo) per axis.
uint morton_code(vec3 centroid3, vec3 lo, vec3 scale) {
    precise vec3 offset = centroid3 - lo;
    precise vec3 cell = offset * scale;
    uvec3 q = uvec3(clamp(cell, vec3(0.0), vec3(MORTON_CELLS - 1.0)));
    return (morton_expand_bits(q.x) << 2) | (morton_expand_bits(q.y) << 1)
        | morton_expand_bits(q.z);
}

#endif
