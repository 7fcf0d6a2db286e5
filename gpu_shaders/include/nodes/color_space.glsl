// SPDX-License-Identifier: GPL-3.0-or-later
// RGB <-> HSV and RGB <-> HSL as Blender's colour nodes define them (Mix's Hue/Saturation/
// Color/Value blends, Hue/Saturation/Value, Separate/Combine Color, the Color Ramp's HSV and
// HSL modes). Hue is in [0, 1); a grey has hue and saturation 0. Values above 1 pass through
// (scene-linear colours are unbounded), which is why the HSV value is the maximum channel
// rather than a clamped one.
#ifndef HYBRID_NODES_COLOR_SPACE_GLSL
#define HYBRID_NODES_COLOR_SPACE_GLSL

vec3 node_rgb_to_hsv(vec3 rgb) {
    float cmax = max(rgb.r, max(rgb.g, rgb.b));
    float cmin = min(rgb.r, min(rgb.g, rgb.b));
    float delta = cmax - cmin;
    float s = cmax != 0.0 ? delta / cmax : 0.0;
    float h = 0.0;
    if (s != 0.0) {
        vec3 c = (vec3(cmax) - rgb) / delta;
        if (rgb.r == cmax) h = c.b - c.g;
        else if (rgb.g == cmax) h = 2.0 + c.r - c.b;
        else h = 4.0 + c.g - c.r;
        h /= 6.0;
        if (h < 0.0) h += 1.0;
    }
    return vec3(h, s, cmax);
}

vec3 node_hsv_to_rgb(vec3 hsv) {
    float h = hsv.x, s = hsv.y, v = hsv.z;
    if (s == 0.0) return vec3(v);
    if (h == 1.0) h = 0.0;
    h *= 6.0;
    float i = floor(h);
    float f = h - i;
    float p = v * (1.0 - s);
    float q = v * (1.0 - s * f);
    float t = v * (1.0 - s * (1.0 - f));
    if (i == 0.0) return vec3(v, t, p);
    if (i == 1.0) return vec3(q, v, p);
    if (i == 2.0) return vec3(p, v, t);
    if (i == 3.0) return vec3(p, q, v);
    if (i == 4.0) return vec3(t, p, v);
    return vec3(v, p, q);
}

vec3 node_rgb_to_hsl(vec3 rgb) {
    float cmax = max(rgb.r, max(rgb.g, rgb.b));
    float cmin = min(rgb.r, min(rgb.g, rgb.b));
    float l = min(1.0, (cmax + cmin) * 0.5);
    if (cmax == cmin) return vec3(0.0, 0.0, l);
    float d = cmax - cmin;
    // Out-of-range colours can zero the denominator (cmax + cmin == 0 or 2): saturation 0
    // there, the finite value Cycles' film shows for its infinity.
    float denominator = l > 0.5 ? 2.0 - cmax - cmin : cmax + cmin;
    float s = denominator != 0.0 ? d / denominator : 0.0;
    float h;
    if (cmax == rgb.r) h = (rgb.g - rgb.b) / d + (rgb.g < rgb.b ? 6.0 : 0.0);
    else if (cmax == rgb.g) h = (rgb.b - rgb.r) / d + 2.0;
    else h = (rgb.r - rgb.g) / d + 4.0;
    return vec3(h / 6.0, s, l);
}

vec3 node_hsl_to_rgb(vec3 hsl) {
    float h = hsl.x, s = hsl.y, l = hsl.z;
    float r = abs(h * 6.0 - 3.0) - 1.0;
    float g = 2.0 - abs(h * 6.0 - 2.0);
    float b = 2.0 - abs(h * 6.0 - 4.0);
    float chroma = (1.0 - abs(2.0 * l - 1.0)) * s;
    return (clamp(vec3(r, g, b), 0.0, 1.0) - 0.5) * chroma + l;
}

#endif
