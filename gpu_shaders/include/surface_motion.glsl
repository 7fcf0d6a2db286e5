// SPDX-License-Identifier: GPL-3.0-or-later
// What passes/surface_motion/ leaves for the kernels that look a pixel up in last frame's
// image (the denoiser's reprojection, the diffuse gather's history_paths): which instance's
// move each primary pixel shows, and the moves.
#ifndef HYBRID_SURFACE_MOTION_GLSL
#define HYBRID_SURFACE_MOTION_GLSL

uniform sampler2D u_motion;           // R32F, the primary view's size: entry + 1, 0 where nothing moved
uniform sampler2D u_motion_matrices;  // RGBA32F, 4 x entries: row e the columns of entry e's move

// Takes the surface point p and normal n of `pixel` back to where they stood last frame
// (the world-to-world move previous x current^-1; the normal by its inverse transpose),
// where the pixel's instance moved; false, leaving them, where it did not.
bool surface_moved_back(ivec2 pixel, inout vec3 p, inout vec3 n) {
    int entry = int(texelFetch(u_motion, pixel, 0).r + 0.5) - 1;
    if (entry < 0) return false;
    mat4 move = mat4(texelFetch(u_motion_matrices, ivec2(0, entry), 0), texelFetch(u_motion_matrices, ivec2(1, entry), 0),
                     texelFetch(u_motion_matrices, ivec2(2, entry), 0), texelFetch(u_motion_matrices, ivec2(3, entry), 0));
    p = (move * vec4(p, 1.0)).xyz;
    n = normalize(transpose(inverse(mat3(move))) * n);
    return true;
}

#endif
