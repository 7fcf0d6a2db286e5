// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's RGB Curves (ShaderNodeRGBCurve), Vector Curves (ShaderNodeVectorCurve) and Float
// Curve (ShaderNodeFloatCurve) nodes as lookups in tables the host bakes
// (blender_adapter/export/node_tables.py): NODE_RAMP_TABLE_SIZE samples over the x range
// [min_x, max_x] that the curves' points span, one column per channel or axis (the RGB table
// already applies the combined C curve before each channel's own).
//
// node_curve_coords(x, min_x, max_x, extrapolate, out i0, out i1, out weight)
//   the table lookup of an input x; value = mix of table[i0] and table[i1] by
//   node_table_mix (nodes/color_ramp.glsl). Curves always interpolate; extrapolate is true
//   when the CurveMapping's `extend` is EXTRAPOLATED (the end slope of the table continues)
//   and false for HORIZONTAL (the end value holds). An empty x range reads sample 0.
//   RGB Curves: per channel c, x = color[c] and the value is column c of the mix.
//   Vector Curves: per axis, x = vector[axis], column axis.
//   Float Curve: x = "Value", column 0.
// node_curves_finish(fac, original, curved, out result): mix by the factor, unclamped:
//   RGB Curves "Fac" 1.0, "Color" (1,1,1,1) -> "Color";
//   Vector Curves "Fac" 1.0, "Vector" (0,0,0) -> "Vector";
//   Float Curve "Factor" 1.0, "Value" 1.0 -> "Value" (node_curve_finish_float).
#ifndef HYBRID_NODES_CURVES_GLSL
#define HYBRID_NODES_CURVES_GLSL
#include "include/nodes/color_ramp.glsl"

void node_curve_coords(float x, float min_x, float max_x, bool extrapolate, out int i0, out int i1,
                       out float weight) {
    float range = max_x - min_x;
    float relative = range != 0.0 ? (x - min_x) / range : 0.0;
    node_table_coords(relative, NODE_RAMP_TABLE_SIZE, true, extrapolate, i0, i1, weight);
}

void node_curves_finish(float fac, vec3 original, vec3 curved, out vec3 result) {
    result = (1.0 - fac) * original + fac * curved;
}

void node_curve_finish_float(float fac, float original, float curved, out float result) {
    result = (1.0 - fac) * original + fac * curved;
}

#endif
