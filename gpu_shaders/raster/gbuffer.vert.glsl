// SPDX-License-Identifier: GPL-3.0-or-later
// Primary G-buffer, vertex stage (paper §3.1). Vertices arrive in world space (the adapter
// bakes matrix_world into them), so one view-projection serves every object.
// Inputs: hybrid_engine/gpu_scene.py VERTEX_ATTRIBUTES (one buffer per attribute, the
// Geometry arrays as uploaded) and the per-triangle material ids at
// TRIANGLE_MATERIAL_BINDING. Every draw addresses vertices 3 * triangle + corner (direct
// draws through `first`, the culled cube-map draws through their index buffer), so
// gl_VertexID / 3 is the triangle.
uniform mat4 u_view_proj;

in vec3 in_pos;
in vec3 in_normal;
in vec2 in_uv;

layout(std430, binding = 1) readonly buffer TriangleMaterials { int triangle_materials[]; };

out vec3 v_world;
out vec3 v_normal;
out vec2 v_uv;
flat out int v_material;

void main() {
    v_world = in_pos;
    v_normal = in_normal;
    v_uv = in_uv;
    v_material = triangle_materials[gl_VertexID / 3];
    gl_Position = u_view_proj * vec4(in_pos, 1.0);
}
