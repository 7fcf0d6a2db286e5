// SPDX-License-Identifier: GPL-3.0-or-later
// Cycles' Vector pass over a view's samples (passes/film/vector.py): this sample's vector at
// each pixel, added into the sums (u_restart: the view's first sample starts them), and the
// pass as Cycles' film delivers it: the vectors' sum over the count of samples that hit (0
// where none did: the background).
//
// The sample's vector: the raster positions of the surface point the sample's G-buffer
// shows, at the frame before, this frame and the frame after (pixels, y up as the render
// result stores rows), as Cycles' kernel writes them: xy = previous - this, zw = this -
// next. The point is the pixel's depth through the sample's inverse view-projection, and its
// raster position this frame is taken through the sample's view-projection again (not the
// pixel's centre), by the same arithmetic as at the other frames: a still point under a
// still camera moves by exactly 0, as in Cycles. The frames around it take
// it through its instance's motion, found by the world row the G-buffer keeps (u_row):
// MotionRows lists, sorted by row, the instances that move or deform (first row, end row,
// index of its two world-to-world matrices in MotionMatrices or -1, index of its corners'
// positions in MotionCorners or -1); a row outside them is still, and only the camera moves
// it. A deforming instance's point keeps its weights in its triangle (the world rows,
// triangle_input.glsl) on the triangle's corners of the other frames. What the G-buffer's
// alpha test dropped is not there: the pixel moves with the surface the sample sees.
layout(local_size_x = 8, local_size_y = 8) in;

#include "triangle_input.glsl"
#include "motion_rows.glsl"
#include "triangle_weights.glsl"
#include "denoise.glsl"

layout(std430) readonly buffer MotionMatrices { mat4 motion_matrices[]; };  // previous, next
layout(std430) readonly buffer MotionCorners { vec4 motion_corners[]; };    // previous, next

uniform sampler2D u_depth;            // the sample's primary G-buffer
uniform sampler2D u_normal_material;  // w: the signed material id, 0 where no surface
uniform isampler2D u_row;             // the world row per pixel
uniform mat4 u_view_proj;             // the sample's, as the G-buffer drew it
uniform mat4 u_inv_view_proj;         // ... inverted
uniform mat4 u_previous_view_proj;    // the sample's camera moved to the frame before
uniform mat4 u_next_view_proj;        // ... and to the frame after

layout(rgba32f) uniform image2D u_sums;
layout(r32f) uniform image2D u_hits;
layout(rgba32f) writeonly uniform image2D u_vector_pass;
uniform ivec2 u_size;
uniform int u_restart;

vec2 raster(vec4 clip) {
    return (clip.xy / clip.w * 0.5 + 0.5) * vec2(u_size);
}

void main() {
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(texel, u_size))) return;
    vec4 value = vec4(0.0);
    float hit = 0.0;
    if (denoise_surface_id(texelFetch(u_normal_material, texel, 0).w) != 0) {
        hit = 1.0;
        vec4 point = vec4(denoise_unproject(u_inv_view_proj, texel, u_size, texelFetch(u_depth, texel, 0).r), 1.0);
        vec4 previous = point, next = point;
        int row = texelFetch(u_row, texel, 0).r;
        int k = motion_entry(row);
        if (k >= 0) {
            ivec4 entry = motion_rows[k];
            if (entry.w >= 0) {
                vec3 w = triangle_weights(point.xyz, input_vertex(uint(row), 0u), input_vertex(uint(row), 1u),
                                          input_vertex(uint(row), 2u));
                int corner = entry.w + 6 * (row - entry.x);  // two vec4 per corner, three corners per row
                previous = w.x * motion_corners[corner] + w.y * motion_corners[corner + 2] + w.z * motion_corners[corner + 4];
                next = w.x * motion_corners[corner + 1] + w.y * motion_corners[corner + 3] + w.z * motion_corners[corner + 5];
            } else if (entry.z >= 0) {
                previous = motion_matrices[entry.z] * point;
                next = motion_matrices[entry.z + 1] * point;
            }
        }
        vec2 here = raster(u_view_proj * point);
        value = vec4(raster(u_previous_view_proj * previous) - here, here - raster(u_next_view_proj * next));
    }
    vec4 sums = value;
    float hits = hit;
    if (u_restart == 0) {
        sums += imageLoad(u_sums, texel);
        hits += imageLoad(u_hits, texel).r;
    }
    imageStore(u_sums, texel, sums);
    imageStore(u_hits, texel, vec4(hits));
    imageStore(u_vector_pass, texel, hits > 0.0 ? sums / hits : vec4(0.0));
}
