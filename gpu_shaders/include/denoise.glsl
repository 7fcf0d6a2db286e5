// SPDX-License-Identifier: GPL-3.0-or-later
// What the denoiser's kernels (gpu_shaders/denoise/) share: a G-buffer texel's world
// position and surface id, the surface texels they read (position and normal in one fetch),
// the two guide values of the filtered estimate, and the test of whether two points lie on
// one surface.
//
// The filtered estimate is the frame's ambient target: rgb the diffuse irradiance (not yet
// multiplied by the albedo, so a texture's edges are not in it), a the sky's visibility.
// Either may be the noisy one (the traced gather fills rgb, the screen-space occlusion only
// a), so both are guides: the luminance of rgb and a, each with its own variance.
#ifndef HYBRID_DENOISE_GLSL
#define HYBRID_DENOISE_GLSL

#include "octahedral.glsl"

// The world-space point of texel `texel` of a view of `size` texels whose depth buffer holds
// `depth` there, through that view's inverse view-projection.
vec3 denoise_unproject(mat4 inv_view_proj, ivec2 texel, ivec2 size, float depth) {
    vec2 ndc = (vec2(texel) + 0.5) / vec2(size) * 2.0 - 1.0;
    vec4 world = inv_view_proj * vec4(ndc, depth * 2.0 - 1.0, 1.0);
    return world.xyz / world.w;
}

// The surface id of a G-buffer texel: its material index + 1 (0: background), from the
// signed id gbuffer.frag.glsl keeps in normal_material.w (the sign says which side faced).
int denoise_surface_id(float w) {
    return int(abs(w) + 0.5);
}

// A surface texel of the denoiser (written by reproject.comp.glsl, read by every step after,
// and by the next frame's reprojection): xyz the world-space point, w its unit normal
// (octahedral, two snorm16 in one float's bits), or DENOISE_BACKGROUND where the pixel sees
// no surface (a pattern packSnorm2x16 never makes: it writes -1 as -32767).
const uint DENOISE_BACKGROUND = 0x80008000u;

vec4 denoise_pack_surface(vec3 p, vec3 n) {
    return vec4(p, uintBitsToFloat(packSnorm2x16(octahedral_encode(n))));
}

bool denoise_is_background(vec4 surface) {
    return floatBitsToUint(surface.w) == DENOISE_BACKGROUND;
}

vec3 denoise_surface_normal(vec4 surface) {
    return octahedral_decode(unpackSnorm2x16(floatBitsToUint(surface.w)));
}

// The two guides of an ambient texel: the luminance of its irradiance, and its sky visibility.
vec2 denoise_guides(vec4 ambient) {
    return vec2(dot(ambient.rgb, vec3(0.2126, 0.7152, 0.0722)), ambient.a);
}

// How far q lies off the tangent plane of p (unit normal n), relative to `scale` (p's
// distance from the camera): 0 on one flat surface wherever q is on it, large across a
// silhouette, where the depth buffer jumps from one surface to another behind it.
float denoise_plane_offset(vec3 p, vec3 n, vec3 q, float scale) {
    return abs(dot(q - p, n)) / max(scale, 1e-6);
}

// max(0, c)^128 by squaring (SVGF's normal weight): a pow() is an exp and a log per tap.
float denoise_normal_weight(float c) {
    float w = max(c, 0.0);
    w *= w; w *= w; w *= w; w *= w; w *= w; w *= w; w *= w;
    return w;
}

#endif
