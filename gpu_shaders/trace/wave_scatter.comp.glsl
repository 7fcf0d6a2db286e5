// SPDX-License-Identifier: GPL-3.0-or-later
// Wave tracer, compaction: one invocation per parent of a wave copies its children from its
// slots to their places in the next wave's ray queue and the occlusion queue (offsets:
// BlockSums after wave_scan.comp.glsl, plus the children of the workgroup's earlier
// parents). A child past a queue's capacity is not traced: a ray takes the sky along its
// direction, an occlusion ray the sky as seen (as the megakernel does with rays that find no
// room on its stack), added to the parent's contribution slot (wave 0: its pixel).
// Storage blocks: WaveState, Children, ChildMasks, BlockSums (read), NextRays,
//   NextOcclusions (WaveRay[], written), Contributions (read/write), PixelAccum
//   (read/write, wave 0). Uniforms: u_wave_slot, u_capacity, u_first_wave, sky.glsl's.
#include "wave_queue.glsl"
#include "sky.glsl"

layout(local_size_x = WAVE_LOCAL) in;

layout(std430) readonly buffer Children { WaveRay children[]; };
layout(std430) readonly buffer ChildMasks { uint child_masks[]; };
layout(std430) readonly buffer BlockSums { uvec2 block_sums[]; };
layout(std430) writeonly buffer NextRays { WaveRay next_rays[]; };
layout(std430) writeonly buffer NextOcclusions { WaveRay next_occlusions[]; };
layout(std430) buffer Contributions { vec4 contributions[]; };
layout(std430) buffer PixelAccum { vec4 pixel_accum[]; };
uniform uint u_capacity;
uniform int u_first_wave;  // 1: the parents are the pixels (wave 0)

shared uint masks[WAVE_LOCAL];

void main() {
    uint i = wave_index();
    uint local = gl_LocalInvocationIndex;
    bool live = i < wave_count();
    uint mask = live ? child_masks[i] : 0u;
    masks[local] = mask;
    barrier();
    if (!live || mask == 0u) return;
    uvec2 at = block_sums[wave_group()];
    for (uint k = 0u; k < local; ++k) at += uvec2(child_rays(masks[k]), child_occlusions(masks[k]));
    vec3 untraced = vec3(0.0);
    for (uint c = 0u; c < child_rays(mask); ++c) {
        WaveRay r = children[3u * i + c];
        if (at.x + c < u_capacity) next_rays[at.x + c] = r;
        else untraced += r.weight * sky_radiance(r.dir);
    }
    if (child_occlusions(mask) != 0u) {
        WaveRay r = children[3u * i + 2u];
        if (at.y < u_capacity) next_occlusions[at.y] = r;
        else untraced += r.weight;
    }
    if (any(notEqual(untraced, vec3(0.0)))) {
        if (u_first_wave != 0) pixel_accum[i].rgb += untraced;
        else contributions[i].rgb += untraced;
    }
}
