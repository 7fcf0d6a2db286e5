// SPDX-License-Identifier: GPL-3.0-or-later
// The World's irradiance as nine SH coefficients (include/world_light.glsl): one workgroup
// integrates the sky's radiance over a latitude-longitude grid of SKY_GRID_W x SKY_GRID_H
// cells (solid angle per cell 2 pi / W * pi / H * cos(latitude)) against the SH basis, then
// scales band l by the clamped cosine's factor A_l (pi, 2 pi / 3, pi / 4). The environment is
// read at the mip level nearest the grid, so each cell averages the texels it covers.
// Runs only when the World changes (hybrid_engine/passes/lighting/sky_light.py).
//
// Storage block SkyIrradianceOut (vec4[9], written); the sky's uniforms (sky.glsl).
#include "scene_layout.glsl"
#include "sky.glsl"
#include "sh9.glsl"

#define SKY_GRID_W 128
#define SKY_GRID_H 64
#define THREADS 256

layout(local_size_x = THREADS) in;
layout(std430) writeonly buffer SkyIrradianceOut { vec4 sh_out[9]; };

uniform float u_grid_lod;  // mip level of u_sky_env nearest SKY_GRID_W texels wide

shared vec3 partial[THREADS];

void main() {
    uint t = gl_LocalInvocationID.x;
    vec3 acc[9];
    for (int k = 0; k < 9; ++k) acc[k] = vec3(0.0);
    const float d_phi = 2.0 * PI / float(SKY_GRID_W);
    const float d_lat = PI / float(SKY_GRID_H);
    for (uint cell = t; cell < uint(SKY_GRID_W * SKY_GRID_H); cell += uint(THREADS)) {
        float u = (float(cell % uint(SKY_GRID_W)) + 0.5) / float(SKY_GRID_W);
        float v = (float(cell / uint(SKY_GRID_W)) + 0.5) / float(SKY_GRID_H);
        float phi = (0.5 - u) * 2.0 * PI;  // inverse of equirect_uv
        float lat = (v - 0.5) * PI;
        vec3 d = vec3(cos(lat) * cos(phi), cos(lat) * sin(phi), sin(lat));
        vec3 radiance = sky_radiance_lod(d, u_grid_lod) * (d_phi * d_lat * cos(lat));
        float y[9];
        sh9_basis(d, y);
        for (int k = 0; k < 9; ++k) acc[k] += radiance * y[k];
    }
    const float band[3] = float[3](PI, 2.0 * PI / 3.0, PI / 4.0);
    for (int k = 0; k < 9; ++k) {
        partial[t] = acc[k];
        barrier();
        for (uint stride = uint(THREADS) / 2u; stride > 0u; stride >>= 1) {
            if (t < stride) partial[t] += partial[t + stride];
            barrier();
        }
        if (t == 0u) {
            int l = k == 0 ? 0 : (k < 4 ? 1 : 2);
            sh_out[k] = vec4(partial[0] * band[l], 0.0);
        }
        barrier();
    }
}
