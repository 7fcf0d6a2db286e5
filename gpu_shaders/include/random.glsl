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

// Where position keys are measured from (RasterView.uniforms, FrameResources.bindings):
// u_random_unit, the scene's typical object size (scene/scale.py's typical_object_size);
// u_key_eye and u_key_pixel, the camera's eye and its pixel on the optical axis (width at the
// eye, growth per unit of distance: raster_view.axis_pixel). 0 where a program is bound
// without them: one scene unit, no pixel.
uniform float u_random_unit;
uniform vec3 u_key_eye;
uniform vec2 u_key_pixel;

// The power of two of the typical object size (`unit`: u_random_unit, or one scene unit)
// that `pixels` pixel footprints at p span, floor(log2(...)): the grid level of the world
// cells keyed by position (position_key, radiance_cache.glsl). False where the program is
// bound without a pixel.
bool footprint_level(vec3 p, float pixels, out float unit, out float level) {
    unit = u_random_unit > 0.0 ? u_random_unit : 1.0;
    float footprint = (u_key_pixel.x + u_key_pixel.y * distance(p, u_key_eye)) * pixels;
    level = floor(log2(footprint / unit));
    return footprint > 0.0;
}

// A key of a world position: the same surface point seen through a cropped projection (a
// render region, a viewport border, a sub-pixel sample) draws the same numbers as in the
// whole frame, where a pixel index would not. The point is quantised to cells of a quarter
// to a half of the pixel's footprint there, so that neighbouring pixels draw their own
// numbers, and no finer: a position read back from the depth buffer carries its rounding,
// and each point that moves across a cell's boundary draws other numbers. The cell is the
// typical object size times a power of two, so that
//   * one scene modelled in millimetres, metres or kilometres draws the same numbers at the
//     same points, and its noise is one pattern at every scale, as its light is;
//   * a surface keeps its numbers while the camera moves, until its distance doubles.
// The cells are centred on the grid's points (the + 0.5): a surface at a round coordinate
// (a floor at z = 0, whose points read back a hair above or below it) lies inside one cell,
// not on the boundary between two. Without a pixel, cells of 1/4096 of the unit.
uvec3 position_key(vec3 p) {
    float unit, level;
    level = footprint_level(p, 1.0, unit, level) ? clamp(level - 1.0, -100.0, 100.0) : -12.0;
    vec3 q = p / (unit * exp2(level));
    uvec3 key = uvec3(ivec3(floor(clamp(q, vec3(-2.0e9), vec3(2.0e9)) + 0.5)));
    return key ^ uvec3(0u, 0u, pcg_hash(uint(level + 128.0)));
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
