// SPDX-License-Identifier: GPL-3.0-or-later
// What passes/surface_motion/ leaves for the kernels that look a pixel up in last frame's
// image (the denoiser's reprojection, the diffuse gather's history_paths): where each
// primary pixel's surface stood last frame, where its instance moved or deformed.
#ifndef HYBRID_SURFACE_MOTION_GLSL
#define HYBRID_SURFACE_MOTION_GLSL

uniform sampler2D u_motion;       // RGBA32F, the primary view's size: last frame's point, entry + 1 (0: nothing moved)
uniform sampler2D u_motion_turn;  // RGBA16F: the quaternion taking the normal now to the normal then

// Takes the surface point p and normal n of `pixel` back to where they stood last frame,
// where the pixel's instance moved or deformed; false, leaving them, where it did not.
bool surface_moved_back(ivec2 pixel, inout vec3 p, inout vec3 n) {
    vec4 previous = texelFetch(u_motion, pixel, 0);
    if (!(previous.w > 0.5)) return false;
    vec4 q = texelFetch(u_motion_turn, pixel, 0);
    p = previous.xyz;
    n = normalize(n + 2.0 * cross(q.xyz, cross(q.xyz, n) + q.w * n));
    return true;
}

#endif
