// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's colour adjustment nodes: Hue/Saturation/Value, Invert Color, Gamma and
// Brightness/Contrast, as Cycles applies them to scene-linear colours.
//
// node_hue_saturation_value(hue, saturation, value, factor, color, out result)
//   ShaderNodeHueSaturation: "Hue" 0.5 (0.5 keeps the hue; the shift wraps), "Saturation" 1.0
//   (the product is clamped to [0, 1]), "Value" 1.0 (a multiplier, unclamped), "Fac" 1.0,
//   "Color" (0.8,0.8,0.8,1) -> "Color". Negative channels after the mix are cut to 0.
// node_invert(factor, color, out result)
//   ShaderNodeInvert: "Fac" 1.0, "Color" (0,0,0,1) -> "Color" = mix(color, 1 - color, fac).
// node_gamma(color, gamma, out result)
//   ShaderNodeGamma: "Color" (1,1,1,1), "Gamma" 1.0 -> "Color": each positive channel to
//   the power gamma (others kept); gamma 0 gives white.
// node_bright_contrast(color, bright, contrast, out result)
//   ShaderNodeBrightContrast: "Color" (1,1,1,1), "Bright" 0.0, "Contrast" 0.0 -> "Color":
//   max((1 + contrast) * c + bright - contrast / 2, 0) per channel.
#ifndef HYBRID_NODES_COLOR_ADJUST_GLSL
#define HYBRID_NODES_COLOR_ADJUST_GLSL
#include "include/nodes/color_space.glsl"

void node_hue_saturation_value(float hue, float saturation, float value, float factor, vec3 color,
                               out vec3 result) {
    vec3 hsv = node_rgb_to_hsv(color);
    hsv.x += hue - 0.5;
    hsv.x -= floor(hsv.x);
    hsv.y = clamp(hsv.y * saturation, 0.0, 1.0);
    hsv.z *= value;
    vec3 shifted = node_hsv_to_rgb(hsv);
    result = max(factor * shifted + (1.0 - factor) * color, vec3(0.0));
}

void node_invert(float factor, vec3 color, out vec3 result) {
    result = (1.0 - factor) * color + factor * (vec3(1.0) - color);
}

void node_gamma(vec3 color, float gamma, out vec3 result) {
    if (gamma == 0.0) {
        result = vec3(1.0);
        return;
    }
    result = color;
    for (int k = 0; k < 3; ++k) {
        if (color[k] > 0.0) result[k] = pow(color[k], gamma);
    }
}

void node_bright_contrast(vec3 color, float bright, float contrast, out vec3 result) {
    float a = 1.0 + contrast;
    float b = bright - contrast * 0.5;
    result = max(a * color + vec3(b), vec3(0.0));
}

#endif
