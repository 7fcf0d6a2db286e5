// SPDX-License-Identifier: GPL-3.0-or-later
// Wave tracer, wave 0 (paper §3.4, the secondary rays of the primary G-buffer): one
// invocation per pixel, in row order. A specular pixel spawns its bounce-1 rays exactly as
// the megakernel does (trace_ray.glsl spawn_primary). Compiled twice (wave_queue.glsl):
// with WAVE_COUNT it only counts them per workgroup; otherwise, once wave_scan.comp.glsl
// has turned the counts into offsets, it writes them into the first ray queue, in pixel
// order, and initialises every pixel's accumulator (PixelAccum: rgb the traced light, a = 1
// where the pixel spawns rays, and so takes the traced light in wave_composite.comp.glsl).
// Host defines: those of trace/hybrid_trace.comp.glsl (trace_ray.glsl), WAVE_COUNT.
//   Storage blocks: WaveState, BlockSums; without WAVE_COUNT NextRays, NextOcclusions and
//   PixelAccum (vec4 per pixel); trace_ray.glsl's. Uniforms: u_wave_slot (0), without
//   WAVE_COUNT u_ray_capacity and u_occlusion_capacity; trace_ray.glsl's.
#ifndef WAVE_COUNT
#define WAVE_SPAWN
#endif
#define TRACE_SHADING_ONLY
#include "trace_ray.glsl"
#include "wave_queue.glsl"

layout(local_size_x = WAVE_LOCAL) in;

#ifdef WAVE_SPAWN
layout(std430) writeonly buffer PixelAccum { vec4 pixel_accum[]; };
#endif

void main() {
    uint i = wave_index();
    bool live = i < wave_count();
    bool spawns = false;
    if (live) {
        ivec2 pixel = ivec2(int(i % uint(u_size.x)), int(i / uint(u_size.x)));
        vec4 nm;
        Material m;
        if (primary_specular(pixel, nm, m)) {
            vec3 p, view_dir, n;
            primary_surface(pixel, nm, p, view_dir, n);
            spawn_primary(pixel, m, p, view_dir, n);
            spawns = true;
        }
    }
#ifdef WAVE_COUNT
    emit_counts();
#else
    wave_pixel = i;
    vec3 untraced = emit_children();
    if (live) pixel_accum[i] = spawns ? vec4(past_depth_limit + untraced, 1.0) : vec4(0.0);
#endif
}
