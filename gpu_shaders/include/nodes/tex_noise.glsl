// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's Noise Texture node: Perlin's gradient noise (Perlin 2002, "Improving Noise": the
// quintic fade and the 12/16/32-direction gradient sets picked by hash bits) on the integer
// lattice, hashed with Blender's lookup3 (nodes/hash.glsl) so that a cell draws the same
// gradient as in Cycles, summed over octaves in one of Musgrave's fractal forms (Ebert et al.,
// "Texturing and Modeling", ch. 16: fBm, multifractal, hybrid multifractal, ridged
// multifractal, heterogeneous terrain).
//
// The gradient noise is scaled per dimension so that its signed range is about [-1, 1]
// (Blender's factors 0.25, 0.6616, 0.9820, 0.8344 for 1D to 4D), and coordinates repeat every
// 100000 units so that float precision holds far from the origin, as in Blender.
//
// node_tex_noise(dimensions, type, normalize, vector, w, scale, detail, roughness, lacunarity,
//                offset, gain, distortion, out fac, out color)
//   Blender node: "Noise Texture" (ShaderNodeTexNoise).
//   dimensions (noise_dimensions): 1 = '1D', 2 = '2D', 3 = '3D' (default), 4 = '4D'.
//   type (noise_type): 0 = 'FBM' (default), 1 = 'MULTIFRACTAL', 2 = 'HYBRID_MULTIFRACTAL',
//        3 = 'RIDGED_MULTIFRACTAL', 4 = 'HETERO_TERRAIN'.
//   normalize (normalize): 1 = on (default), 0 = off; only 'FBM' reads it, as in Blender.
//   Input sockets (identifier: Blender default):
//     Vector: Generated coordinates when unlinked (the caller supplies them), W: 0.0,
//     Scale: 5.0, Detail: 2.0 (clamped to [0, 15]; a fraction blends in the next octave),
//     Roughness: 0.5 (clamped to >= 0), Lacunarity: 2.0, Offset: 0.0, Gain: 1.0,
//     Distortion: 0.0.
//   Outputs: Fac (the fractal at the point) and Color (Fac, and the same fractal at two
//   points moved by fixed random offsets).
#ifndef HYBRID_NODES_TEX_NOISE_GLSL
#define HYBRID_NODES_TEX_NOISE_GLSL
#include "include/nodes/hash.glsl"

const int NOISE_FBM = 0;
const int NOISE_MULTIFRACTAL = 1;
const int NOISE_HYBRID_MULTIFRACTAL = 2;
const int NOISE_RIDGED_MULTIFRACTAL = 3;
const int NOISE_HETERO_TERRAIN = 4;

// Perlin's quintic: its first and second derivatives vanish at the lattice, so octaves have
// no visible grid creases.
float noise_fade(float t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
vec2 noise_fade(vec2 t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
vec3 noise_fade(vec3 t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
vec4 noise_fade(vec4 t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

float noise_flip(float v, uint bit) { return bit != 0u ? -v : v; }

// Gradient dot offset. 1D: slopes +-1..8 from the low four bits.
float noise_grad(uint h, float x) {
    h &= 15u;
    return noise_flip(float(1u + (h & 7u)) * x, h & 8u);
}
// 2D: eight directions (+-1, +-2) and (+-2, +-1) from the low three bits.
float noise_grad(uint h, vec2 d) {
    h &= 7u;
    float u = h < 4u ? d.x : d.y;
    float v = 2.0 * (h < 4u ? d.y : d.x);
    return noise_flip(u, h & 1u) + noise_flip(v, h & 2u);
}
// 3D: Perlin's twelve cube-edge directions, padded to sixteen.
float noise_grad(uint h, vec3 d) {
    h &= 15u;
    float u = h < 8u ? d.x : d.y;
    float v = h < 4u ? d.y : ((h == 12u || h == 14u) ? d.x : d.z);
    return noise_flip(u, h & 1u) + noise_flip(v, h & 2u);
}
// 4D: the 32 edge directions of the hypercube.
float noise_grad(uint h, vec4 d) {
    h &= 31u;
    float u = h < 24u ? d.x : d.y;
    float v = h < 16u ? d.y : d.z;
    float s = h < 8u ? d.z : d.w;
    return noise_flip(u, h & 1u) + noise_flip(v, h & 2u) + noise_flip(s, h & 4u);
}

float noise_perlin(float p) {
    float fl = floor(p);
    int i = int(fl);
    float f = p - fl;
    return mix(noise_grad(hash_int(i), f), noise_grad(hash_int(i + 1), f - 1.0), noise_fade(f));
}

float noise_perlin(vec2 p) {
    vec2 fl = floor(p);
    ivec2 i = ivec2(fl);
    vec2 f = p - fl;
    vec2 u = noise_fade(f);
    float c00 = noise_grad(hash_int2(i.x, i.y), f);
    float c10 = noise_grad(hash_int2(i.x + 1, i.y), f - vec2(1.0, 0.0));
    float c01 = noise_grad(hash_int2(i.x, i.y + 1), f - vec2(0.0, 1.0));
    float c11 = noise_grad(hash_int2(i.x + 1, i.y + 1), f - vec2(1.0, 1.0));
    return mix(mix(c00, c10, u.x), mix(c01, c11, u.x), u.y);
}

float noise_perlin(vec3 p) {
    vec3 fl = floor(p);
    ivec3 i = ivec3(fl);
    vec3 f = p - fl;
    vec3 u = noise_fade(f);
    float z[2];
    for (int k = 0; k < 2; ++k) {
        float fz = f.z - float(k);
        float c00 = noise_grad(hash_int3(i.x, i.y, i.z + k), vec3(f.x, f.y, fz));
        float c10 = noise_grad(hash_int3(i.x + 1, i.y, i.z + k), vec3(f.x - 1.0, f.y, fz));
        float c01 = noise_grad(hash_int3(i.x, i.y + 1, i.z + k), vec3(f.x, f.y - 1.0, fz));
        float c11 = noise_grad(hash_int3(i.x + 1, i.y + 1, i.z + k), vec3(f.x - 1.0, f.y - 1.0, fz));
        z[k] = mix(mix(c00, c10, u.x), mix(c01, c11, u.x), u.y);
    }
    return mix(z[0], z[1], u.z);
}

float noise_perlin(vec4 p) {
    vec4 fl = floor(p);
    ivec4 i = ivec4(fl);
    vec4 f = p - fl;
    vec4 u = noise_fade(f);
    float zw[4];
    for (int k = 0; k < 4; ++k) {
        int dz = k & 1, dw = k >> 1;
        float fz = f.z - float(dz), fw = f.w - float(dw);
        int z = i.z + dz, w = i.w + dw;
        float c00 = noise_grad(hash_int4(i.x, i.y, z, w), vec4(f.x, f.y, fz, fw));
        float c10 = noise_grad(hash_int4(i.x + 1, i.y, z, w), vec4(f.x - 1.0, f.y, fz, fw));
        float c01 = noise_grad(hash_int4(i.x, i.y + 1, z, w), vec4(f.x, f.y - 1.0, fz, fw));
        float c11 = noise_grad(hash_int4(i.x + 1, i.y + 1, z, w), vec4(f.x - 1.0, f.y - 1.0, fz, fw));
        zw[k] = mix(mix(c00, c10, u.x), mix(c01, c11, u.x), u.y);
    }
    return mix(mix(zw[0], zw[1], u.z), mix(zw[2], zw[3], u.z), u.w);
}

// Coordinates repeat every 100000 units (C's fmod: truncated, so small coordinates pass
// unchanged); from a million on, a half-cell shift keeps them off the lattice, where the
// gradient noise is zero.
float noise_wrap(float p) { return p - 100000.0 * trunc(p / 100000.0) + (abs(p) >= 1000000.0 ? 0.5 : 0.0); }
vec2 noise_wrap(vec2 p) { return vec2(noise_wrap(p.x), noise_wrap(p.y)); }
vec3 noise_wrap(vec3 p) { return vec3(noise_wrap(p.xy), noise_wrap(p.z)); }
vec4 noise_wrap(vec4 p) { return vec4(noise_wrap(p.xy), noise_wrap(p.zw)); }

// Signed noise, about [-1, 1], per dimension.
float noise_signed(float p) { return 0.2500 * noise_perlin(noise_wrap(p)); }
float noise_signed(vec2 p) { return 0.6616 * noise_perlin(noise_wrap(p)); }
float noise_signed(vec3 p) { return 0.9820 * noise_perlin(noise_wrap(p)); }
float noise_signed(vec4 p) { return 0.8344 * noise_perlin(noise_wrap(p)); }
// Unsigned noise, about [0, 1].
float noise_unsigned(float p) { return 0.5 * noise_signed(p) + 0.5; }
float noise_unsigned(vec2 p) { return 0.5 * noise_signed(p) + 0.5; }
float noise_unsigned(vec3 p) { return 0.5 * noise_signed(p) + 0.5; }
float noise_unsigned(vec4 p) { return 0.5 * noise_signed(p) + 0.5; }

// One signed noise of the first `dimensions` components of p: the fractal sums below are
// written once for every dimension.
float noise_signed_dim(int dimensions, vec4 p) {
    if (dimensions == 1) return noise_signed(p.x);
    if (dimensions == 2) return noise_signed(p.xy);
    if (dimensions == 3) return noise_signed(p.xyz);
    return noise_signed(p);
}

// The fractal sums, after Musgrave (Ebert et al., ch. 16), written as one octave loop with
// a single noise call so that a shader holding every type and dimension stays small. Octave i
// has amplitude Roughness^i and frequency Lacunarity^i. A fractional Detail adds one partial
// octave weighted by the fraction (Ridged Multifractal has none, as in Blender).
//   fBm: sum of amplitude * noise; normalized, divided by the sum of amplitudes and mapped to
//     [0, 1], and the partial octave blends the two normalized sums.
//   Multifractal: product of (1 + amplitude * noise): rough areas get rougher.
//   Heterogeneous terrain: octave 0 is Offset + noise, then each octave adds
//     (noise + Offset) * amplitude * value: valleys stay smooth, peaks grow detail.
//   Hybrid multifractal: signal = (noise + Offset) * amplitude, added with a weight that is the
//     previous signal times Gain (capped at 1); octaves stop once the weight is negligible.
//   Ridged multifractal: signal = (Offset - |noise|)^2, sharp ridges where the noise crosses
//     zero; from octave 1 each signal is weighted by the previous one times Gain, in [0, 1].
float noise_fractal(int type, int dims, vec4 p, float detail, float roughness, float lacunarity,
                    float offset, float gain, bool normalize) {
    int octaves = int(detail);
    float frac = type == NOISE_RIDGED_MULTIFRACTAL ? 0.0 : detail - floor(detail);
    int last = frac != 0.0 ? octaves + 1 : octaves;
    float value = type == NOISE_MULTIFRACTAL ? 1.0 : 0.0;
    float amp = 1.0, amp_sum = 0.0, weight = 1.0, signal = 0.0;
    float fbm_partial = 0.0, partial_amp_sum = 1.0;
    for (int i = 0; i <= last; ++i) {
        if (type == NOISE_HYBRID_MULTIFRACTAL && weight <= 0.001) break;
        float n = noise_signed_dim(dims, p);
        float part = i > octaves ? frac : 1.0;  // the partial octave's weight
        if (type == NOISE_FBM) {
            if (i > octaves) {
                fbm_partial = value + n * amp;
                partial_amp_sum = amp_sum + amp;
            } else {
                value += n * amp;
                amp_sum += amp;
            }
        } else if (type == NOISE_MULTIFRACTAL) {
            value *= part * amp * n + 1.0;
        } else if (type == NOISE_HETERO_TERRAIN) {
            value = i == 0 ? offset + n : value + part * (n + offset) * amp * value;
        } else if (type == NOISE_HYBRID_MULTIFRACTAL) {
            weight = min(weight, 1.0);
            signal = (n + offset) * amp;
            value += part * weight * signal;
            weight *= gain * signal;
        } else {  // NOISE_RIDGED_MULTIFRACTAL
            float previous = signal;
            signal = offset - abs(n);
            signal *= signal;
            if (i > 0) {
                signal *= clamp(previous * gain, 0.0, 1.0);
                value += signal * amp;
            } else {
                value = signal;
            }
        }
        amp *= roughness;
        p *= lacunarity;
    }
    if (type != NOISE_FBM) return value;
    float low = normalize ? 0.5 * value / amp_sum + 0.5 : value;
    if (frac == 0.0) return low;
    float high = normalize ? 0.5 * fbm_partial / partial_amp_sum + 0.5 : fbm_partial;
    return mix(low, high, frac);
}

// Blender's fixed random offset number `seed` for a `dims`-dimensional point: each component
// in [100, 200], far enough that the shifted noise is unrelated to the unshifted one.
vec4 noise_random_offset(int dims, float seed) {
    if (dims == 1) return vec4(100.0 + 100.0 * hash_float_to_float(seed), 0.0, 0.0, 0.0);
    vec4 o;
    for (int k = 0; k < 4; ++k) o[k] = 100.0 + 100.0 * hash_vec2_to_float(vec2(seed, float(k)));
    if (dims == 2) return vec4(o.xy, 0.0, 0.0);
    if (dims == 3) return vec4(o.xyz, 0.0);
    return o;
}

// `channels`: how many of Fac (the Color's red), green and blue to compute, 1 or 3; each is a
// fractal sum of its own, so a graph that reads only Fac pays a third (node_output_read).
void node_tex_noise_channels(int dimensions, int type, int normalize, vec3 vector, float w, float scale,
                             float detail, float roughness, float lacunarity, float offset, float gain,
                             float distortion, int channels, out float fac, out vec3 color) {
    int dims = clamp(dimensions, 1, 4);
    // The point's components in the order the dimensions use them: 1D reads W alone.
    vec4 p = dims == 1 ? vec4(w, 0.0, 0.0, 0.0) : vec4(vector, w) * scale;
    if (dims == 1) p.x *= scale;
    if (dims == 2) p.zw = vec2(0.0);
    if (dims == 3) p.w = 0.0;
    detail = clamp(detail, 0.0, 15.0);
    roughness = max(roughness, 0.0);
    bool norm = normalize != 0;

    // Distortion: each component moves by an independent noise, seeds 0 .. dims-1.
    if (distortion != 0.0) {
        vec4 shift = vec4(0.0);
        for (int k = 0; k < dims; ++k)
            shift[k] = noise_signed_dim(dims, p + noise_random_offset(dims, float(k))) * distortion;
        p += shift;
    }
    // Fac, then the Color's green and blue: the same fractal at fixed offsets, seeds dims and
    // dims + 1. One call site in a loop keeps the shader small.
    color = vec3(0.0);
    for (int k = 0; k < min(channels, 3); ++k) {
        vec4 q = k == 0 ? p : p + noise_random_offset(dims, float(dims + k - 1));
        color[k] = noise_fractal(type, dims, q, detail, roughness, lacunarity, offset, gain, norm);
    }
    fac = color.x;
}

void node_tex_noise(int dimensions, int type, int normalize, vec3 vector, float w, float scale,
                    float detail, float roughness, float lacunarity, float offset, float gain,
                    float distortion, out float fac, out vec3 color) {
    node_tex_noise_channels(dimensions, type, normalize, vector, w, scale, detail, roughness, lacunarity,
                            offset, gain, distortion, 3, fac, color);
}

#endif
