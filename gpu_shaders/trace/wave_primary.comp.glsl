// SPDX-License-Identifier: GPL-3.0-or-later
// Wave tracer, wave 0 (paper §3.4, the secondary rays of the primary G-buffer): one
// invocation per pixel, in row order, compacts the specular pixels into the first ray queue.
// A specular pixel spawns its bounce-1 rays into its child slots (wave_queue.glsl) exactly as
// the megakernel does (trace_ray.glsl spawn_primary); every pixel initialises its
// accumulator (PixelAccum: rgb the traced light, a = 1 where the pixel spawns rays, and so
// takes the traced light in wave_composite.comp.glsl).
// Host defines: those of trace/hybrid_trace.comp.glsl (trace_ray.glsl). Storage blocks:
//   WaveState, Children, ChildMasks, BlockSums (wave_queue.glsl), PixelAccum (vec4 per
//   pixel), and trace_ray.glsl's. Uniforms: u_wave_slot (0) and trace_ray.glsl's.
#define WAVE_EMIT
#define TRACE_SHADING_ONLY
#include "trace_ray.glsl"
#include "wave_queue.glsl"

layout(local_size_x = WAVE_LOCAL) in;

layout(std430) writeonly buffer PixelAccum { vec4 pixel_accum[]; };

void main() {
    uint i = wave_index();
    bool live = i < wave_count();
    if (live) {
        ivec2 pixel = ivec2(int(i % uint(u_size.x)), int(i / uint(u_size.x)));
        wave_parent = i;
        vec4 nm;
        Material m;
        vec4 accum = vec4(0.0);
        if (primary_specular(pixel, nm, m)) {
            vec3 p, view_dir, n;
            primary_surface(pixel, nm, p, view_dir, n);
            wave_key = uvec4(position_key(p), i);
            spawn_primary(pixel, m, p, view_dir, n);
            accum = vec4(past_depth_limit, 1.0);
        }
        pixel_accum[i] = accum;
    }
    emit_children(live);
}
