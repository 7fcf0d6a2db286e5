// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's Checker Texture node: a 3D checkerboard of unit cells in (Vector * Scale); a cell
// whose integer coordinates sum to an odd number shows Color1, the others Color2.
//
// node_tex_checker(vector, color1, color2, scale, out color, out fac)
//   Blender node "Checker Texture" (ShaderNodeTexChecker); no settings.
//   Inputs (socket identifier: Blender default):
//     Vector: Generated texture coordinates when unlinked (the caller supplies them)
//     Color1: (0.8, 0.8, 0.8)
//     Color2: (0.2, 0.2, 0.2)
//     Scale:  5.0
//   Outputs: Color (Color1 or Color2), Fac (1.0 in Color1 cells, else 0.0).
//
// Cells are floor() of the scaled coordinate after Blender's nudge (add 1e-6, then shrink by
// 1e-6): a surface lying exactly on a whole number (the plane z = 0, a cube face at 1) then
// falls in one cell instead of flickering between two. The parity of a negative cell is taken
// on its two's complement bits, which equals the parity of its absolute value, so the board
// continues across zero without a doubled row.
#ifndef HYBRID_NODES_TEX_CHECKER_GLSL
#define HYBRID_NODES_TEX_CHECKER_GLSL

float node_tex_checker_parity(vec3 p) {
    vec3 nudged = (p + vec3(0.000001)) * 0.999999;
    ivec3 cell = ivec3(floor(nudged));
    return float((cell.x ^ cell.y ^ cell.z) & 1);
}

void node_tex_checker(vec3 vector, vec3 color1, vec3 color2, float scale, out vec3 color, out float fac) {
    fac = node_tex_checker_parity(vector * scale);
    color = fac == 1.0 ? color1 : color2;
}

#endif
