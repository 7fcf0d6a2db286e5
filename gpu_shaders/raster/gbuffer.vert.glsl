// SPDX-License-Identifier: GPL-3.0-or-later
// Primary G-buffer, vertex stage (paper §3.1). Vertices arrive in world space (the adapter
// bakes matrix_world into them), so one view-projection serves every object.
// Inputs: hybrid_engine/gpu_scene.py VERTEX_FORMAT = pos 3f, normal 3f, uv 2f, material 1i.
uniform mat4 u_view_proj;

in vec3 in_pos;
in vec3 in_normal;
in vec2 in_uv;
in int in_material;

out vec3 v_world;
out vec3 v_normal;
out vec2 v_uv;
flat out int v_material;

void main() {
    v_world = in_pos;
    v_normal = in_normal;
    v_uv = in_uv;
    v_material = in_material;
    gl_Position = u_view_proj * vec4(in_pos, 1.0);
}
