// SPDX-License-Identifier: GPL-3.0-or-later
// The denoiser's share of the film's mean (hybrid_engine/passes/denoise/denoise.py,
// ``film_share``): the viewport's film averages the frames of a still view, and each frame's
// filtered estimate E_s is itself the temporal step's mean of all the frames so far. The film's
// mean of those means would count the first, noisiest and most filtered frames most (the
// first one 1/1 + 1/2 + ... of its n shares). Instead each sample s of the film adds
//   D_s = (s + 1) E_s - s E_(s-1)
// so that the film's mean of D_0 .. D_s is E_s itself, the best estimate so far. The
// shading is linear in the ambient estimate, so the colour's mean follows.
//
// Bindings: u_estimate (RGBA32F, E_s), u_prev_shown (RGBA32F, E_(s-1)) read; images u_shown
//   (RGBA32F: E_s, the next sample's E_(s-1)) and u_share (RGBA32F: D_s) written.
// Uniforms: u_size, u_sample (s; 0: the film starts over, D_0 = E_0).
// Workgroup 8x8.
layout(local_size_x = 8, local_size_y = 8) in;

uniform sampler2D u_estimate;
uniform sampler2D u_prev_shown;
uniform ivec2 u_size;
uniform float u_sample;

layout(rgba32f) writeonly uniform image2D u_shown;
layout(rgba32f) writeonly uniform image2D u_share;

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, u_size))) return;
    vec4 estimate = texelFetch(u_estimate, pixel, 0);
    vec4 share = u_sample > 0.0 ? (u_sample + 1.0) * estimate - u_sample * texelFetch(u_prev_shown, pixel, 0)
                                : estimate;
    imageStore(u_shown, pixel, estimate);
    imageStore(u_share, pixel, share);
}
