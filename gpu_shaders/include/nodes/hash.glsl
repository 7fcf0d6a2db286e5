// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's hash for procedural textures: Bob Jenkins' lookup3 (public domain), applied to
// the bit patterns of float coordinates. Every procedural node that must match Cycles pixel
// for pixel (White Noise, Noise, Voronoi, Wave's distortion) draws its random numbers from
// here, so the same cell gets the same number as in Blender. Written from lookup3's
// published description: the seed is 0xdeadbeef plus four times the word count plus 13, the
// words are added to a, b, c (a fourth word goes through one mix first), and `final` scrambles.
#ifndef HYBRID_NODES_HASH_GLSL
#define HYBRID_NODES_HASH_GLSL

uint hash_rotate(uint x, int k) { return (x << uint(k)) | (x >> uint(32 - k)); }

void hash_mix(inout uint a, inout uint b, inout uint c) {
    a -= c; a ^= hash_rotate(c, 4);  c += b;
    b -= a; b ^= hash_rotate(a, 6);  a += c;
    c -= b; c ^= hash_rotate(b, 8);  b += a;
    a -= c; a ^= hash_rotate(c, 16); c += b;
    b -= a; b ^= hash_rotate(a, 19); a += c;
    c -= b; c ^= hash_rotate(b, 4);  b += a;
}

void hash_final(inout uint a, inout uint b, inout uint c) {
    c ^= b; c -= hash_rotate(b, 14);
    a ^= c; a -= hash_rotate(c, 11);
    b ^= a; b -= hash_rotate(a, 25);
    c ^= b; c -= hash_rotate(b, 16);
    a ^= c; a -= hash_rotate(c, 4);
    b ^= a; b -= hash_rotate(a, 14);
    c ^= b; c -= hash_rotate(b, 24);
}

uint hash_uint(uint kx) {
    uint a = 0xdeadbeefu + (1u << 2u) + 13u, b = a, c = a;
    a += kx;
    hash_final(a, b, c);
    return c;
}
uint hash_uint2(uint kx, uint ky) {
    uint a = 0xdeadbeefu + (2u << 2u) + 13u, b = a, c = a;
    b += ky; a += kx;
    hash_final(a, b, c);
    return c;
}
uint hash_uint3(uint kx, uint ky, uint kz) {
    uint a = 0xdeadbeefu + (3u << 2u) + 13u, b = a, c = a;
    c += kz; b += ky; a += kx;
    hash_final(a, b, c);
    return c;
}
uint hash_uint4(uint kx, uint ky, uint kz, uint kw) {
    uint a = 0xdeadbeefu + (4u << 2u) + 13u, b = a, c = a;
    a += kx; b += ky; c += kz;
    hash_mix(a, b, c);
    a += kw;
    hash_final(a, b, c);
    return c;
}

// Integer coordinates (lattice cells): the words are the integers' bit patterns.
uint hash_int(int kx) { return hash_uint(uint(kx)); }
uint hash_int2(int kx, int ky) { return hash_uint2(uint(kx), uint(ky)); }
uint hash_int3(int kx, int ky, int kz) { return hash_uint3(uint(kx), uint(ky), uint(kz)); }
uint hash_int4(int kx, int ky, int kz, int kw) { return hash_uint4(uint(kx), uint(ky), uint(kz), uint(kw)); }

// A uniform number in [0, 1] from a hash.
float hash_uint_to_unit(uint k) { return float(k) / 4294967295.0; }

// Float coordinates: the words are the floats' bit patterns.
float hash_float_to_float(float k) { return hash_uint_to_unit(hash_uint(floatBitsToUint(k))); }
float hash_vec2_to_float(vec2 k) { return hash_uint_to_unit(hash_uint2(floatBitsToUint(k.x), floatBitsToUint(k.y))); }
float hash_vec3_to_float(vec3 k) {
    return hash_uint_to_unit(hash_uint3(floatBitsToUint(k.x), floatBitsToUint(k.y), floatBitsToUint(k.z)));
}
float hash_vec4_to_float(vec4 k) {
    return hash_uint_to_unit(hash_uint4(floatBitsToUint(k.x), floatBitsToUint(k.y), floatBitsToUint(k.z),
                                        floatBitsToUint(k.w)));
}

// Three or more numbers from one point: the point extended by constant words 1, 2 (and 3),
// so each component is an independent draw, as Blender's vector hashes do.
vec2 hash_vec2_to_vec2(vec2 k) { return vec2(hash_vec2_to_float(k), hash_vec3_to_float(vec3(k, 1.0))); }
vec3 hash_float_to_vec3(float k) {
    return vec3(hash_float_to_float(k), hash_vec2_to_float(vec2(k, 1.0)), hash_vec2_to_float(vec2(k, 2.0)));
}
vec3 hash_vec2_to_vec3(vec2 k) {
    return vec3(hash_vec2_to_float(k), hash_vec3_to_float(vec3(k, 1.0)), hash_vec3_to_float(vec3(k, 2.0)));
}
vec3 hash_vec3_to_vec3(vec3 k) {
    return vec3(hash_vec3_to_float(k), hash_vec4_to_float(vec4(k, 1.0)), hash_vec4_to_float(vec4(k, 2.0)));
}
vec3 hash_vec4_to_vec3(vec4 k) {
    return vec3(hash_vec4_to_float(k), hash_vec4_to_float(k.zxwy), hash_vec4_to_float(k.wzyx));
}

// Integer lattice cells (Voronoi's feature points and cell colours): Jarzynski and Olano's
// PCG hashes ("Hash Functions for GPU Rendering", JCGT 9(3), 2020) in 2, 3 and 4 words, as
// Blender runs them: on signed integers (so the shift by 16 is arithmetic and the products
// wrap), with the sign bit cleared at the end. Blender scales the 31-bit results by
// 1 / float(0x7FFFFFFF), which rounds to 2^-31, so a component lies in [0, 1].
ivec2 hash_pcg2d_i(ivec2 v) {
    v = v * 1664525 + 1013904223;
    v.x += v.y * 1664525; v.y += v.x * 1664525;
    v ^= v >> 16;
    v.x += v.y * 1664525; v.y += v.x * 1664525;
    return v & 0x7FFFFFFF;
}
ivec3 hash_pcg3d_i(ivec3 v) {
    v = v * 1664525 + 1013904223;
    v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
    v ^= v >> 16;
    v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
    return v & 0x7FFFFFFF;
}
ivec4 hash_pcg4d_i(ivec4 v) {
    v = v * 1664525 + 1013904223;
    v.x += v.y * v.w; v.y += v.z * v.x; v.z += v.x * v.y; v.w += v.y * v.z;
    v ^= v >> 16;
    v.x += v.y * v.w; v.y += v.z * v.x; v.z += v.x * v.y; v.w += v.y * v.z;
    return v & 0x7FFFFFFF;
}
const float HASH_PCG_TO_UNIT = 1.0 / 2147483648.0;
vec2 hash_ivec2_to_vec2(ivec2 k) { return vec2(hash_pcg2d_i(k)) * HASH_PCG_TO_UNIT; }
vec3 hash_ivec3_to_vec3(ivec3 k) { return vec3(hash_pcg3d_i(k)) * HASH_PCG_TO_UNIT; }
vec4 hash_ivec4_to_vec4(ivec4 k) { return vec4(hash_pcg4d_i(k)) * HASH_PCG_TO_UNIT; }
// A 2D cell's colour is the 3D hash of (x, y, 0), as in Blender.
vec3 hash_ivec2_to_vec3(ivec2 k) { return hash_ivec3_to_vec3(ivec3(k, 0)); }

#endif
