// SPDX-License-Identifier: GPL-3.0-or-later
// A ray's hit as the wave tracer's traversal kernel hands it to the shading kernel
// (trace_ray.glsl's Hit in std430, 64 bytes).
#ifndef HYBRID_WAVE_HIT_GLSL
#define HYBRID_WAVE_HIT_GLSL

struct WaveHit {
    vec3 position;
    int kind;
    vec3 normal;
    int material;
    vec3 geometric;
    float lod;
    vec4 uv;  // xy
};

WaveHit pack_hit(Hit h) {
    return WaveHit(h.position, h.kind, h.normal, h.material, h.geometric, h.lod, vec4(h.uv, 0.0, 0.0));
}

Hit unpack_hit(WaveHit w) {
    Hit h;
    h.kind = w.kind;
    h.position = w.position;
    h.normal = w.normal;
    h.geometric = w.geometric;
    h.material = w.material;
    h.uv = w.uv.xy;
    h.lod = w.lod;
    return h;
}

#endif
