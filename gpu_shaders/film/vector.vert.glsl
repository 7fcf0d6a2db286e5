// SPDX-License-Identifier: GPL-3.0-or-later
// Cycles' Vector pass, vertex stage (passes/film/vector.py): the world rows as the G-buffer
// draws them (vertex 3 * row + corner, gbuffer.vert.glsl), drawn with the sample's
// view-projection, and each corner's clip position at this frame, the frame before and the
// frame after. The corner reaches the other frames' world through its instance's motion:
// MotionRows lists, sorted by row, the instances that move or deform (first row, end row,
// index of its two world-to-world matrices in MotionMatrices or -1, index of its corners'
// positions in MotionCorners or -1); a row outside them is still, and only the camera
// moves it. The fragment stage divides the interpolated clip positions: they are linear in
// the surface point, so their perspective-correct interpolation is exact.
// ALPHA_TEST defined (scenes with alpha): the UV and the triangle's material go to the
// fragment stage, which drops what the G-buffer drops (gbuffer.frag.glsl); with
// NODE_CLOSURE_ALPHA (some material's coverage is an alpha program) the point and its row too.
in vec3 in_pos;
#ifdef ALPHA_TEST
in vec2 in_uv;
layout(std430) readonly buffer TriangleMaterials { int triangle_materials[]; };
out vec2 v_uv;
flat out int v_material;
#ifdef NODE_CLOSURE_ALPHA
out vec3 v_world;
flat out int v_row;
#endif
#endif

uniform mat4 u_view_proj;           // this sample's, as drawn
uniform mat4 u_previous_view_proj;  // the sample's camera moved to the frame before
uniform mat4 u_next_view_proj;      // ... and to the frame after

#include "motion_rows.glsl"
layout(std430) readonly buffer MotionMatrices { mat4 motion_matrices[]; };  // previous, next
layout(std430) readonly buffer MotionCorners { vec4 motion_corners[]; };    // previous, next

out vec4 v_center;
out vec4 v_previous;
out vec4 v_next;

void main() {
    int row = gl_VertexID / 3;
    vec4 world = vec4(in_pos, 1.0);
    vec4 previous = world;
    vec4 next = world;
    int k = motion_entry(row);
    if (k >= 0) {
        ivec4 entry = motion_rows[k];
        if (entry.w >= 0) {
            int corner = entry.w + 2 * (gl_VertexID - 3 * entry.x);
            previous = motion_corners[corner];
            next = motion_corners[corner + 1];
        } else if (entry.z >= 0) {
            previous = motion_matrices[entry.z] * world;
            next = motion_matrices[entry.z + 1] * world;
        }
    }
#ifdef ALPHA_TEST
    v_uv = in_uv;
    v_material = triangle_materials[row];
#ifdef NODE_CLOSURE_ALPHA
    v_world = in_pos;
    v_row = row;
#endif
#endif
    gl_Position = u_view_proj * world;
    v_center = gl_Position;
    v_previous = u_previous_view_proj * previous;
    v_next = u_next_view_proj * next;
}
