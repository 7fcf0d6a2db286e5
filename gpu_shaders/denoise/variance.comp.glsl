// SPDX-License-Identifier: GPL-3.0-or-later
// The denoiser's variance estimate (Schied et al. 2017, §4.2): how noisy each pixel's two
// guides (include/denoise.glsl) are, which sets how much the wavelet filter that follows may
// blur them. Where the history is long enough (u_min_length frames) it is the temporal
// variance of the moments the temporal step kept; where it is short (a pixel that just
// started over) a few frames say little, so the moments of the 5x5 pixels around it on the
// same surface are taken instead, and the estimate raised by u_min_length / n while they
// are few frames old. Either is then scaled to the variance of the blend of the n frames
// the temporal step averaged (mean_factor), which is what the filter blurs: a long history
// is filtered little, and a still view converges to its unfiltered mean.
//
// Bindings: u_moments (RGBA32F), u_length (RG32F), u_surface (RGBA32F) read; image u_variance (RG32F: the two guides' variances) written.
// Workgroup 8x8.
#include "denoise.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

uniform sampler2D u_moments;
uniform sampler2D u_length;
uniform sampler2D u_surface;
uniform vec3 u_camera_position;
uniform int u_orthographic;
uniform ivec2 u_size;
uniform float u_min_length;
uniform float u_plane_sigma;
uniform float u_alpha_color;  // the temporal blend's floor (reproject.comp.glsl)

layout(rg32f) writeonly uniform image2D u_variance;

vec2 variance_of(vec4 m) {
    return max(m.yw - m.xz * m.xz, vec2(0.0));
}

// The variance of the temporal blend of n frames relative to one frame's: the mean of n
// frames while 1 / n is above the blend's floor, then an exponential average of weight
// alpha, whose variance is alpha / (2 - alpha) of one frame's.
float mean_factor(float n) {
    return n * u_alpha_color <= 1.0 ? 1.0 / max(n, 1.0) : u_alpha_color / (2.0 - u_alpha_color);
}

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, u_size))) return;
    vec4 surface = texelFetch(u_surface, pixel, 0);
    float history = texelFetch(u_length, pixel, 0).r;
    if (denoise_is_background(surface) || history >= u_min_length) {
        imageStore(u_variance, pixel, vec4(variance_of(texelFetch(u_moments, pixel, 0)) * mean_factor(history), 0.0, 0.0));
        return;
    }
    vec3 p = surface.xyz;
    vec3 n = denoise_surface_normal(surface);
    float scale = u_orthographic != 0 ? 1.0 : distance(p, u_camera_position);
    vec4 sum = vec4(0.0);
    float weight = 0.0;
    for (int dy = -2; dy <= 2; ++dy) {
        for (int dx = -2; dx <= 2; ++dx) {
            ivec2 q = pixel + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, u_size))) continue;
            vec4 surface_q = texelFetch(u_surface, q, 0);
            if (denoise_is_background(surface_q)) continue;
            float w = denoise_normal_weight(dot(n, denoise_surface_normal(surface_q)))
                      * exp(-denoise_plane_offset(p, n, surface_q.xyz, scale) / u_plane_sigma);
            sum += w * texelFetch(u_moments, q, 0);
            weight += w;
        }
    }
    vec2 variance = variance_of(sum / max(weight, 1e-6)) * (u_min_length / max(history, 1.0)) * mean_factor(history);
    imageStore(u_variance, pixel, vec4(variance, 0.0, 0.0));
}
