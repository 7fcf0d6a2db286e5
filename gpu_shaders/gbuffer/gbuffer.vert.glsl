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
// INSTANCED defined (the "gpu" variant of the vertices kernel, gpu/variants.py; the primary
// view only): indexed draws of object-space meshes (scene_upload/raster_meshes.py), one
// indirect command per instance whose baseInstance is the instance (view_cull/
// instanced_draw.py). Inputs in_object_pos, in_object_normal, in_uv: a mesh's distinct
// corners, shared by its triangles, so the post-transform vertex cache shades each once.
// The vertex stage transforms them by the instance's matrices (InstanceTable, read at
// gl_BaseInstanceARB) with instance_space.glsl, the instance transform's own arithmetic, so
// positions and normals equal the world-space rows bit for bit. A vertex belongs to several
// triangles, so it cannot carry a triangle's material: it passes the instance's first world
// row, and the fragment stage reads the material of row + gl_PrimitiveID (the draw draws
// the mesh's triangles in order). No CUBE_FACE or FACE_VIEWPORTS variant of it.
// The triangle's world row goes to the fragment stage as v_row (INSTANCED: its instance's
// first row, v_first_row, plus gl_PrimitiveID there): the primary view stores it per pixel
// (passes/surface_motion/ and passes/film/ read it), node programs find the instance
// by it (include/node_program.glsl), and the cube-map faces keep it with node programs.
#if defined(INSTANCED) && (defined(CUBE_FACE) || defined(FACE_VIEWPORTS))
#error "INSTANCED draws the primary view only"
#endif
#if defined(FACE_VIEWPORTS) || defined(INSTANCED)
#extension GL_ARB_shader_draw_parameters : require
#endif
#ifdef FACE_VIEWPORTS
#extension GL_ARB_shader_viewport_layer_array : require
#endif
#include "scene_layout.glsl"
#ifdef INSTANCED
#include "instance_space.glsl"
#endif

#ifdef FACE_VIEWPORTS
uniform mat4 u_face_view_proj[FACE_VIEWPORTS];
#else
uniform mat4 u_view_proj;
#endif

#ifdef INSTANCED
in vec3 in_object_pos;
in vec3 in_object_normal;
layout(std430) readonly buffer InstanceTable { Instance instances[]; };
#else
in vec3 in_pos;
in vec3 in_normal;
layout(std430) readonly buffer TriangleMaterials { int triangle_materials[]; };
#endif
in vec2 in_uv;

#ifdef CUBE_FACE
layout(std430) readonly buffer MaterialBuffer { Material materials[]; };
#endif

out vec3 v_world;
out vec3 v_normal;
out vec2 v_uv;
#ifdef INSTANCED
flat out int v_first_row;
#else
flat out int v_material;
#endif
#if !defined(INSTANCED) && (defined(NODE_PROGRAMS) || !defined(CUBE_FACE))
flat out int v_row;  // the triangle's world row
#endif

void main() {
#ifdef INSTANCED
    Instance inst = instances[gl_BaseInstanceARB];
    vec3 world = instance_point(inst, in_object_pos);
    v_normal = instance_normal(instance_normal_matrix(inst), in_object_normal);
    v_first_row = inst.info.x;
#else
    vec3 world = in_pos;
    v_normal = in_normal;
    v_material = triangle_materials[gl_VertexID / 3];
#if defined(NODE_PROGRAMS) || !defined(CUBE_FACE)
    v_row = gl_VertexID / 3;
#endif
#endif
    v_world = world;
    v_uv = in_uv;
#ifdef FACE_VIEWPORTS
    gl_Position = u_face_view_proj[gl_DrawIDARB] * vec4(world, 1.0);
    gl_ViewportIndex = gl_DrawIDARB;
#else
    gl_Position = u_view_proj * vec4(world, 1.0);
#endif
#ifdef CUBE_FACE
    if (materials[v_material].emission_trans.a > 0.0) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // beyond x = w: outside for every vertex
    }
#endif
}
