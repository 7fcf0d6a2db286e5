// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's Gradient Texture node: a ramp in [0, 1] shaped by the gradient type, from the
// input vector's x (linear family), x + y (diagonal), its length (spheres) or its angle about
// the z axis (radial). The result is clamped to [0, 1]; Color is that value in grey.
//
// node_tex_gradient(type, vector, out color, out fac)
//   Blender node "Gradient Texture" (ShaderNodeTexGradient).
//   type (setting gradient_type; Blender default LINEAR):
//     0 LINEAR            x
//     1 QUADRATIC         max(x, 0)^2
//     2 EASING            smoothstep of x clamped to [0, 1] (3 t^2 - 2 t^3)
//     3 DIAGONAL          (x + y) / 2
//     4 SPHERICAL         1 - |vector|
//     5 QUADRATIC_SPHERE  (1 - |vector|)^2, negative part cut first
//     6 RADIAL            atan2(y, x) / 2 pi + 0.5
//   Inputs (socket identifier: Blender default):
//     Vector: Generated texture coordinates when unlinked (the caller supplies them)
//   Outputs: Color (fac, fac, fac), Fac.
//
// The spheres measure from 0.999999 rather than 1, as Blender does, so a point on the unit
// sphere gives exactly 0 rather than a rounding residue of either sign.
#ifndef HYBRID_NODES_TEX_GRADIENT_GLSL
#define HYBRID_NODES_TEX_GRADIENT_GLSL

float node_tex_gradient_value(int type, vec3 v) {
    if (type == 0) return v.x;
    if (type == 1) { float r = max(v.x, 0.0); return r * r; }
    if (type == 2) { float r = clamp(v.x, 0.0, 1.0); return r * r * (3.0 - 2.0 * r); }
    if (type == 3) return 0.5 * (v.x + v.y);
    if (type == 6) return atan(v.y, v.x) * (0.5 / 3.14159265358979) + 0.5;
    float r = max(0.999999 - length(v), 0.0);
    if (type == 5) return r * r;
    if (type == 4) return r;
    return 0.0;
}

void node_tex_gradient(int type, vec3 vector, out vec3 color, out float fac) {
    fac = clamp(node_tex_gradient_value(type, vector), 0.0, 1.0);
    color = vec3(fac);
}

#endif
