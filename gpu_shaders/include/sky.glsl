// SPDX-License-Identifier: GPL-3.0-or-later
// The World background: a constant colour or an equirectangular environment texture
// (Blender's mapping, see hybrid_engine/scene/data.py Sky). Paper §3.4: rays that leave the
// cube map through a far plane end in this outer environment map.
//
// The environment is mipmapped (hybrid_engine/passes/lighting/sky_light.py): rough reflections look it up
// at a level whose texels cover their lobe (sky_radiance_rough), the prefiltered lookup of
// split-sum image-based lighting, with plain box-filtered mips.
#include "scene_layout.glsl"

uniform vec3 u_sky_color;
uniform float u_sky_strength;
uniform int u_sky_has_env;
uniform sampler2D u_sky_env;
uniform float u_sky_env_levels;  // mip levels of u_sky_env (1 without mips)
uniform float u_sky_env_width;   // its base width in texels

vec2 equirect_uv(vec3 dir) {
    // Blender: u = -atan2(y, x) / 2pi + 0.5, v = atan2(z, hypot(x, y)) / pi + 0.5
    float u = -atan(dir.y, dir.x) / (2.0 * PI) + 0.5;
    float v = atan(dir.z, length(dir.xy)) / PI + 0.5;
    return vec2(u, v);
}

vec3 sky_radiance_lod(vec3 dir, float lod) {
    if (u_sky_has_env != 0 && all(lessThan(abs(dir), vec3(1e30))) && dot(dir, dir) > 0.0) {
        return textureLod(u_sky_env, equirect_uv(normalize(dir)), lod).rgb * u_sky_strength;
    }
    return u_sky_color * u_sky_strength;
}

vec3 sky_radiance(vec3 dir) {
    return sky_radiance_lod(dir, 0.0);
}

// The sky seen by a GGX lobe of the given roughness around `dir`: the mip level whose texel
// spans the lobe's width (about roughness^2 radians, in texels of 2 pi / width).
vec3 sky_radiance_rough(vec3 dir, float roughness) {
    float alpha = roughness * roughness;
    float texels = alpha * u_sky_env_width / (2.0 * PI);
    float lod = clamp(log2(max(texels, 1.0)) + 1.0, 0.0, max(u_sky_env_levels - 1.0, 0.0));
    return sky_radiance_lod(dir, alpha > 0.0 ? lod : 0.0);
}
