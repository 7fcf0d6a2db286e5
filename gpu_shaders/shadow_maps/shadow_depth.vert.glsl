// SPDX-License-Identifier: GPL-3.0-or-later
// Shadow-map depth pass (paper §3.5), vertex stage: world-space vertices into one shadow
// slot of the atlas (the host sets the viewport to the slot's rectangle).
// FACE_VIEWPORTS defined (the "gpu" variant of the faces kernel, gpu/variants.py): up to
// FACE_VIEWPORTS slots -- a point lamp's six cube faces -- in one multi-draw of their culled
// lists (view_cull.py), draw d into slot d's viewport (gpu/viewport_array.py).
#ifdef FACE_VIEWPORTS
#extension GL_ARB_shader_viewport_layer_array : require
#extension GL_ARB_shader_draw_parameters : require
uniform mat4 u_face_view_proj[FACE_VIEWPORTS];
#else
uniform mat4 u_view_proj;
#endif

in vec3 in_pos;

void main() {
#ifdef FACE_VIEWPORTS
    gl_Position = u_face_view_proj[gl_DrawIDARB] * vec4(in_pos, 1.0);
    gl_ViewportIndex = gl_DrawIDARB;
#else
    gl_Position = u_view_proj * vec4(in_pos, 1.0);
#endif
}
