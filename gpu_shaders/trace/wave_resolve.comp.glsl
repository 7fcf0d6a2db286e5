// SPDX-License-Identifier: GPL-3.0-or-later
// Wave tracer, accumulation: the rays of a queue lie grouped by pixel (the compaction is
// stable), so the first ray of each pixel's run adds the light of the run's records
// (wave_queue.glsl words 0-2), in queue order, to its pixel's accumulator: one writer per
// pixel, no float atomics, the same sum on every run.
// Storage blocks: WaveState, Rays (the queue), PixelAccum (read/write). Uniforms:
//   u_wave_slot, u_ray_words.
#define WAVE_READ
#include "wave_queue.glsl"

layout(local_size_x = WAVE_LOCAL) in;

layout(std430) buffer PixelAccum { vec4 pixel_accum[]; };

void main() {
    uint i = wave_index();
    uint n = wave_count();
    if (i >= n) return;
    uint pixel = ray_pixel(i);
    if (i > 0u && ray_pixel(i - 1u) == pixel) return;
    vec3 sum = vec3(0.0);
    for (uint j = i; j < n && ray_pixel(j) == pixel; ++j) sum += ray_words_vec3(j);
    pixel_accum[pixel].rgb += sum;
}
