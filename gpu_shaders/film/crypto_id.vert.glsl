// SPDX-License-Identifier: GPL-3.0-or-later
// Cryptomatte's id raster, vertex stage (passes/film/cryptomatte.py): the world-space rows as
// the G-buffer draws them (vertex 3 * row + corner, gbuffer.vert.glsl), with the sample's
// jittered view-projection, so that each sample sees which triangle covers the pixel at
// that sample's sub-pixel position. The row goes to the fragment stage, which writes it.
in vec3 in_pos;

uniform mat4 u_view_proj;

flat out int v_row;

void main() {
    v_row = gl_VertexID / 3;
    gl_Position = u_view_proj * vec4(in_pos, 1.0);
}
