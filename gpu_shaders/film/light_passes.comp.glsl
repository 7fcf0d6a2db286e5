// SPDX-License-Identifier: GPL-3.0-or-later
// Cycles' light passes of a view's samples (hybrid_engine/passes/film/light_passes.py): this
// sample's layers (include/light_passes.glsl, written by the shading and the tracer) are
// added into the running sums, and the passes as Cycles delivers them are written back over
// the sample's layers, which the read-back reads:
//   Direct and Indirect = the sum of the lobe's light / the sum of its colour (0 where the
//   colour is 0: Cycles' film divides the same way), so that (Direct + Indirect) x Color
//   is the lobe's share of Combined; Color, Emission, Environment, AO (rgb, its grey) and
//   Mist are the means.
// u_restart: the view's first sample; the sums start from it.
// Bindings: images u_light_samples (read and written) and u_light_sums (read and written),
//   RGBA32F, LP_LAYERS tiles of u_size texels each (include/light_passes.glsl).
#define LIGHT_PASSES_FILM
#include "light_passes.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(rgba32f) uniform image2D u_light_sums;  // tiled as u_light_samples
uniform ivec2 u_size;
uniform int u_restart;
uniform float u_count;  // samples in the sums after this one

// The resolved layers, as light_passes.py RESOLVED reads them.
#define OUT_DIFFUSE_DIRECT 0
#define OUT_DIFFUSE_INDIRECT 1
#define OUT_DIFFUSE_COLOR 2  // a: AO
#define OUT_GLOSSY_DIRECT 3
#define OUT_GLOSSY_INDIRECT 4
#define OUT_GLOSSY_COLOR 5  // a: Mist
#define OUT_TRANSMISSION_INDIRECT 6
#define OUT_TRANSMISSION_COLOR 7
#define OUT_EMISSION 8
#define OUT_ENVIRONMENT 9

vec3 divided(vec3 light, vec3 color) {
    return vec3(color.r != 0.0 ? light.r / color.r : 0.0, color.g != 0.0 ? light.g / color.g : 0.0,
                color.b != 0.0 ? light.b / color.b : 0.0);
}

void main() {
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(texel, u_size))) return;
    vec4 sums[LP_LAYERS];
    for (int layer = 0; layer < LP_LAYERS; ++layer) {
        ivec2 at = light_texel(texel, layer);
        vec4 sample_value = imageLoad(u_light_samples, at);
        sums[layer] = u_restart != 0 ? sample_value : imageLoad(u_light_sums, at) + sample_value;
        imageStore(u_light_sums, at, sums[layer]);
    }
    vec4 diffuse_color = sums[LP_DIFFUSE_COLOR];
    vec4 glossy_color = sums[LP_GLOSSY_COLOR];
    vec3 transmission_color = sums[LP_TRANSMISSION_COLOR].rgb;
    float mean = 1.0 / u_count;
    light_store(texel, OUT_DIFFUSE_DIRECT, divided(sums[LP_DIFFUSE_DIRECT].rgb, diffuse_color.rgb));
    light_store(texel, OUT_DIFFUSE_INDIRECT, divided(sums[LP_DIFFUSE_INDIRECT].rgb, diffuse_color.rgb));
    light_store(texel, OUT_DIFFUSE_COLOR, diffuse_color * mean);
    light_store(texel, OUT_GLOSSY_DIRECT, divided(sums[LP_GLOSSY_DIRECT].rgb, glossy_color.rgb));
    light_store(texel, OUT_GLOSSY_INDIRECT, divided(sums[LP_GLOSSY_INDIRECT].rgb, glossy_color.rgb));
    light_store(texel, OUT_GLOSSY_COLOR, glossy_color * mean);
    light_store(texel, OUT_TRANSMISSION_INDIRECT, divided(sums[LP_TRANSMISSION_INDIRECT].rgb, transmission_color));
    light_store(texel, OUT_TRANSMISSION_COLOR, transmission_color * mean);
    light_store(texel, OUT_EMISSION, sums[LP_EMISSION].rgb * mean);
    light_store(texel, OUT_ENVIRONMENT, sums[LP_ENVIRONMENT].rgb * mean);
}
