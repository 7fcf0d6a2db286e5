// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's Map Range (ShaderNodeMapRange) and Clamp (ShaderNodeClamp) nodes.
//
// node_map_range(interpolation, use_clamp, value, from_min, from_max, to_min, to_max, steps,
//                out result)
//   Float: "Value" 1.0, "From Min" 0.0, "From Max" 1.0, "To Min" 0.0, "To Max" 1.0,
//   "Steps" 4.0 (STEPPED only) -> "Result"; use_clamp is the node's `clamp` (default True),
//   honoured by LINEAR and STEPPED only, as in Blender.
// node_map_range_vector(...): data_type FLOAT_VECTOR, the same per axis: "Vector" (0,0,0),
//   "From_Min_FLOAT3" (0,0,0), "From_Max_FLOAT3" (1,1,1), "To_Min_FLOAT3" (0,0,0),
//   "To_Max_FLOAT3" (1,1,1), "Steps_FLOAT3" (4,4,4) -> "Vector".
//   interpolation codes (Blender's `interpolation_type` enum, in its own order):
//     0 LINEAR  1 STEPPED  2 SMOOTHSTEP  3 SMOOTHERSTEP
//   An empty source range (from_min == from_max) gives 0 for Float and to_min for
//   FLOAT_VECTOR, whatever the interpolation: Blender's two data types differ there.
//
// node_clamp(clamp_type, value, min, max, out result)
//   "Value" 1.0, "Min" 0.0, "Max" 1.0 -> "Result".
//   clamp_type codes (Blender's `clamp_type` enum): 0 MINMAX  1 RANGE
//   MINMAX is min(max(value, min), max) even when min > max (the result is then max); RANGE
//   swaps the bounds first.
#ifndef HYBRID_NODES_MAP_RANGE_GLSL
#define HYBRID_NODES_MAP_RANGE_GLSL

float node_smootherstep(float edge0, float edge1, float x) {
    float d = edge1 - edge0;
    float t = clamp(d != 0.0 ? (x - edge0) / d : 0.0, 0.0, 1.0);
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

float node_map_range_factor(int interpolation, float value, float from_min, float from_max, float steps) {
    if (interpolation == 2) {
        // the vector rule: the linear factor, clamped, through the cubic; same as the float
        // rule wherever the source range is not empty
        float d = from_max - from_min;
        float t = clamp(d != 0.0 ? (value - from_min) / d : 0.0, 0.0, 1.0);
        return (3.0 - 2.0 * t) * t * t;
    }
    if (interpolation == 3) {
        bool reversed = from_min > from_max;
        float lo = reversed ? from_max : from_min;
        float hi = reversed ? from_min : from_max;
        float s = node_smootherstep(lo, hi, value);
        return reversed ? 1.0 - s : s;
    }
    float factor = from_max != from_min ? (value - from_min) / (from_max - from_min) : 0.0;
    if (interpolation == 1) factor = steps > 0.0 ? floor(factor * (steps + 1.0)) / steps : 0.0;
    return factor;
}

void node_map_range_axis(int interpolation, bool use_clamp, float value, float from_min, float from_max,
                         float to_min, float to_max, float steps, out float result) {
    float factor = node_map_range_factor(interpolation, value, from_min, from_max, steps);
    result = to_min + factor * (to_max - to_min);
    if (use_clamp && interpolation <= 1) {
        result = to_max > to_min ? clamp(result, to_min, to_max) : clamp(result, to_max, to_min);
    }
}

void node_map_range(int interpolation, bool use_clamp, float value, float from_min, float from_max,
                    float to_min, float to_max, float steps, out float result) {
    if (from_max == from_min) {
        result = 0.0;
        return;
    }
    node_map_range_axis(interpolation, use_clamp, value, from_min, from_max, to_min, to_max, steps, result);
}

void node_map_range_vector(int interpolation, bool use_clamp, vec3 value, vec3 from_min, vec3 from_max,
                           vec3 to_min, vec3 to_max, vec3 steps, out vec3 result) {
    for (int k = 0; k < 3; ++k) {
        float r;
        node_map_range_axis(interpolation, use_clamp, value[k], from_min[k], from_max[k], to_min[k], to_max[k],
                       steps[k], r);
        result[k] = r;
    }
}

void node_clamp(int clamp_type, float value, float min_value, float max_value, out float result) {
    if (clamp_type == 1 && min_value > max_value) {
        result = min(max(value, max_value), min_value);
    } else {
        result = min(max(value, min_value), max_value);
    }
}

#endif
