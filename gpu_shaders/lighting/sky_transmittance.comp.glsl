// SPDX-License-Identifier: GPL-3.0-or-later
// The Multiple Scattering sky's transmittance table (include/nodes/sky_atmosphere.glsl):
// SKY_LUT_W x SKY_LUT_H texels of one Sky Texture node's atmosphere, written at rows
// u_row .. u_row + SKY_LUT_H - 1 of u_target. Each in-scattering sample of the sky reads the
// light reaching it from the sun (and from the ground below) here instead of marching
// towards the sun again: 64 table reads in place of 64 x 64 density evaluations per texel
// of the bake. Run by world_bake.py before the bake, only when the World changes.
#include "include/nodes/sky_atmosphere.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f) uniform writeonly image2D u_target;
uniform int u_row;
uniform vec3 u_density;  // the node's air, aerosol and ozone multipliers

void main() {
    ivec2 at = ivec2(gl_GlobalInvocationID.xy);
    if (at.x >= SKY_LUT_W || at.y >= SKY_LUT_H) return;
    // Texel x holds cos(zenith) = 2 x / (W - 1) - 1, row y the altitude y / (H - 1) of the
    // shell: the corners are exact, as the reads in tex_sky.glsl expect.
    float cos_zenith = float(at.x) / float(SKY_LUT_W - 1) * 2.0 - 1.0;
    float altitude = float(at.y) / float(SKY_LUT_H - 1);
    imageStore(u_target, ivec2(at.x, u_row + at.y), sky_ms_transmittance(cos_zenith, altitude, u_density));
}
