// SPDX-License-Identifier: GPL-3.0-or-later
// Shadow-map depth pass (paper §3.5), vertex stage: world-space vertices into one shadow
// slot of the atlas (the host sets the viewport to the slot's rectangle).
// FACE_VIEWPORTS defined (the "gpu" variant of the faces kernel, gpu/variants.py): up to
// FACE_VIEWPORTS slots -- a point lamp's six cube faces -- in one multi-draw of their culled
// lists (view_cull.py), draw d into slot d's viewport (gpu/viewport_array.py).
// INSTANCED defined (the "gpu" variant of the vertices kernel): object-space mesh vertices
// drawn indexed, one indirect command per instance (view_cull/instanced_draw.py), moved to
// world space by the instance at gl_BaseInstanceARB with the instance transform's own
// arithmetic (instance_space.glsl; gbuffer/gbuffer.vert.glsl says why): the same depths
// as drawing the world-space rows, bit for bit. Not combined with FACE_VIEWPORTS.
// ALPHA_TEST defined: the fragment stage's alpha test also gets the UV and the triangle's
// material (its row; for INSTANCED the instance's first row, as gbuffer.vert.glsl); with
// NODE_PROGRAMS also the world position and row, for a material's alpha program.
#if defined(INSTANCED) && defined(FACE_VIEWPORTS)
#error "INSTANCED draws one slot per draw"
#endif
#if defined(FACE_VIEWPORTS) || defined(INSTANCED)
#extension GL_ARB_shader_draw_parameters : require
#endif
#ifdef FACE_VIEWPORTS
#extension GL_ARB_shader_viewport_layer_array : require
uniform mat4 u_face_view_proj[FACE_VIEWPORTS];
#else
uniform mat4 u_view_proj;
#endif

#ifdef INSTANCED
#include "instance_space.glsl"
in vec3 in_object_pos;
layout(std430) readonly buffer InstanceTable { Instance instances[]; };
#else
in vec3 in_pos;
#endif
#ifdef ALPHA_TEST
in vec2 in_uv;
out vec2 v_uv;
#ifdef NODE_PROGRAMS  // closure alpha: the point, its world row and the lamp's view of it for the alpha program
out vec3 v_world;
out vec3 v_seen_along;
#ifndef INSTANCED
flat out int v_row;
#endif
#endif
#ifdef INSTANCED
flat out int v_first_row;
#else
layout(std430) readonly buffer TriangleMaterials { int triangle_materials[]; };
flat out int v_material;
#endif
#endif

#if defined(ALPHA_TEST) && defined(NODE_PROGRAMS)
// The direction the slot's view looks along through the point of clip position c under the
// view-projection m, away from the lamp: the direction along which the point's x / w and
// y / w stay, as its depth grows (perspective and orthographic slots alike). A shadow ray
// that meets a blocker there comes from a receiver further along it, so it is the blocker's
// Incoming, which Fresnel and Layer Weight read (Cycles' I = -D of the shadow ray).
vec3 shadow_view_ray(mat4 m, vec4 c) {
    vec3 rx = vec3(m[0].x, m[1].x, m[2].x), ry = vec3(m[0].y, m[1].y, m[2].y);
    vec3 rz = vec3(m[0].z, m[1].z, m[2].z), rw = vec3(m[0].w, m[1].w, m[2].w);
    vec3 d = cross(c.w * rx - c.x * rw, c.w * ry - c.y * rw);
    d = dot(rz, d) * c.w - dot(rw, d) * c.z < 0.0 ? -d : d;
    float l = dot(d, d);
    return l > 0.0 ? d * inversesqrt(l) : vec3(0.0);
}
#endif

void main() {
#ifdef INSTANCED
    vec3 world = instance_point(instances[gl_BaseInstanceARB], in_object_pos);
#else
    vec3 world = in_pos;
#endif
#ifdef ALPHA_TEST
    v_uv = in_uv;
#ifdef NODE_PROGRAMS
    v_world = world;
#ifndef INSTANCED
    v_row = gl_VertexID / 3;
#endif
#endif
#ifdef INSTANCED
    v_first_row = instances[gl_BaseInstanceARB].info.x;
#else
    v_material = triangle_materials[gl_VertexID / 3];
#endif
#endif
#ifdef FACE_VIEWPORTS
    mat4 view_proj = u_face_view_proj[gl_DrawIDARB];
    gl_ViewportIndex = gl_DrawIDARB;
#else
    mat4 view_proj = u_view_proj;
#endif
    gl_Position = view_proj * vec4(world, 1.0);
#if defined(ALPHA_TEST) && defined(NODE_PROGRAMS)
    v_seen_along = shadow_view_ray(view_proj, gl_Position);
#endif
}
