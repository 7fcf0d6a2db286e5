// SPDX-License-Identifier: GPL-3.0-or-later
// A ray's hit as the wave tracer's traversal kernel hands it to the shading kernel
// (trace_ray.glsl's Hit): HIT_WORDS 32-bit words per ray (wave_trace.py HIT_BYTES),
//   0    kind (bits 30-31) and material (bits 0-29)
//   1-3  shading normal, 4-6 geometric normal (float bits)
//   7-8  texture coordinate, 9 its mip level (float bits)
// and the position in the ray's own record (wave_queue.glsl words 0-2, over the origin the
// shading no longer needs). Every field is kept to the bit: the shading spawns the next
// rays from them, and the waves trace exactly the megakernel's rays. Needs WAVE_READ.
#ifndef HYBRID_WAVE_HIT_GLSL
#define HYBRID_WAVE_HIT_GLSL

// With NODE_PROGRAMS eight words more: 10 the triangle row (node programs read the hit's
// object), 11-13 dP/du, 14-16 dP/dv (the tangent frame) and 17 the ray cone's footprint.
#ifdef NODE_PROGRAMS
#define HIT_WORDS 18u
#else
#define HIT_WORDS 10u
#endif

#ifdef WAVE_HIT_WRITE
layout(std430) writeonly buffer Hits { uint hits[]; };

void store_hit(uint i, Hit h) {
    uint at = i * HIT_WORDS;
    hits[at] = (uint(h.kind) << 30u) | uint(h.material);
    if (h.kind == HIT_SKY) return;  // the shading needs no more
    store_ray_words_vec3(i, h.position);
    QUEUE_STORE_VEC3(hits, at + 1u, h.normal)
    QUEUE_STORE_VEC3(hits, at + 4u, h.geometric)
    hits[at + 7u] = floatBitsToUint(h.uv.x);
    hits[at + 8u] = floatBitsToUint(h.uv.y);
    hits[at + 9u] = floatBitsToUint(h.lod);
#ifdef NODE_PROGRAMS
    hits[at + 10u] = uint(h.row);
    QUEUE_STORE_VEC3(hits, at + 11u, h.dp_du)
    QUEUE_STORE_VEC3(hits, at + 14u, h.dp_dv)
    hits[at + 17u] = floatBitsToUint(h.footprint);
#endif
}
#else
layout(std430) readonly buffer Hits { uint hits[]; };

Hit load_hit(uint i) {
    uint at = i * HIT_WORDS;
    Hit h;
    uint head = hits[at];
    h.kind = int(head >> 30u);
    h.material = int(head & 0x3fffffffu);
    h.position = vec3(0.0);
    h.normal = vec3(0.0, 0.0, 1.0);
    h.geometric = h.normal;
    h.uv = vec2(0.0);
    h.lod = 0.0;
#ifdef NODE_PROGRAMS
    h.row = -1;
    h.dp_du = vec3(0.0);
    h.dp_dv = vec3(0.0);
    h.footprint = 0.0;
#endif
    if (h.kind == HIT_SKY) return h;
    h.position = ray_words_vec3(i);
    h.normal = QUEUE_VEC3(hits, at + 1u);
    h.geometric = QUEUE_VEC3(hits, at + 4u);
    h.uv = uintBitsToFloat(uvec2(hits[at + 7u], hits[at + 8u]));
    h.lod = uintBitsToFloat(hits[at + 9u]);
#ifdef NODE_PROGRAMS
    h.row = int(hits[at + 10u]);
    h.dp_du = QUEUE_VEC3(hits, at + 11u);
    h.dp_dv = QUEUE_VEC3(hits, at + 14u);
    h.footprint = uintBitsToFloat(hits[at + 17u]);
#endif
    return h;
}
#endif

#endif
