// SPDX-License-Identifier: GPL-3.0-or-later
// The running mean of a view's samples (frame/accumulation.py), on the GPU: the frame's
// colour is added into a float32 sum with Kahan's compensation, so that the mean of many
// samples keeps float32's precision as a float64 sum would (the compensation carries the
// low bits each addition drops), and the mean is written for the read-back.
//
// u_restart: this is the view's first sample; the sum starts from it.
// Bindings: images u_color (the frame's colour, read), u_sum and u_compensation (the
// running state, read and written), u_mean (written), all RGBA32F, u_size texels.
layout(local_size_x = 8, local_size_y = 8) in;

layout(rgba32f) readonly uniform image2D u_color;
layout(rgba32f) uniform image2D u_sum;
layout(rgba32f) uniform image2D u_compensation;
layout(rgba32f) writeonly uniform image2D u_mean;

uniform ivec2 u_size;
uniform int u_restart;
uniform float u_count;  // samples in the sum after this one

void main() {
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(texel, u_size))) {
        return;
    }
    vec4 color = imageLoad(u_color, texel);
    precise vec4 sum;
    precise vec4 compensation;
    if (u_restart != 0) {
        sum = color;
        compensation = vec4(0.0);
    } else {
        // Kahan summation; `precise` keeps the compiler from folding (t - s) - y to 0.
        vec4 s = imageLoad(u_sum, texel);
        vec4 c = imageLoad(u_compensation, texel);
        precise vec4 y = color - c;
        precise vec4 t = s + y;
        compensation = (t - s) - y;
        sum = t;
    }
    imageStore(u_sum, texel, sum);
    imageStore(u_compensation, texel, compensation);
    // The sum less what it still owes (the compensation), over the count.
    imageStore(u_mean, texel, (sum - compensation) / u_count);
}
