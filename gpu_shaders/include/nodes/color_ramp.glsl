// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's Color Ramp node (ShaderNodeValToRGB) as a lookup in a table the host bakes
// (blender_adapter/export/node_tables.py): NODE_RAMP_TABLE_SIZE RGBA samples of the ramp at
// i / (size - 1), the form Cycles renders it in. The spline shapes (Ease, Cardinal, B-Spline)
// and the HSV/HSL hue directions all live in the table; here is only the lookup, shared with
// the curve nodes (nodes/curves.glsl): which two samples and what weight.
//
// node_table_coords(x, size, interpolate, extrapolate, out i0, out i1, out weight)
//   x in table units ([0, 1] spans the table). Inside, the value is
//   node_table_mix(table[i0], table[i1], weight) with i1 = i0 + 1 (or i0 when the lookup does
//   not interpolate); outside [0, 1] the end sample is held, or, with extrapolate, the line
//   through the two end samples is continued (weight is then negative: i1 is the inner
//   neighbour of the end sample i0).
// node_color_ramp_coords(interpolation, fac, out i0, out i1, out weight)
//   "Fac" 0.5 -> after the fetch, "Color" = rgb and "Alpha" = a of
//   node_table_mix(table[i0], table[i1], weight).
//   interpolation codes (Blender's ColorRamp `interpolation` enum, in its own order):
//     0 EASE  1 CARDINAL  2 LINEAR  3 B_SPLINE  4 CONSTANT
//   (color_mode RGB/HSV/HSL and hue_interpolation NEAR/FAR/CW/CCW only shape the table.)
#ifndef HYBRID_NODES_COLOR_RAMP_GLSL
#define HYBRID_NODES_COLOR_RAMP_GLSL

const int NODE_RAMP_TABLE_SIZE = 257;  // Cycles' table: 257 samples, at i / 256

void node_table_coords(float x, int size, bool interpolate, bool extrapolate, out int i0, out int i1,
                       out float weight) {
    float last = float(size - 1);
    if (extrapolate && x < 0.0) {
        i0 = 0;
        i1 = 1;
        weight = x * last;
        return;
    }
    if (extrapolate && x > 1.0) {
        i0 = size - 1;
        i1 = size - 2;
        weight = (1.0 - x) * last;  // away from the last sample, past it
        return;
    }
    float f = clamp(x, 0.0, 1.0) * last;  // a NaN lands on sample 0 below
    i0 = clamp(int(f), 0, size - 1);
    float t = f - float(i0);
    bool blend = interpolate && t > 0.0;
    i1 = blend ? min(i0 + 1, size - 1) : i0;
    weight = blend ? t : 0.0;
}

vec4 node_table_mix(vec4 a, vec4 b, float weight) {
    return (1.0 - weight) * a + weight * b;
}

void node_color_ramp_coords(int interpolation, float fac, out int i0, out int i1, out float weight) {
    node_table_coords(fac, NODE_RAMP_TABLE_SIZE, interpolation != 4, false, i0, i1, weight);
}

#endif
