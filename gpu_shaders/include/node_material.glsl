// SPDX-License-Identifier: GPL-3.0-or-later
// What the passes that shade a primary pixel from the G-buffer need of node programs
// (include/node_program.glsl), without the interpreter: whether a material has a program
// (Material.textures2.w >= 0) and its material at a pixel the G-buffer ran it for.
#ifndef HYBRID_NODE_MATERIAL_GLSL
#define HYBRID_NODE_MATERIAL_GLSL
#include "scene_layout.glsl"

// A primary pixel's material whose program the G-buffer ran (gbuffer.frag.glsl): its
// surface target holds roughness, metallic, transmission and coat, its emission target
// the closure's emission itself (hence the row's emission of 1: the shading multiplies).
Material node_gbuffer_material(Material m, vec4 surface) {
    m.params.z = clamp(surface.x, 0.0, 1.0);
    m.base_color_refl.a = clamp(surface.y, 0.0, 1.0);
    m.emission_trans = vec4(1.0, 1.0, 1.0, min(clamp(surface.z, 0.0, 1.0), 1.0 - m.base_color_refl.a));
    m.params.w = clamp(surface.w, 0.0, 1.0);
    m.textures2.xy = ivec2(-1);
    return m;
}

bool material_has_program(Material m) { return m.textures2.w >= 0; }

#endif
