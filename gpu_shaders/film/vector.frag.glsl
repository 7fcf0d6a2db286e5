// SPDX-License-Identifier: GPL-3.0-or-later
// Cycles' Vector pass, fragment stage: the raster positions of the surface point at the
// frame before, this frame and the frame after (pixels, y up as the render result stores
// rows), written as Cycles' kernel writes them: xy = previous - this, zw = this - next.
// Location 1 marks the texel as hit (the background stays 0): the film averages the
// vectors over the samples that hit, as Cycles divides by its motion weight.
in vec4 v_center;
in vec4 v_previous;
in vec4 v_next;

uniform ivec2 u_size;

layout(location = 0) out vec4 out_vector;
layout(location = 1) out float out_hit;

vec2 raster(vec4 clip) {
    return (clip.xy / clip.w * 0.5 + 0.5) * vec2(u_size);
}

void main() {
    vec2 center = raster(v_center);
    out_vector = vec4(raster(v_previous) - center, center - raster(v_next));
    out_hit = 1.0;
}
