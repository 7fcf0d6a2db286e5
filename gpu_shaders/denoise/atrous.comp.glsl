// SPDX-License-Identifier: GPL-3.0-or-later
// One level of the denoiser's edge-avoiding a-trous wavelet filter (Dammertz et al. 2010;
// Schied et al. 2017, §4.3): a 5x5 B3-spline kernel (1/16, 1/4, 3/8, 1/4, 1/16 per axis) whose
// taps lie u_step pixels apart; the host runs it with steps 1, 2, 4, ... so that a few
// levels reach far at 25 taps each.
//
// Each tap's weight is the kernel's times three edge-stopping terms:
//   - plane: a tap off this pixel's tangent plane (another object, or one behind a
//     silhouette) by more than u_plane_sigma of the distance to the camera weighs little;
//   - normal: max(0, n.n_q)^128 (creases, curved surfaces);
//   - guides: |guide - guide_q| against u_sigma_guide standard deviations of the two pixels'
//     variance (the mean of this pixel's, 3x3-blurred, and the tap's), for each guide: where
//     the estimate is clean the filter keeps its detail (a shadow's edge), where it is noisy
//     it averages. The stop is shared by the two pixels: with this pixel's variance alone a
//     bright outlier (a path that found a lamp-lit wall), noisy around itself, would spread
//     its light into its own mean while its cleaner neighbours kept it out of theirs, and
//     the skewed light of the paths would lose energy.
// The estimate is irradiance, before the albedo multiplies it (deferred_shade.comp.glsl), so
// a texture's edges are not in what is blurred and come back sharp in the shading; mirrors
// and glass are not in it at all (the tracer adds them to the colour).
// The variance is filtered with the squared weights, as the variance of a weighted mean.
//
// With u_linear (the two coarsest levels, whose taps lie 4 and 8 pixels apart;
// hybrid_engine/passes/denoise/denoise.py, LINEAR_LEVELS) the pixel takes the value at its
// own place of the weighted least-squares plane through its taps, instead of their weighted
// mean: local linear regression (as kernel regression corrects a kernel's bias at a
// boundary; the first-order case of Koskela et al. 2019's blockwise regression). Where the stops cut the kernel off on one side (a
// wall beside a partition, a room's corner, the image's border, a shadow's gradient the
// guides have found), the mean of the taps that remain lies off the pixel, and on a gradient
// of the light it is the light of another place: a band of too bright or too dark pixels
// along every edge, as wide as the kernel, and the levels' shifts add up. The plane's slope
// is itself an estimate; it is taken by its Wiener gain, slope^2 / (slope^2 + its variance),
// from the propagated variances, so that where the taps are noisy (a short history, a dim
// wall) the level stays the plain mean and adds no noise. The result is held within the
// taps' range widened by its width on either side (at a border the plane's value lies beyond
// the taps it was fitted to, but not far), and is never negative. A pixel whose history is
// shorter than u_min_length fits no plane: its noise would be mistaken for slope.
//
// Bindings: u_color_in (RGBA32F), u_variance_in (RG32F), u_surface (RGBA32F), u_length (RG32F) read; images u_color_out (RGBA32F), u_variance_out (RG32F)
//   written.
// Workgroup 8x8.
#include "denoise.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

uniform sampler2D u_color_in;
uniform sampler2D u_variance_in;
uniform sampler2D u_surface;
uniform vec3 u_camera_position;
uniform int u_orthographic;
uniform ivec2 u_size;
uniform int u_step;
uniform float u_plane_sigma;
uniform float u_sigma_guide;
uniform int u_linear;          // fit a plane (header)
uniform sampler2D u_length;    // the history's length per pixel (frames, in r)
uniform float u_min_length;    // ... below which no plane is fitted

layout(rgba32f) writeonly uniform image2D u_color_out;
layout(rg32f) writeonly uniform image2D u_variance_out;

// The plane's ridge: a share of the taps' weight added to the slope's normal equations, so
// that taps along one line (a strip of surface one tap wide) fit their mean across it.
const float LINEAR_RIDGE = 0.01;
const float B3[3] = float[3](3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0);

// The variance blurred over 3x3 pixels (a Gaussian's 1-2-1 weights): one pixel's estimate
// is itself noisy, and stopping edges on it would keep noise as if it were detail.
vec2 blurred_variance(ivec2 pixel) {
    vec2 sum = vec2(0.0);
    float weight = 0.0;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = pixel + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, u_size))) continue;
            float w = (dx == 0 ? 2.0 : 1.0) * (dy == 0 ? 2.0 : 1.0);
            sum += w * texelFetch(u_variance_in, q, 0).rg;
            weight += w;
        }
    }
    return sum / weight;
}

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, u_size))) return;
    vec4 center = texelFetch(u_color_in, pixel, 0);
    vec2 center_variance = texelFetch(u_variance_in, pixel, 0).rg;
    vec4 surface = texelFetch(u_surface, pixel, 0);
    if (denoise_is_background(surface)) {
        imageStore(u_color_out, pixel, center);
        imageStore(u_variance_out, pixel, vec4(center_variance, 0.0, 0.0));
        return;
    }
    vec3 p = surface.xyz;
    vec3 n = denoise_surface_normal(surface);
    float scale = u_orthographic != 0 ? 1.0 : distance(p, u_camera_position);
    vec2 guide = denoise_guides(center);
    vec2 variance_p = blurred_variance(pixel);

    // Moments of the plane's fit, over the taps' offsets o (in taps): sums of w o, w o o^T,
    // w o c, and of w^2 o var, w^2 o o^T var for its variance; and the taps' range.
    vec2 s_o = vec2(0.0);
    vec3 s_oo = vec3(0.0);  // xx, yy, xy
    vec4 c_x = vec4(0.0), c_y = vec4(0.0);
    vec2 v_x = vec2(0.0), v_y = vec2(0.0), v_xx = vec2(0.0), v_yy = vec2(0.0), v_xy = vec2(0.0);
    vec4 lo = center, hi = center;
    vec4 sum = center * (B3[0] * B3[0]);
    vec2 sum_variance = center_variance * (B3[0] * B3[0]) * (B3[0] * B3[0]);
    float weight = B3[0] * B3[0];
    // No branch per tap: a tap off the image or on the background weighs 0 (a CPU driver
    // runs a branch's both sides for a vector of pixels anyway, and the loop unrolls).
    for (int dy = -2; dy <= 2; ++dy) {
        for (int dx = -2; dx <= 2; ++dx) {
            ivec2 want = pixel + ivec2(dx, dy) * u_step;
            ivec2 q = clamp(want, ivec2(0), u_size - 1);
            vec4 surface_q = texelFetch(u_surface, q, 0);
            vec4 color_q = texelFetch(u_color_in, q, 0);
            vec2 variance_q = texelFetch(u_variance_in, q, 0).rg;
            vec2 guide_stop = abs(guide - denoise_guides(color_q)) / (u_sigma_guide * sqrt(0.5 * (variance_p + variance_q)) + 1e-4);
            float keep = (want == q && !denoise_is_background(surface_q) && (dx != 0 || dy != 0)) ? 1.0 : 0.0;
            float w = keep * B3[abs(dx)] * B3[abs(dy)]
                      * denoise_normal_weight(dot(n, denoise_surface_normal(surface_q)))
                      * exp(-denoise_plane_offset(p, n, surface_q.xyz, scale) / u_plane_sigma
                            - guide_stop.x - guide_stop.y);
            sum += w * color_q;
            sum_variance += w * w * variance_q;
            weight += w;
            if (u_linear != 0) {
                vec2 o = vec2(dx, dy);
                s_o += w * o;
                s_oo += w * vec3(o.x * o.x, o.y * o.y, o.x * o.y);
                c_x += (w * o.x) * color_q;
                c_y += (w * o.y) * color_q;
                vec2 wv = (w * w) * variance_q;
                v_x += wv * o.x; v_y += wv * o.y;
                v_xx += wv * (o.x * o.x); v_yy += wv * (o.y * o.y); v_xy += wv * (o.x * o.y);
                // The range of the taps that count (a tap the stops all but removed does not).
                if (w > 1e-3 * B3[abs(dx)] * B3[abs(dy)]) { lo = min(lo, color_q); hi = max(hi, color_q); }
            }
        }
    }
    vec4 mean = sum / weight;
    vec2 mean_variance = sum_variance / (weight * weight);
    if (u_linear != 0 && texelFetch(u_length, pixel, 0).r >= u_min_length) {
        // The plane's value at o = 0: the first row of the inverse of the normal equations'
        // matrix [[W, Sx, Sy], [Sx, Sxx, Sxy], [Sy, Sxy, Syy]] times the sums (W a, Sx c, Sy c).
        float xx = s_oo.x + LINEAR_RIDGE * weight, yy = s_oo.y + LINEAR_RIDGE * weight, xy = s_oo.z;
        float m00 = xx * yy - xy * xy, m01 = s_o.y * xy - s_o.x * yy, m02 = s_o.x * xy - s_o.y * xx;
        float det = weight * m00 + s_o.x * m01 + s_o.y * m02;
        vec3 row = vec3(m00, m01, m02) / det;
        vec4 fit = row.x * sum + row.y * c_x + row.z * c_y;
        vec2 fit_variance = row.x * row.x * sum_variance + 2.0 * row.x * row.y * v_x + 2.0 * row.x * row.z * v_y
                            + row.y * row.y * v_xx + 2.0 * row.y * row.z * v_xy + row.z * row.z * v_yy;
        // The correction the slope makes, taken by its Wiener gain: the fit is the mean plus
        // a term uncorrelated with it, whose variance is the difference of theirs.
        vec2 delta = denoise_guides(fit) - denoise_guides(mean);
        vec2 delta_variance = max(fit_variance - mean_variance, vec2(0.0));
        vec2 gain = delta * delta / (delta * delta + delta_variance + 1e-20);
        if (det > 0.0 && !any(isnan(gain))) {
            mean = max(clamp(mean + (fit - mean) * vec4(gain.xxx, gain.y), lo - (hi - lo), hi + (hi - lo)), vec4(0.0));
            mean_variance += gain * gain * delta_variance;
        }
    }
    imageStore(u_color_out, pixel, mean);
    imageStore(u_variance_out, pixel, vec4(mean_variance, 0.0, 0.0));
}
