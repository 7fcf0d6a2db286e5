// SPDX-License-Identifier: GPL-3.0-or-later
// The ray queues of the wave tracer (hybrid_engine/passes/trace/wave_trace.py): one record
// per ray, the dispatch arguments and counts the kernels leave for each other on the GPU,
// and the flat index of an indirect dispatch over a queue.
//
// struct WaveRay (std430, 64 bytes):
//   vec3 origin; int depth (-1: an occlusion ray); vec3 dir; float blur (the roughest lobe
//   on its path); vec3 weight; float reach (how far it looks); uvec4 key (xyz: the
//   position_key of its pixel's primary hit, the numbers every bounce of the pixel draws;
//   w: the pixel, y * width + x).
// WaveState: uvec4 per slot, (groups x, groups y, 1, count): slot 2 d the rays of wave d
//   (wave 0: the pixels), slot 2 d + 1 the occlusion rays wave d's hits spawned; a kernel
//   over a queue is dispatched indirectly from its slot's xyz and reads the count from w.
//   The last slot's x holds the most rays any wave wanted (capacity overflow).
// A parent (a pixel of wave 0, a ray of a later wave) leaves up to three children in its
// slots of Children (3 per parent: reflection, refraction, occlusion) and their number in
// ChildMasks (bits 0-1 the rays, bit 2 the occlusion ray); BlockSums holds the children of
// each workgroup of WAVE_LOCAL parents, then (wave_scan.comp.glsl) their exclusive offsets.
#ifndef HYBRID_WAVE_QUEUE_GLSL
#define HYBRID_WAVE_QUEUE_GLSL

#define WAVE_LOCAL 64

struct WaveRay {
    vec3 origin;
    int depth;
    vec3 dir;
    float blur;
    vec3 weight;
    float reach;
    uvec4 key;
};

layout(std430) buffer WaveState { uvec4 wave_args[]; };

uniform int u_wave_slot;  // the slot of the queue this dispatch runs over

uint wave_count() { return wave_args[u_wave_slot].w; }
uint wave_group() { return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x; }
uint wave_index() { return wave_group() * uint(WAVE_LOCAL) + gl_LocalInvocationID.x; }

uint child_rays(uint mask) { return mask & 3u; }
uint child_occlusions(uint mask) { return mask >> 2u; }

#ifdef WAVE_EMIT
// The parents' side: children in their slots, their numbers per parent and per workgroup.
layout(std430) writeonly buffer Children { WaveRay children[]; };
layout(std430) writeonly buffer ChildMasks { uint child_masks[]; };
layout(std430) writeonly buffer BlockSums { uvec2 block_sums[]; };

uint wave_parent = 0u;
uvec4 wave_key = uvec4(0u);
uint wave_mask = 0u;

bool ray_room() { return true; }

// A spawned ray into the parent's next free slot (occlusion rays into the third).
void store_ray(vec3 origin, vec3 dir, vec3 weight, int depth, float blur, float reach) {
    WaveRay r = WaveRay(origin, depth, dir, blur, weight, reach, wave_key);
    if (depth < 0) {
        children[3u * wave_parent + 2u] = r;
        wave_mask |= 4u;
    } else {
        children[3u * wave_parent + child_rays(wave_mask)] = r;
        wave_mask += 1u;
    }
}

shared uint emit_rays;
shared uint emit_occlusions;

// Record this parent's children (every invocation calls it, in uniform control flow; a
// parent past the queue's end has none).
void emit_children(bool live) {
    if (gl_LocalInvocationIndex == 0u) {
        emit_rays = 0u;
        emit_occlusions = 0u;
    }
    barrier();
    if (live) {
        child_masks[wave_parent] = wave_mask;
        if (child_rays(wave_mask) != 0u) atomicAdd(emit_rays, child_rays(wave_mask));
        if (child_occlusions(wave_mask) != 0u) atomicAdd(emit_occlusions, child_occlusions(wave_mask));
    }
    barrier();
    if (gl_LocalInvocationIndex == 0u) block_sums[wave_group()] = uvec2(emit_rays, emit_occlusions);
}
#endif

#endif
