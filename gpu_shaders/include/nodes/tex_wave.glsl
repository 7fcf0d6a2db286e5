// SPDX-License-Identifier: GPL-3.0-or-later
// Blender's Wave Texture node: a periodic profile of a phase that grows along an axis (bands) or
// with the distance from an axis or the origin (rings), optionally bent by the normalized fBm
// of the Noise Texture (nodes/tex_noise.glsl) so that the stripes look like wood or marble.
//
// node_tex_wave(wave_type, bands_direction, rings_direction, wave_profile, vector, scale,
//               distortion, detail, detail_scale, detail_roughness, phase_offset,
//               out color, out fac)
//   Blender node: "Wave Texture" (ShaderNodeTexWave).
//   wave_type: 0 = 'BANDS' (default), 1 = 'RINGS'.
//   bands_direction: 0 = 'X' (default), 1 = 'Y', 2 = 'Z', 3 = 'DIAGONAL'.
//   rings_direction: 0 = 'X' (default), 1 = 'Y', 2 = 'Z', 3 = 'SPHERICAL'.
//   wave_profile: 0 = 'SIN' (default), 1 = 'SAW', 2 = 'TRI'.
//   Input sockets (identifier: Blender default):
//     Vector: Generated coordinates when unlinked (the caller supplies them), Scale: 5.0,
//     Distortion: 0.0, Detail: 2.0, Detail Scale: 1.0, Detail Roughness: 0.5,
//     Phase Offset: 0.0.
//   Outputs: Color (grey, the Fac in every channel) and Fac, in [0, 1].
#ifndef HYBRID_NODES_TEX_WAVE_GLSL
#define HYBRID_NODES_TEX_WAVE_GLSL
#include "include/nodes/tex_noise.glsl"

const float WAVE_PI = 3.14159265358979;

void node_tex_wave(int wave_type, int bands_direction, int rings_direction, int wave_profile,
                   vec3 vector, float scale, float distortion, float detail, float detail_scale,
                   float detail_roughness, float phase_offset, out vec3 color, out float fac) {
    // Blender nudges the point off exact zeros, where a ring's distance has no direction.
    vec3 p = (vector * scale + 0.000001) * 0.999999;
    float phase;
    if (wave_type == 0) {
        // Twenty radians per unit along an axis; the diagonal's sum of three axes, ten.
        if (bands_direction == 0) phase = p.x * 20.0;
        else if (bands_direction == 1) phase = p.y * 20.0;
        else if (bands_direction == 2) phase = p.z * 20.0;
        else phase = (p.x + p.y + p.z) * 10.0;
    } else {
        // Distance from the axis (that axis' component dropped), or from the origin.
        vec3 r = p;
        if (rings_direction == 0) r.x = 0.0;
        else if (rings_direction == 1) r.y = 0.0;
        else if (rings_direction == 2) r.z = 0.0;
        phase = length(r) * 20.0;
    }
    phase += phase_offset;
    if (distortion != 0.0) {
        // The Noise Texture's normalized 3D fBm at lacunarity 2, recentred to [-1, 1].
        float n = noise_fractal(NOISE_FBM, 3, vec4(p * detail_scale, 0.0), clamp(detail, 0.0, 15.0),
                                detail_roughness, 2.0, 0.0, 1.0, true);
        phase += distortion * (2.0 * n - 1.0);
    }
    if (wave_profile == 0) {
        fac = 0.5 + 0.5 * sin(phase - 0.5 * WAVE_PI);  // starts at 0, like the others
    } else {
        float t = phase / (2.0 * WAVE_PI);
        fac = wave_profile == 1 ? t - floor(t) : 2.0 * abs(t - floor(t + 0.5));
    }
    color = vec3(fac);
}

#endif
