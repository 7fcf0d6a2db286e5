// SPDX-License-Identifier: GPL-3.0-or-later
// The ray queues of the wave tracer (hybrid_engine/passes/trace/wave_trace.py): one packed
// record per ray, the dispatch arguments and counts the kernels leave for each other on the
// GPU, the flat index of an indirect dispatch over a queue, and the two halves of the stable
// compaction that moves a wave's children into the next queues.
//
// A queued ray is a record of 32-bit words (std430 uint[]), RAY_WORDS apart in a ray queue
// and OCCLUSION_WORDS apart in the occlusion queue (wave_trace.py RAY_BYTES, OCCLUSION_BYTES):
//   0-2  origin (float bits); after the traversal the hit's position (wave_hit.glsl), after
//        the shading (or the any-hit trace) the light the ray brought, which
//        wave_resolve.comp.glsl adds to its pixel: a record is rewritten in place as it is
//        consumed, so no buffer of hit positions or contributions is needed;
//   3-5  direction (float bits: traced exactly as the megakernel traces it);
//   6-7  weight (pack_weight: three 18-bit mantissas under the largest channel's exponent);
//   8    the pixel, y * width + x;
//   9    (ray queues only) blur, the roughest lobe on its path (float bits).
// What every ray of a queue shares is not stored: the bounce depth (a wave is one depth),
// the reach (unbounded for rays, AO Distance for occlusion rays, trace_ray.glsl
// push_occlusion) and an occlusion ray's blur (1); nor what the pixel gives: the key of its
// random numbers (position_key of its primary hit), recomputed from the depth buffer.
// WaveState: uvec4 per slot, (groups x, groups y, 1, count): slot 2 d the rays of wave d
//   (wave 0: the pixels), slot 2 d + 1 the occlusion rays wave d's hits spawned; a kernel
//   over a queue is dispatched indirectly from its slot's xyz and reads the count from w.
//   The last slot's xy hold the most rays and occlusion rays any wave of the frame wanted.
// BlockSums: the children (rays, occlusion rays) of each workgroup of WAVE_LOCAL parents,
//   counted by a WAVE_COUNT kernel, then (wave_scan.comp.glsl) their exclusive offsets, at
//   which a WAVE_SPAWN kernel writes them (in the parents' order: stable).
#ifndef HYBRID_WAVE_QUEUE_GLSL
#define HYBRID_WAVE_QUEUE_GLSL

#define WAVE_LOCAL 64
#define RAY_WORDS 10u
#define OCCLUSION_WORDS 9u

layout(std430) buffer WaveState { uvec4 wave_args[]; };

uniform int u_wave_slot;  // the slot of the queue this dispatch runs over

uint wave_count() { return wave_args[u_wave_slot].w; }
uint wave_group() { return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x; }
uint wave_index() { return wave_group() * uint(WAVE_LOCAL) + gl_LocalInvocationID.x; }

// A ray's weight in two words: the biased float exponent of its largest channel and each
// channel's mantissa below it in 18 bits (a relative step of 2^-18 of the largest channel,
// far below what an 8-bit image shows). Float's whole exponent range, so no weight that the
// megakernel would still follow underflows here, and a positive channel stays positive: the
// children a ray spawns depend on it (trace_ray.glsl push), and the counters with them.
uvec2 pack_weight(vec3 w) {
    float largest = max(max(w.r, w.g), w.b);
    if (!(largest > 0.0)) return uvec2(0u);
    uint e = clamp((floatBitsToUint(largest) >> 23u) & 0xffu, 1u, 253u);
    // w / 2^(e - 127) lies in [0, 2): two exact scalings keep each step within float's range.
    vec3 scaled = max(w, vec3(0.0)) * uintBitsToFloat((254u - e) << 23u) * 131072.0;
    uvec3 q = min(uvec3(scaled + 0.5), uvec3(0x3ffffu));
    q = max(q, uvec3(greaterThan(w, vec3(0.0))));
    return uvec2(q.r | (q.g << 18u), (q.g >> 14u) | (q.b << 4u) | (e << 22u));
}

vec3 unpack_weight(uvec2 p) {
    uint e = p.y >> 22u;
    if (e == 0u) return vec3(0.0);
    uvec3 q = uvec3(p.x & 0x3ffffu, (p.x >> 18u) | ((p.y & 0xfu) << 14u), (p.y >> 4u) & 0x3ffffu);
    return vec3(q) * (1.0 / 131072.0) * uintBitsToFloat(e << 23u);
}

struct QueuedRay {
    vec3 origin;
    vec3 dir;
    vec3 weight;
    uint pixel;
    float blur;  // ray queues only
};

#define QUEUE_VEC3(array, at) uintBitsToFloat(uvec3(array[(at)], array[(at) + 1u], array[(at) + 2u]))
#define QUEUE_STORE_VEC3(array, at, v) { uvec3 bits_ = floatBitsToUint(v); \
    array[(at)] = bits_.x; array[(at) + 1u] = bits_.y; array[(at) + 2u] = bits_.z; }
#define QUEUE_STORE_RAY(array, words, i, origin, dir, weight, pixel) { uint at_ = (i) * (words); \
    QUEUE_STORE_VEC3(array, at_, origin) QUEUE_STORE_VEC3(array, at_ + 3u, dir) \
    uvec2 w_ = pack_weight(weight); array[at_ + 6u] = w_.x; array[at_ + 7u] = w_.y; array[at_ + 8u] = (pixel); }

#ifdef WAVE_READ
// The queue a kernel runs over: a ray queue (u_ray_words RAY_WORDS) or the occlusion queue
// (OCCLUSION_WORDS), read and rewritten in place.
layout(std430) buffer Rays { uint rays[]; };
uniform uint u_ray_words;

QueuedRay load_ray(uint i) {
    uint at = i * u_ray_words;
    QueuedRay r;
    r.origin = QUEUE_VEC3(rays, at);
    r.dir = QUEUE_VEC3(rays, at + 3u);
    r.weight = unpack_weight(uvec2(rays[at + 6u], rays[at + 7u]));
    r.pixel = rays[at + 8u];
    r.blur = u_ray_words == RAY_WORDS ? uintBitsToFloat(rays[at + 9u]) : 1.0;
    return r;
}

uint ray_pixel(uint i) { return rays[i * u_ray_words + 8u]; }
// Words 0-2: the hit's position (traversal), then the light the ray brought.
vec3 ray_words_vec3(uint i) { return QUEUE_VEC3(rays, i * u_ray_words); }
void store_ray_words_vec3(uint i, vec3 v) QUEUE_STORE_VEC3(rays, i * u_ray_words, v)
#endif

#if defined(WAVE_COUNT) || defined(WAVE_SPAWN)
// The parents' side (trace_ray.glsl's ray_room and store_ray): a parent (a pixel of wave 0,
// a hit of a later wave) holds its children (at most a reflection, a refraction and an
// occlusion ray) until the workgroup knows where they go.
bool ray_room() { return true; }
uint held_rays = 0u;
uint held_occlusions = 0u;
#endif

#ifdef WAVE_COUNT
// The counting pass: only how many children each workgroup's parents spawn.
layout(std430) writeonly buffer BlockSums { uvec2 block_sums[]; };

void store_ray(vec3 origin, vec3 dir, vec3 weight, int depth, float blur, float reach) {
    if (depth < 0) held_occlusions += 1u;
    else held_rays += 1u;
}

shared uint emit_rays;
shared uint emit_occlusions;

// The workgroup's children into BlockSums (every invocation calls it, in uniform control
// flow; a parent past the queue's end has none).
void emit_counts() {
    if (gl_LocalInvocationIndex == 0u) {
        emit_rays = 0u;
        emit_occlusions = 0u;
    }
    barrier();
    if (held_rays != 0u) atomicAdd(emit_rays, held_rays);
    if (held_occlusions != 0u) atomicAdd(emit_occlusions, held_occlusions);
    barrier();
    if (gl_LocalInvocationIndex == 0u) block_sums[wave_group()] = uvec2(emit_rays, emit_occlusions);
}
#endif

#ifdef WAVE_SPAWN
// The spawning pass: the same children, written straight into the next queues at the
// workgroup's offset (BlockSums after wave_scan.comp.glsl) plus the children of its lower
// lanes. A child past a queue's capacity is not traced: a ray takes the sky along its
// direction, an occlusion ray the sky as seen (as the megakernel does with rays that find no
// room on its stack); emit_children returns that light for the parent to keep.
#define LOCAL_SIZE WAVE_LOCAL
#define WORKGROUP_SCAN_TYPE uvec2
#include "workgroup_scan.glsl"

layout(std430) readonly buffer BlockSums { uvec2 block_sums[]; };
layout(std430) writeonly buffer NextRays { uint next_rays[]; };
layout(std430) writeonly buffer NextOcclusions { uint next_occlusions[]; };
uniform uint u_ray_capacity;
uniform uint u_occlusion_capacity;

uint wave_pixel = 0u;  // the parent's pixel
vec3 held_origin[2];
vec3 held_dir[2];
vec3 held_weight[2];
float held_blur[2];
vec3 held_occlusion_origin;
vec3 held_occlusion_dir;
vec3 held_occlusion_weight;

void store_ray(vec3 origin, vec3 dir, vec3 weight, int depth, float blur, float reach) {
    if (depth < 0) {
        held_occlusion_origin = origin;
        held_occlusion_dir = dir;
        held_occlusion_weight = weight;
        held_occlusions = 1u;
    } else {
        held_origin[held_rays] = origin;
        held_dir[held_rays] = dir;
        held_weight[held_rays] = weight;
        held_blur[held_rays] = blur;
        held_rays += 1u;
    }
}

vec3 emit_children() {
    uvec2 total;
    uvec2 at = workgroup_exclusive_scan(uvec2(held_rays, held_occlusions), total);
    if (held_rays + held_occlusions == 0u) return vec3(0.0);
    at += block_sums[wave_group()];
    vec3 untraced = vec3(0.0);
    for (uint c = 0u; c < held_rays; ++c) {
        uint slot = at.x + c;
        if (slot < u_ray_capacity) {
            QUEUE_STORE_RAY(next_rays, RAY_WORDS, slot, held_origin[c], held_dir[c], held_weight[c], wave_pixel)
            next_rays[slot * RAY_WORDS + 9u] = floatBitsToUint(held_blur[c]);
        } else {
            untraced += held_weight[c] * sky_radiance(held_dir[c]);
        }
    }
    if (held_occlusions != 0u) {
        if (at.y < u_occlusion_capacity) {
            QUEUE_STORE_RAY(next_occlusions, OCCLUSION_WORDS, at.y, held_occlusion_origin, held_occlusion_dir,
                            held_occlusion_weight, wave_pixel)
        } else {
            untraced += held_occlusion_weight;
        }
    }
    return untraced;
}
#endif

#endif
