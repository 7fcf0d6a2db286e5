// SPDX-License-Identifier: GPL-3.0-or-later
// Wave tracer, accumulation: the rays of a queue lie grouped by pixel (the compaction is
// stable), so the first ray of each pixel's run adds the run's contributions, in queue
// order, to its pixel's accumulator: one writer per pixel, no float atomics, the same sum
// on every run.
// Storage blocks: WaveState, Rays (the queue), Contributions (read), PixelAccum
//   (read/write). Uniforms: u_wave_slot.
#include "wave_queue.glsl"

layout(local_size_x = WAVE_LOCAL) in;

layout(std430) readonly buffer Rays { WaveRay rays[]; };
layout(std430) readonly buffer Contributions { vec4 contributions[]; };
layout(std430) buffer PixelAccum { vec4 pixel_accum[]; };

void main() {
    uint i = wave_index();
    uint n = wave_count();
    if (i >= n) return;
    uint pixel = rays[i].key.w;
    if (i > 0u && rays[i - 1u].key.w == pixel) return;
    vec3 sum = vec3(0.0);
    for (uint j = i; j < n && rays[j].key.w == pixel; ++j) sum += contributions[j].rgb;
    pixel_accum[pixel].rgb += sum;
}
