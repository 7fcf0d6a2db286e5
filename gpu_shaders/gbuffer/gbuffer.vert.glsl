// SPDX-License-Identifier: GPL-3.0-or-later
// Primary G-buffer, vertex stage (paper §3.1). Vertices arrive in world space (the adapter
// bakes matrix_world into them), so one view-projection serves every object.
// Inputs: hybrid_engine/passes/scene_upload/scene_buffers.py VERTEX_ATTRIBUTES (one buffer per attribute, the
// Geometry arrays as uploaded) and the per-triangle material ids (TriangleMaterials). Every draw addresses vertices 3 * triangle + corner (direct
// draws through `first`, the culled cube-map draws through their index buffer), so
// gl_VertexID / 3 is the triangle.
// CUBE_FACE defined (the cube-map faces): a triangle of a refractive material is moved
// outside the clip volume, all three vertices alike, so the clipper drops it whole and it
// writes nothing (gbuffer.frag.glsl: the faces hold what lies behind refractive surfaces).
// Dropping it here rather than discarding its fragments keeps the early depth test for the
// fragment stage, which a shader that can discard loses. Same G-buffers either way.
// FACE_VIEWPORTS defined (the "gpu" variant of the faces kernel, gpu/variants.py): all
// faces in one multi-draw of their culled lists (view_cull.py), draw d being face d: its
// matrix is u_face_view_proj[d] and it rasterizes into viewport d, its tile of the atlas
// (gpu/viewport_array.py). Same arithmetic per vertex as one draw per face.
#ifdef FACE_VIEWPORTS
#extension GL_ARB_shader_viewport_layer_array : require
#extension GL_ARB_shader_draw_parameters : require
#endif
#include "scene_layout.glsl"

#ifdef FACE_VIEWPORTS
uniform mat4 u_face_view_proj[FACE_VIEWPORTS];
#else
uniform mat4 u_view_proj;
#endif

in vec3 in_pos;
in vec3 in_normal;
in vec2 in_uv;

layout(std430) readonly buffer TriangleMaterials { int triangle_materials[]; };
#ifdef CUBE_FACE
layout(std430) readonly buffer MaterialBuffer { Material materials[]; };
#endif

out vec3 v_world;
out vec3 v_normal;
out vec2 v_uv;
flat out int v_material;

void main() {
    v_world = in_pos;
    v_normal = in_normal;
    v_uv = in_uv;
    v_material = triangle_materials[gl_VertexID / 3];
#ifdef FACE_VIEWPORTS
    gl_Position = u_face_view_proj[gl_DrawIDARB] * vec4(in_pos, 1.0);
    gl_ViewportIndex = gl_DrawIDARB;
#else
    gl_Position = u_view_proj * vec4(in_pos, 1.0);
#endif
#ifdef CUBE_FACE
    if (materials[v_material].emission_trans.a > 0.0) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // beyond x = w: outside for every vertex
    }
#endif
}
