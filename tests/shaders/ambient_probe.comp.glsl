// SPDX-License-Identifier: GPL-3.0-or-later
// A stand-in for the frame's ambient estimate (tests/test_denoise.py): writes into the
// G-buffer's ambient target, for every surface pixel, a known irradiance that belongs to the
// surface point (u_pattern 0: a smooth function of the world position, the same wherever the
// camera is; 1: the constant u_level; 2: stripes across x, u_level wide, alternately 0.2
// and 0.8, edges sharper than a pixel; 3: a linear ramp across x, u_level at x = 0, rising a tenth of it
// per unit), times 1 + u_noise * xi with xi uniform in [-1, 1],
// fresh per pixel and per u_sample: noise whose mean is the irradiance. rgb and a (the sky's
// visibility) get the same value.
#include "random.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f) writeonly uniform image2D u_ambient;
uniform sampler2D u_depth;
uniform sampler2D u_normal_material;
uniform mat4 u_inv_view_proj;
uniform ivec2 u_size;
uniform int u_pattern;
uniform float u_level;
uniform float u_noise;
uniform int u_sample;

float pattern(vec3 p) {
    return 0.5 + 0.3 * sin(1.7 * p.x) * cos(1.3 * p.y) + 0.1 * p.z;
}

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, u_size))) return;
    if (texelFetch(u_normal_material, pixel, 0).w == 0.0) {
        imageStore(u_ambient, pixel, vec4(0.0));
        return;
    }
    vec2 ndc = (vec2(pixel) + 0.5) / vec2(u_size) * 2.0 - 1.0;
    vec4 world = u_inv_view_proj * vec4(ndc, texelFetch(u_depth, pixel, 0).r * 2.0 - 1.0, 1.0);
    vec3 p = world.xyz / world.w;
    float value = u_pattern == 0 ? pattern(p) : u_pattern == 1 ? u_level
                  : u_pattern == 3 ? u_level * (1.0 + 0.1 * p.x) : fract(p.x / (2.0 * u_level)) < 0.5 ? 0.2 : 0.8;
    float xi = random2(uvec4(uvec2(pixel), uint(u_sample), 7u)).x * 2.0 - 1.0;
    value *= 1.0 + u_noise * xi;
    imageStore(u_ambient, pixel, vec4(vec3(value), value));
}
