// SPDX-License-Identifier: GPL-3.0-or-later
// The World background: a constant colour or an equirectangular environment texture
// (Blender's mapping, see hybrid_engine/scene_data.py Sky). Paper §3.4: rays that leave the
// cube map through a far plane end in this outer environment map.
#include "scene_layout.glsl"

uniform vec3 u_sky_color;
uniform float u_sky_strength;
uniform int u_sky_has_env;
uniform sampler2D u_sky_env;

vec2 equirect_uv(vec3 dir) {
    // Blender: u = -atan2(y, x) / 2pi + 0.5, v = atan2(z, hypot(x, y)) / pi + 0.5
    float u = -atan(dir.y, dir.x) / (2.0 * PI) + 0.5;
    float v = atan(dir.z, length(dir.xy)) / PI + 0.5;
    return vec2(u, v);
}

vec3 sky_radiance(vec3 dir) {
    if (u_sky_has_env != 0 && all(lessThan(abs(dir), vec3(1e30))) && dot(dir, dir) > 0.0) {
        return textureLod(u_sky_env, equirect_uv(normalize(dir)), 0.0).rgb * u_sky_strength;
    }
    return u_sky_color * u_sky_strength;
}
