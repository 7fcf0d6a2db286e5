// SPDX-License-Identifier: GPL-3.0-or-later
// Per-sample random numbers for the stochastic estimates (glossy lobes, ambient occlusion,
// soft-shadow filter rotations): a PCG hash of a key (pixel, sample, bounce, use), so each
// sample of one view draws fresh numbers and their average converges (the viewport's
// accumulation, antialias.py), while one sample is reproducible.
#ifndef HYBRID_RANDOM_GLSL
#define HYBRID_RANDOM_GLSL

uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

uint hash_key(uvec4 key) {
    return pcg_hash(key.x ^ pcg_hash(key.y ^ pcg_hash(key.z ^ pcg_hash(key.w))));
}

// The length position keys are measured in: the scene's typical object size
// (FrameResources.random_unit, scene/scale.py's typical_object_size), so that one scene
// modelled in millimetres, metres or kilometres draws the same numbers at the same points
// and its noise is one pattern at every scale, as its light is. 0 (a program bound without
// the lighting): one scene unit.
uniform float u_random_unit;

// A key of a world position, quantised to 1/4096 of the typical object size: the same
// surface point seen through a cropped projection (a render region, a viewport border)
// draws the same numbers as in the whole frame, where a pixel index would not. A cell must
// stay under a pixel's footprint, yet no finer than it needs: a position read back from the
// depth buffer carries its rounding, which differs from one scale to another, and every
// point that rounding moves across a cell's boundary draws other numbers. The cells are
// centred on the grid's points (the + 0.5), so that a surface at a round coordinate (a floor
// at z = 0, whose points read back a hair above or below it) lies inside one cell, not on
// the boundary between two.
uvec3 position_key(vec3 p) {
    vec3 q = p / (u_random_unit > 0.0 ? u_random_unit : 1.0);
    return uvec3(ivec3(floor(clamp(q, vec3(-4.0e5), vec3(4.0e5)) * 4096.0 + 0.5)));
}

// Two uniform numbers in [0, 1) for `key`.
vec2 random2(uvec4 key) {
    uint a = hash_key(key);
    uint b = pcg_hash(a ^ 0x9e3779b9u);
    return vec2(float(a >> 8u), float(b >> 8u)) * (1.0 / 16777216.0);
}

// An orthonormal frame (t, b) around unit n (Duff et al. 2017).
void basis_around(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}
#endif
