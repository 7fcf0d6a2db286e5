// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's Separate Color (ShaderNodeSeparateColor) and Combine Color (ShaderNodeCombineColor)
// nodes in their three modes. The hue, saturation and value or lightness are Blender's
// (nodes/color_space.glsl), all in [0, 1].
//
// node_separate_color(mode, color, out a, out b, out c)
//   "Color" (0.8,0.8,0.8,1) -> "Red" "Green" "Blue" (named Hue/Saturation/Value or
//   Hue/Saturation/Lightness in the other modes; the identifiers stay Red/Green/Blue).
// node_combine_color(mode, a, b, c, out color)
//   "Red" 0.0, "Green" 0.0, "Blue" 0.0 -> "Color".
//   mode codes (Blender's `mode` enum, in its own order): 0 RGB  1 HSV  2 HSL
#ifndef HYBRID_NODES_SEPARATE_COMBINE_GLSL
#define HYBRID_NODES_SEPARATE_COMBINE_GLSL
#include "include/nodes/color_space.glsl"

void node_separate_color(int mode, vec3 color, out float a, out float b, out float c) {
    vec3 v = mode == 1 ? node_rgb_to_hsv(color) : (mode == 2 ? node_rgb_to_hsl(color) : color);
    a = v.x;
    b = v.y;
    c = v.z;
}

void node_combine_color(int mode, float a, float b, float c, out vec3 color) {
    vec3 v = vec3(a, b, c);
    color = mode == 1 ? node_hsv_to_rgb(v) : (mode == 2 ? node_hsl_to_rgb(v) : v);
}

#endif
