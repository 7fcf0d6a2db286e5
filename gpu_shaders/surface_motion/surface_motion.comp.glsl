// SPDX-License-Identifier: GPL-3.0-or-later
// Surface motion (passes/surface_motion/surface_motion.py): for each primary pixel whose
// triangle belongs to an instance that moved or deformed since last frame, where its surface
// point stood then and the turn of its normal; zeros everywhere else.
//
// One invocation per pixel. The primary G-buffer keeps each pixel's world row (gbuffer
// .frag.glsl out_row), so the pixel's instance is a binary search of that row in the moved
// instances' table (include/motion_rows.glsl: first row, end row, entry, first row of its
// rows of last frame or -1), and no geometry is drawn again: the cost follows the pixels, not
// the moved triangles. The point is the pixel's depth through the inverse view-projection,
// the point the denoiser's reprojection and the diffuse gather start from
// (include/denoise.glsl denoise_unproject); the normal is the G-buffer's.
//   - A moved instance (entry.w < 0): the point and the normal taken by its world-to-world
//     move (u_motion_matrices, row e the move's columns), the normal by its inverse
//     transpose.
//   - A deformed one (entry.w >= 0): the point's barycentric coordinates in its triangle now
//     (the world rows, triangle_input.glsl) placed on the same triangle of last frame
//     (PreviousPositions, its rows packed from entry.w); the normal turned as the
//     triangle's own normal turned (for a flat face that is the turn; for a smoothly shaded
//     one, the turn of the face the pixel lies on).
// Output: u_previous (RGBA32F) last frame's point and entry + 1; u_turn (RGBA16F) the
// quaternion taking the normal now to the normal then (include/surface_motion.glsl reads
// both).
layout(local_size_x = 8, local_size_y = 8) in;

#include "triangle_input.glsl"
#include "motion_rows.glsl"
#include "triangle_weights.glsl"
#include "denoise.glsl"

layout(std430) readonly buffer PreviousPositions { float previous_positions[]; };

uniform sampler2D u_depth;            // the primary G-buffer's depth
uniform sampler2D u_normal_material;  // its normal (xyz) and signed material id (w; 0: no surface)
uniform isampler2D u_row;             // its world row per pixel
uniform sampler2D u_motion_matrices;  // RGBA32F, row e: entry e's move, by columns
uniform mat4 u_inv_view_proj;
uniform ivec2 u_size;

layout(rgba32f) writeonly uniform image2D u_previous;
layout(rgba16f) writeonly uniform image2D u_turn;

// The shortest rotation taking unit vector a to unit vector b, as a quaternion (xyz, w);
// opposite vectors (no shortest one) keep the normal as it is.
vec4 turn_between(vec3 a, vec3 b) {
    float w = 1.0 + dot(a, b);
    if (!(w > 1e-6)) return vec4(0.0, 0.0, 0.0, 1.0);
    return normalize(vec4(cross(a, b), w));
}

vec3 previous_corner(int row, int corner) {
    int at = row * 9 + corner * 3;
    return vec3(previous_positions[at], previous_positions[at + 1], previous_positions[at + 2]);
}

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, u_size))) return;
    vec4 nm = texelFetch(u_normal_material, pixel, 0);
    int row = texelFetch(u_row, pixel, 0).r;
    int k = denoise_surface_id(nm.w) != 0 ? motion_entry(row) : -1;
    if (k < 0) {
        imageStore(u_previous, pixel, vec4(0.0));
        imageStore(u_turn, pixel, vec4(0.0, 0.0, 0.0, 1.0));
        return;
    }
    ivec4 entry = motion_rows[k];
    vec3 p = denoise_unproject(u_inv_view_proj, pixel, u_size, texelFetch(u_depth, pixel, 0).r);
    vec3 n = normalize(nm.xyz);
    vec3 p_then;
    vec4 turn;
    if (entry.w >= 0) {
        vec3 a = input_vertex(uint(row), 0u), b = input_vertex(uint(row), 1u), c = input_vertex(uint(row), 2u);
        int before = entry.w + row - entry.x;
        vec3 a0 = previous_corner(before, 0), b0 = previous_corner(before, 1), c0 = previous_corner(before, 2);
        vec3 w = triangle_weights(p, a, b, c);
        p_then = w.x * a0 + w.y * b0 + w.z * c0;
        vec3 g = cross(b - a, c - a), g0 = cross(b0 - a0, c0 - a0);
        turn = dot(g, g) > 0.0 && dot(g0, g0) > 0.0 ? turn_between(normalize(g), normalize(g0))
                                                    : vec4(0.0, 0.0, 0.0, 1.0);
    } else {
        mat4 move = mat4(texelFetch(u_motion_matrices, ivec2(0, entry.z), 0),
                         texelFetch(u_motion_matrices, ivec2(1, entry.z), 0),
                         texelFetch(u_motion_matrices, ivec2(2, entry.z), 0),
                         texelFetch(u_motion_matrices, ivec2(3, entry.z), 0));
        p_then = (move * vec4(p, 1.0)).xyz;
        turn = turn_between(n, normalize(transpose(inverse(mat3(move))) * n));
    }
    imageStore(u_previous, pixel, vec4(p_then, float(entry.z + 1)));
    imageStore(u_turn, pixel, turn);
}
