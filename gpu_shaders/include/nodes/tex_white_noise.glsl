// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's White Noise Texture node: a random value and colour per input point, from the
// hash of its coordinates (nodes/hash.glsl), in 1 to 4 dimensions (W is the 1D input and the
// fourth coordinate).
#ifndef HYBRID_NODES_TEX_WHITE_NOISE_GLSL
#define HYBRID_NODES_TEX_WHITE_NOISE_GLSL
#include "include/nodes/hash.glsl"

void node_tex_white_noise(int dimensions, vec3 vector, float w, out float value, out vec3 color) {
    if (dimensions == 1) {
        value = hash_float_to_float(w);
        color = hash_float_to_vec3(w);
    } else if (dimensions == 2) {
        value = hash_vec2_to_float(vector.xy);
        color = hash_vec2_to_vec3(vector.xy);
    } else if (dimensions == 3) {
        value = hash_vec3_to_float(vector);
        color = hash_vec3_to_vec3(vector);
    } else {
        value = hash_vec4_to_float(vec4(vector, w));
        color = hash_vec4_to_vec3(vec4(vector, w));
    }
}

#endif
